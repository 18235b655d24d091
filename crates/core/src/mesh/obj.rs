//! Wavefront OBJ triangle surfaces (display meshes).
//!
//! Reads `v x y z [w | r g b]` and `f` records in every index form (`a`, `a/b`, `a//c`,
//! `a/b/c`). Indices are **1-based**; negative indices count back from the last element
//! defined so far (`-1` is the latest). Polygons are fanned into triangles `(0, i, i+1)`, which
//! keeps their winding: OBJ faces are counter-clockwise seen from outside, so triangles get
//! outward normals by the right-hand rule. `vn` and `vt` are counted (so face references to them
//! can be checked) but not stored; every other statement (`usemtl`, `mtllib`, `o`, `g`, `s`,
//! `l`, ...) is ignored. Unreferenced vertices are kept, so indices match the file.

use std::path::Path;

use nalgebra::Vector3;

use super::text::{self, parse_error};
use super::{MeshError, SurfaceMesh};

/// Reads an OBJ file as a triangle surface.
pub fn read(path: impl AsRef<Path>) -> Result<SurfaceMesh, MeshError> {
    let path = path.as_ref();
    parse(&text::read_text(path)?, path)
}

/// Whether a text looks like an OBJ surface: it has an `f` record.
pub fn looks_like(text: &str) -> bool {
    text::lines(text).any(|(_, l)| l.split_ascii_whitespace().next() == Some("f"))
}

/// The largest positive reference to a list (vertex, texture coordinate or normal) and the
/// line that made it, checked against the list's length at the end (a positive index may refer
/// to an element defined later in the file).
#[derive(Default)]
struct MaxRef {
    index: usize,
    line: usize,
}

impl MaxRef {
    fn note(&mut self, index: usize, line: usize) {
        if index > self.index {
            *self = MaxRef { index, line };
        }
    }

    fn check(&self, path: &Path, len: usize, what: &str) -> Result<(), MeshError> {
        if self.index > len {
            return Err(parse_error(
                path,
                self.line,
                format!(
                    "{what} index {} is out of range: the file has {len} {what}s, \
                     so 1-based indices run from 1 to {len}",
                    self.index
                ),
            ));
        }
        Ok(())
    }
}

/// Parses OBJ text; `path` is used only in error messages.
pub fn parse(text: &str, path: &Path) -> Result<SurfaceMesh, MeshError> {
    let mut positions: Vec<Vector3<f64>> = Vec::new();
    let mut triangles: Vec<[usize; 3]> = Vec::new();
    let (mut normals, mut texcoords) = (0usize, 0usize);
    let mut max_ref = [MaxRef::default(), MaxRef::default(), MaxRef::default()];
    let mut face: Vec<usize> = Vec::with_capacity(8);
    for (line, content) in text::lines(text) {
        let mut fields = content.split_ascii_whitespace();
        match fields.next() {
            Some("v") => {
                let mut xyz = [0.0; 3];
                let mut n = 0;
                for t in fields {
                    let x = text::coordinate(path, line, t)?;
                    if n < 3 {
                        xyz[n] = x;
                    }
                    n += 1;
                }
                if !matches!(n, 3 | 4 | 6) {
                    return Err(parse_error(
                        path,
                        line,
                        format!("expected `v x y z` (optionally w, or r g b), found {n} numbers"),
                    ));
                }
                positions.push(xyz.into());
            }
            Some("vn") => normals += 1,
            Some("vt") => texcoords += 1,
            Some("f") => {
                face.clear();
                let counts = [positions.len(), texcoords, normals];
                for t in fields {
                    face.push(face_vertex(path, line, t, counts, &mut max_ref)?);
                }
                if face.len() < 3 {
                    return Err(parse_error(
                        path,
                        line,
                        format!("a face needs at least 3 vertices, found {}", face.len()),
                    ));
                }
                for (i, &v) in face.iter().enumerate() {
                    if face[i + 1..].contains(&v) {
                        return Err(parse_error(
                            path,
                            line,
                            format!("face repeats vertex index {}", v + 1),
                        ));
                    }
                }
                for i in 1..face.len() - 1 {
                    triangles.push([face[0], face[i], face[i + 1]]);
                }
            }
            _ => {}
        }
    }
    max_ref[0].check(path, positions.len(), "vertex")?;
    max_ref[1].check(path, texcoords, "texture coordinate")?;
    max_ref[2].check(path, normals, "normal")?;
    let end = text::last_line(text);
    if positions.is_empty() {
        return Err(text::empty_mesh(path, end, "no `v` records"));
    }
    if triangles.is_empty() {
        return Err(text::empty_mesh(path, end, "no `f` records"));
    }
    Ok(SurfaceMesh {
        positions,
        triangles,
    })
}

/// Parses one face vertex `a`, `a/b`, `a//c` or `a/b/c`; returns the 0-based vertex index.
/// `counts` are the numbers of vertices, texture coordinates and normals defined so far.
fn face_vertex(
    path: &Path,
    line: usize,
    token: &str,
    counts: [usize; 3],
    max_ref: &mut [MaxRef; 3],
) -> Result<usize, MeshError> {
    const WHAT: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    let mut vertex = 0;
    let mut parts = 0;
    for (k, part) in token.split('/').enumerate() {
        parts += 1;
        if k >= 3 {
            break;
        }
        if part.is_empty() && k == 1 {
            continue; // `a//c`
        }
        let raw: i64 = part.parse().map_err(|_| {
            parse_error(
                path,
                line,
                format!("expected a face vertex `v`, `v/t`, `v//n` or `v/t/n`, found `{token}`"),
            )
        })?;
        let index = if raw > 0 {
            let index = raw as usize;
            max_ref[k].note(index, line);
            index - 1
        } else if raw < 0 && raw.unsigned_abs() as usize <= counts[k] {
            counts[k] - raw.unsigned_abs() as usize
        } else {
            return Err(parse_error(
                path,
                line,
                format!(
                    "{} index {raw} in `{token}` is out of range: {} {}s are defined so far \
                     (indices are 1-based; negative ones count back from the latest)",
                    WHAT[k], counts[k], WHAT[k]
                ),
            ));
        };
        if k == 0 {
            vertex = index;
        }
    }
    if parts > 3 || token.ends_with('/') {
        return Err(parse_error(
            path,
            line,
            format!("expected a face vertex `v`, `v/t`, `v//n` or `v/t/n`, found `{token}`"),
        ));
    }
    Ok(vertex)
}
