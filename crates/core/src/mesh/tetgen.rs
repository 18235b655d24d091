//! TetGen ASCII `.node` + `.ele`.
//!
//! `.node`: header `n 3 attributes markers`, then `id x y z [attributes...] [marker]`.
//! `.ele`: header `m nodes_per_tet attributes`, then `id i j k l [more nodes] [attributes...]`.
//! The index base (0 or 1) is the first point id, and the `.ele` indices use it too. Point ids
//! must be consecutive from there (TetGen writes them so; anything else would make `.ele`
//! indices ambiguous). Attribute and boundary-marker columns are checked to be numbers and
//! skipped. For 10-node (quadratic) tets only the 4 corners, which come first, are kept.
//! `#` starts a comment.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::text::{self, TetCollector, parse_error};
use super::{MeshError, TetMesh};

/// Reads a TetGen mesh given the path of either its `.node` or its `.ele` file; the other one
/// must sit next to it with the same stem.
pub fn read(path: impl AsRef<Path>) -> Result<TetMesh, MeshError> {
    let path = path.as_ref();
    let (node_path, ele_path) = companion_paths(path);
    let companion = if path == ele_path {
        &node_path
    } else {
        &ele_path
    };
    let read_both = |p: &Path| {
        text::read_text(p).map_err(|e| match e {
            MeshError::Io { error, .. } if p == companion => MeshError::MissingCompanion {
                path: path.to_path_buf(),
                companion: companion.clone(),
                error,
            },
            other => other,
        })
    };
    let node_text = read_both(&node_path)?;
    let ele_text = read_both(&ele_path)?;
    parse(&node_text, &node_path, &ele_text, &ele_path)
}

/// The `.node` and `.ele` paths that belong to `path`.
pub fn companion_paths(path: &Path) -> (PathBuf, PathBuf) {
    (path.with_extension("node"), path.with_extension("ele"))
}

/// Parses the two texts; the paths are used only in error messages.
pub fn parse(
    node_text: &str,
    node_path: &Path,
    ele_text: &str,
    ele_path: &Path,
) -> Result<TetMesh, MeshError> {
    let (positions, base) = parse_nodes(node_text, node_path)?;
    let tets = parse_elements(ele_text, ele_path, base)?;
    let tets = tets.finish(ele_path, positions.len())?;
    Ok(TetMesh { positions, tets })
}

/// A header or data line split into fields, with its line number.
type Record<'a> = (usize, Vec<&'a str>);

/// The non-blank lines of a text as fields.
fn records(text: &str) -> impl Iterator<Item = Record<'_>> {
    text::lines(text).filter_map(|(line, content)| {
        let fields: Vec<&str> = content.split_ascii_whitespace().collect();
        (!fields.is_empty()).then_some((line, fields))
    })
}

/// Parses the header line: `min..=max` integer fields.
fn header(
    record: Option<Record>,
    path: &Path,
    text: &str,
    form: &str,
    (min, max): (usize, usize),
) -> Result<(usize, Vec<usize>), MeshError> {
    let (line, fields) =
        record.ok_or_else(|| text::empty_mesh(path, text::last_line(text), "no header line"))?;
    if fields.len() < min || fields.len() > max {
        return Err(parse_error(
            path,
            line,
            format!("expected a header `{form}`, found {} fields", fields.len()),
        ));
    }
    let values = fields
        .iter()
        .map(|t| text::count(path, line, t, "header field"))
        .collect::<Result<Vec<_>, _>>()?;
    Ok((line, values))
}

/// Checks a data line's field count and that the entry list has not run past the header.
fn check_record(
    path: &Path,
    line: usize,
    fields: &[&str],
    expected: usize,
    i: usize,
    n: usize,
    form: &str,
) -> Result<(), MeshError> {
    if i >= n {
        return Err(parse_error(
            path,
            line,
            format!("more entries than the header's count {n}"),
        ));
    }
    if fields.len() != expected {
        return Err(parse_error(
            path,
            line,
            format!(
                "expected {expected} fields ({form}, as the header says), found {}",
                fields.len()
            ),
        ));
    }
    Ok(())
}

fn truncated(path: &Path, text: &str, what: &str, i: usize, n: usize) -> MeshError {
    parse_error(
        path,
        text::last_line(text),
        format!("file ends after {i} {what}, but the header announces {n}"),
    )
}

/// Most attributes a header may announce per entry (TetGen writes a handful).
const MAX_ATTRIBUTES: usize = 1 << 16;

/// Fields per data line: `fixed` plus the header's attribute count, which is checked (a huge
/// count would otherwise wrap the sum and let short lines through).
fn line_width(
    path: &Path,
    line: usize,
    fixed: usize,
    attributes: usize,
) -> Result<usize, MeshError> {
    if attributes > MAX_ATTRIBUTES {
        return Err(parse_error(
            path,
            line,
            format!(
                "the header announces {attributes} attributes per entry; at most {MAX_ATTRIBUTES}"
            ),
        ));
    }
    Ok(fixed + attributes)
}

/// Parses a `.node` file; returns positions and the index base.
fn parse_nodes(text: &str, path: &Path) -> Result<(Vec<Vector3<f64>>, usize), MeshError> {
    let mut records = records(text);
    let (line, h) = header(
        records.next(),
        path,
        text,
        "points 3 attributes markers",
        (2, 4),
    )?;
    let (n, dim) = (h[0], h[1]);
    let attributes = h.get(2).copied().unwrap_or(0);
    let markers = h.get(3).copied().unwrap_or(0);
    if dim != 3 {
        return Err(parse_error(
            path,
            line,
            format!("dimension must be 3, found {dim}"),
        ));
    }
    if markers > 1 {
        return Err(parse_error(
            path,
            line,
            format!("the boundary-marker flag must be 0 or 1, found {markers}"),
        ));
    }
    if n == 0 {
        return Err(text::empty_mesh(
            path,
            line,
            "the header announces 0 points",
        ));
    }
    let width = line_width(path, line, 4 + markers, attributes)?;
    let form = "id x y z, then attributes and marker";
    let capacity = text::announced(path, line, n, "points", text.len())?;
    let mut positions = Vec::with_capacity(capacity);
    let mut base = 0;
    for (i, (line, fields)) in records.enumerate() {
        check_record(path, line, &fields, width, i, n, form)?;
        let id = text::integer(path, line, fields[0], "point id")?;
        if i == 0 {
            if id != 0 && id != 1 {
                return Err(parse_error(
                    path,
                    line,
                    format!("the first point id must be 0 or 1 (the index base), found {id}"),
                ));
            }
            base = id as usize;
        } else if id != (base + i) as i64 {
            return Err(parse_error(
                path,
                line,
                format!(
                    "point ids must be consecutive: expected {}, found {id}",
                    base + i
                ),
            ));
        }
        let mut xyz = [0.0; 3];
        for (x, t) in xyz.iter_mut().zip(&fields[1..4]) {
            *x = text::coordinate(path, line, t)?;
        }
        for t in &fields[4..] {
            if t.parse::<f64>().is_err() {
                return Err(parse_error(
                    path,
                    line,
                    format!("expected a number (attribute or marker), found `{t}`"),
                ));
            }
        }
        positions.push(xyz.into());
    }
    if positions.len() < n {
        return Err(truncated(path, text, "points", positions.len(), n));
    }
    Ok((positions, base))
}

/// Parses an `.ele` file with the index base of its `.node` file.
fn parse_elements(text: &str, path: &Path, base: usize) -> Result<TetCollector, MeshError> {
    let mut records = records(text);
    let (line, h) = header(
        records.next(),
        path,
        text,
        "tets nodes_per_tet attributes",
        (2, 3),
    )?;
    let (m, per_tet) = (h[0], h[1]);
    let attributes = h.get(2).copied().unwrap_or(0);
    if per_tet != 4 && per_tet != 10 {
        return Err(parse_error(
            path,
            line,
            format!("nodes per tet must be 4 or 10, found {per_tet}"),
        ));
    }
    if m == 0 {
        return Err(text::empty_mesh(path, line, "the header announces 0 tets"));
    }
    let width = line_width(path, line, 1 + per_tet, attributes)?;
    let form = "id, node indices, then attributes";
    let capacity = text::announced(path, line, m, "tets", text.len())?;
    let mut tets = TetCollector::new(base, capacity);
    let mut count = 0;
    for (i, (line, fields)) in records.enumerate() {
        check_record(path, line, &fields, width, i, m, form)?;
        text::integer(path, line, fields[0], "tet id")?;
        let mut tet = [0; 4];
        for (v, t) in tet.iter_mut().zip(&fields[1..5]) {
            *v = text::vertex_index(path, line, t, base as i64)?;
        }
        for t in &fields[5..1 + per_tet] {
            text::vertex_index(path, line, t, base as i64)?;
        }
        for t in &fields[1 + per_tet..] {
            if t.parse::<f64>().is_err() {
                return Err(parse_error(
                    path,
                    line,
                    format!("expected a number (attribute), found `{t}`"),
                ));
            }
        }
        tets.push(path, line, tet)?;
        count += 1;
    }
    if count < m {
        return Err(truncated(path, text, "tets", count, m));
    }
    Ok(tets)
}
