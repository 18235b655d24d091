//! Writing simulation states for viewers: VTK XML unstructured grids (`.vtu`) with a ParaView
//! collection (`.pvd`), and Wavefront OBJ surfaces (the tet mesh's boundary, or a display mesh
//! skinned onto the tets), numbered frame by frame during a run.
//!
//! - [`frames`]: the run [`crate::run::Observer`] that writes frames ([`FrameWriter`])
//!   and what a frame holds ([`FrameContent`]);
//! - [`display`]: the scene's `[display]` section and loading + skinning its mesh;
//! - [`vtu`], [`pvd`], [`obj`]: the three file writers (plain functions over slices);
//! - [`base64`]: the encoding of VTU binary arrays.
//!
//! The VTK XML is written by hand rather than with the `vtkio` crate: the subset needed (one
//! unstructured grid of tets, Float64 arrays, a collection file) is about a hundred lines, it
//! adds no dependency (vtkio 0.6.3 pulls in old nom and quick-xml versions that warn about
//! future incompatibility on every build), and the output is checked against an independent
//! reader (meshio) in the tests.

pub mod base64;
pub mod display;
pub mod frames;
pub mod obj;
pub mod pvd;
pub mod vtu;

pub use display::{Display, DisplayConfig, DisplayError, load_display};
pub use frames::{
    ExportFormat, Frame, FrameContent, FrameWriter, SERIES_FILE, UnknownExportFormat,
};
pub use obj::write_obj;
pub use pvd::write_pvd;
pub use vtu::{VtuGrid, write_vtu};
