//! Choosing a reader: by extension, and by content where an extension is shared (`.mesh` is
//! either MEDIT or the plain Brown format) or missing. Gmsh and VTK files are recognized by
//! their first bytes (`$MeshFormat`, `<?xml`/`<VTKFile`, `# vtk DataFile`) whatever their
//! extension; a `.msh`, `.vtu` or `.vtk` file that does not start so is read by the reader its
//! extension names, whose error then says what it expected.

use std::fmt;
use std::path::Path;

use serde::Serialize;

use super::{MeshError, SurfaceMesh, TetMesh, gmsh, medit, obj, plain, tetgen, text, vtk};

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
    /// Gmsh `.msh` 2.2 or 4.1, ASCII or binary (linear tets).
    #[serde(rename = "gmsh")]
    Gmsh,
    /// VTK XML unstructured grid `.vtu` (linear tets).
    #[serde(rename = "vtu")]
    Vtu,
    /// Legacy VTK `.vtk`, ASCII unstructured grid (linear tets).
    #[serde(rename = "vtk")]
    LegacyVtk,
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
            MeshFormat::Gmsh => "Gmsh .msh",
            MeshFormat::Vtu => "VTK XML .vtu",
            MeshFormat::LegacyVtk => "legacy VTK .vtk",
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
    let bytes = std::fs::read(path).map_err(|error| MeshError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    let ext = extension(path);
    if gmsh::looks_like(&bytes) || (ext.as_deref() == Some("msh") && !vtk::looks_like_vtu(&bytes)) {
        return Ok((MeshFormat::Gmsh, AnyMesh::Tet(gmsh::parse(&bytes, path)?)));
    }
    if vtk::looks_like_vtu(&bytes) || ext.as_deref() == Some("vtu") {
        let frame = vtk::parse_vtu(&bytes, path)?;
        return Ok((MeshFormat::Vtu, AnyMesh::Tet(frame.mesh)));
    }
    let content = text::decode_text(path, bytes)?;
    if vtk::looks_like_legacy(content.as_bytes()) || ext.as_deref() == Some("vtk") {
        let mesh = vtk::parse_legacy(&content, path)?;
        return Ok((MeshFormat::LegacyVtk, AnyMesh::Tet(mesh)));
    }
    let format = detect(path, &content)?;
    let mesh = match format {
        MeshFormat::Medit => AnyMesh::Tet(medit::parse(&content, path)?),
        MeshFormat::Plain => AnyMesh::Tet(plain::parse(&content, path)?),
        MeshFormat::Obj => AnyMesh::Surface(obj::parse(&content, path)?),
        // Not produced by `detect`; kept total so a future change cannot panic here.
        MeshFormat::TetGen => AnyMesh::Tet(tetgen::read(path)?),
        MeshFormat::Gmsh => AnyMesh::Tet(gmsh::parse(content.as_bytes(), path)?),
        MeshFormat::Vtu => AnyMesh::Tet(vtk::parse_vtu(content.as_bytes(), path)?.mesh),
        MeshFormat::LegacyVtk => AnyMesh::Tet(vtk::parse_legacy(&content, path)?),
    };
    Ok((format, mesh))
}

/// Reads a tet mesh: MEDIT or plain `.mesh` (told apart by content), TetGen `.node`/`.ele`,
/// Gmsh `.msh`, VTK `.vtu` or legacy `.vtk`.
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
             .mesh), `$MeshFormat` (Gmsh), `<?xml` (VTK .vtu), `# vtk DataFile` (legacy VTK), or an .obj, .node or \
             .ele extension"
        ),
    })
}
