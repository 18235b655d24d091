//! Legacy VTK (`.vtk`) unstructured grids of linear tets, ASCII or BINARY (big-endian, as
//! VTK and meshio write them by default): `DATASET UNSTRUCTURED_GRID`, `POINTS`, then the
//! cells in the `CELLS n size` layout of versions up to 4.2 or the `OFFSETS`/`CONNECTIVITY`
//! layout of 5.1, then `CELL_TYPES`. `METADATA` blocks (which VTK writes after arrays with
//! information keys, so a file it has read and written again has them) and dataset `FIELD`
//! data are read past wherever they come; reading stops at `POINT_DATA` or `CELL_DATA`.
//! `legacy_arrays.rs` reads the values.
//!
//! Refused with a message saying so: another dataset type, a second `POINTS`, `CELLS` or
//! `CELL_TYPES`, a 4.2 cell list whose counts do not use exactly its announced size, and 5.1
//! `OFFSETS` that do not start at 0.

use std::path::Path;

use nalgebra::Vector3;

use super::super::bytes::{Cursor, bad_coordinate, clip};
use super::super::text::{self, parse_error};
use super::super::{MeshError, TetMesh};
use super::cells::cells;
use super::legacy_arrays::{Reader, Scalar};

/// Whether bytes look like legacy VTK (`# vtk DataFile` first).
pub fn looks_like_legacy(bytes: &[u8]) -> bool {
    bytes.starts_with(b"# vtk DataFile")
}

/// Reads a legacy `.vtk` file (ASCII or BINARY).
pub fn read_legacy(path: impl AsRef<Path>) -> Result<TetMesh, MeshError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|error| MeshError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    parse_legacy(&bytes, path)
}

/// Parses legacy `.vtk` bytes (ASCII or BINARY); `path` is used only in error messages.
pub fn parse_legacy(bytes: &[u8], path: &Path) -> Result<TetMesh, MeshError> {
    let mut c = Cursor::new(bytes, path);
    let header = match c.line()? {
        Some((_, line)) => line,
        None => "",
    };
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
    // Line 2 is a free-form title (any bytes).
    let rest = &bytes[c.pos..];
    c.pos += rest
        .iter()
        .position(|&b| b == b'\n')
        .map_or(rest.len(), |i| i + 1);
    let mut r = Reader { c, binary: false };
    let (at, encoding) = r.word("ASCII or BINARY")?;
    r.binary = if encoding.eq_ignore_ascii_case("ASCII") {
        false
    } else if encoding.eq_ignore_ascii_case("BINARY") {
        true
    } else {
        return Err(r.c.error_at(
            at,
            format!("expected ASCII or BINARY, found `{}`", clip(encoding)),
        ));
    };
    let (at, dataset) = r.word("DATASET")?;
    let (_, kind) = r.word("the dataset type")?;
    if !dataset.eq_ignore_ascii_case("DATASET") || !kind.eq_ignore_ascii_case("UNSTRUCTURED_GRID") {
        return Err(r.c.error_at(
            at,
            format!(
                "expected `DATASET UNSTRUCTURED_GRID`, found `{} {}` (only unstructured \
                 grids hold tets)",
                clip(dataset),
                clip(kind)
            ),
        ));
    }
    let mut points = None;
    let mut cell_data: Option<CellList> = None;
    let mut types = None;
    while let Some((at, keyword)) = r.next_word()? {
        let line = r.c.line_at(at);
        match keyword.to_ascii_uppercase().as_str() {
            "POINTS" => {
                once(points.is_some(), path, line, "POINTS")?;
                let n = r.count("the number of points")?;
                let ty = r.scalar("the point data type")?;
                let (_, xyz) = r.values(ty, 3 * n, "POINTS", "a coordinate")?;
                let mut p = Vec::with_capacity(n);
                for (k, x) in xyz.chunks_exact(3).enumerate() {
                    if let Some(msg) = x.iter().find_map(|&v| bad_coordinate(v)) {
                        return Err(parse_error(path, line, format!("point {k}: {msg}")));
                    }
                    p.push(Vector3::new(x[0], x[1], x[2]));
                }
                points = Some(p);
                r.skip_metadata()?;
            }
            "CELLS" => {
                once(cell_data.is_some(), path, line, "CELLS")?;
                let a = r.count("the number of cells")?;
                let b = r.count("the size of the cell list")?;
                cell_data = Some(if major >= 5 {
                    cells_51(&mut r, path, line, a, b)?
                } else {
                    cells_42(&mut r, path, line, a, b)?
                });
            }
            "CELL_TYPES" => {
                once(types.is_some(), path, line, "CELL_TYPES")?;
                let n = r.count("the number of cell types")?;
                // VTK writes cell types as 32-bit ints.
                types = Some(r.values(Scalar::I32, n, "CELL_TYPES", "a cell type")?);
                r.skip_metadata()?;
            }
            "FIELD" => r.skip_field()?,
            "METADATA" => r.skip_metadata_block(),
            "POINT_DATA" | "CELL_DATA" => break,
            _ => {
                return Err(parse_error(
                    path,
                    line,
                    format!(
                        "unexpected `{}` (expected POINTS, CELLS, CELL_TYPES, FIELD, METADATA, \
                         POINT_DATA or CELL_DATA)",
                        clip(keyword)
                    ),
                ));
            }
        }
    }
    let end = r.c.line_at(bytes.len());
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

/// A `CELLS` section as XML lists cells: the connectivity, each cell's end in it, and the
/// lines of the connectivity and of the ends (offsets or counts).
type CellList = (Vec<f64>, Vec<f64>, [usize; 2]);

/// Connectivity, cell ends and their lines from a 5.x `CELLS a b` section (`a` offsets
/// starting at 0, `b` connectivity entries, each an array with a type).
fn cells_51(
    r: &mut Reader,
    path: &Path,
    line: usize,
    a: usize,
    b: usize,
) -> Result<CellList, MeshError> {
    r.keyword("OFFSETS")?;
    let ty = r.scalar("the offsets' data type")?;
    let (ol, offsets) = r.values(ty, a, "OFFSETS", "an offset")?;
    r.skip_metadata()?;
    r.keyword("CONNECTIVITY")?;
    let ty = r.scalar("the connectivity's data type")?;
    let (cl, conn) = r.values(ty, b, "CONNECTIVITY", "a point index")?;
    r.skip_metadata()?;
    // 5.1 offsets start with 0 and end at the connectivity's length; the XML form lists cell
    // ends.
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
            "CELLS announces no offsets but a connectivity: 5.x files list one offset more \
             than there are cells, starting at 0",
        ));
    }
    let ends = offsets.get(1..).unwrap_or(&[]).to_vec();
    Ok((conn, ends, [cl, ol]))
}

/// Connectivity, cell ends and their lines from a 4.x `CELLS a b` section: `b` 32-bit ints,
/// each cell its point count then its point indices.
fn cells_42(
    r: &mut Reader,
    path: &Path,
    line: usize,
    a: usize,
    b: usize,
) -> Result<CellList, MeshError> {
    let (cl, list) = r.values(Scalar::I32, b, "CELLS", "a cell entry")?;
    let (mut conn, mut ends) = (Vec::new(), Vec::with_capacity(a.min(list.len())));
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
                    "cell {c}: its point count `{k}` is not a count that fits in the {b} \
                     entries CELLS announces (each cell is `n` then its `n` point indices)"
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
                "CELLS announces a list of {b} entries, but its {a} cells use {i}: the size \
                 must be the number of cells plus their point indices"
            ),
        ));
    }
    Ok((conn, ends, [cl, cl]))
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
