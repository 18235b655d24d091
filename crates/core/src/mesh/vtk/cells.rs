//! The tets among VTK cells, which both VTK formats list the same way (connectivity, offsets,
//! cell types): cells of type 10 (`VTK_TETRA`) become the tets; other linear cells (vertices,
//! lines, triangles) are read past; quadratic tets (24) are refused, and so is a type that is
//! not an exact integer from 0 to 255, or offsets that do not end at the connectivity's end.

use std::path::Path;

use super::super::MeshError;
use super::super::text::{self, TetCollector, parse_error};

/// VTK's linear tetrahedron.
const VTK_TETRA: i64 = 10;
/// The largest VTK cell type (VTK stores them as an unsigned char).
const MAX_CELL_TYPE: f64 = 255.0;
/// VTK's quadratic tetrahedron.
const VTK_QUADRATIC_TETRA: i64 = 24;

/// The tets among VTK cells given as connectivity, offsets (the end of each cell in the
/// connectivity, as in XML) and types.
pub(super) fn cells(
    path: &Path,
    connectivity: &[f64],
    offsets: &[f64],
    types: &[f64],
    [cl, ol, tl]: [usize; 3],
    num_points: usize,
) -> Result<Vec<[usize; 4]>, MeshError> {
    let index = |x: f64, line: usize, what: &str| -> Result<usize, MeshError> {
        if x.fract() == 0.0 && x >= 0.0 && x < usize::MAX as f64 {
            Ok(x as usize)
        } else {
            Err(parse_error(
                path,
                line,
                format!("{what} {x} is not a valid index"),
            ))
        }
    };
    let mut tets = TetCollector::new(0, types.len().min(connectivity.len() / 4));
    let mut start = 0usize;
    for (i, &kind) in types.iter().enumerate() {
        let end = index(offsets[i], ol, "offset")?;
        if end < start || end > connectivity.len() {
            return Err(parse_error(
                path,
                ol,
                format!(
                    "cell {i}: offset {end} is out of order or beyond the {} connectivity entries",
                    connectivity.len()
                ),
            ));
        }
        // VTK cell types are small integers (an unsigned char); anything else is not a cell.
        if !(kind.fract() == 0.0 && (0.0..=MAX_CELL_TYPE).contains(&kind)) {
            return Err(parse_error(
                path,
                tl,
                format!(
                    "cell {i}: cell type `{kind}` is not a VTK cell type (an integer from 0 to \
                     255; a linear tet is 10)"
                ),
            ));
        }
        let kind = kind as i64;
        if kind == VTK_QUADRATIC_TETRA {
            return Err(parse_error(
                path,
                tl,
                format!(
                    "cell {i} is a quadratic tet (type 24); only linear tets (10) are supported"
                ),
            ));
        }
        if kind == VTK_TETRA {
            if end - start != 4 {
                return Err(parse_error(
                    path,
                    ol,
                    format!("cell {i} is a tet with {} vertices", end - start),
                ));
            }
            let mut tet = [0; 4];
            for (slot, &x) in tet.iter_mut().zip(&connectivity[start..end]) {
                *slot = index(x, cl, "connectivity entry")?;
            }
            tets.push(path, cl, tet)?;
        }
        start = end;
    }
    if start != connectivity.len() {
        return Err(parse_error(
            path,
            ol,
            format!(
                "the cells end at connectivity entry {start}, but the connectivity holds {} \
                 entries",
                connectivity.len()
            ),
        ));
    }
    if tets.tets.is_empty() {
        return Err(text::empty_mesh(path, tl, "no tets (cell type 10)"));
    }
    tets.finish(path, num_points)
}
