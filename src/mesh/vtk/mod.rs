//! VTK unstructured grids of linear tets, two formats with a file each: [`xml`] reads `.vtu`
//! (softbench's own frames, with [`read_vtu_frame`] keeping their point data and time) and
//! [`legacy`] reads ASCII `.vtk`; `cells.rs` turns the VTK cell list both have into tets.

mod cells;
pub mod legacy;
pub mod xml;

pub use legacy::{looks_like_legacy, parse_legacy, read_legacy};
pub use xml::{VtuFrame, looks_like_vtu, parse_vtu, read_vtu, read_vtu_frame};
