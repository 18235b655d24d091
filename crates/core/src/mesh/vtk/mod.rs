//! VTK unstructured grids of linear tets, two formats: [`xml`] reads `.vtu` (with
//! [`read_vtu_frame`] keeping softbench's frames' point data and time) and [`legacy`] reads
//! `.vtk`, ASCII and binary (`legacy_arrays.rs` reads their values); `cells.rs` turns the VTK cell list both have into tets. The XML
//! reader's parts: `tags.rs` (the XML it needs), `binary.rs` (a binary array's header and
//! block table), `compressors.rs` (zlib, LZ4, LZMA), `base64.rs` and `appended.rs` (the
//! `<AppendedData>` section).

mod appended;
mod base64;
mod binary;
mod cells;
mod compressors;
pub mod legacy;
mod legacy_arrays;
mod tags;
pub mod xml;

pub use legacy::{looks_like_legacy, parse_legacy, read_legacy};
pub use xml::{VtuFrame, looks_like_vtu, parse_vtu, read_vtu, read_vtu_frame};
