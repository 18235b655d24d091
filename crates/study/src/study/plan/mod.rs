//! Planning a study: `load` reads a study file, resolves its kind, expands the grid into run
//! specs and checks every run (building each distinct scene) before anything is written;
//! `own_keys` refuses grids and `[set]`s over the scene keys a kind decides itself.

pub mod load;
pub mod own_keys;
