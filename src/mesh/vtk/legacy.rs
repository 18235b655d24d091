//! Legacy ASCII VTK (`.vtk`) unstructured grids of linear tets: `DATASET UNSTRUCTURED_GRID`,
//! the `CELLS n size` layout of versions up to 4.2 and the `OFFSETS`/`CONNECTIVITY` layout of
//! 5.1. `BINARY` files are refused with a message saying so, and so is a second `POINTS`,
//! `CELLS` or `CELL_TYPES`, a 4.2 cell list whose counts do not use exactly its announced
//! size, and 5.1 `OFFSETS` that do not start at 0.

use std::path::Path;

use nalgebra::Vector3;

use super::super::bytes::{bad_coordinate, clip};
use super::super::text::{self, Tokens, parse_error};
use super::super::{MeshError, TetMesh};
use super::cells::cells;

/// Whether a text looks like legacy VTK (`# vtk DataFile` first).
pub fn looks_like_legacy(bytes: &[u8]) -> bool {
    bytes.starts_with(b"# vtk DataFile")
}

/// Reads a legacy ASCII `.vtk` file.
pub fn read_legacy(path: impl AsRef<Path>) -> Result<TetMesh, MeshError> {
    let path = path.as_ref();
    parse_legacy(&text::read_text(path)?, path)
}

/// Parses legacy ASCII `.vtk` text; `path` is used only in error messages.
pub fn parse_legacy(content: &str, path: &Path) -> Result<TetMesh, MeshError> {
    let mut lines = content.split('\n');
    let header = lines.next().unwrap_or("").trim();
    let Some(version) = header.strip_prefix("# vtk DataFile Version") else {
        return Err(parse_error(
            path,
            1,
            "expected `# vtk DataFile Version x.y` to start a legacy VTK file",
        ));
    };
    let major: u32 = version
        .trim()
        .split('.')
        .next()
        .and_then(|v| v.parse().ok())
        .ok_or_else(|| parse_error(path, 1, format!("unreadable version `{}`", clip(version))))?;
    // Line 2 is a free-form title; tokens start at line 3, with line numbers kept.
    let skip = content
        .match_indices('\n')
        .nth(1)
        .map_or(content.len(), |(i, _)| i);
    let body = format!("\n{}", &content[skip..]);
    let mut tokens = Tokens::new(&body);
    let t = &mut tokens;
    let len = content.len();
    let (line, encoding) = tok(t, path, "ASCII or BINARY")?;
    if !encoding.eq_ignore_ascii_case("ASCII") {
        return Err(parse_error(
            path,
            line,
            format!(
                "`{}`: only ASCII legacy VTK is read (write binary grids as .vtu)",
                clip(encoding)
            ),
        ));
    }
    let (line, dataset) = tok(t, path, "DATASET")?;
    let (_, kind) = tok(t, path, "the dataset type")?;
    if !dataset.eq_ignore_ascii_case("DATASET") || !kind.eq_ignore_ascii_case("UNSTRUCTURED_GRID") {
        return Err(parse_error(
            path,
            line,
            format!(
                "expected `DATASET UNSTRUCTURED_GRID`, found `{} {}`",
                clip(dataset),
                clip(kind)
            ),
        ));
    }
    let mut points = None;
    let mut cell_data: Option<(Vec<f64>, Vec<f64>, [usize; 2])> = None;
    let mut types = None;
    while let Some((line, keyword)) = t.next() {
        match keyword.to_ascii_uppercase().as_str() {
            "POINTS" => {
                once(points.is_some(), path, line, "POINTS")?;
                let n = count(t, path, "the number of points", len)?;
                tok(t, path, "the point data type")?;
                let (_, xyz) = numbers(t, path, 3 * n, "a coordinate", len)?;
                let mut p = Vec::with_capacity(n);
                for (k, x) in xyz.chunks_exact(3).enumerate() {
                    if let Some(msg) = x.iter().find_map(|&v| bad_coordinate(v)) {
                        return Err(parse_error(path, line, format!("point {k}: {msg}")));
                    }
                    p.push(Vector3::new(x[0], x[1], x[2]));
                }
                points = Some(p);
            }
            "CELLS" => {
                once(cell_data.is_some(), path, line, "CELLS")?;
                let a = count(t, path, "the number of cells", len)?;
                let b = count(t, path, "the size of the cell list", len)?;
                if major >= 5 {
                    keyword_token(t, path, "OFFSETS")?;
                    tok(t, path, "the offsets' data type")?;
                    let (ol, offsets) = numbers(t, path, a, "an offset", len)?;
                    keyword_token(t, path, "CONNECTIVITY")?;
                    tok(t, path, "the connectivity's data type")?;
                    let (cl, conn) = numbers(t, path, b, "a point index", len)?;
                    // 5.1 offsets start with 0 and end at the connectivity's length; the XML
                    // form lists cell ends.
                    if offsets.first().is_some_and(|&o| o != 0.0) {
                        return Err(parse_error(
                            path,
                            ol,
                            format!(
                                "OFFSETS starts at {}; legacy VTK 5 offsets start at 0",
                                offsets[0]
                            ),
                        ));
                    }
                    if a == 0 && b != 0 {
                        return Err(parse_error(
                            path,
                            line,
                            "CELLS announces no offsets but a connectivity: 5.x files list \
                             one offset more than there are cells, starting at 0",
                        ));
                    }
                    let ends = offsets.get(1..).unwrap_or(&[]).to_vec();
                    cell_data = Some((conn, ends, [cl, ol]));
                } else {
                    let (cl, list) = numbers(t, path, b, "a cell entry", len)?;
                    let (mut conn, mut ends) = (Vec::new(), Vec::with_capacity(a));
                    let mut i = 0usize;
                    for c in 0..a {
                        // A per-cell count must be an integer that fits in what is left.
                        let k = list.get(i).copied().unwrap_or(-1.0);
                        let left = list.len() - i.min(list.len());
                        if !(k >= 0.0 && k.fract() == 0.0 && k < left as f64) {
                            return Err(parse_error(
                                path,
                                cl,
                                format!(
                                    "cell {c}: its point count `{k}` is not a count that fits in \
                                     the {b} entries CELLS announces (each cell is `n` then \
                                     its `n` point indices)"
                                ),
                            ));
                        }
                        let k = k as usize;
                        conn.extend_from_slice(&list[i + 1..i + 1 + k]);
                        i += 1 + k;
                        ends.push(conn.len() as f64);
                    }
                    if i != list.len() {
                        return Err(parse_error(
                            path,
                            line,
                            format!(
                                "CELLS announces a list of {b} entries, but its {a} cells use \
                                 {i}: the size must be the number of cells plus their point \
                                 indices"
                            ),
                        ));
                    }
                    cell_data = Some((conn, ends, [cl, cl]));
                }
            }
            "CELL_TYPES" => {
                once(types.is_some(), path, line, "CELL_TYPES")?;
                let n = count(t, path, "the number of cell types", len)?;
                types = Some(numbers(t, path, n, "a cell type", len)?);
            }
            "POINT_DATA" | "CELL_DATA" | "FIELD" | "METADATA" => break,
            _ => {
                return Err(parse_error(
                    path,
                    line,
                    format!(
                        "unexpected `{}` (expected POINTS, CELLS, CELL_TYPES, POINT_DATA or \
                         CELL_DATA)",
                        clip(keyword)
                    ),
                ));
            }
        }
    }
    let end = text::last_line(content);
    let points = points.ok_or_else(|| text::empty_mesh(path, end, "no POINTS"))?;
    let (conn, ends, [cl, ol]) =
        cell_data.ok_or_else(|| text::empty_mesh(path, end, "no CELLS"))?;
    let (tl, types) = types.ok_or_else(|| text::empty_mesh(path, end, "no CELL_TYPES"))?;
    if types.len() != ends.len() {
        return Err(parse_error(
            path,
            tl,
            format!("{} cell types for {} cells", types.len(), ends.len()),
        ));
    }
    let tets = cells(path, &conn, &ends, &types, [cl, ol, tl], points.len())?;
    Ok(TetMesh {
        positions: points,
        tets,
    })
}

/// Refuses a second section `word`: a file has one of each.
fn once(seen: bool, path: &Path, line: usize, word: &str) -> Result<(), MeshError> {
    if seen {
        Err(parse_error(
            path,
            line,
            format!("a second `{word}` section: a legacy VTK grid has one"),
        ))
    } else {
        Ok(())
    }
}

/// The next legacy token, or an error saying the file ends where `what` was expected.
fn tok<'a>(t: &mut Tokens<'a>, path: &Path, what: &str) -> Result<(usize, &'a str), MeshError> {
    let line = t.line();
    t.next()
        .ok_or_else(|| parse_error(path, line, format!("file ends where {what} was expected")))
}

/// Expects the keyword `word` (any case).
fn keyword_token(t: &mut Tokens, path: &Path, word: &str) -> Result<(), MeshError> {
    let (line, found) = tok(t, path, word)?;
    if found.eq_ignore_ascii_case(word) {
        Ok(())
    } else {
        Err(parse_error(
            path,
            line,
            format!("expected `{word}`, found `{}`", clip(found)),
        ))
    }
}

/// A count, checked against the mesh budget.
fn count(t: &mut Tokens, path: &Path, what: &str, len: usize) -> Result<usize, MeshError> {
    let (line, token) = tok(t, path, what)?;
    let n = text::count(path, line, token, what)?;
    text::announced(path, line, n, what, len)?;
    Ok(n)
}

/// `n` numbers and the line of the first.
fn numbers(
    t: &mut Tokens,
    path: &Path,
    n: usize,
    what: &str,
    len: usize,
) -> Result<(usize, Vec<f64>), MeshError> {
    let mut values = Vec::with_capacity(n.min(len / 2 + 1));
    let mut first = t.line();
    for i in 0..n {
        let (line, token) = tok(t, path, what)?;
        if i == 0 {
            first = line;
        }
        let x = token.parse::<f64>().map_err(|_| {
            parse_error(
                path,
                line,
                format!("expected {what}, found `{}`", clip(token)),
            )
        })?;
        values.push(x);
    }
    Ok((first, values))
}
