//! Skinning: a display mesh follows a tet mesh through fixed barycentric weights.
//!
//! Each display vertex `p` gets the four vertices of one tet of the **rest** tet mesh and
//! weights `w` (summing to 1) such that `p = Σ w_k X_k` at rest. During a simulation the
//! display vertex is `Σ w_k x_k`, i.e. `display = W x` with a sparse `W` of four entries per
//! row. Since the weights are affine coordinates, any affine deformation `x -> A x + b` of the
//! tet mesh moves the display mesh by the same map.
//!
//! - A vertex inside a tet (barycentric coordinates all `>= -1e-10`) gets that tet's
//!   barycentric coordinates; when several tets contain it (on a shared face), the one it is
//!   deepest inside.
//! - A vertex in no tet gets the **nearest** tet: the weights are the barycentric coordinates of
//!   the closest point of that tet, so at rest the vertex is moved onto the tet mesh (by the
//!   reported distance), and under deformation it follows that closest point.
//!   [`Skinning::outside`] lists such vertices with their distances.
//!
//! Building uses a [`TetGrid`] over the tets' bounding boxes: a containment query tests only
//! the tets listed in the point's cell, and a nearest query searches shells of cells outwards.

use nalgebra::{Matrix3, Vector3};

use super::TetMesh;
use super::tet_grid::TetGrid;

/// Barycentric coordinates down to this (negative) value count as inside.
const INSIDE_TOLERANCE: f64 = 1e-10;

/// Why a skinning could not be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SkinningError {
    /// The tet mesh has no tets to bind to.
    #[error("the tet mesh has no tets to bind the display mesh to")]
    NoTets,
    /// A tet refers to a vertex that does not exist.
    #[error("tet {tet} refers to vertex {vertex}, but the mesh has {vertices} vertices")]
    IndexOutOfRange {
        tet: usize,
        vertex: usize,
        vertices: usize,
    },
    /// A display vertex has a non-finite coordinate.
    #[error("display vertex {vertex} is not finite")]
    NonFinite { vertex: usize },
}

impl crate::error_class::Classify for SkinningError {
    /// The display mesh or the tet mesh it binds to is not usable.
    fn class(&self) -> crate::error_class::ErrorClass {
        crate::error_class::ErrorClass::BadInput
    }
}

/// A display vertex outside the tet mesh, bound to the closest point of its nearest tet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OutsideVertex {
    /// Index of the display vertex.
    pub vertex: usize,
    /// The tet it is bound to.
    pub tet: usize,
    /// Its distance to that tet at rest (mesh units).
    pub distance: f64,
}

/// Fixed barycentric weights binding display vertices to a tet mesh (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Skinning {
    num_sim_vertices: usize,
    /// Per display vertex: the four tet-mesh vertices it follows.
    vertices: Vec<[usize; 4]>,
    /// Per display vertex: their weights (sum 1).
    weights: Vec<[f64; 4]>,
    outside: Vec<OutsideVertex>,
}

/// A tet prepared for barycentric queries: its first vertex and the inverse edge matrix.
#[derive(Clone, Copy)]
struct Affine {
    x0: Vector3<f64>,
    /// `None` for a degenerate (flat) tet, which only the nearest-tet search can pick.
    inv: Option<Matrix3<f64>>,
}

impl Affine {
    fn new(x: [Vector3<f64>; 4]) -> Self {
        let dm = Matrix3::from_columns(&[x[1] - x[0], x[2] - x[0], x[3] - x[0]]);
        let inv = dm.try_inverse().filter(|m| m.iter().all(|v| v.is_finite()));
        Self { x0: x[0], inv }
    }

    fn barycentric(&self, p: &Vector3<f64>) -> Option<[f64; 4]> {
        let l = self.inv? * (p - self.x0);
        Some([1.0 - l.x - l.y - l.z, l.x, l.y, l.z])
    }
}

impl Skinning {
    /// Binds each of `points` (display vertices, in the rest frame of `mesh`) to a tet of
    /// `mesh` (see the module docs for the rule).
    pub fn new(mesh: &TetMesh, points: &[Vector3<f64>]) -> Result<Self, SkinningError> {
        let n = mesh.num_vertices();
        if mesh.tets.is_empty() {
            return Err(SkinningError::NoTets);
        }
        for (tet, t) in mesh.tets.iter().enumerate() {
            if let Some(&vertex) = t.iter().find(|&&v| v >= n) {
                return Err(SkinningError::IndexOutOfRange {
                    tet,
                    vertex,
                    vertices: n,
                });
            }
        }
        if let Some(vertex) = points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
            return Err(SkinningError::NonFinite { vertex });
        }
        let corners = |t: usize| mesh.tets[t].map(|v| mesh.positions[v]);
        let affine: Vec<Affine> = (0..mesh.num_tets())
            .map(|t| Affine::new(corners(t)))
            .collect();
        let grid = TetGrid::new(&mesh.positions, &mesh.tets);
        let mut skin = Skinning {
            num_sim_vertices: n,
            vertices: Vec::with_capacity(points.len()),
            weights: Vec::with_capacity(points.len()),
            outside: Vec::new(),
        };
        for (i, p) in points.iter().enumerate() {
            // The containing tet the point is deepest inside.
            let mut best: Option<(usize, [f64; 4], f64)> = None;
            for &t in grid.candidates(p) {
                let t = t as usize;
                if let Some(l) = affine[t].barycentric(p) {
                    let depth = l.iter().copied().fold(f64::INFINITY, f64::min);
                    if depth >= -INSIDE_TOLERANCE && best.is_none_or(|(_, _, d)| depth > d) {
                        best = Some((t, l, depth));
                        // Strictly inside: in a conforming mesh no other tet contains it.
                        if depth > INSIDE_TOLERANCE {
                            break;
                        }
                    }
                }
            }
            let (tet, weights) = match best {
                Some((t, l, _)) => (t, l),
                None => {
                    let (tet, distance) = grid
                        .nearest(p, |t| (closest_point_on_tet(corners(t), p).0 - p).norm())
                        .expect("the mesh has tets");
                    skin.outside.push(OutsideVertex {
                        vertex: i,
                        tet,
                        distance,
                    });
                    (tet, closest_point_on_tet(corners(tet), p).1)
                }
            };
            skin.vertices.push(mesh.tets[tet]);
            skin.weights.push(weights);
        }
        Ok(skin)
    }

    /// Number of display vertices.
    pub fn num_display_vertices(&self) -> usize {
        self.vertices.len()
    }

    /// Number of tet-mesh vertices [`Self::apply`] expects.
    pub fn num_sim_vertices(&self) -> usize {
        self.num_sim_vertices
    }

    /// The four tet-mesh vertices display vertex `i` follows.
    pub fn vertices(&self, i: usize) -> [usize; 4] {
        self.vertices[i]
    }

    /// The weights of display vertex `i` (sum 1; all in [0, 1] for an outside vertex).
    pub fn weights(&self, i: usize) -> [f64; 4] {
        self.weights[i]
    }

    /// The display vertices that lie in no tet, in index order, with their nearest tet and
    /// distance.
    pub fn outside(&self) -> &[OutsideVertex] {
        &self.outside
    }

    /// The largest distance of an outside vertex to the tet mesh (0 when all are inside).
    pub fn max_outside_distance(&self) -> f64 {
        self.outside.iter().map(|o| o.distance).fold(0.0, f64::max)
    }

    /// Display positions for tet-mesh positions `x` (all vertices, in mesh order).
    ///
    /// # Panics
    /// When `x.len()` is not [`Self::num_sim_vertices`].
    pub fn apply(&self, x: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
        let mut out = vec![Vector3::zeros(); self.num_display_vertices()];
        self.apply_into(x, &mut out);
        out
    }

    /// [`Self::apply`] into a preallocated buffer (no allocation).
    ///
    /// # Panics
    /// When `x.len()` is not [`Self::num_sim_vertices`] or `out.len()` is not
    /// [`Self::num_display_vertices`].
    pub fn apply_into(&self, x: &[Vector3<f64>], out: &mut [Vector3<f64>]) {
        assert_eq!(
            x.len(),
            self.num_sim_vertices,
            "one position per tet-mesh vertex"
        );
        assert_eq!(
            out.len(),
            self.vertices.len(),
            "one output per display vertex"
        );
        for ((o, v), w) in out.iter_mut().zip(&self.vertices).zip(&self.weights) {
            *o = x[v[0]] * w[0] + x[v[1]] * w[1] + x[v[2]] * w[2] + x[v[3]] * w[3];
        }
    }
}

/// The point of tet `x` closest to `p` and its barycentric coordinates (all in [0, 1]).
/// Inside a (non-degenerate) tet that is `p` itself.
fn closest_point_on_tet(x: [Vector3<f64>; 4], p: &Vector3<f64>) -> (Vector3<f64>, [f64; 4]) {
    if let Some(l) = Affine::new(x).barycentric(p)
        && l.iter().all(|&c| c >= 0.0)
    {
        return (*p, l);
    }
    let mut best = (Vector3::zeros(), [0.0; 4], f64::INFINITY);
    for face in super::surface::TET_FACES {
        let (q, uvw) = closest_point_on_triangle(p, x[face[0]], x[face[1]], x[face[2]]);
        let d = (q - p).norm_squared();
        if d < best.2 {
            let mut l = [0.0; 4];
            for (k, &v) in face.iter().enumerate() {
                l[v] = uvw[k];
            }
            best = (q, l, d);
        }
    }
    (best.0, best.1)
}

/// The point of triangle `abc` closest to `p`, with its barycentric coordinates (Ericson,
/// *Real-Time Collision Detection*, 5.1.5: Voronoi regions of vertices, edges, face).
fn closest_point_on_triangle(
    p: &Vector3<f64>,
    a: Vector3<f64>,
    b: Vector3<f64>,
    c: Vector3<f64>,
) -> (Vector3<f64>, [f64; 3]) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (a, [1.0, 0.0, 0.0]);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (b, [0.0, 1.0, 0.0]);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (a + ab * v, [1.0 - v, v, 0.0]);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (c, [0.0, 0.0, 1.0]);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (a + ac * w, [1.0 - w, 0.0, w]);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * w, [0.0, 1.0 - w, w]);
    }
    let denom = va + vb + vc;
    if denom == 0.0 || !denom.is_finite() {
        // A degenerate (zero-area) triangle: fall back to its vertices.
        return [
            (a, [1.0, 0.0, 0.0]),
            (b, [0.0, 1.0, 0.0]),
            (c, [0.0, 0.0, 1.0]),
        ]
        .into_iter()
        .min_by(|x, y| {
            (x.0 - p)
                .norm_squared()
                .total_cmp(&(y.0 - p).norm_squared())
        })
        .expect("three vertices");
    }
    let (v, w) = (vb / denom, vc / denom);
    (a + ab * v + ac * w, [1.0 - v - w, v, w])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closest_point_on_triangle_covers_every_region() {
        let (a, b, c) = (Vector3::zeros(), Vector3::x(), Vector3::y());
        let cases = [
            (Vector3::new(-1.0, -1.0, 1.0), Vector3::zeros()),
            (Vector3::new(2.0, -0.5, 0.0), Vector3::x()),
            (Vector3::new(-0.5, 2.0, 3.0), Vector3::y()),
            (Vector3::new(0.5, -1.0, 0.0), Vector3::new(0.5, 0.0, 0.0)),
            (Vector3::new(-1.0, 0.5, 0.0), Vector3::new(0.0, 0.5, 0.0)),
            (Vector3::new(1.0, 1.0, 0.0), Vector3::new(0.5, 0.5, 0.0)),
            (Vector3::new(0.25, 0.25, 7.0), Vector3::new(0.25, 0.25, 0.0)),
        ];
        for (p, expected) in cases {
            let (q, l) = closest_point_on_triangle(&p, a, b, c);
            assert!((q - expected).norm() < 1e-15, "{p:?}: {q:?}");
            let r = a * l[0] + b * l[1] + c * l[2];
            assert!((r - q).norm() < 1e-15 && (l.iter().sum::<f64>() - 1.0).abs() < 1e-15);
        }
    }
}
