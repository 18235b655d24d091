//! The plain `.mesh` format of the Brown CS2240/CS224 FEM stencil: one record per line,
//! `v x y z` for a vertex and `t i j k l` for a tet, no header. Indices are **0-based** and
//! refer to the `v` lines in file order. Blank lines and `#` comments are allowed; scientific
//! notation is accepted (the stencil's own regex loader does not accept it).

use std::path::Path;

use nalgebra::Vector3;

use super::text::{self, TetCollector, parse_error};
use super::{MeshError, TetMesh};

/// Reads a plain (Brown) `.mesh` file.
pub fn read(path: impl AsRef<Path>) -> Result<TetMesh, MeshError> {
    let path = path.as_ref();
    parse(&text::read_text(path)?, path)
}

/// Whether a text looks like the plain format: its first record is a `v` or `t` line.
pub fn looks_like(text: &str) -> bool {
    text::lines(text)
        .find_map(|(_, l)| l.split_ascii_whitespace().next())
        .is_some_and(|t| t == "v" || t == "t")
}

/// Parses plain `.mesh` text; `path` is used only in error messages.
pub fn parse(text: &str, path: &Path) -> Result<TetMesh, MeshError> {
    let mut positions: Vec<Vector3<f64>> = Vec::new();
    let mut tets = TetCollector::new(0, 0);
    for (line, content) in text::lines(text) {
        let mut fields = content.split_ascii_whitespace();
        let Some(kind) = fields.next() else { continue };
        match kind {
            "v" => {
                let mut xyz = [0.0; 3];
                fill(&mut fields, &mut xyz, path, line, "v x y z", |t| {
                    text::coordinate(path, line, t)
                })?;
                positions.push(xyz.into());
            }
            "t" => {
                let mut tet = [0; 4];
                fill(&mut fields, &mut tet, path, line, "t i j k l", |t| {
                    text::vertex_index(path, line, t, 0)
                })?;
                tets.push(path, line, tet)?;
            }
            other => {
                return Err(parse_error(
                    path,
                    line,
                    format!("expected a `v x y z` or `t i j k l` line, found `{other}`"),
                ));
            }
        }
    }
    let end = text::last_line(text);
    if positions.is_empty() {
        return Err(text::empty_mesh(path, end, "no `v` lines"));
    }
    if tets.tets.is_empty() {
        return Err(text::empty_mesh(path, end, "no `t` lines"));
    }
    let tets = tets.finish(path, positions.len())?;
    Ok(TetMesh { positions, tets })
}

/// Parses exactly `out.len()` fields, so a short or long line is an error naming the form.
fn fill<'a, T>(
    fields: &mut impl Iterator<Item = &'a str>,
    out: &mut [T],
    path: &Path,
    line: usize,
    form: &str,
    parse: impl Fn(&str) -> Result<T, MeshError>,
) -> Result<(), MeshError> {
    let n = out.len();
    let wrong_count = |found: usize| {
        parse_error(
            path,
            line,
            format!("expected `{form}` ({n} numbers), found {found}"),
        )
    };
    for (i, slot) in out.iter_mut().enumerate() {
        let token = fields.next().ok_or_else(|| wrong_count(i))?;
        *slot = parse(token)?;
    }
    let extra = fields.count();
    if extra > 0 {
        return Err(wrong_count(n + extra));
    }
    Ok(())
}
