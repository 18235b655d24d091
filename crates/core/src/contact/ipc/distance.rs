//! Unsigned squared distances between mesh primitives for Incremental Potential Contact (IPC,
//! Li et al. 2020), with exact gradients and Hessians, and IPC's edge–edge mollifier.
//!
//! A pair is classified by its closest features ([`PointTriangleCase`], [`EdgeEdgeCase`]); its
//! squared distance is that case's smooth formula (point–point, point–line, point–plane or
//! line–line), equal to the distance between the closed primitives. Derivatives are the
//! formula's, w.r.t. the vertices in argument order, xyz per vertex (zero for vertices off the
//! closest features).
//!
//! Hessians are closed forms: each formula is a function of a few difference vectors and at
//! most one cross product, whose derivatives are short expressions, carried to the vertices by
//! a ±1 map. That is a few hundred flops on the stack per pair, with no allocation and no new
//! crate, where a second-order forward-mode number over 12 variables would spend hundreds of
//! flops on each of its dozens of products.
//!
//! Nearly parallel edges and sliver triangles keep full precision: their normal is computed
//! with fused multiply-adds, so cases fall back to lower-dimensional ones only at round-off
//! level (`sin² θ ≤ ε²`, not IPC's `1e-20`; see `DEGENERATE_SIN2`). No input yields NaN.

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Gradient w.r.t. two vertices.
pub type Vec6 = SVector<f64, 6>;
/// Hessian w.r.t. two vertices.
pub type Mat6 = SMatrix<f64, 6, 6>;
/// Gradient w.r.t. three vertices.
pub type Vec9 = SVector<f64, 9>;
/// Hessian w.r.t. three vertices.
pub type Mat9 = SMatrix<f64, 9, 9>;
/// Gradient w.r.t. four vertices.
pub type Vec12 = SVector<f64, 12>;
/// Hessian w.r.t. four vertices.
pub type Mat12 = SMatrix<f64, 12, 12>;

type V3 = Vector3<f64>;

/// Fallback threshold on `sin²` of the angle between two edges (for a triangle `|n|²/ℓ⁴`, `ℓ`
/// its longest edge; for a point and an edge `|e|²/|p − e0|²`). Falling back moves the distance
/// by at most about `ε` times the primitives' size, below the rounding of the positions. IPC
/// uses `1e-20` because the plain cross product's rounding tilts `n` by `ε/sin θ`, which moves
/// a line–line distance by up to `2e-6` of the edge length at that angle; `accurate_cross`
/// removes that error, so the formulas stay accurate (`~ε |ea0 − eb0|`) down to this threshold.
/// Nearly parallel line–line Hessians grow like `1/sin² θ`; the mollifier, which vanishes like
/// `sin² θ`, keeps the mollified barrier's bounded.
const DEGENERATE_SIN2: f64 = f64::EPSILON * f64::EPSILON;

/// Which features of a point–triangle pair are closest (IPC's distance types).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PointTriangleCase {
    /// Vertex 0, 1 or 2 (`t0`, `t1`, `t2`): point–point.
    Vertex(u8),
    /// Edge 0 (`t0t1`), 1 (`t1t2`) or 2 (`t2t0`): point–line.
    Edge(u8),
    /// The triangle's interior: point–plane.
    Face,
}

/// Which features of an edge–edge pair are closest (IPC's distance types).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EdgeEdgeCase {
    /// End `i` of edge a (`ea_i`) and end `j` of edge b (`eb_j`): point–point.
    Points(u8, u8),
    /// End `i` of edge a against the interior of edge b: point–line.
    PointA(u8),
    /// End `j` of edge b against the interior of edge a: point–line.
    PointB(u8),
    /// Interior points of both edges: line–line.
    Lines,
}

/// Which feature of a segment is closest to a point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum PointEdgeCase {
    Start,
    End,
    Line,
}

/// The closest features of point `p` and triangle `(t0, t1, t2)`.
pub fn point_triangle_case(p: &V3, t0: &V3, t1: &V3, t2: &V3) -> PointTriangleCase {
    let t = [t0, t1, t2];
    let e = [t1 - t0, t2 - t1, t0 - t2];
    let ee = [
        e[0].norm_squared(),
        e[1].norm_squared(),
        e[2].norm_squared(),
    ];
    let l2 = ee[0].max(ee[1]).max(ee[2]);
    let n = accurate_cross(&e[0], &(t2 - t0));
    if n.norm_squared() <= DEGENERATE_SIN2 * l2 * l2 {
        return degenerate_triangle_case(p, t);
    }
    // re[k] / ee[k] is the parameter of p's projection on the line of edge k.
    let re: [f64; 3] = std::array::from_fn(|k| (p - t[k]).dot(&e[k]));
    for k in 0..3 {
        let prev = (k + 2) % 3;
        if re[k] <= 0.0 && re[prev] >= ee[prev] {
            return PointTriangleCase::Vertex(k as u8);
        }
    }
    for k in 0..3 {
        // `e[k] × n` points out of the triangle, in its plane.
        if re[k] > 0.0 && re[k] < ee[k] && (p - t[k]).dot(&e[k].cross(&n)) >= 0.0 {
            return PointTriangleCase::Edge(k as u8);
        }
    }
    PointTriangleCase::Face
}

/// A (nearly) zero-area triangle is its three edges: the closest of three point–edge pairs.
fn degenerate_triangle_case(p: &V3, t: [&V3; 3]) -> PointTriangleCase {
    let mut best = (f64::INFINITY, PointTriangleCase::Vertex(0));
    for k in 0..3 {
        let l = (k + 1) % 3;
        let (case, d2) = point_edge_eval(p, t[k], t[l]);
        let case = match case {
            PointEdgeCase::Start => PointTriangleCase::Vertex(k as u8),
            PointEdgeCase::End => PointTriangleCase::Vertex(l as u8),
            PointEdgeCase::Line => PointTriangleCase::Edge(k as u8),
        };
        if d2 < best.0 {
            best = (d2, case);
        }
    }
    best.1
}

/// The closest features of edges `(ea0, ea1)` and `(eb0, eb1)`.
pub fn edge_edge_case(ea0: &V3, ea1: &V3, eb0: &V3, eb1: &V3) -> EdgeEdgeCase {
    let (u, v, w) = (ea1 - ea0, eb1 - eb0, ea0 - eb0);
    let n = accurate_cross(&u, &v);
    let nn = n.norm_squared();
    if nn > DEGENERATE_SIN2 * u.norm_squared() * v.norm_squared() {
        // The lines' closest points are ea0 + s u and eb0 + t v with (s, t) = (sn, tn) / nn.
        let sn = accurate_cross(&v, &w).dot(&n);
        let tn = accurate_cross(&u, &w).dot(&n);
        if sn > 0.0 && sn < nn && tn > 0.0 && tn < nn {
            return EdgeEdgeCase::Lines;
        }
    }
    // Otherwise the minimum over the parameter square lies on its boundary, whose four sides
    // are the four point–edge pairs.
    let (ea, eb) = ([ea0, ea1], [eb0, eb1]);
    let mut best = (f64::INFINITY, EdgeEdgeCase::Points(0, 0));
    for i in 0..2u8 {
        let (case, d2) = point_edge_eval(ea[i as usize], eb0, eb1);
        let case = match case {
            PointEdgeCase::Start => EdgeEdgeCase::Points(i, 0),
            PointEdgeCase::End => EdgeEdgeCase::Points(i, 1),
            PointEdgeCase::Line => EdgeEdgeCase::PointA(i),
        };
        if d2 < best.0 {
            best = (d2, case);
        }
    }
    for j in 0..2u8 {
        let (case, d2) = point_edge_eval(eb[j as usize], ea0, ea1);
        let case = match case {
            PointEdgeCase::Start => EdgeEdgeCase::Points(0, j),
            PointEdgeCase::End => EdgeEdgeCase::Points(1, j),
            PointEdgeCase::Line => EdgeEdgeCase::PointB(j),
        };
        if d2 < best.0 {
            best = (d2, case);
        }
    }
    best.1
}

/// The closest feature of segment `(e0, e1)` to `p`; a (nearly) zero-length edge is its start.
fn point_edge_case(p: &V3, e0: &V3, e1: &V3) -> PointEdgeCase {
    let (r, e) = (p - e0, e1 - e0);
    let (re, ee) = (r.dot(&e), e.norm_squared());
    if re <= 0.0 || ee <= DEGENERATE_SIN2 * r.norm_squared() {
        PointEdgeCase::Start
    } else if re >= ee {
        PointEdgeCase::End
    } else {
        PointEdgeCase::Line
    }
}

/// The point–edge case and its squared distance.
fn point_edge_eval(p: &V3, e0: &V3, e1: &V3) -> (PointEdgeCase, f64) {
    let case = point_edge_case(p, e0, e1);
    let d2 = match case {
        PointEdgeCase::Start => (p - e0).norm_squared(),
        PointEdgeCase::End => (p - e1).norm_squared(),
        PointEdgeCase::Line => point_line_value(p, e0, e1),
    };
    (case, d2)
}

/// `|a − b|²`.
pub fn point_point_distance_squared(a: &V3, b: &V3) -> f64 {
    (a - b).norm_squared()
}

/// Squared distance from `p` to the segment `(e0, e1)`.
pub fn point_edge_distance_squared(p: &V3, e0: &V3, e1: &V3) -> f64 {
    point_edge_eval(p, e0, e1).1
}

/// Squared distance from `p` to the closed triangle `(t0, t1, t2)`.
pub fn point_triangle_distance_squared(p: &V3, t0: &V3, t1: &V3, t2: &V3) -> f64 {
    let t = [t0, t1, t2];
    match point_triangle_case(p, t0, t1, t2) {
        PointTriangleCase::Vertex(k) => (p - t[k as usize]).norm_squared(),
        PointTriangleCase::Edge(k) => {
            let k = k as usize;
            point_line_value(p, t[k], t[(k + 1) % 3])
        }
        PointTriangleCase::Face => plane_value(&(p - t0), &(t1 - t0), &(t2 - t0)),
    }
}

/// Squared distance between the segments `(ea0, ea1)` and `(eb0, eb1)`.
pub fn edge_edge_distance_squared(ea0: &V3, ea1: &V3, eb0: &V3, eb1: &V3) -> f64 {
    let (ea, eb) = ([ea0, ea1], [eb0, eb1]);
    match edge_edge_case(ea0, ea1, eb0, eb1) {
        EdgeEdgeCase::Points(i, j) => (ea[i as usize] - eb[j as usize]).norm_squared(),
        EdgeEdgeCase::PointA(i) => point_line_value(ea[i as usize], eb0, eb1),
        EdgeEdgeCase::PointB(j) => point_line_value(eb[j as usize], ea0, ea1),
        EdgeEdgeCase::Lines => plane_value(&(ea0 - eb0), &(ea1 - ea0), &(eb1 - eb0)),
    }
}

/// `|a − b|²`, its gradient and Hessian w.r.t. `(a, b)`.
pub fn point_point_distance_derivatives(a: &V3, b: &V3) -> (f64, Vec6, Mat6) {
    let d = a - b;
    let mut g = Vec6::zeros();
    g.fixed_rows_mut::<3>(0).copy_from(&(2.0 * d));
    g.fixed_rows_mut::<3>(3).copy_from(&(-2.0 * d));
    let i2 = 2.0 * Matrix3::identity();
    let mut h = Mat6::zeros();
    h.fixed_view_mut::<3, 3>(0, 0).copy_from(&i2);
    h.fixed_view_mut::<3, 3>(3, 3).copy_from(&i2);
    h.fixed_view_mut::<3, 3>(0, 3).copy_from(&-i2);
    h.fixed_view_mut::<3, 3>(3, 0).copy_from(&-i2);
    (d.norm_squared(), g, h)
}

/// Squared distance from `p` to the segment `(e0, e1)`, with the gradient and Hessian of its
/// case's formula w.r.t. `(p, e0, e1)`.
pub fn point_edge_distance_derivatives(p: &V3, e0: &V3, e1: &V3) -> (f64, Vec9, Mat9) {
    match point_edge_case(p, e0, e1) {
        PointEdgeCase::Start => embed(point_point_distance_derivatives(p, e0), &[0, 1]),
        PointEdgeCase::End => embed(point_point_distance_derivatives(p, e1), &[0, 2]),
        PointEdgeCase::Line => point_line_derivatives(p, e0, e1),
    }
}

/// d², gradient and Hessian w.r.t. `(p, t0, t1, t2)`, using the formula of the case at these
/// positions.
pub fn point_triangle_distance_derivatives(
    p: &V3,
    t0: &V3,
    t1: &V3,
    t2: &V3,
) -> (f64, Vec12, Mat12) {
    let t = [t0, t1, t2];
    match point_triangle_case(p, t0, t1, t2) {
        PointTriangleCase::Vertex(k) => {
            let k = k as usize;
            embed(point_point_distance_derivatives(p, t[k]), &[0, 1 + k])
        }
        PointTriangleCase::Edge(k) => {
            let (k, l) = (k as usize, (k as usize + 1) % 3);
            embed(point_line_derivatives(p, t[k], t[l]), &[0, 1 + k, 1 + l])
        }
        PointTriangleCase::Face => {
            let (d2, g, h) = plane_derivatives(&(p - t0), &(t1 - t0), &(t2 - t0));
            // (p − t0, t1 − t0, t2 − t0) from (p, t0, t1, t2).
            let (g, h) = pull_back(&g, &h, &[1., -1., 0., 0., 0., -1., 1., 0., 0., -1., 0., 1.]);
            (d2, g, h)
        }
    }
}

/// d², gradient and Hessian w.r.t. `(ea0, ea1, eb0, eb1)`, using the formula of the case at
/// these positions.
pub fn edge_edge_distance_derivatives(
    ea0: &V3,
    ea1: &V3,
    eb0: &V3,
    eb1: &V3,
) -> (f64, Vec12, Mat12) {
    let (ea, eb) = ([ea0, ea1], [eb0, eb1]);
    match edge_edge_case(ea0, ea1, eb0, eb1) {
        EdgeEdgeCase::Points(i, j) => {
            let (i, j) = (i as usize, j as usize);
            embed(point_point_distance_derivatives(ea[i], eb[j]), &[i, 2 + j])
        }
        EdgeEdgeCase::PointA(i) => {
            let i = i as usize;
            embed(point_line_derivatives(ea[i], eb0, eb1), &[i, 2, 3])
        }
        EdgeEdgeCase::PointB(j) => {
            let j = j as usize;
            embed(point_line_derivatives(eb[j], ea0, ea1), &[2 + j, 0, 1])
        }
        EdgeEdgeCase::Lines => {
            let (d2, g, h) = plane_derivatives(&(ea0 - eb0), &(ea1 - ea0), &(eb1 - eb0));
            // (ea0 − eb0, ea1 − ea0, eb1 − eb0) from (ea0, ea1, eb0, eb1).
            let (g, h) = pull_back(&g, &h, &[1., 0., -1., 0., -1., 1., 0., 0., 0., 0., -1., 1.]);
            (d2, g, h)
        }
    }
}

/// IPC's mollifier threshold `ε_x = 1e-3 |ea0 − ea1|² |eb0 − eb1|²` from rest positions.
pub fn edge_edge_mollifier_threshold(
    ea0_rest: &V3,
    ea1_rest: &V3,
    eb0_rest: &V3,
    eb1_rest: &V3,
) -> f64 {
    1e-3 * (ea0_rest - ea1_rest).norm_squared() * (eb0_rest - eb1_rest).norm_squared()
}

/// IPC's edge–edge mollifier with its gradient and Hessian w.r.t. `(ea0, ea1, eb0, eb1)`:
/// `m = c(2 − c)` with `c = x / eps_x`, `x = |(ea1 − ea0)×(eb1 − eb0)|²`, while `x < eps_x`,
/// else 1 (C¹ at the threshold). `eps_x ≤ 0` gives 1.
pub fn edge_edge_mollifier(
    ea0: &V3,
    ea1: &V3,
    eb0: &V3,
    eb1: &V3,
    eps_x: f64,
) -> (f64, Vec12, Mat12) {
    let (u, v) = (ea1 - ea0, eb1 - eb0);
    let n = u.cross(&v);
    let x = n.norm_squared();
    if x >= eps_x {
        return (1.0, Vec12::zeros(), Mat12::zeros());
    }
    // x = |n|² over (u, v): gradient (N_uᵀ 2n, N_vᵀ 2n), Hessian 2NᵀN plus the cross term.
    let (nu, nv) = (-v.cross_matrix(), u.cross_matrix());
    let mut gx = Vec6::zeros();
    gx.fixed_rows_mut::<3>(0).copy_from(&(2.0 * nu.tr_mul(&n)));
    gx.fixed_rows_mut::<3>(3).copy_from(&(2.0 * nv.tr_mul(&n)));
    let uv = 2.0 * (nu.tr_mul(&nv) - n.cross_matrix());
    let mut hx = Mat6::zeros();
    hx.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(2.0 * nu.tr_mul(&nu)));
    hx.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(2.0 * nv.tr_mul(&nv)));
    hx.fixed_view_mut::<3, 3>(0, 3).copy_from(&uv);
    hx.fixed_view_mut::<3, 3>(3, 0).copy_from(&uv.transpose());
    let c = x / eps_x;
    let (dm, d2m) = (2.0 * (1.0 - c) / eps_x, -2.0 / (eps_x * eps_x));
    let gy = dm * gx;
    let hy = dm * hx + d2m * gx * gx.transpose();
    // (ea1 − ea0, eb1 − eb0) from (ea0, ea1, eb0, eb1).
    let (g, h) = pull_back(&gy, &hy, &[-1., 1., 0., 0., 0., 0., -1., 1.]);
    (c * (2.0 - c), g, h)
}

/// `a × b` with each component accurate to a few ulps: the plain product where `a` and `b` are
/// more than ~6° apart (its rounding then tilts it by at most ~10ε), else Kahan's difference of
/// products with fused multiply-adds (a libm call where the target lacks FMA).
fn accurate_cross(a: &V3, b: &V3) -> V3 {
    fn dop(a: f64, b: f64, c: f64, d: f64) -> f64 {
        let cd = c * d;
        a.mul_add(b, -cd) + (-c).mul_add(d, cd)
    }
    let n = a.cross(b);
    if n.norm_squared() >= 1e-2 * a.norm_squared() * b.norm_squared() {
        return n;
    }
    V3::new(
        dop(a.y, b.z, a.z, b.y),
        dop(a.z, b.x, a.x, b.z),
        dop(a.x, b.y, a.y, b.x),
    )
}

/// `|(p − e0)×(e1 − e0)|² / |e1 − e0|²`.
fn point_line_value(p: &V3, e0: &V3, e1: &V3) -> f64 {
    let e = e1 - e0;
    (p - e0).cross(&e).norm_squared() / e.norm_squared()
}

/// `(r·n)² / |n|²` with `n = a × b`.
fn plane_value(r: &V3, a: &V3, b: &V3) -> f64 {
    let n = accurate_cross(a, b);
    let h = r.dot(&n);
    h * h / n.norm_squared()
}

/// Point–line formula and its derivatives w.r.t. `(p, e0, e1)`. With `r = p − e0`,
/// `e = e1 − e0`, `q = r·e/|e|²` and `δ = r − q e`: `∂/∂r = 2δ`, `∂/∂e = −2qδ`.
fn point_line_derivatives(p: &V3, e0: &V3, e1: &V3) -> (f64, Vec9, Mat9) {
    let (r, e) = (p - e0, e1 - e0);
    let beta = e.norm_squared();
    let q = r.dot(&e) / beta;
    let delta = r - q * e;
    let m = delta - q * e;
    let id = Matrix3::identity();
    let mut g = Vec6::zeros();
    g.fixed_rows_mut::<3>(0).copy_from(&(2.0 * delta));
    g.fixed_rows_mut::<3>(3).copy_from(&(-2.0 * q * delta));
    let re = -2.0 * q * id - (2.0 / beta) * e * m.transpose();
    let mut h = Mat6::zeros();
    h.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(2.0 * id - (2.0 / beta) * e * e.transpose()));
    h.fixed_view_mut::<3, 3>(0, 3).copy_from(&re);
    h.fixed_view_mut::<3, 3>(3, 0).copy_from(&re.transpose());
    h.fixed_view_mut::<3, 3>(3, 3)
        .copy_from(&(2.0 * q * q * id - (2.0 / beta) * m * m.transpose()));
    let d2 = r.cross(&e).norm_squared() / beta;
    // (p − e0, e1 − e0) from (p, e0, e1).
    let (g, h) = pull_back(&g, &h, &[1., -1., 0., 0., -1., 1.]);
    (d2, g, h)
}

/// `(r·n)²/|n|²` with `n = a × b` and its derivatives w.r.t. `(r, a, b)`: those w.r.t.
/// `(r, n)` in terms of `n̂` and the signed distance `s = r·n̂`, chained through
/// `∂n/∂a = −[b]×`, `∂n/∂b = [a]×` and the bilinear term `∂²(g·n)/∂a∂b = −[g]×`.
fn plane_derivatives(r: &V3, a: &V3, b: &V3) -> (f64, Vec9, Mat9) {
    let n = accurate_cross(a, b);
    let beta = n.norm_squared();
    let h = r.dot(&n);
    let d2 = h * h / beta;
    let nu = beta.sqrt();
    let nh = n / nu;
    let s = h / nu;
    let id = Matrix3::identity();
    let f_r = 2.0 * s * nh;
    let f_n = (2.0 * s / nu) * (r - s * nh);
    let f_rr = 2.0 * nh * nh.transpose();
    let f_rn = (2.0 / nu) * (nh * r.transpose() + s * id - 2.0 * s * nh * nh.transpose());
    let rn = r * nh.transpose();
    let f_nn = (2.0 * r * r.transpose() - 4.0 * s * (rn + rn.transpose()) - 2.0 * s * s * id
        + 8.0 * s * s * nh * nh.transpose())
        / beta;
    let (na, nb) = (-b.cross_matrix(), a.cross_matrix());
    let mut g = Vec9::zeros();
    g.fixed_rows_mut::<3>(0).copy_from(&f_r);
    g.fixed_rows_mut::<3>(3).copy_from(&na.tr_mul(&f_n));
    g.fixed_rows_mut::<3>(6).copy_from(&nb.tr_mul(&f_n));
    let blocks = [
        [f_rr, f_rn * na, f_rn * nb],
        [
            Matrix3::zeros(),
            na.tr_mul(&(f_nn * na)),
            na.tr_mul(&(f_nn * nb)) - f_n.cross_matrix(),
        ],
        [Matrix3::zeros(), Matrix3::zeros(), nb.tr_mul(&(f_nn * nb))],
    ];
    let mut hess = Mat9::zeros();
    for (i, row) in blocks.iter().enumerate() {
        for (j, block) in row.iter().enumerate().skip(i) {
            hess.fixed_view_mut::<3, 3>(3 * i, 3 * j).copy_from(block);
            hess.fixed_view_mut::<3, 3>(3 * j, 3 * i)
                .copy_from(&block.transpose());
        }
    }
    (d2, g, hess)
}

/// Gradient and Hessian w.r.t. vertices `x` from those w.r.t. vectors
/// `y_k = Σ_i coef[k·(C/3) + i] x_i`: `Aᵀg` and `AᵀHA` (exactly symmetric), skipping the zero
/// blocks of `A`.
fn pull_back<const R: usize, const C: usize>(
    g: &SVector<f64, R>,
    h: &SMatrix<f64, R, R>,
    coef: &[f64],
) -> (SVector<f64, C>, SMatrix<f64, C, C>) {
    debug_assert_eq!(coef.len() * 9, R * C);
    let mut gx = SVector::<f64, C>::zeros();
    let mut ha = SMatrix::<f64, R, C>::zeros();
    let mut hx = SMatrix::<f64, C, C>::zeros();
    for (k, &c) in coef.iter().enumerate() {
        let (y, x) = (3 * (k / (C / 3)), 3 * (k % (C / 3)));
        if c != 0.0 {
            for d in 0..3 {
                gx[x + d] += c * g[y + d];
                ha.column_mut(x + d).axpy(c, &h.column(y + d), 1.0);
            }
        }
    }
    for (k, &c) in coef.iter().enumerate() {
        let (y, x) = (3 * (k / (C / 3)), 3 * (k % (C / 3)));
        if c != 0.0 {
            for d in 0..3 {
                for j in 0..C {
                    hx[(x + d, j)] += c * ha[(y + d, j)];
                }
            }
        }
    }
    // Exactly symmetric (the two passes round differently).
    for i in 0..C {
        for j in i + 1..C {
            let mean = 0.5 * (hx[(i, j)] + hx[(j, i)]);
            (hx[(i, j)], hx[(j, i)]) = (mean, mean);
        }
    }
    (gx, hx)
}

/// Places the derivatives w.r.t. a few vertices at `slots` of a larger stencil (zeros
/// elsewhere).
fn embed<const R: usize, const C: usize>(
    (v, g, h): (f64, SVector<f64, R>, SMatrix<f64, R, R>),
    slots: &[usize],
) -> (f64, SVector<f64, C>, SMatrix<f64, C, C>) {
    let mut go = SVector::<f64, C>::zeros();
    let mut ho = SMatrix::<f64, C, C>::zeros();
    for (k, &sk) in slots.iter().enumerate() {
        go.fixed_rows_mut::<3>(3 * sk)
            .copy_from(&g.fixed_rows::<3>(3 * k));
        for (l, &sl) in slots.iter().enumerate() {
            ho.fixed_view_mut::<3, 3>(3 * sk, 3 * sl)
                .copy_from(&h.fixed_view::<3, 3>(3 * k, 3 * l));
        }
    }
    (v, go, ho)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// xorshift64*: deterministic uniform numbers from std alone.
    struct Rng(u64);

    impl Rng {
        fn new(seed: u64) -> Self {
            Self(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
        }
        fn unit(&mut self) -> f64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 53) as f64
        }
        fn range(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * self.unit()
        }
        fn point(&mut self, half: f64) -> V3 {
            V3::new(
                self.range(-half, half),
                self.range(-half, half),
                self.range(-half, half),
            )
        }
        fn direction(&mut self) -> V3 {
            loop {
                let v = self.point(1.0);
                if (0.1..1.0).contains(&v.norm()) {
                    return v.normalize();
                }
            }
        }
    }

    type Derivs<const N: usize> = (f64, SVector<f64, N>, SMatrix<f64, N, N>);

    fn stack<const N: usize>(vs: &[V3]) -> SVector<f64, N> {
        SVector::from_fn(|i, _| vs[i / 3][i % 3])
    }

    fn at<const N: usize>(x: &SVector<f64, N>, i: usize) -> V3 {
        x.fixed_rows::<3>(3 * i).into_owned()
    }

    fn pt(x: &Vec12) -> Derivs<12> {
        point_triangle_distance_derivatives(&at(x, 0), &at(x, 1), &at(x, 2), &at(x, 3))
    }

    fn ee(x: &Vec12) -> Derivs<12> {
        edge_edge_distance_derivatives(&at(x, 0), &at(x, 1), &at(x, 2), &at(x, 3))
    }

    fn pe(x: &Vec9) -> Derivs<9> {
        point_edge_distance_derivatives(&at(x, 0), &at(x, 1), &at(x, 2))
    }

    fn pt_case(x: &Vec12) -> usize {
        match point_triangle_case(&at(x, 0), &at(x, 1), &at(x, 2), &at(x, 3)) {
            PointTriangleCase::Vertex(k) => k as usize,
            PointTriangleCase::Edge(k) => 3 + k as usize,
            PointTriangleCase::Face => 6,
        }
    }

    fn ee_case(x: &Vec12) -> usize {
        match edge_edge_case(&at(x, 0), &at(x, 1), &at(x, 2), &at(x, 3)) {
            EdgeEdgeCase::Points(i, j) => 2 * i as usize + j as usize,
            EdgeEdgeCase::PointA(i) => 4 + i as usize,
            EdgeEdgeCase::PointB(j) => 6 + j as usize,
            EdgeEdgeCase::Lines => 8,
        }
    }

    fn pe_case(x: &Vec9) -> usize {
        point_edge_case(&at(x, 0), &at(x, 1), &at(x, 2)) as usize
    }

    /// Largest errors of central differences, of the value against the gradient and of the
    /// gradient against the Hessian, relative to the largest entry; `None` if a perturbed
    /// stencil changes the case (another formula).
    fn fd_errors<const N: usize>(
        x: &SVector<f64, N>,
        f: impl Fn(&SVector<f64, N>) -> Derivs<N>,
        case: impl Fn(&SVector<f64, N>) -> usize,
    ) -> Option<(f64, f64)> {
        const STEP: f64 = 1e-6;
        let (_, g, h) = f(x);
        assert_eq!(h, h.transpose(), "the Hessian at {x} is not symmetric");
        let mut g_fd = SVector::<f64, N>::zeros();
        let mut h_fd = SMatrix::<f64, N, N>::zeros();
        for i in 0..N {
            let (mut xp, mut xm) = (*x, *x);
            xp[i] += STEP;
            xm[i] -= STEP;
            if case(&xp) != case(x) || case(&xm) != case(x) {
                return None;
            }
            let ((fp, gp, _), (fm, gm, _)) = (f(&xp), f(&xm));
            let dx = xp[i] - xm[i];
            g_fd[i] = (fp - fm) / dx;
            h_fd.set_column(i, &((gp - gm) / dx));
        }
        let rel = |err: f64, size: f64| if err == 0.0 { 0.0 } else { err / size };
        Some((
            rel((g_fd - g).amax(), g.amax()),
            rel((h_fd - h).amax(), h.amax()),
        ))
    }

    /// Draws stencils until each of `cases` cases has passed `PER_CASE` finite-difference
    /// checks (stencils next to a case boundary are skipped); panics on an error or a case
    /// never reached.
    fn check_every_case<const N: usize>(
        cases: usize,
        seed: u64,
        draw: impl Fn(&mut Rng) -> Option<SVector<f64, N>>,
        f: impl Fn(&SVector<f64, N>) -> Derivs<N> + Copy,
        case: impl Fn(&SVector<f64, N>) -> usize + Copy,
    ) {
        const PER_CASE: usize = 25;
        let mut rng = Rng::new(seed);
        let mut checked = vec![0; cases];
        for _ in 0..200_000 {
            if checked.iter().all(|&c| c >= PER_CASE) {
                return;
            }
            let Some(x) = draw(&mut rng) else { continue };
            let k = case(&x);
            if checked[k] >= PER_CASE {
                continue;
            }
            if let Some((eg, eh)) = fd_errors(&x, f, case) {
                assert!(
                    eg < 1e-6 && eh < 1e-5,
                    "case {k} at {x}: gradient error {eg:e}, Hessian error {eh:e}"
                );
                checked[k] += 1;
            }
        }
        panic!("cases checked (PER_CASE = {PER_CASE} each): {checked:?}");
    }

    /// A triangle in [-1, 1]³ without short edges or small angles.
    fn shapely_triangle(rng: &mut Rng) -> Option<[V3; 3]> {
        let t = [rng.point(1.0), rng.point(1.0), rng.point(1.0)];
        let e = [t[1] - t[0], t[2] - t[1], t[0] - t[2]];
        let l2 = e.iter().map(|e| e.norm_squared()).fold(0.0, f64::max);
        let short = e.iter().any(|e| e.norm() < 0.3);
        (!short && e[0].cross(&e[1]).norm_squared() > 0.05 * l2 * l2).then_some(t)
    }

    /// Two edges in [-1, 1]³, neither short, not within about 2° of parallel.
    fn shapely_edges(rng: &mut Rng) -> Option<[V3; 4]> {
        let x = [
            rng.point(1.0),
            rng.point(1.0),
            rng.point(1.0),
            rng.point(1.0),
        ];
        let (u, v) = (x[1] - x[0], x[3] - x[2]);
        let ok = u.norm() > 0.3 && v.norm() > 0.3;
        (ok && u.cross(&v).norm_squared() > 1e-3 * u.norm_squared() * v.norm_squared()).then_some(x)
    }

    /// Edges whose `|ea × eb|²` is `c` times the mollifier threshold of these positions.
    fn edges_at_mollifier_ratio(rng: &mut Rng, c: f64) -> [V3; 4] {
        let (ea0, eb0) = (rng.point(1.0), rng.point(1.0));
        let u = rng.direction();
        let perp = u.cross(&rng.direction()).normalize();
        let sin2 = c * 1e-3;
        let v = (1.0 - sin2).sqrt() * u + sin2.sqrt() * perp;
        let (la, lb) = (rng.range(0.5, 1.5), rng.range(0.5, 1.5));
        [ea0, ea0 + la * u, eb0, eb0 + lb * v]
    }

    /// The smallest `f` over grids of the parameter domain, each grid finer and centred on the
    /// best sample so far. `project` maps parameters into the domain, so every sample is a
    /// pair of points of the primitives and the result is an upper bound of the distance.
    /// Returns the bound and its parameters.
    fn sampled_min(
        f: impl Fn(f64, f64) -> f64,
        project: impl Fn(f64, f64) -> (f64, f64),
    ) -> (f64, f64, f64) {
        const N: usize = 12;
        let (mut best, mut bu, mut bv) = (f64::INFINITY, 0.5, 0.5);
        let mut w = 0.5;
        for _ in 0..32 {
            let (cu, cv) = (bu, bv);
            for i in 0..=N {
                for j in 0..=N {
                    let a = |k: usize| w * (2.0 * k as f64 / N as f64 - 1.0);
                    let (u, v) = project(cu + a(i), cv + a(j));
                    let d = f(u, v);
                    if d < best {
                        (best, bu, bv) = (d, u, v);
                    }
                }
            }
            w *= 0.3;
        }
        (best, bu, bv)
    }

    fn square(u: f64, v: f64) -> (f64, f64) {
        (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0))
    }

    fn simplex(u: f64, v: f64) -> (f64, f64) {
        let (u, v) = (u.max(0.0), v.max(0.0));
        if u + v > 1.0 {
            (u / (u + v), v / (u + v))
        } else {
            (u, v)
        }
    }

    /// `|o + u a + v b|²` in plain arithmetic (quick in unoptimized builds).
    fn affine_norm2(o: V3, a: V3, b: V3) -> impl Fn(f64, f64) -> f64 {
        let (o, a, b): ([f64; 3], [f64; 3], [f64; 3]) = (o.into(), a.into(), b.into());
        move |u, v| (0..3).map(|k| (o[k] + u * a[k] + v * b[k]).powi(2)).sum()
    }

    /// Sampled bound for point–triangle, with barycentric weights of t1 and t2.
    fn sampled_point_triangle(p: &V3, t: &[V3; 3]) -> (f64, f64, f64) {
        let f = affine_norm2(p - t[0], t[0] - t[1], t[0] - t[2]);
        sampled_min(f, simplex)
    }

    /// Sampled bound for edge–edge, with the parameters along each edge.
    fn sampled_edge_edge(x: &[V3; 4]) -> (f64, f64, f64) {
        sampled_min(affine_norm2(x[0] - x[2], x[1] - x[0], x[2] - x[3]), square)
    }

    fn sampled_point_edge(p: &V3, e0: &V3, e1: &V3) -> f64 {
        sampled_min(affine_norm2(p - e0, e0 - e1, V3::zeros()), square).0
    }

    /// The returned `d2` is at most the sampled bound and within `tol` below it.
    fn assert_matches_sampling(what: &str, d2: f64, bound: f64, tol: f64) {
        assert!(
            d2 <= bound * (1.0 + 1e-12) + 1e-30,
            "{what}: d² = {d2:e} exceeds the sampled {bound:e}"
        );
        assert!(
            bound - d2 <= tol,
            "{what}: d² = {d2:e} is {:e} below the sampled {bound:e}",
            bound - d2
        );
    }

    fn assert_finite<const N: usize>(what: &str, (v, g, h): &Derivs<N>) {
        assert!(
            v.is_finite() && *v >= 0.0 && g.iter().chain(h.iter()).all(|x| x.is_finite()),
            "{what}: value {v}, gradient {g}"
        );
    }

    #[test]
    fn point_point_derivatives_match_finite_differences() {
        let f = |x: &Vec6| point_point_distance_derivatives(&at(x, 0), &at(x, 1));
        check_every_case(
            1,
            1,
            |r| Some(stack(&[r.point(1.0), r.point(1.0)])),
            f,
            |_| 0,
        );
    }

    #[test]
    fn point_edge_derivatives_match_finite_differences_in_every_case() {
        let draw = |r: &mut Rng| {
            let x = [r.point(2.0), r.point(1.0), r.point(1.0)];
            ((x[2] - x[1]).norm() > 0.3).then(|| stack(&x))
        };
        check_every_case(3, 2, draw, pe, pe_case);
    }

    #[test]
    fn point_triangle_derivatives_match_finite_differences_in_every_case() {
        let draw = |r: &mut Rng| {
            let [t0, t1, t2] = shapely_triangle(r)?;
            Some(stack(&[r.point(2.0), t0, t1, t2]))
        };
        check_every_case(7, 3, draw, pt, pt_case);
    }

    #[test]
    fn edge_edge_derivatives_match_finite_differences_in_every_case() {
        check_every_case(9, 4, |r| shapely_edges(r).map(|x| stack(&x)), ee, ee_case);
    }

    #[test]
    fn mollifier_derivatives_match_finite_differences_on_both_sides_of_its_threshold() {
        let eps =
            |x: &Vec12| edge_edge_mollifier_threshold(&at(x, 0), &at(x, 1), &at(x, 2), &at(x, 3));
        // The threshold is held fixed (rest positions) while the positions move.
        let draw = |r: &mut Rng| {
            // Away from c = 1, where the gradient vanishes and relative errors mean little.
            let c = if r.unit() < 0.5 {
                r.range(0.05, 0.95)
            } else {
                r.range(1.05, 3.0)
            };
            let x: Vec12 = stack(&edges_at_mollifier_ratio(r, c));
            let e = eps(&x);
            let m =
                move |y: &Vec12| edge_edge_mollifier(&at(y, 0), &at(y, 1), &at(y, 2), &at(y, 3), e);
            let side = move |y: &Vec12| {
                let n = (at(y, 1) - at(y, 0)).cross(&(at(y, 3) - at(y, 2)));
                usize::from(n.norm_squared() < e)
            };
            let (eg, eh) = fd_errors(&x, m, side)?;
            assert!(eg < 1e-6 && eh < 1e-5, "at {x}: errors {eg:e}, {eh:e}");
            let (v, g, h) = m(&x);
            if side(&x) == 0 {
                assert!(v == 1.0 && g == Vec12::zeros() && h == Mat12::zeros());
            } else {
                assert!(v > 0.0 && v < 1.0 && g.amax() > 0.0);
            }
            Some(side(&x))
        };
        let mut rng = Rng::new(5);
        let mut sides = [0; 2];
        for _ in 0..200 {
            if let Some(s) = draw(&mut rng) {
                sides[s] += 1;
            }
        }
        assert!(
            sides.iter().all(|&s| s >= 30),
            "samples per side: {sides:?}"
        );
    }

    #[test]
    fn mollifier_is_c1_at_its_threshold() {
        let mut rng = Rng::new(6);
        for _ in 0..20 {
            let x = edges_at_mollifier_ratio(&mut rng, 0.5);
            let e = edge_edge_mollifier_threshold(&x[0], &x[1], &x[2], &x[3]);
            let (_, g_mid, _) = edge_edge_mollifier(&x[0], &x[1], &x[2], &x[3], e);
            let x_eps = (x[1] - x[0]).cross(&(x[3] - x[2])).norm_squared();
            // Just below the threshold: value 1 and gradient 0 to first order in 1 − c.
            let (v, g, _) = edge_edge_mollifier(&x[0], &x[1], &x[2], &x[3], x_eps * (1.0 + 1e-9));
            assert!(
                (1.0 - v) < 1e-15 && g.amax() < 1e-8 * g_mid.amax(),
                "{v}, {g}"
            );
            let (v, _, _) = edge_edge_mollifier(&x[0], &x[1], &x[2], &x[3], 0.0);
            assert_eq!(v, 1.0);
        }
        let (a0, a1) = (V3::zeros(), V3::new(2.0, 0.0, 0.0));
        let (b0, b1) = (V3::new(0.0, 0.0, 1.0), V3::new(0.0, 3.0, 1.0));
        assert_eq!(
            edge_edge_mollifier_threshold(&a0, &a1, &b0, &b1),
            1e-3 * 4.0 * 9.0
        );
    }

    #[test]
    fn distances_match_dense_sampling() {
        let mut rng = Rng::new(8);
        let (mut pt_seen, mut ee_seen, mut pe_seen) = ([0; 7], [0; 9], [0; 3]);
        for _ in 0..200 {
            let (p, t) = (
                rng.point(2.0),
                [rng.point(1.0), rng.point(1.0), rng.point(1.0)],
            );
            let d2 = point_triangle_distance_squared(&p, &t[0], &t[1], &t[2]);
            let bound = sampled_point_triangle(&p, &t).0;
            assert_matches_sampling(&format!("{p} to {t:?}"), d2, bound, 1e-12);
            pt_seen[pt_case(&stack(&[p, t[0], t[1], t[2]]))] += 1;

            let x = [
                rng.point(1.0),
                rng.point(1.0),
                rng.point(1.0),
                rng.point(1.0),
            ];
            let d2 = edge_edge_distance_squared(&x[0], &x[1], &x[2], &x[3]);
            assert_matches_sampling(&format!("{x:?}"), d2, sampled_edge_edge(&x).0, 1e-12);
            ee_seen[ee_case(&stack(&x))] += 1;

            let d2 = point_edge_distance_squared(&p, &t[0], &t[1]);
            let bound = sampled_point_edge(&p, &t[0], &t[1]);
            assert_matches_sampling(&format!("{p} to {t:?}"), d2, bound, 1e-12);
            pe_seen[pe_case(&stack(&[p, t[0], t[1]]))] += 1;
        }
        let all = pt_seen.iter().chain(&ee_seen).chain(&pe_seen);
        assert!(
            all.copied().all(|n| n > 0),
            "{pt_seen:?} {ee_seen:?} {pe_seen:?}"
        );
    }

    #[test]
    fn cases_name_the_closest_features() {
        // Where the sampled closest points sit clearly on one feature, the case names it.
        let side = |w: f64| match w {
            w if w.abs() < 1e-9 => Some(true),
            w if w > 1e-4 => Some(false),
            _ => None,
        };
        let end = |s: f64| match (side(s)?, side(1.0 - s)?) {
            (true, _) => Some(Some(0u8)),
            (_, true) => Some(Some(1u8)),
            _ => Some(None),
        };
        let mut rng = Rng::new(9);
        let (mut pt_checked, mut ee_checked) = (0, 0);
        for _ in 0..200 {
            let Some(t) = shapely_triangle(&mut rng) else {
                continue;
            };
            let p = rng.point(2.0);
            let (_, u, v) = sampled_point_triangle(&p, &t);
            let zero = [side(1.0 - u - v), side(u), side(v)];
            if let [Some(z0), Some(z1), Some(z2)] = zero {
                let expected = match (z0, z1, z2) {
                    (false, false, false) => PointTriangleCase::Face,
                    (false, false, true) => PointTriangleCase::Edge(0),
                    (true, false, false) => PointTriangleCase::Edge(1),
                    (false, true, false) => PointTriangleCase::Edge(2),
                    (false, true, true) => PointTriangleCase::Vertex(0),
                    (true, false, true) => PointTriangleCase::Vertex(1),
                    (true, true, false) => PointTriangleCase::Vertex(2),
                    (true, true, true) => unreachable!("weights sum to 1"),
                };
                assert_eq!(point_triangle_case(&p, &t[0], &t[1], &t[2]), expected);
                pt_checked += 1;
            }
            let Some(x) = shapely_edges(&mut rng) else {
                continue;
            };
            let (_, s, t) = sampled_edge_edge(&x);
            if let (Some(i), Some(j)) = (end(s), end(t)) {
                let expected = match (i, j) {
                    (Some(i), Some(j)) => EdgeEdgeCase::Points(i, j),
                    (Some(i), None) => EdgeEdgeCase::PointA(i),
                    (None, Some(j)) => EdgeEdgeCase::PointB(j),
                    (None, None) => EdgeEdgeCase::Lines,
                };
                assert_eq!(
                    edge_edge_case(&x[0], &x[1], &x[2], &x[3]),
                    expected,
                    "{x:?}"
                );
                ee_checked += 1;
            }
        }
        assert!(
            pt_checked > 80 && ee_checked > 80,
            "{pt_checked}, {ee_checked}"
        );
    }

    #[test]
    fn derivative_values_equal_the_distance_functions() {
        let mut rng = Rng::new(10);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(b.abs());
        for k in 0..2000 {
            let mut x = [
                rng.point(1.0),
                rng.point(1.0),
                rng.point(1.0),
                rng.point(1.0),
            ];
            // Half the stencils collapse or align some vertices.
            match k % 8 {
                1 => x[2] = x[1],
                3 => x[3] = x[1] + 0.5 * (x[2] - x[1]),
                5 => x[1] = x[0] + (x[3] - x[2]) * rng.range(-2.0, 2.0),
                7 => x[3] = x[2],
                _ => {}
            }
            let y: Vec12 = stack(&x);
            let d2 = point_triangle_distance_squared(&x[0], &x[1], &x[2], &x[3]);
            assert!(close(pt(&y).0, d2), "{x:?}");
            let d2 = edge_edge_distance_squared(&x[0], &x[1], &x[2], &x[3]);
            assert!(close(ee(&y).0, d2), "{x:?}");
            let d2 = point_edge_distance_squared(&x[0], &x[1], &x[2]);
            assert!(close(pe(&stack(&x[..3])).0, d2), "{x:?}");
            let d2 = point_point_distance_squared(&x[0], &x[1]);
            assert!(close(point_point_distance_derivatives(&x[0], &x[1]).0, d2));
        }
    }

    #[test]
    fn hand_computed_configurations() {
        let t = [V3::zeros(), V3::new(1.0, 0.0, 0.0), V3::new(0.0, 1.0, 0.0)];
        let cases = [
            (V3::new(0.2, 0.2, 0.5), PointTriangleCase::Face, 0.25),
            (V3::new(-1.0, -1.0, 0.0), PointTriangleCase::Vertex(0), 2.0),
            (V3::new(2.0, -1.0, 1.0), PointTriangleCase::Vertex(1), 3.0),
            (V3::new(-0.5, 2.0, 0.0), PointTriangleCase::Vertex(2), 1.25),
            (V3::new(0.5, -1.0, 1.0), PointTriangleCase::Edge(0), 2.0),
            (V3::new(1.0, 1.0, 0.0), PointTriangleCase::Edge(1), 0.5),
            (V3::new(-1.0, 0.5, 0.0), PointTriangleCase::Edge(2), 1.0),
        ];
        for (p, case, d2) in cases {
            assert_eq!(point_triangle_case(&p, &t[0], &t[1], &t[2]), case);
            let got = point_triangle_distance_squared(&p, &t[0], &t[1], &t[2]);
            assert!((got - d2).abs() < 1e-15, "{p}: {got}");
        }
        let (a0, a1) = (V3::new(-1.0, 0.0, 0.0), V3::new(1.0, 0.0, 0.0));
        let cases = [
            ((0.0, -1.0, 0.0, 1.0), EdgeEdgeCase::Lines, 1.0),
            ((2.0, -1.0, 2.0, 1.0), EdgeEdgeCase::PointA(1), 2.0),
            ((0.5, 1.0, 0.5, 3.0), EdgeEdgeCase::PointB(0), 2.0),
            ((-2.0, 1.0, -3.0, 3.0), EdgeEdgeCase::Points(0, 0), 3.0),
        ];
        for ((x0, y0, x1, y1), case, d2) in cases {
            let (b0, b1) = (V3::new(x0, y0, 1.0), V3::new(x1, y1, 1.0));
            assert_eq!(edge_edge_case(&a0, &a1, &b0, &b1), case);
            let got = edge_edge_distance_squared(&a0, &a1, &b0, &b1);
            assert!((got - d2).abs() < 1e-15, "{b0} {b1}: {got}");
        }
    }

    #[test]
    fn degenerate_inputs_give_finite_values_and_the_right_distance() {
        let v = |x: f64, y: f64, z: f64| V3::new(x, y, z);
        let (o, ex) = (V3::zeros(), v(1.0, 0.0, 0.0));
        let tiny = v(1e-200, 0.0, 0.0);
        let triangles = [
            ("collinear", [o, ex, v(0.5, 0.0, 0.0)], v(0.3, 0.4, 0.2)),
            (
                "collinear, point on it",
                [o, ex, v(2.0, 0.0, 0.0)],
                v(1.5, 0.0, 0.0),
            ),
            ("two vertices coincide", [o, ex, ex], v(0.5, 1.0, 1.0)),
            ("all vertices coincide", [ex, ex, ex], v(0.5, 1.0, 1.0)),
            ("point on a vertex", [o, ex, v(0.0, 1.0, 0.0)], ex),
            (
                "needle 1e-12 wide",
                [o, ex, v(0.5, 1e-12, 0.0)],
                v(0.5, 0.0, 1e-3),
            ),
            (
                "sliver, point in plane",
                [o, ex, v(0.5, 1e-17, 0.0)],
                v(0.5, -1e-3, 0.0),
            ),
            (
                "tiny triangle",
                [o, tiny, v(0.0, 1e-200, 0.0)],
                v(0.0, 0.0, 1.0),
            ),
        ];
        for (what, t, p) in triangles {
            let d = point_triangle_distance_derivatives(&p, &t[0], &t[1], &t[2]);
            assert_finite(what, &d);
            let bound = sampled_point_triangle(&p, &t).0;
            assert_matches_sampling(what, d.0, bound, 1e-12);
            let d = point_edge_distance_derivatives(&p, &t[0], &t[2]);
            assert_finite(what, &d);
            assert_matches_sampling(what, d.0, sampled_point_edge(&p, &t[0], &t[2]), 1e-12);
        }
        let edges = [
            (
                "edge a is a point",
                [ex, ex, v(0.0, -1.0, 1.0), v(0.0, 1.0, 1.0)],
            ),
            ("both are points", [ex, ex, o, o]),
            (
                "parallel, apart",
                [o, ex, v(0.5, 1.0, 0.0), v(1.5, 1.0, 0.0)],
            ),
            (
                "collinear, overlapping",
                [o, ex, v(0.5, 0.0, 0.0), v(1.5, 0.0, 0.0)],
            ),
            ("identical", [o, ex, o, ex]),
            ("reversed", [o, ex, ex, o]),
            ("crossing", [o, ex, v(0.5, -1.0, 0.0), v(0.5, 1.0, 0.0)]),
            (
                "1e-20 rad apart",
                [o, ex, v(0.0, 0.1, 0.0), v(1.0, 0.1 + 1e-20, 0.0)],
            ),
            (
                "1e-12 rad, touching",
                [o, ex, v(0.0, -1e-12, 0.0), v(1.0, 1e-12, 0.0)],
            ),
            (
                "tiny edge",
                [o, ex, v(0.5, 1.0, 0.0), v(0.5, 1.0, 0.0) + tiny],
            ),
            (
                "1e-160 long, beside",
                [v(0.5e-160, 1.0, 0.0), v(0.0, 2.0, 0.0), o, 1e40 * tiny],
            ),
        ];
        for (what, x) in edges {
            let d = edge_edge_distance_derivatives(&x[0], &x[1], &x[2], &x[3]);
            assert_finite(what, &d);
            assert_matches_sampling(what, d.0, sampled_edge_edge(&x).0, 1e-12);
            let e = edge_edge_mollifier_threshold(&o, &ex, &o, &v(0.0, 1.0, 0.0));
            assert_finite(what, &edge_edge_mollifier(&x[0], &x[1], &x[2], &x[3], e));
        }
        assert_finite("points", &point_point_distance_derivatives(&o, &o));
        let p = v(0.5e-160, 1.0, 0.0);
        let d = point_edge_distance_derivatives(&p, &o, &(1e40 * tiny));
        assert_finite("point beside a 1e-160 edge", &d);
        assert_eq!(
            point_edge_case(&p, &o, &(1e40 * tiny)),
            PointEdgeCase::Start
        );
        // |n|² = 1.6e-33 ≤ ε² ℓ⁴: the three edges, not the plane.
        let t = [o, v(2.0, 0.0, 0.0), v(1.0, 1e-17, 0.0)];
        let p = v(1.0, 2e-18, 1.0);
        assert_ne!(
            point_triangle_case(&p, &t[0], &t[1], &t[2]),
            PointTriangleCase::Face
        );
        let d2 = point_triangle_distance_squared(&p, &t[0], &t[1], &t[2]);
        assert!((d2 - 1.0).abs() < 1e-15);
    }

    #[test]
    fn nearly_parallel_edges_keep_full_precision() {
        // Edge b crosses edge a at angle θ, a distance `gap` above it; rotated at random so
        // the rounding is generic. The plain cross product would err by ~ε/θ here.
        let mut rng = Rng::new(11);
        for theta in [1e-2, 1e-5, 1e-8, 1e-10, 1e-12, 1e-14, 1e-16, 1e-18, 0.0] {
            for gap in [1e-3, 1e-7, 0.0] {
                let axis = rng.direction();
                let rot = nalgebra::Rotation3::new(axis * rng.range(0.0, 3.0));
                let (c, s) = (f64::cos(theta), f64::sin(theta));
                let x = [
                    V3::new(-1.0, 0.0, 0.0),
                    V3::new(1.0, 0.0, 0.0),
                    V3::new(-0.7 * c, -0.7 * s, gap),
                    V3::new(0.9 * c, 0.9 * s, gap),
                ]
                .map(|p| rot * p + V3::new(0.3, -0.2, 0.1));
                let (d2, _, _) = ee(&stack(&x));
                let err = (d2.sqrt() - gap).abs();
                assert!(err < 1e-14, "θ = {theta:e}, gap {gap:e}: error {err:e}");
                let d2 = edge_edge_distance_squared(&x[0], &x[1], &x[2], &x[3]);
                assert!(
                    (d2.sqrt() - gap).abs() < 1e-14,
                    "θ = {theta:e}, gap {gap:e}"
                );
            }
        }
        // The Lines case needs |n|² > ε² |ea|² |eb|²: never for exactly parallel edges.
        let x = [
            V3::zeros(),
            V3::new(2.0, 0.0, 0.0),
            V3::new(0.5, 1.0, 0.0),
            V3::new(1.5, 1.0, 0.0),
        ];
        assert_ne!(
            edge_edge_case(&x[0], &x[1], &x[2], &x[3]),
            EdgeEdgeCase::Lines
        );
        // Crossing in projection at sin² θ = 4e-34: four point–edge pairs.
        let (b0, b1) = (V3::new(0.5, -1e-17, 1.0), V3::new(1.5, 1e-17, 1.0));
        assert_ne!(edge_edge_case(&x[0], &x[1], &b0, &b1), EdgeEdgeCase::Lines);
        // At sin² θ = 4e-24 the line–line formula is still accurate, and used.
        let (b0, b1) = (V3::new(0.5, -1e-12, 1.0), V3::new(1.5, 1e-12, 1.0));
        assert_eq!(edge_edge_case(&x[0], &x[1], &b0, &b1), EdgeEdgeCase::Lines);
        assert_eq!(edge_edge_distance_squared(&x[0], &x[1], &b0, &b1), 1.0);
    }
}
