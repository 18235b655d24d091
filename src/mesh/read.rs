//! Choosing a reader: by extension, and by content where an extension is shared (`.mesh` is
//! either MEDIT or the plain Brown format) or missing.

use std::fmt;
use std::path::Path;

use serde::Serialize;

use super::{MeshError, SurfaceMesh, TetMesh, medit, obj, plain, tetgen, text};

/// The mesh file formats softbench reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum MeshFormat {
    /// MEDIT ASCII `.mesh`, 1-based.
    #[serde(rename = "medit")]
    Medit,
    /// The plain Brown `.mesh` (`v`/`t` lines), 0-based.
    #[serde(rename = "plain")]
    Plain,
    /// TetGen `.node` + `.ele`, base taken from the first point id.
    #[serde(rename = "tetgen")]
    TetGen,
    /// Wavefront OBJ triangle surface, 1-based.
    #[serde(rename = "obj")]
    Obj,
}

impl MeshFormat {
    /// Whether the format holds tets (otherwise it is a triangle surface).
    pub fn is_volume(self) -> bool {
        !matches!(self, MeshFormat::Obj)
    }
}

impl fmt::Display for MeshFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            MeshFormat::Medit => "MEDIT .mesh",
            MeshFormat::Plain => "plain v/t .mesh",
            MeshFormat::TetGen => "TetGen .node/.ele",
            MeshFormat::Obj => "Wavefront OBJ",
        })
    }
}

/// A mesh of either kind, as read from a file whose kind was not known beforehand.
#[derive(Clone, Debug, PartialEq)]
pub enum AnyMesh {
    /// A tetrahedral mesh.
    Tet(TetMesh),
    /// A triangle surface.
    Surface(SurfaceMesh),
}

/// Reads a mesh of any supported format; returns the format it was read as.
pub fn read_mesh(path: impl AsRef<Path>) -> Result<(MeshFormat, AnyMesh), MeshError> {
    let path = path.as_ref();
    if is_tetgen_path(path) {
        return Ok((MeshFormat::TetGen, AnyMesh::Tet(tetgen::read(path)?)));
    }
    let content = text::read_text(path)?;
    let format = detect(path, &content)?;
    let mesh = match format {
        MeshFormat::Medit => AnyMesh::Tet(medit::parse(&content, path)?),
        MeshFormat::Plain => AnyMesh::Tet(plain::parse(&content, path)?),
        MeshFormat::Obj => AnyMesh::Surface(obj::parse(&content, path)?),
        // Not produced by `detect`; kept total so a future change cannot panic here.
        MeshFormat::TetGen => AnyMesh::Tet(tetgen::read(path)?),
    };
    Ok((format, mesh))
}

/// Reads a tet mesh: MEDIT or plain `.mesh` (told apart by content), or TetGen `.node`/`.ele`.
pub fn read_tet_mesh(path: impl AsRef<Path>) -> Result<TetMesh, MeshError> {
    let path = path.as_ref();
    match read_mesh(path)? {
        (_, AnyMesh::Tet(mesh)) => Ok(mesh),
        (format, AnyMesh::Surface(_)) => Err(MeshError::Invalid {
            path: path.to_path_buf(),
            message: format!("this is a {format} triangle surface, not a tet mesh"),
        }),
    }
}

/// Reads a triangle surface (OBJ). A tet mesh is refused rather than silently reduced to its
/// boundary; use [`TetMesh::boundary_surface`] for that.
pub fn read_surface_mesh(path: impl AsRef<Path>) -> Result<SurfaceMesh, MeshError> {
    let path = path.as_ref();
    match read_mesh(path)? {
        (_, AnyMesh::Surface(mesh)) => Ok(mesh),
        (format, AnyMesh::Tet(_)) => Err(MeshError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "this is a {format} tet mesh, not a surface; read it with read_tet_mesh and \
                 take its boundary_surface()"
            ),
        }),
    }
}

fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

fn is_tetgen_path(path: &Path) -> bool {
    matches!(extension(path).as_deref(), Some("node" | "ele"))
}

/// Tells the format of a (non-TetGen) file from its extension and content.
fn detect(path: &Path, content: &str) -> Result<MeshFormat, MeshError> {
    let ext = extension(path);
    if ext.as_deref() == Some("obj") {
        return Ok(MeshFormat::Obj);
    }
    if medit::looks_like(content) {
        return Ok(MeshFormat::Medit);
    }
    let is_mesh = ext.as_deref() == Some("mesh");
    // Without an extension, a `v`-first file is OBJ if it has faces, plain if it has tets.
    if !is_mesh && obj::looks_like(content) {
        return Ok(MeshFormat::Obj);
    }
    if plain::looks_like(content) {
        return Ok(MeshFormat::Plain);
    }
    let first = text::lines(content)
        .find_map(|(line, l)| l.split_ascii_whitespace().next().map(|t| (line, t)));
    let Some((line, token)) = first else {
        let end = text::last_line(content);
        return Err(text::empty_mesh(path, end, "the file has no records"));
    };
    Err(MeshError::UnknownFormat {
        path: path.to_path_buf(),
        message: format!(
            "line {line} starts with `{token}`; expected `MeshVersionFormatted` (MEDIT .mesh), a `v x y z` line (plain \
             .mesh), or an .obj, .node or .ele extension"
        ),
    })
}
