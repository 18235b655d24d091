//! Planning a study: `load` reads a study file, resolves its kind, expands the grid into run
//! specs and checks every run (building each distinct scene) before anything is written;
//! `own_keys` refuses grids and `[set]`s over the scene keys a kind decides itself;
//! `peer_blocks` leaves out, as omissions, the blocks of peer methods this command has not
//! registered.

pub mod load;
pub mod own_keys;
pub mod peer_blocks;
