//! Choosing a reader from the [format table](super::formats), by content first and extension
//! second:
//!
//! 1. A format read from its path (its mesh spans several files: TetGen's `.node` + `.ele`)
//!    that claims the file's extension reads it; the file is not opened first.
//! 2. A format whose sniffer is [sure](Sniff::Sure) of the content (Gmsh's `$MeshFormat`, VTK's
//!    `<?xml` or `# vtk DataFile`, MEDIT's `MeshVersionFormatted`) reads it, whatever the
//!    extension.
//! 3. Else the format that claims the extension; when several do (`.mesh`: MEDIT or plain),
//!    the first of them whose sniffer says [maybe](Sniff::Maybe); when none does (no
//!    extension, `.txt`), the first format whose sniffer says maybe (an `f` record: OBJ; a
//!    `v` or `t` first record: plain).
//! 4. Else the file's format is unknown, and the message says what each format's files start
//!    with.
//!
//! So a `.msh`, `.vtu` or `.vtk` file that does not start as its format does is still read by
//! the reader its extension names, whose error then says what it expected.

use std::path::Path;

use super::formats::{self, MeshFormat, Reader, Sniff};
use super::{AnyMesh, MeshError, SurfaceMesh, TetMesh, text};

/// Reads a mesh of any registered format; returns the format it was read as.
pub fn read_mesh(path: impl AsRef<Path>) -> Result<(MeshFormat, AnyMesh), MeshError> {
    let path = path.as_ref();
    // Reading a folder fails with an OS error that does not say what was given.
    if path.is_dir() {
        return Err(MeshError::Invalid {
            path: path.to_path_buf(),
            message: "is a folder (directory), not a mesh file; name a mesh file inside it".into(),
        });
    }
    let ext = extension(path);
    let formats = MeshFormat::all();
    let claims = |f: &MeshFormat| ext.as_deref().is_some_and(|e| f.claims(e));
    let by_path = formats
        .iter()
        .find(|f| matches!(f.entry().reader, Reader::Files(_)) && claims(f));
    if let Some(&format) = by_path {
        return read_as(format, path, Vec::new());
    }
    let bytes = std::fs::read(path).map_err(|error| MeshError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    let sniffed: Vec<(MeshFormat, Sniff)> = formats
        .iter()
        .map(|&f| (f, (f.entry().sniff)(&bytes)))
        .collect();
    let first = |among: &[(MeshFormat, Sniff)], sniff: Sniff| {
        among.iter().find(|(_, s)| *s == sniff).map(|&(f, _)| f)
    };
    let claimants: Vec<(MeshFormat, Sniff)> =
        sniffed.iter().copied().filter(|(f, _)| claims(f)).collect();
    let chosen = first(&sniffed, Sniff::Sure).or_else(|| match claimants.as_slice() {
        [(format, _)] => Some(*format),
        [] => first(&sniffed, Sniff::Maybe),
        several => first(several, Sniff::Maybe),
    });
    match chosen {
        Some(format) => read_as(format, path, bytes),
        None => Err(unknown_format(path, &text::decode_text(path, bytes)?)),
    }
}

/// Reads `path`, whose content is `bytes` (unread for a [`Reader::Files`] format), as `format`.
fn read_as(
    format: MeshFormat,
    path: &Path,
    bytes: Vec<u8>,
) -> Result<(MeshFormat, AnyMesh), MeshError> {
    let mesh = match format.entry().reader {
        Reader::Text(parse) => parse(&text::decode_text(path, bytes)?, path)?,
        Reader::Bytes(parse) => parse(&bytes, path)?,
        Reader::Files(read) => read(path)?,
    };
    Ok((format, mesh))
}

/// Reads a tet mesh, of any registered format that holds tets.
pub fn read_tet_mesh(path: impl AsRef<Path>) -> Result<TetMesh, MeshError> {
    let path = path.as_ref();
    match read_mesh(path)? {
        (_, AnyMesh::Tet(mesh)) => Ok(mesh),
        (format, AnyMesh::Surface(_)) => Err(MeshError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "this is a {} triangle surface, not a tet mesh",
                format.title()
            ),
        }),
    }
}

/// Reads a triangle surface (an OBJ, or any registered surface format). A tet mesh is refused rather than silently reduced to its
/// boundary; use [`TetMesh::boundary_surface`] for that.
pub fn read_surface_mesh(path: impl AsRef<Path>) -> Result<SurfaceMesh, MeshError> {
    let path = path.as_ref();
    match read_mesh(path)? {
        (_, AnyMesh::Surface(mesh)) => Ok(mesh),
        (format, AnyMesh::Tet(_)) => Err(MeshError::Invalid {
            path: path.to_path_buf(),
            message: format!(
                "this is a {} tet mesh, not a surface; read it with read_tet_mesh and \
                 take its boundary_surface()",
                format.title()
            ),
        }),
    }
}

fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
}

/// The error for a file no format recognizes: its first token, and what each format's files
/// start with.
fn unknown_format(path: &Path, content: &str) -> MeshError {
    let first = text::lines(content)
        .find_map(|(line, l)| l.split_ascii_whitespace().next().map(|t| (line, t)));
    let Some((line, token)) = first else {
        let end = text::last_line(content);
        return text::empty_mesh(path, end, "the file has no records");
    };
    MeshError::UnknownFormat {
        path: path.to_path_buf(),
        message: format!(
            "line {line} starts with `{}`; expected {}",
            excerpt(token),
            formats::expected_starts()
        ),
    }
}

/// Longest excerpt of a file quoted in the unknown-format error, in characters.
const EXCERPT_CHARS: usize = 40;

/// The start of `token`, at most [`EXCERPT_CHARS`] characters, with control and non-ASCII
/// characters escaped (`\0`, `\u{1b}`) so a binary file cannot garble the terminal; `...`
/// marks a cut.
fn excerpt(token: &str) -> String {
    let mut out: String = token
        .chars()
        .take(EXCERPT_CHARS)
        .flat_map(char::escape_debug)
        .collect();
    if token.chars().nth(EXCERPT_CHARS).is_some() {
        out.push_str("...");
    }
    out
}
