//! MEDIT ASCII `.mesh` (INRIA): `MeshVersionFormatted v`, `Dimension 3`, then sections
//! `Vertices n` (x y z ref), `Tetrahedra n` (i j k l ref), optional other sections that are read
//! past (`Triangles`, `Edges`, ...), and `End`.
//!
//! Indices are **1-based** in the file and 0-based in the returned [`TetMesh`]. Keywords are
//! case-insensitive, `#` starts a comment, numbers may use scientific notation, and the file is
//! read as a token stream, so a count may sit on the keyword's line or the next one and a record
//! may span lines. A missing `End` is accepted at end of file (every section before it was
//! complete, or reading would have failed). Only `Dimension 3` is supported.

use std::path::Path;

use super::text::{self, TetCollector, Tokens, parse_error};
use super::{MeshError, TetMesh};

/// Sections that are read past: keyword and the number of tokens per entry (in 3D).
const SKIPPED_SECTIONS: [(&str, usize); 12] = [
    ("Edges", 3),
    ("Triangles", 4),
    ("Quadrilaterals", 5),
    ("Hexahedra", 9),
    ("Corners", 1),
    ("Ridges", 1),
    ("RequiredVertices", 1),
    ("RequiredEdges", 1),
    ("RequiredTriangles", 1),
    ("Normals", 3),
    ("NormalAtVertices", 2),
    ("Tangents", 3),
];

/// Reads a MEDIT `.mesh` file.
pub fn read(path: impl AsRef<Path>) -> Result<TetMesh, MeshError> {
    let path = path.as_ref();
    parse(&text::read_text(path)?, path)
}

/// Whether a text looks like MEDIT: its first token (after comments) is `MeshVersionFormatted`.
pub fn looks_like(text: &str) -> bool {
    Tokens::new(text)
        .next()
        .is_some_and(|(_, t)| t.eq_ignore_ascii_case("MeshVersionFormatted"))
}

/// Parses MEDIT text; `path` is used only in error messages.
pub fn parse(text: &str, path: &Path) -> Result<TetMesh, MeshError> {
    let mut tokens = Tokens::new(text);
    let err = |line, msg: String| parse_error(path, line, msg);

    match tokens.next() {
        Some((_, t)) if t.eq_ignore_ascii_case("MeshVersionFormatted") => {}
        Some((line, t)) => {
            return Err(err(
                line,
                format!("expected `MeshVersionFormatted` to start a MEDIT file, found `{t}`"),
            ));
        }
        None => return Err(text::empty_mesh(path, 1, "the file has no content")),
    }
    let (line, version) = next_token(&mut tokens, path, "the format version")?;
    text::integer(path, line, version, "format version")?;

    let mut positions = None;
    let mut tets: Option<TetCollector> = None;
    let mut tets_line = 0;
    while let Some((line, keyword)) = tokens.next() {
        if keyword.eq_ignore_ascii_case("End") {
            break;
        } else if keyword.eq_ignore_ascii_case("Dimension") {
            let (l, d) = next_token(&mut tokens, path, "the dimension")?;
            if text::integer(path, l, d, "dimension")? != 3 {
                return Err(err(
                    l,
                    format!("only `Dimension 3` is supported, found `{d}`"),
                ));
            }
        } else if keyword.eq_ignore_ascii_case("Vertices") {
            if positions.is_some() {
                return Err(err(line, "a second `Vertices` section".into()));
            }
            positions = Some(read_vertices(&mut tokens, path, line)?);
        } else if keyword.eq_ignore_ascii_case("Tetrahedra") {
            if tets.is_some() {
                return Err(err(line, "a second `Tetrahedra` section".into()));
            }
            tets_line = line;
            tets = Some(read_tets(&mut tokens, path, line)?);
        } else if let Some(&(name, width)) = SKIPPED_SECTIONS
            .iter()
            .find(|(name, _)| keyword.eq_ignore_ascii_case(name))
        {
            skip_section(&mut tokens, path, line, name, width)?;
        } else if keyword.parse::<f64>().is_ok() {
            return Err(err(
                line,
                format!(
                    "expected a section keyword, found the number `{keyword}`: \
                     does the previous section's count match its number of entries?"
                ),
            ));
        } else {
            return Err(err(
                line,
                format!(
                    "unknown MEDIT keyword `{keyword}` (known: Dimension, Vertices, \
                     Tetrahedra, End, and the skipped sections {})",
                    SKIPPED_SECTIONS.map(|(n, _)| n).join(", ")
                ),
            ));
        }
    }

    let end = tokens.line();
    let positions =
        positions.ok_or_else(|| text::empty_mesh(path, end, "no `Vertices` section"))?;
    let tets = tets.ok_or_else(|| text::empty_mesh(path, end, "no `Tetrahedra` section"))?;
    if positions.is_empty() {
        return Err(text::empty_mesh(
            path,
            end,
            "the `Vertices` section is empty",
        ));
    }
    if tets.tets.is_empty() {
        return Err(text::empty_mesh(
            path,
            tets_line,
            "the `Tetrahedra` section is empty",
        ));
    }
    let tets = tets.finish(path, positions.len())?;
    Ok(TetMesh { positions, tets })
}

/// The next token, or a truncation error naming what was expected.
fn next_token<'a>(
    tokens: &mut Tokens<'a>,
    path: &Path,
    what: &str,
) -> Result<(usize, &'a str), MeshError> {
    tokens.next().ok_or_else(|| {
        parse_error(
            path,
            tokens.line(),
            format!("file ends where {what} was expected"),
        )
    })
}

/// Reads a section's entry count.
fn section_count(tokens: &mut Tokens, path: &Path, name: &str) -> Result<usize, MeshError> {
    let (line, t) = next_token(tokens, path, &format!("the `{name}` count"))?;
    text::count(path, line, t, &format!("`{name}` count"))
}

/// The next token of entry `i` of a section, with a truncation error that says how far the
/// section got.
fn entry_token<'a>(
    tokens: &mut Tokens<'a>,
    path: &Path,
    name: &str,
    start_line: usize,
    i: usize,
    n: usize,
) -> Result<(usize, &'a str), MeshError> {
    tokens.next().ok_or_else(|| {
        parse_error(
            path,
            tokens.line(),
            format!(
                "file ends inside the `{name}` section: it holds {i} complete entries of the \
                 {n} announced at line {start_line}"
            ),
        )
    })
}

fn read_vertices(
    tokens: &mut Tokens,
    path: &Path,
    start_line: usize,
) -> Result<Vec<nalgebra::Vector3<f64>>, MeshError> {
    let n = section_count(tokens, path, "Vertices")?;
    let capacity = text::announced(path, tokens.line(), n, "vertices", tokens.text_len)?;
    let mut positions = Vec::with_capacity(capacity);
    for i in 0..n {
        let mut xyz = [0.0; 3];
        for x in &mut xyz {
            let (line, t) = entry_token(tokens, path, "Vertices", start_line, i, n)?;
            *x = text::coordinate(path, line, t)
                .map_err(|e| in_entry(e, "Vertices", start_line, i, n))?;
        }
        let (line, t) = entry_token(tokens, path, "Vertices", start_line, i, n)?;
        text::integer(path, line, t, "vertex reference")
            .map_err(|e| in_entry(e, "Vertices", start_line, i, n))?;
        positions.push(xyz.into());
    }
    Ok(positions)
}

fn read_tets(
    tokens: &mut Tokens,
    path: &Path,
    start_line: usize,
) -> Result<TetCollector, MeshError> {
    let n = section_count(tokens, path, "Tetrahedra")?;
    let capacity = text::announced(path, tokens.line(), n, "tets", tokens.text_len)?;
    let mut tets = TetCollector::new(1, capacity);
    for i in 0..n {
        let mut tet = [0; 4];
        let mut first_line = 0;
        for (k, v) in tet.iter_mut().enumerate() {
            let (line, t) = entry_token(tokens, path, "Tetrahedra", start_line, i, n)?;
            if k == 0 {
                first_line = line;
            }
            *v = text::vertex_index(path, line, t, 1)
                .map_err(|e| in_entry(e, "Tetrahedra", start_line, i, n))?;
        }
        let (line, t) = entry_token(tokens, path, "Tetrahedra", start_line, i, n)?;
        text::integer(path, line, t, "tet reference")
            .map_err(|e| in_entry(e, "Tetrahedra", start_line, i, n))?;
        tets.push(path, first_line, tet)?;
    }
    Ok(tets)
}

fn skip_section(
    tokens: &mut Tokens,
    path: &Path,
    start_line: usize,
    name: &str,
    width: usize,
) -> Result<(), MeshError> {
    let n = section_count(tokens, path, name)?;
    for i in 0..n {
        for _ in 0..width {
            let (line, t) = entry_token(tokens, path, name, start_line, i, n)?;
            if t.parse::<f64>().is_err() {
                let e = parse_error(path, line, format!("expected a number, found `{t}`"));
                return Err(in_entry(e, name, start_line, i, n));
            }
        }
    }
    Ok(())
}

/// Adds "which entry of which section" to a parse error, since a wrong count shows up as a
/// keyword where a number was expected.
fn in_entry(e: MeshError, name: &str, start_line: usize, i: usize, n: usize) -> MeshError {
    match e {
        MeshError::Parse {
            path,
            line,
            message,
        } => MeshError::Parse {
            path,
            line,
            message: format!(
                "{message} (entry {} of the `{name}` section that starts at line {start_line} \
                 and announces {n} entries)",
                i + 1
            ),
        },
        other => other,
    }
}
