//! Exact check that a triangulated surface intersects neither itself nor a set of obstacle
//! triangles.
//!
//! Used on sampled frames to certify a run "intersection-free" without trusting the contact
//! barrier meant to guarantee it: the barrier works in floating point with a tolerance, while
//! this check decides every case as exact arithmetic on the f64 input would. Triangle boxes go
//! through the [`BroadPhase`] hierarchy (exact closed boxes, so touching triangles are
//! candidates); each candidate pair is then decided with Shewchuk's adaptive orientation
//! predicates (`robust::orient3d`, `robust::orient2d`), which are fast in floating point and
//! fall back to exact expansion arithmetic only near degeneracy. No tolerance anywhere:
//! touching counts as intersecting, and coplanar and zero-area triangles are decided exactly.
//!
//! What counts within one mesh: two triangles that share no vertex and intersect, and an edge
//! of one triangle that meets another triangle sharing no vertex with that edge (this catches
//! a triangle folded through a neighbour around a common vertex). Triangles sharing an edge
//! are not tested, so a neighbour folded perfectly flat onto the other across their common
//! edge goes unreported. Vertices are told apart by index, so the mesh must be welded: two
//! indices at one position are reported as touching.
//!
//! Cost: the broad phase (O(n log n + k) for n triangles and k candidate pairs, see
//! [`crate::contact::ipc::broad_phase`]) plus O(1) predicates per candidate, at most 24
//! `orient3d` for a pair with no shared vertex; buffers are allocated per call (a check of a
//! sampled frame, not a hot path).
//!
//! Positions must be finite: a NaN corner makes a NaN box, which the broad phase never pairs,
//! so a diverged frame would pass; check finiteness first. Exactness assumes the predicates'
//! products neither overflow nor underflow, which holds for coordinate differences between
//! about 1e-70 and 1e70 (or zero).

use crate::contact::broad_phase::{Aabb, BroadPhase};
use nalgebra::Vector3;
use robust::{Coord, Coord3D};

/// One intersecting pair found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Intersection {
    /// Index of the first triangle.
    pub first: u32,
    /// Index of the second triangle (into the second set in [`intersections_between`]).
    pub second: u32,
}

/// Summary of a check.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct IntersectionReport {
    /// Pairs of triangles found intersecting.
    pub intersecting_pairs: u64,
    /// Pairs whose boxes overlap and that had something to test (in one mesh: pairs not
    /// sharing an edge), i.e. the pairs decided by the exact predicates.
    pub candidate_pairs: u64,
    /// The intersecting pair that comes first in (first, second) order, if any.
    pub first: Option<Intersection>,
}

impl IntersectionReport {
    /// Counts one decided pair.
    fn record(&mut self, first: u32, second: u32, intersecting: bool) {
        self.candidate_pairs += 1;
        if intersecting {
            self.intersecting_pairs += 1;
            self.first.get_or_insert(Intersection { first, second });
        }
    }
}

/// Self-intersection of the triangles (vertex indices into `positions`): pairs sharing no
/// vertex that intersect, and pairs sharing one vertex where an edge of one meets the other
/// (see the module doc). Pairs sharing an edge are skipped.
///
/// # Panics
/// If an index is out of range, or there are more than `u32::MAX` triangles.
pub fn self_intersections(
    positions: &[Vector3<f64>],
    triangles: &[[usize; 3]],
) -> IntersectionReport {
    let boxes = triangle_boxes(positions, triangles);
    let mut pairs = Vec::new();
    BroadPhase::default().self_pairs(&boxes, &mut pairs);
    let mut report = IntersectionReport::default();
    for (i, j) in pairs {
        let (ti, tj) = (triangles[i as usize], triangles[j as usize]);
        if let Some(hit) = mesh_pair(positions, ti, tj) {
            report.record(i, j, hit);
        }
    }
    report
}

/// Intersections between the triangles `ta` (into `pa`) and `tb` (into `pb`), e.g. a body's
/// surface and a static obstacle mesh; nothing is shared, so every pair is tested.
///
/// # Panics
/// If an index is out of range, or a set has more than `u32::MAX` triangles.
pub fn intersections_between(
    pa: &[Vector3<f64>],
    ta: &[[usize; 3]],
    pb: &[Vector3<f64>],
    tb: &[[usize; 3]],
) -> IntersectionReport {
    let (boxes_a, boxes_b) = (triangle_boxes(pa, ta), triangle_boxes(pb, tb));
    let mut pairs = Vec::new();
    BroadPhase::default().pairs(&boxes_a, &boxes_b, &mut pairs);
    let mut report = IntersectionReport::default();
    for (i, j) in pairs {
        let hit = triangles_intersect(corners(pa, ta[i as usize]), corners(pb, tb[j as usize]));
        report.record(i, j, hit);
    }
    report
}

/// Exact: do the closed triangles (a0, a1, a2) and (b0, b1, b2) intersect (touching counts)?
/// Zero-area triangles are the segment or point they are.
pub fn triangles_intersect(a: [&Vector3<f64>; 3], b: [&Vector3<f64>; 3]) -> bool {
    // Each vertex's side of the other triangle's plane; all strictly on one side: apart.
    let side_b = b.map(|p| orient3d(a[0], a[1], a[2], p));
    let side_a = a.map(|p| orient3d(b[0], b[1], b[2], p));
    if strictly_one_side(side_a) || strictly_one_side(side_b) {
        return false;
    }
    // Two closed triangles meet iff an edge of one meets the other: the ends of the segment
    // (or 2D region, if coplanar) they share lie on their boundaries.
    let (axis_a, axis_b) = (projection_axis(a), projection_axis(b));
    let edge_meets = |t: [&Vector3<f64>; 3], side: [i8; 3], other, axis| {
        (0..3).any(|i| {
            let j = (i + 1) % 3;
            edge_meets_triangle(t[i], t[j], side[i], side[j], other, axis)
        })
    };
    edge_meets(a, side_a, b, axis_b) || edge_meets(b, side_b, a, axis_a)
}

/// Exact: does the closed segment (e0, e1) meet the closed triangle (t0, t1, t2) (touching
/// counts)? Zero-length segments and zero-area triangles are the points or segments they are.
pub fn segment_intersects_triangle(
    e0: &Vector3<f64>,
    e1: &Vector3<f64>,
    t0: &Vector3<f64>,
    t1: &Vector3<f64>,
    t2: &Vector3<f64>,
) -> bool {
    let t = [t0, t1, t2];
    let (s0, s1) = (orient3d(t0, t1, t2, e0), orient3d(t0, t1, t2, e1));
    edge_meets_triangle(e0, e1, s0, s1, t, projection_axis(t))
}

fn triangle_boxes(positions: &[Vector3<f64>], triangles: &[[usize; 3]]) -> Vec<Aabb> {
    triangles
        .iter()
        .map(|&[i, j, k]| Aabb::from_points(&[positions[i], positions[j], positions[k]]))
        .collect()
}

fn corners(positions: &[Vector3<f64>], t: [usize; 3]) -> [&Vector3<f64>; 3] {
    t.map(|i| &positions[i])
}

/// Decides one candidate pair of a mesh: `None` if nothing is to be tested (every edge of
/// each shares a vertex with the other: they share an edge), else whether they intersect.
fn mesh_pair(positions: &[Vector3<f64>], ti: [usize; 3], tj: [usize; 3]) -> Option<bool> {
    if !ti.iter().any(|v| tj.contains(v)) {
        return Some(triangles_intersect(
            corners(positions, ti),
            corners(positions, tj),
        ));
    }
    let mut tested = false;
    for (t, other) in [(ti, tj), (tj, ti)] {
        let [o0, o1, o2] = corners(positions, other);
        for k in 0..3 {
            let (u, w) = (t[k], t[(k + 1) % 3]);
            if other.contains(&u) || other.contains(&w) {
                continue;
            }
            tested = true;
            if segment_intersects_triangle(&positions[u], &positions[w], o0, o1, o2) {
                return Some(true);
            }
        }
    }
    tested.then_some(false)
}

/// Whether all three signs are positive or all negative.
fn strictly_one_side(s: [i8; 3]) -> bool {
    s[0] != 0 && s[0] == s[1] && s[1] == s[2]
}

/// Whether the closed segment (e0, e1) meets triangle `t`, given the ends' sides `s0`, `s1`
/// of its plane and its [`projection_axis`].
fn edge_meets_triangle(
    e0: &Vector3<f64>,
    e1: &Vector3<f64>,
    s0: i8,
    s1: i8,
    t: [&Vector3<f64>; 3],
    axis: Option<usize>,
) -> bool {
    let Some(axis) = axis else {
        // A zero-area triangle is the union of its edges.
        return (0..3).any(|i| segments_meet(e0, e1, t[i], t[(i + 1) % 3]));
    };
    if s0 * s1 > 0 {
        return false;
    }
    if s0 == 0 && s1 == 0 {
        let inside = |p| point_in_triangle_2d(p, t, axis);
        return inside(e0)
            || inside(e1)
            || (0..3).any(|i| segments_meet_2d(e0, e1, t[i], t[(i + 1) % 3], axis));
    }
    // The segment crosses the plane at one point; it lies in the triangle iff the line's
    // orientations against the three edges have no two strictly opposite signs.
    let o = [0, 1, 2].map(|i| orient3d(e0, e1, t[i], t[(i + 1) % 3]));
    !(o.contains(&1) && o.contains(&-1))
}

/// Whether the closed segments (p0, p1) and (q0, q1) meet: they are coplanar and meet in
/// every coordinate projection (one of which is one-to-one on their common plane).
fn segments_meet(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> bool {
    orient3d(p0, p1, q0, q1) == 0 && (0..3).all(|axis| segments_meet_2d(p0, p1, q0, q1, axis))
}

/// Whether the closed segments meet once coordinate `axis` is dropped (any lengths, zero
/// included).
fn segments_meet_2d(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
    axis: usize,
) -> bool {
    let (d0, d1) = (orient2d(p0, p1, q0, axis), orient2d(p0, p1, q1, axis));
    let (d2, d3) = (orient2d(q0, q1, p0, axis), orient2d(q0, q1, p1, axis));
    if d0 * d1 < 0 && d2 * d3 < 0 {
        return true;
    }
    (d0 == 0 && within(p0, p1, q0, axis))
        || (d1 == 0 && within(p0, p1, q1, axis))
        || (d2 == 0 && within(q0, q1, p0, axis))
        || (d3 == 0 && within(q0, q1, p1, axis))
}

/// For `p` on the line of (a, b) in the projection dropping `axis`: whether it lies between.
fn within(a: &Vector3<f64>, b: &Vector3<f64>, p: &Vector3<f64>, axis: usize) -> bool {
    [(axis + 1) % 3, (axis + 2) % 3]
        .iter()
        .all(|&k| a[k].min(b[k]) <= p[k] && p[k] <= a[k].max(b[k]))
}

/// Whether `p` lies in the closed triangle `t` once coordinate `axis` is dropped (`t` must not
/// be degenerate there).
fn point_in_triangle_2d(p: &Vector3<f64>, t: [&Vector3<f64>; 3], axis: usize) -> bool {
    let o = [0, 1, 2].map(|i| orient2d(t[i], t[(i + 1) % 3], p, axis));
    !(o.contains(&1) && o.contains(&-1))
}

/// A coordinate whose dropping leaves the triangle with nonzero area (so the projection is
/// one-to-one on its plane), or `None` if its corners are collinear.
fn projection_axis(t: [&Vector3<f64>; 3]) -> Option<usize> {
    (0..3).find(|&axis| orient2d(t[0], t[1], t[2], axis) != 0)
}

/// The sign of the orientation of (a, b, c, d), exact.
fn orient3d(a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>, d: &Vector3<f64>) -> i8 {
    let c3 = |p: &Vector3<f64>| Coord3D {
        x: p.x,
        y: p.y,
        z: p.z,
    };
    sign(robust::orient3d(c3(a), c3(b), c3(c), c3(d)))
}

/// The sign of the orientation of (a, b, c) with coordinate `axis` dropped, exact.
fn orient2d(a: &Vector3<f64>, b: &Vector3<f64>, c: &Vector3<f64>, axis: usize) -> i8 {
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let c2 = |p: &Vector3<f64>| Coord { x: p[u], y: p[v] };
    sign(robust::orient2d(c2(a), c2(b), c2(c)))
}

fn sign(x: f64) -> i8 {
    (x > 0.0) as i8 - (x < 0.0) as i8
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashMap;

    /// SplitMix64.
    struct Rng(u64);
    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        fn below(&mut self, n: u64) -> i64 {
            (self.next() % n) as i64
        }
        fn uniform(&mut self) -> f64 {
            (self.next() >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
        Vector3::new(x, y, z)
    }

    fn tri(t: &[Vector3<f64>; 3]) -> [&Vector3<f64>; 3] {
        [&t[0], &t[1], &t[2]]
    }

    fn meet(a: [Vector3<f64>; 3], b: [Vector3<f64>; 3]) -> bool {
        triangles_intersect(tri(&a), tri(&b))
    }

    /// The z = 0 triangle every hand case is tested against.
    fn base() -> [Vector3<f64>; 3] {
        [v(0.0, 0.0, 0.0), v(2.0, 0.0, 0.0), v(0.0, 2.0, 0.0)]
    }

    #[test]
    fn crossing_triangles_intersect() {
        let b = [v(0.5, 0.5, -1.0), v(0.5, 0.5, 1.0), v(0.5, 3.0, 0.0)];
        assert!(meet(base(), b) && meet(b, base()));
        // The same vertical triangle moved past the hypotenuse misses.
        let b = b.map(|p| p + v(1.5, 1.0, 0.0));
        assert!(!meet(base(), b));
    }

    #[test]
    fn touching_at_a_point_intersects() {
        // A vertex on the face, a vertex on a vertex, an edge across an edge.
        let on_face = [v(0.5, 0.5, 0.0), v(0.5, 0.5, 1.0), v(1.0, 0.0, 1.0)];
        let on_vertex = [v(2.0, 0.0, 0.0), v(3.0, 0.0, 1.0), v(3.0, 1.0, 1.0)];
        let across_edge = [v(1.0, 1.0, -1.0), v(1.0, 1.0, 1.0), v(3.0, 3.0, 0.0)];
        for b in [on_face, on_vertex, across_edge] {
            assert!(meet(base(), b) && meet(b, base()), "{b:?}");
        }
        let above = on_face.map(|p| p + v(0.0, 0.0, 1e-300));
        assert!(!meet(base(), above));
    }

    #[test]
    fn coplanar_triangles_are_decided_exactly() {
        let overlapping = [v(1.0, -1.0, 0.0), v(1.0, 1.0, 0.0), v(3.0, 0.0, 0.0)];
        let inside = [v(0.25, 0.25, 0.0), v(0.5, 0.25, 0.0), v(0.25, 0.5, 0.0)];
        let sharing_a_vertex = [v(2.0, 0.0, 0.0), v(3.0, 0.0, 0.0), v(3.0, 1.0, 0.0)];
        let touching_the_hypotenuse = [v(1.0, 1.0, 0.0), v(2.0, 2.0, 0.0), v(2.0, 1.0, 0.0)];
        for b in [
            overlapping,
            inside,
            sharing_a_vertex,
            touching_the_hypotenuse,
        ] {
            assert!(meet(base(), b) && meet(b, base()), "{b:?}");
        }
        let disjoint = [v(1.5, 1.0, 0.0), v(3.0, 1.0, 0.0), v(1.5, 3.0, 0.0)];
        let just_past_the_hypotenuse = touching_the_hypotenuse.map(|p| p + v(1e-15, 0.0, 0.0));
        for b in [disjoint, just_past_the_hypotenuse] {
            assert!(!meet(base(), b) && !meet(b, base()), "{b:?}");
        }
    }

    #[test]
    fn parallel_triangles_apart_by_1e_15_do_not_intersect() {
        let lift = |t: [Vector3<f64>; 3], dz: f64| t.map(|p| p + v(0.0, 0.0, dz));
        assert!(!meet(base(), lift(base(), 1e-15)));
        assert!(!meet(lift(base(), 1.0), lift(base(), 1.0 + 1e-15)));
        assert!(meet(lift(base(), 1.0), lift(base(), 1.0)));
        // Tilted: the plane x + y + z = 1 and a copy pushed off it by rounding-size steps.
        let a = [v(1.0, 0.0, 0.0), v(0.0, 1.0, 0.0), v(0.0, 0.0, 1.0)];
        let off = a.map(|p| p + v(1e-15, 1e-15, 1e-15));
        assert!(!meet(a, off) && meet(a, a));
    }

    #[test]
    fn degenerate_triangles_are_their_segments_and_points() {
        let needle = [v(0.5, 0.5, -1.0), v(0.5, 0.5, 1.0), v(0.5, 0.5, 0.25)];
        assert!(meet(base(), needle) && meet(needle, base()));
        let point = [v(0.5, 0.5, 0.0); 3];
        assert!(meet(base(), point) && !meet(base(), point.map(|p| p + v(0.0, 0.0, 1e-9))));
        let s1 = [v(0.0, 0.0, 0.0), v(1.0, 1.0, 1.0), v(2.0, 2.0, 2.0)];
        let s2 = [v(2.0, 2.0, 2.0), v(3.0, 3.0, 3.0), v(2.5, 2.5, 2.5)];
        let s3 = [v(2.5, 2.5, 2.5), v(3.0, 3.0, 3.0), v(2.75, 2.75, 2.75)];
        assert!(meet(s1, s2) && !meet(s1, s3));
        let (half, whole) = ((s1[0], s1[1]), (s1[0], s1[2]));
        let collinear = |(e0, e1): (Vector3<f64>, Vector3<f64>)| {
            segment_intersects_triangle(&e0, &e1, &s2[0], &s2[1], &s2[2])
        };
        assert!(!collinear(half) && collinear(whole));
    }

    #[test]
    fn segments_meet_in_every_arrangement() {
        let o = v(0.0, 0.0, 0.0);
        let x = |t: f64| v(t, 0.0, 0.0);
        let meets = |p0, p1, q0, q1, expected: bool| {
            for [a, b, c, d] in [
                [p0, p1, q0, q1],
                [p1, p0, q1, q0],
                [q0, q1, p0, p1],
                [q1, q0, p1, p0],
            ] {
                assert_eq!(
                    segments_meet(&a, &b, &c, &d),
                    expected,
                    "{a:?} {b:?} {c:?} {d:?}"
                );
            }
        };
        meets(x(0.0), x(2.0), x(1.0), v(1.0, 1.0, 0.0), true); // T-junction
        meets(x(0.0), x(2.0), x(1.0), v(1.0, 0.0, 1.0), true);
        meets(x(0.0), x(2.0), v(1.0, 1e-300, 0.0), v(1.0, 1.0, 0.0), false);
        meets(x(0.0), x(1.0), x(1.0), x(3.0), true); // collinear along an axis
        meets(x(0.0), x(1.0), x(2.0), x(3.0), false);
        meets(x(0.0), x(3.0), x(1.0), x(2.0), true);
        meets(x(0.0), x(1.0), x(1.0 + 1e-15), x(2.0), false);
        meets(o, o, o, o, true); // points
        meets(o, o, x(1e-300), x(1e-300), false);
        meets(
            x(-1.0),
            x(1.0),
            v(0.0, -1.0, 1e-15),
            v(0.0, 1.0, 1e-15),
            false,
        ); // skew
        meets(x(-1.0), x(1.0), v(0.0, -1.0, 0.0), v(0.0, 1.0, 0.0), true);
        // Skew, yet crossing in all three coordinate projections.
        meets(
            v(1.0, 0.0, 1.0),
            v(1.0, 3.0, 2.0),
            v(2.0, 3.0, 2.0),
            v(0.0, 3.0, 1.0),
            false,
        );
    }

    #[test]
    fn segments_against_a_triangle() {
        let t = base();
        let hits = |a: Vector3<f64>, b: Vector3<f64>| {
            segment_intersects_triangle(&a, &b, &t[0], &t[1], &t[2])
        };
        assert!(
            hits(v(0.5, 0.5, -1.0), v(0.5, 0.5, 1.0)),
            "through the face"
        );
        assert!(
            hits(v(0.0, 0.0, -1.0), v(0.0, 0.0, 1.0)),
            "through a vertex"
        );
        assert!(
            hits(v(1.0, 1.0, -1.0), v(1.0, 1.0, 1.0)),
            "through the hypotenuse"
        );
        assert!(
            hits(v(0.5, 0.5, 0.0), v(0.5, 0.5, 1.0)),
            "ending on the face"
        );
        assert!(
            hits(v(-1.0, 1.0, 0.0), v(3.0, 1.0, 0.0)),
            "coplanar, across"
        );
        assert!(
            hits(v(0.5, 0.5, 0.0), v(0.5, 0.5, 0.0)),
            "a point on the face"
        );
        assert!(
            hits(v(2.0, -1.0, 0.0), v(2.0, 1.0, 0.0)),
            "coplanar, touching a vertex"
        );
        assert!(
            hits(v(1.0, 1.0, 0.0), v(3.0, 3.0, 0.0)),
            "coplanar, from the hypotenuse out"
        );
        assert!(
            !hits(v(0.5, 0.5, 1e-300), v(0.5, 0.5, 1.0)),
            "ending just above"
        );
        assert!(
            !hits(v(-1.0, 3.0, 0.0), v(3.0, 3.0, 0.0)),
            "coplanar, outside"
        );
        assert!(
            !hits(v(1.1, 1.0, -1.0), v(1.1, 1.0, 1.0)),
            "past the hypotenuse"
        );
        assert!(!hits(v(0.0, 0.0, 1.0), v(1.0, 1.0, 1.0)), "parallel above");
    }

    /// Grid points and triangles to exact i128 arithmetic.
    type I3 = [i128; 3];
    fn sub(a: I3, b: I3) -> I3 {
        [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
    }
    fn cross(a: I3, b: I3) -> I3 {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    }
    fn dot(a: I3, b: I3) -> i128 {
        a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    }
    fn det(a: I3, b: I3, c: I3) -> i128 {
        dot(a, cross(b, c))
    }

    /// Separating-axis oracle in exact integers for non-degenerate triangles (`None` for a
    /// zero-area one): each is the limit of a thin prism, so they are apart iff some face
    /// normal or edge-pair cross product of the two prisms separates them strictly.
    fn sat_oracle(a: [I3; 3], b: [I3; 3]) -> Option<bool> {
        let edges = |t: [I3; 3]| [sub(t[1], t[0]), sub(t[2], t[1]), sub(t[0], t[2])];
        let (ea, eb) = (edges(a), edges(b));
        let (na, nb) = (cross(ea[0], ea[1]), cross(eb[0], eb[1]));
        if na == [0; 3] || nb == [0; 3] {
            return None;
        }
        let mut axes = vec![na, nb, cross(na, nb)];
        for i in 0..3 {
            axes.extend([
                cross(na, ea[i]),
                cross(nb, eb[i]),
                cross(ea[i], nb),
                cross(na, eb[i]),
            ]);
            axes.extend(eb.iter().map(|&e| cross(ea[i], e)));
        }
        let range = |t: [I3; 3], n| {
            let d = t.map(|p| dot(n, p));
            (*d.iter().min().unwrap(), *d.iter().max().unwrap())
        };
        let apart = axes.into_iter().any(|n| {
            let ((lo_a, hi_a), (lo_b, hi_b)) = (range(a, n), range(b, n));
            hi_a < lo_b || hi_b < lo_a
        });
        Some(!apart)
    }

    /// Cramer's-rule oracle for a segment crossing a triangle's plane at one point (`None`
    /// if the segment is parallel to the plane or the triangle has zero area).
    fn cramer_oracle(e0: I3, e1: I3, t: [I3; 3]) -> Option<bool> {
        let (d, f, g, r) = (sub(e1, e0), sub(t[1], t[0]), sub(t[2], t[0]), sub(t[0], e0));
        let mut m = det(d, f, g);
        if m == 0 {
            return None;
        }
        let (mut s, mut u, mut w) = (det(r, f, g), -det(d, r, g), -det(d, f, r));
        if m < 0 {
            (m, s, u, w) = (-m, -s, -u, -w);
        }
        Some((0..=m).contains(&s) && u >= 0 && w >= 0 && u + w <= m)
    }

    /// A random triangle pair on the grid {0..4}^3, often coplanar or sharing points.
    fn grid_pair(rng: &mut Rng) -> ([I3; 3], [I3; 3]) {
        let mut p = [[0i128; 3]; 6].map(|_| [0; 3].map(|_: i128| rng.below(5) as i128));
        match rng.below(6) {
            0 | 1 => p.iter_mut().for_each(|q| q[2] = 2), // coplanar
            2 => p[3] = p[rng.below(3) as usize],         // a shared point
            _ => {}
        }
        ([p[0], p[1], p[2]], [p[3], p[4], p[5]])
    }

    /// The grid points as floats, scaled and shifted exactly (powers of two).
    fn to_f64(t: [I3; 3], scale: f64, shift: f64) -> [Vector3<f64>; 3] {
        t.map(|p| Vector3::from_fn(|k, _| shift + scale * p[k] as f64))
    }

    const PLACEMENTS: [(f64, f64); 4] = [
        (1.0, 0.0),
        (1.0 / (1u64 << 40) as f64, 0.0),
        (1.0 / (1u64 << 20) as f64, 1.0),
        (1.0, (1u64 << 40) as f64),
    ];

    #[test]
    fn triangles_intersect_agrees_with_an_exact_separating_axis_oracle() {
        let mut rng = Rng(1);
        let (mut checked, mut hits, mut coplanar_hits) = (0, 0, 0);
        for n in 0..200_000 {
            let (a, b) = grid_pair(&mut rng);
            let Some(expected) = sat_oracle(a, b) else {
                continue;
            };
            let (scale, shift) = PLACEMENTS[n % PLACEMENTS.len()];
            let (fa, fb) = (to_f64(a, scale, shift), to_f64(b, scale, shift));
            assert_eq!(meet(fa, fb), expected, "{a:?} {b:?}");
            checked += 1;
            hits += expected as u32;
            let coplanar = [b[0], b[1], b[2]]
                .iter()
                .all(|&q| det(sub(a[1], a[0]), sub(a[2], a[0]), sub(q, a[0])) == 0);
            coplanar_hits += (expected && coplanar) as u32;
        }
        assert!(
            checked > 100_000 && hits > 20_000 && coplanar_hits > 5_000,
            "{checked} {hits} {coplanar_hits}"
        );
        assert!(checked - hits > 20_000);
    }

    #[test]
    fn segment_intersects_triangle_agrees_with_cramers_rule() {
        let mut rng = Rng(2);
        let (mut checked, mut hits) = (0, 0);
        for n in 0..200_000 {
            let (t, e) = grid_pair(&mut rng);
            let Some(expected) = cramer_oracle(e[0], e[1], t) else {
                continue;
            };
            let (scale, shift) = PLACEMENTS[n % PLACEMENTS.len()];
            let (ft, fe) = (to_f64(t, scale, shift), to_f64(e, scale, shift));
            assert_eq!(
                segment_intersects_triangle(&fe[0], &fe[1], &ft[0], &ft[1], &ft[2]),
                expected,
                "{e:?} {t:?}"
            );
            checked += 1;
            hits += expected as u32;
        }
        assert!(
            checked > 50_000 && hits > 5_000 && checked - hits > 5_000,
            "{checked} {hits}"
        );
    }

    #[test]
    fn triangles_intersect_ignores_order_even_when_degenerate() {
        let mut rng = Rng(3);
        for _ in 0..50_000 {
            let (a, b) = grid_pair(&mut rng);
            let (fa, fb) = (to_f64(a, 0.5, 0.0), to_f64(b, 0.5, 0.0));
            let expected = meet(fa, fb);
            assert_eq!(meet(fb, fa), expected);
            assert_eq!(meet([fa[1], fa[2], fa[0]], [fb[0], fb[2], fb[1]]), expected);
        }
    }

    /// Positions and triangles.
    type Mesh = (Vec<Vector3<f64>>, Vec<[usize; 3]>);

    /// The surface of the cube [origin, origin + size]^3, split into n x n squares a face,
    /// two triangles each, vertices welded.
    fn cube(origin: Vector3<f64>, size: f64, n: i64) -> Mesh {
        let mut index = HashMap::new();
        let mut positions = Vec::new();
        let mut vertex = |g: [i64; 3]| {
            *index.entry(g).or_insert_with(|| {
                positions.push(origin + Vector3::from_fn(|k, _| g[k] as f64 / n as f64 * size));
                positions.len() - 1
            })
        };
        let mut triangles = Vec::new();
        for axis in 0..3 {
            for side in [0, n] {
                let at = |i: i64, j: i64| {
                    let mut g = [0; 3];
                    (g[axis], g[(axis + 1) % 3], g[(axis + 2) % 3]) = (side, i, j);
                    g
                };
                for i in 0..n {
                    for j in 0..n {
                        let q = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]
                            .map(&mut vertex);
                        triangles.extend([[q[0], q[1], q[2]], [q[0], q[2], q[3]]]);
                    }
                }
            }
        }
        (positions, triangles)
    }

    /// Both meshes in one, unwelded.
    fn join(a: &Mesh, b: &Mesh) -> Mesh {
        let shift = a.0.len();
        let positions = a.0.iter().chain(&b.0).copied().collect();
        let triangles =
            a.1.iter()
                .copied()
                .chain(b.1.iter().map(|t| t.map(|i| i + shift)))
                .collect();
        (positions, triangles)
    }

    #[test]
    fn a_closed_cube_surface_does_not_intersect_itself() {
        let (p, t) = cube(Vector3::zeros(), 1.0, 1);
        assert_eq!(t.len(), 12);
        let report = self_intersections(&p, &t);
        assert_eq!(report.intersecting_pairs, 0, "{report:?}");
        assert!(report.candidate_pairs > 0);
        // Finer, and jittered off the grid: many fans of triangles around a vertex.
        let (mut p, t) = cube(v(0.1, -0.2, 0.3), 2.0, 12);
        let mut rng = Rng(4);
        let h = 2.0 / 12.0;
        p.iter_mut()
            .for_each(|q| *q += v(rng.uniform(), rng.uniform(), rng.uniform()) * 0.05 * h);
        let report = self_intersections(&p, &t);
        assert_eq!(report.intersecting_pairs, 0, "{report:?}");
        assert!(report.candidate_pairs > t.len() as u64);
    }

    #[test]
    fn interpenetrating_cubes_intersect() {
        let (a, b) = (
            cube(Vector3::zeros(), 1.0, 1),
            cube(v(0.5, 0.5, 0.5), 1.0, 1),
        );
        let between = intersections_between(&a.0, &a.1, &b.0, &b.1);
        assert!(between.intersecting_pairs > 0, "{between:?}");
        let hit = between.first.unwrap();
        let (ta, tb) = (a.1[hit.first as usize], b.1[hit.second as usize]);
        assert!(triangles_intersect(corners(&a.0, ta), corners(&b.0, tb)));
        let (p, t) = join(&a, &b);
        let within = self_intersections(&p, &t);
        assert_eq!(within.intersecting_pairs, between.intersecting_pairs);
    }

    #[test]
    fn touching_cubes_intersect_until_moved_1e_9_apart() {
        let a = cube(Vector3::zeros(), 1.0, 3);
        let touching = cube(v(1.0, 0.2, -0.3), 1.0, 2);
        let apart = cube(v(1.0 + 1e-9, 0.2, -0.3), 1.0, 2);
        let between = |b: &Mesh| intersections_between(&a.0, &a.1, &b.0, &b.1);
        let within = |b: &Mesh| {
            let (p, t) = join(&a, b);
            self_intersections(&p, &t)
        };
        assert!(between(&touching).intersecting_pairs > 0);
        assert!(within(&touching).intersecting_pairs > 0);
        assert_eq!(between(&apart), IntersectionReport::default());
        assert_eq!(within(&apart).intersecting_pairs, 0);
        // A tilted obstacle on the plane x + z = 2, touching the edge x = z = 1: its box
        // overlaps the cube's, so the exact predicates decide.
        let roof = vec![v(2.0, -1.0, 0.0), v(2.0, 2.0, 0.0), v(0.0, 0.5, 2.0)];
        let lifted: Vec<_> = roof.iter().map(|p| p + v(1e-9, 0.0, 1e-9)).collect();
        let on_roof = |p: &[Vector3<f64>]| intersections_between(&a.0, &a.1, p, &[[0, 1, 2]]);
        assert!(on_roof(&roof).intersecting_pairs > 0);
        let report = on_roof(&lifted);
        assert_eq!(report.intersecting_pairs, 0);
        assert!(report.candidate_pairs > 0, "{report:?}");
    }

    #[test]
    fn a_vertex_pushed_through_the_opposite_face_is_caught() {
        let (mut p, t) = cube(Vector3::zeros(), 1.0, 4);
        let top_centre = p.iter().position(|q| *q == v(0.5, 0.5, 1.0)).unwrap();
        p[top_centre].z = -0.5;
        let report = self_intersections(&p, &t);
        assert!(report.intersecting_pairs >= 4, "{report:?}");
    }

    #[test]
    fn a_triangle_folded_through_a_neighbour_at_a_shared_vertex_is_caught() {
        let p = vec![
            base()[0],
            base()[1],
            base()[2],
            v(0.5, 0.5, -1.0),
            v(0.5, 0.5, 1.0),
        ];
        let report = self_intersections(&p, &[[0, 1, 2], [0, 3, 4]]);
        assert_eq!(report.intersecting_pairs, 1);
        assert_eq!(
            report.first,
            Some(Intersection {
                first: 0,
                second: 1
            })
        );
        // Folded the other way it only meets its neighbour at the shared vertex.
        let p = vec![
            base()[0],
            base()[1],
            base()[2],
            v(-0.5, -0.5, -1.0),
            v(-0.5, -0.5, 1.0),
        ];
        let report = self_intersections(&p, &[[0, 1, 2], [0, 3, 4]]);
        assert_eq!((report.intersecting_pairs, report.candidate_pairs), (0, 1));
    }

    #[test]
    fn triangles_sharing_an_edge_are_skipped() {
        // Folded flat onto each other across the shared edge: overlapping, yet adjacent.
        let p = vec![
            v(0.0, 0.0, 0.0),
            v(2.0, 0.0, 0.0),
            v(0.0, 2.0, 0.0),
            v(1.0, 1.0, 0.0),
        ];
        let report = self_intersections(&p, &[[0, 1, 2], [1, 0, 3]]);
        assert_eq!(report, IntersectionReport::default());
        assert!(meet([p[0], p[1], p[2]], [p[1], p[0], p[3]]));
    }
}
