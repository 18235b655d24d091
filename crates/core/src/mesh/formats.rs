//! The mesh file formats softbench reads: one table, one line per format. The reader dispatch
//! ([`read_mesh`](super::read_mesh)), `softbench mesh-info --help`, `softbench list`, the
//! message on a file of unknown format and the format tests are all driven by it. A program
//! that depends on softbench adds its own format with `MESH_FORMATS.register(..)` before it
//! reads meshes.
//!
//! **Adding a format** is one file plus one line here. Write `src/mesh/<format>.rs` with a
//! parser from the file's text, bytes or path to a [`TetMesh`](super::TetMesh) or
//! [`SurfaceMesh`](super::SurfaceMesh), whose errors are [`MeshError`]s naming the file and
//! line (`text.rs` and `bytes.rs` have the plumbing), and, if its files can be recognized by
//! their content, a `looks_like`; declare the module in `mod.rs`; add its line to
//! `BUILTIN` below (name, title, extensions, what its files start with, sniffer, reader,
//! description). `tests/mesh_format_table.rs` then fails until it has a small sample of the
//! format, which it reads back through the dispatch.

use std::path::Path;

use super::{AnyMesh, MeshError, gmsh, medit, obj, plain, tetgen, vtk};
use crate::registry::{Entry, Fact, Registry};

/// What a format's sniffer makes of a file's content.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sniff {
    /// Not this format's content.
    No,
    /// Content this format's files have but others' may too (`v x y z` lines): it decides
    /// between the formats that claim the file's extension, or among all of them when none
    /// does. Formats are asked in table order.
    Maybe,
    /// The content starts with this format's signature: the file is read as this format
    /// whatever its extension.
    Sure,
}

impl Sniff {
    /// `Sure` when `yes`, else `No`.
    pub fn sure_if(yes: bool) -> Sniff {
        if yes { Sniff::Sure } else { Sniff::No }
    }

    /// `Maybe` when `yes`, else `No`.
    pub fn maybe_if(yes: bool) -> Sniff {
        if yes { Sniff::Maybe } else { Sniff::No }
    }
}

/// How a format reads a file; `path` is for error messages (and, for [`Reader::Files`], the
/// file to read).
#[derive(Clone, Copy)]
pub enum Reader {
    /// Parses the file's text; a file that is not UTF-8 is an error at the line of its first
    /// bad byte.
    Text(fn(&str, &Path) -> Result<AnyMesh, MeshError>),
    /// Parses the file's bytes (formats with binary blocks).
    Bytes(fn(&[u8], &Path) -> Result<AnyMesh, MeshError>),
    /// Reads the mesh itself, given the path of one of its files (formats spread over several
    /// files, such as TetGen's `.node` + `.ele`). Such a format is chosen by extension alone,
    /// before the file is opened.
    Files(fn(&Path) -> Result<AnyMesh, MeshError>),
}

/// Everything the rest of the code asks about a mesh format.
pub struct MeshFormatEntry {
    /// The name `mesh-info --json` and `softbench list` use.
    pub name: &'static str,
    /// What `mesh-info` and messages call it ("MEDIT .mesh").
    pub title: &'static str,
    /// The extensions it claims, lowercase, without the dot.
    pub extensions: &'static [&'static str],
    /// What its files start with, for the message on a file of unknown format (`""` for a
    /// format told by its extension only).
    pub starts_with: &'static str,
    /// What it makes of a file's bytes (a text format looks at their UTF-8 prefix,
    /// [`utf8_prefix`]).
    pub sniff: fn(&[u8]) -> Sniff,
    /// Reads a file of the format.
    pub reader: Reader,
    /// One line on what it is.
    pub description: &'static str,
}

impl Entry for MeshFormatEntry {
    fn name(&self) -> &'static str {
        self.name
    }
    fn description(&self) -> &'static str {
        self.description
    }
    fn facts(&self) -> Vec<Fact> {
        vec![("extensions", dotted(self.extensions).join(","))]
    }
}

/// The extensions with their dots (`.mesh`).
fn dotted(extensions: &[&str]) -> Vec<String> {
    extensions.iter().map(|e| format!(".{e}")).collect()
}

/// The longest prefix of `bytes` that is UTF-8, for the sniffers of text formats.
pub fn utf8_prefix(bytes: &[u8]) -> &str {
    match std::str::from_utf8(bytes) {
        Ok(text) => text,
        Err(e) => std::str::from_utf8(&bytes[..e.valid_up_to()]).unwrap_or_default(),
    }
}

/// The built-in formats. The order is the listing order and the order sniffers are asked in:
/// OBJ comes before plain because a `v`-first file with `f` records is an OBJ surface.
static BUILTIN: &[MeshFormatEntry] = &[
    MeshFormatEntry {
        name: "medit",
        title: "MEDIT .mesh",
        extensions: &["mesh"],
        starts_with: "`MeshVersionFormatted`",
        sniff: |b| Sniff::sure_if(medit::looks_like(utf8_prefix(b))),
        reader: Reader::Text(|t, p| medit::parse(t, p).map(AnyMesh::Tet)),
        description: "MEDIT ASCII .mesh (INRIA): Vertices and Tetrahedra sections, 1-based",
    },
    MeshFormatEntry {
        name: "obj",
        title: "Wavefront OBJ",
        extensions: &["obj"],
        starts_with: "",
        sniff: |b| Sniff::maybe_if(obj::looks_like(utf8_prefix(b))),
        reader: Reader::Text(|t, p| obj::parse(t, p).map(AnyMesh::Surface)),
        description: "Wavefront OBJ triangle surface (display meshes): v and f records, 1-based",
    },
    MeshFormatEntry {
        name: "plain",
        title: "plain v/t .mesh",
        extensions: &["mesh"],
        starts_with: "a `v x y z` line",
        sniff: |b| Sniff::maybe_if(plain::looks_like(utf8_prefix(b))),
        reader: Reader::Text(|t, p| plain::parse(t, p).map(AnyMesh::Tet)),
        description: "the Brown FEM stencil's .mesh: `v x y z` and `t i j k l` lines, 0-based",
    },
    MeshFormatEntry {
        name: "tetgen",
        title: "TetGen .node/.ele",
        extensions: &["node", "ele"],
        starts_with: "",
        sniff: |_| Sniff::No,
        reader: Reader::Files(|p| tetgen::read(p).map(AnyMesh::Tet)),
        description: "TetGen .node + .ele (either file names both), index base from the first id",
    },
    MeshFormatEntry {
        name: "gmsh",
        title: "Gmsh .msh",
        extensions: &["msh"],
        starts_with: "`$MeshFormat`",
        sniff: |b| Sniff::sure_if(gmsh::looks_like(b)),
        reader: Reader::Bytes(|b, p| gmsh::parse(b, p).map(AnyMesh::Tet)),
        description: "Gmsh .msh 2.2 or 4.1, ASCII or binary, linear tets",
    },
    MeshFormatEntry {
        name: "vtu",
        title: "VTK XML .vtu",
        extensions: &["vtu"],
        starts_with: "`<?xml`",
        sniff: |b| Sniff::sure_if(vtk::xml::looks_like_vtu(b)),
        reader: Reader::Bytes(|b, p| {
            vtk::xml::parse_vtu(b, p).map(|frame| AnyMesh::Tet(frame.mesh))
        }),
        description: "VTK XML unstructured grid .vtu (ascii, base64 or appended; zlib, LZ4 or LZMA), linear tets",
    },
    MeshFormatEntry {
        name: "vtk",
        title: "legacy VTK .vtk",
        extensions: &["vtk"],
        starts_with: "`# vtk DataFile`",
        sniff: |b| Sniff::sure_if(vtk::legacy::looks_like_legacy(b)),
        reader: Reader::Bytes(|b, p| vtk::legacy::parse_legacy(b, p).map(AnyMesh::Tet)),
        description: "legacy VTK .vtk unstructured grid (versions to 4.2 and 5.1, ASCII or binary), linear tets",
    },
];

/// Every mesh format: the built-in ones, then the ones registered at run time.
pub static MESH_FORMATS: Registry<MeshFormatEntry> = Registry::new("mesh format", BUILTIN);

crate::registry_handle! {
    /// A mesh file format: shown and serialized as its name (`medit`); [`MeshFormat::title`]
    /// is what `mesh-info` prints.
    pub struct MeshFormat(MeshFormatEntry) in MESH_FORMATS;
}

impl MeshFormat {
    /// What `mesh-info` and messages call it ("MEDIT .mesh").
    pub fn title(self) -> &'static str {
        self.entry().title
    }

    /// Whether it claims the (lowercase) extension `ext`.
    pub fn claims(self, ext: &str) -> bool {
        self.entry().extensions.contains(&ext)
    }
}

/// What the files of each format start with (or their extensions), for the message on a file
/// of unknown format.
pub(crate) fn expected_starts() -> String {
    let all = MeshFormat::all();
    let mut expected: Vec<String> = all
        .iter()
        .map(|f| f.entry())
        .filter(|e| !e.starts_with.is_empty())
        .map(|e| format!("{} ({})", e.starts_with, e.title))
        .collect();
    let by_extension: Vec<String> = all
        .iter()
        .map(|f| f.entry())
        .filter(|e| e.starts_with.is_empty())
        .flat_map(|e| dotted(e.extensions))
        .collect();
    if let Some((last, rest)) = by_extension.split_last() {
        let list = if rest.is_empty() {
            last.clone()
        } else {
            format!("{} or {last}", rest.join(", "))
        };
        expected.push(format!("an {list} extension"));
    }
    match expected.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{}, or {last}", rest.join(", ")),
        _ => expected.join(""),
    }
}
