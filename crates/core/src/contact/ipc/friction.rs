//! Lagged smooth friction of Incremental Potential Contact (Li et al. 2020, §5), one contact
//! stencil at a time: its potential, gradient and (PSD-projected) Hessian.
//!
//! # Model
//!
//! Everything of a contact `k` but the positions is *lagged*: evaluated by the caller once, at
//! the positions that start the step (or the lagging iteration), and held fixed for the solve:
//! - `λ_k ≥ 0` (N), the normal force magnitude of the barrier at the lagged positions;
//! - `T_k` (3×2), an orthonormal basis of the plane ⊥ the lagged contact normal `n_k`;
//! - `w_k`, closest-point weights over the stencil's vertices (at most 4), so that the relative
//!   displacement of the two closest points is `Σ_i w_i Δx_i` (point–triangle
//!   `(1, −β0, −β1, −β2)`, edge–edge `(1−α, α, −(1−β), −β)`, point–edge `(1, −(1−α), −α)`,
//!   point–point `(1, −1)`, vertex against an analytic obstacle `(1)`);
//! - `Δo_k` (m), the obstacle's own displacement over the step at the contact point (zero for
//!   self-contact).
//!
//! With `Γ_k = [w_1 I₃ … w_n I₃]` (3×3n), the tangential relative displacement over the step is
//!
//! ```text
//! u_k = T_kᵀ (Σ_i w_i (x_i − x_i^t) − Δo_k) = T_kᵀ (Γ_k (x − x^t) − Δo_k)   ∈ R²  (m)
//! ```
//!
//! and the friction potential (J) is `D_k(x) = μ λ_k f0(|u_k|)`, with IPC's C¹ mollifier of the
//! static–kinetic transition over the slip `ε_u = ε_v dt` (m):
//!
//! ```text
//! f1(y) = 2y/ε_u − y²/ε_u²                  (y < ε_u),   1  (y ≥ ε_u)
//! f0(y) = −y³/(3ε_u²) + y²/ε_u + ε_u/3      (y < ε_u),   y  (y ≥ ε_u)    f0' = f1, f0(ε_u) = ε_u
//! ```
//!
//! With `y = |u|` and `û = u/y`, the derivatives (N and N/m) are
//!
//! ```text
//! ∇D  = μλ Γᵀ T (f1(y)/y) u
//! ∇²D = μλ Γᵀ T M Tᵀ Γ,   M = f1(y)/y I₂ + (f1'(y) y − f1(y))/y³ u uᵀ
//!                           = f1(y)/y (I₂ − û ûᵀ) + f1'(y) û ûᵀ.
//! ```
//!
//! The last form is the one evaluated: it has no `y³` and extends continuously to `u = 0`,
//! where `f1(y)/y → 2/ε_u = f1'(0)` and `M = (2/ε_u) I₂` — a stiff but finite static
//! friction, with zero force. Per vertex the force is `−μλ w_i (f1(y)/y) T u`: once sliding
//! (`y ≥ ε_u`) it is Coulomb's `μλ |w_i|` against the slip `T û`, and for self-contact
//! (`Σ w_i = 0`) the forces sum to zero.
//!
//! # PSD projection
//!
//! `M` has eigenvalue `f1(y)/y` across the slip and `f1'(y)` along it, and `∇²D` is a
//! congruence of `M`, so it is PSD wherever `M` is. The projection clamps both eigenvalues at
//! zero, as IPC does for the 2×2 inner matrix of the mollified regime. Sliding (`y ≥ ε_u`)
//! gives `M = (1/y)(I₂ − û ûᵀ)`, PSD, so the projection is exact there. Note that for *this*
//! mollifier the along-slip eigenvalue in the mollified regime, `f1'(y) = 2(ε_u − y)/ε_u²`, is
//! also `≥ 0` (it is computed in that form, so its sign is exact): the projection changes
//! nothing there either, and is kept as the contract for callers and for other mollifiers.
//!
//! The Hessian is the exact one of the *lagged* potential (λ, T, w frozen), not of the fully
//! coupled friction; iterating the lagging to convergence is the caller's matter. Nothing here
//! allocates.

use nalgebra::{Matrix2, Matrix3, Matrix3x2, Vector2, Vector3};

/// A contact's lagged friction data (fixed for a time step's solve).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrictionStencil {
    /// Vertex ids into the caller's position arrays; the first `count` are used.
    pub vertices: [usize; 4],
    /// Number of vertices used, 1 to 4.
    pub count: usize,
    /// Closest-point weights `w_i`, one per used vertex.
    pub weights: [f64; 4],
    /// Tangent basis `T`: orthonormal columns ⊥ the lagged contact normal.
    pub basis: Matrix3x2<f64>,
    /// Lagged normal force magnitude `λ ≥ 0` (N).
    pub normal_force: f64,
    /// Obstacle displacement `Δo` over the step at the contact point (m); zero for self-contact.
    pub obstacle_offset: Vector3<f64>,
}

/// Friction settings: coefficient μ, ε_v (m/s), the step dt.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrictionParameters {
    /// Friction coefficient `μ ≥ 0`.
    pub mu: f64,
    /// Slip speed `ε_v > 0` (m/s) below which friction is mollified (static).
    pub epsilon_v: f64,
    /// Time step `dt > 0` (s).
    pub dt: f64,
}

impl FrictionParameters {
    /// The slip `ε_u = ε_v dt` (m) below which friction is mollified.
    pub fn eps_u(&self) -> f64 {
        self.epsilon_v * self.dt
    }
}

/// The mollified slip potential `f0(y)` (m) for `y ≥ 0`: `f0' = f1`, `f0(y) = y` for `y ≥ ε_u`.
pub fn f0(y: f64, eps_u: f64) -> f64 {
    debug_assert!(eps_u > 0.0 && y >= 0.0);
    if y < eps_u {
        y * y * (1.0 - y / (3.0 * eps_u)) / eps_u + eps_u / 3.0
    } else {
        y
    }
}

/// The mollifier `f1(y) = f0'(y)` for `y ≥ 0`: rises from 0 to 1 on `[0, ε_u]`, then 1.
pub fn f1(y: f64, eps_u: f64) -> f64 {
    debug_assert!(eps_u > 0.0 && y >= 0.0);
    if y < eps_u {
        y * (2.0 * eps_u - y) / (eps_u * eps_u)
    } else {
        1.0
    }
}

/// `f1(y)/y` (1/m) for `y ≥ 0`, with its limit `2/ε_u` at `y = 0` (no division by zero).
pub fn f1_over_y(y: f64, eps_u: f64) -> f64 {
    debug_assert!(eps_u > 0.0 && y >= 0.0);
    if y < eps_u {
        (2.0 * eps_u - y) / (eps_u * eps_u)
    } else {
        1.0 / y
    }
}

/// `f1'(y)` (1/m) for `y ≥ 0`: `2(ε_u − y)/ε_u²` below `ε_u`, 0 above (never negative).
pub fn f1_derivative(y: f64, eps_u: f64) -> f64 {
    debug_assert!(eps_u > 0.0 && y >= 0.0);
    if y < eps_u {
        2.0 * (eps_u - y) / (eps_u * eps_u)
    } else {
        0.0
    }
}

impl FrictionStencil {
    /// Tangent basis of a normal n (unit): two orthonormal vectors ⊥ n, deterministic and
    /// continuous where possible.
    ///
    /// Duff et al. 2017 ("Building an orthonormal basis, revisited"): `(t0, t1, n)` is a
    /// right-handed orthonormal frame, smooth in `n` on each open hemisphere `n_z > 0`,
    /// `n_z < 0`, with an in-plane jump across `n_z = 0` (no tangent field on the sphere is
    /// continuous everywhere). The jump is harmless here: `D` depends on `T` only through
    /// `T Tᵀ = I − n nᵀ`. `n` is normalized first; a zero `n` gives the basis of `+z`.
    pub fn basis_for_normal(n: &Vector3<f64>) -> Matrix3x2<f64> {
        let n = n.try_normalize(0.0).unwrap_or_else(Vector3::z);
        let sign = 1.0_f64.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let t0 = Vector3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t1 = Vector3::new(b, sign + n.y * n.y * a, -n.y);
        Matrix3x2::from_columns(&[t0, t1])
    }

    /// The used `(vertex, weight)` pairs.
    fn used(&self) -> impl Iterator<Item = (usize, f64)> + '_ {
        debug_assert!(
            (1..=4).contains(&self.count),
            "FrictionStencil: count must be 1 to 4"
        );
        self.vertices
            .iter()
            .copied()
            .zip(self.weights.iter().copied())
            .take(self.count)
    }

    /// `μλ`, checking the parameters in debug builds.
    fn scale(&self, p: &FrictionParameters) -> f64 {
        debug_assert!(p.mu >= 0.0 && self.normal_force >= 0.0 && p.eps_u() > 0.0);
        p.mu * self.normal_force
    }

    /// The tangential relative displacement u at positions x against start positions x_start
    /// (full arrays, indexed by vertices): `u = Tᵀ (Σ_i w_i (x_i − x_start_i) − Δo)` (m).
    ///
    /// # Panics
    /// If a used vertex id is out of range of `x` or `x_start`.
    pub fn tangential_displacement(
        &self,
        x: &[Vector3<f64>],
        x_start: &[Vector3<f64>],
    ) -> Vector2<f64> {
        let mut d = -self.obstacle_offset;
        for (v, w) in self.used() {
            d += w * (x[v] - x_start[v]);
        }
        self.basis.transpose() * d
    }

    /// The friction potential `D = μλ f0(|u|)` (J).
    pub fn energy(
        &self,
        p: &FrictionParameters,
        x: &[Vector3<f64>],
        x_start: &[Vector3<f64>],
    ) -> f64 {
        let u = self.tangential_displacement(x, x_start);
        self.scale(p) * f0(u.norm(), p.eps_u())
    }

    /// Call `add(vertex, ∂D/∂x_vertex)` (N) once per used vertex, in stencil order.
    pub fn gradient(
        &self,
        p: &FrictionParameters,
        x: &[Vector3<f64>],
        x_start: &[Vector3<f64>],
        add: &mut dyn FnMut(usize, Vector3<f64>),
    ) {
        let u = self.tangential_displacement(x, x_start);
        let g = self.basis * (self.scale(p) * f1_over_y(u.norm(), p.eps_u()) * u);
        for (v, w) in self.used() {
            add(v, w * g);
        }
    }

    /// Call `add(row vertex, col vertex, 3×3 block)` (N/m) for every ordered pair of the used
    /// vertices (diagonal pairs included); with `project`, the PSD-projected Hessian (see the
    /// module doc: for this mollifier it equals the exact one up to round-off).
    pub fn hessian(
        &self,
        p: &FrictionParameters,
        x: &[Vector3<f64>],
        x_start: &[Vector3<f64>],
        project: bool,
        add: &mut dyn FnMut(usize, usize, &Matrix3<f64>),
    ) {
        let u = self.tangential_displacement(x, x_start);
        let y = u.norm();
        let eps_u = p.eps_u();
        let (mut across, mut along) = (f1_over_y(y, eps_u), f1_derivative(y, eps_u));
        if project {
            across = across.max(0.0);
            along = along.max(0.0);
        }
        let m = if y > 0.0 {
            let uu = (u / y) * (u / y).transpose();
            across * (Matrix2::identity() - uu) + along * uu
        } else {
            // f1(y)/y and f1'(y) both tend to 2/ε_u at y = 0.
            across * Matrix2::identity()
        };
        let k = self.scale(p) * (self.basis * m * self.basis.transpose());
        for (vi, wi) in self.used() {
            for (vj, wj) in self.used() {
                add(vi, vj, &(wi * wj * k));
            }
        }
    }
}

/// Distances at or below this fraction of the geometry's coordinate scale count as touching.
const TOUCHING: f64 = 64.0 * f64::EPSILON;

/// The largest coordinate magnitude of `points` (at least 1), the scale of their round-off.
fn coordinate_scale(points: &[&Vector3<f64>]) -> f64 {
    points.iter().fold(1.0, |s, q| s.max(q.amax()))
}

/// `d / |d|` if `|d|` is above round-off at `scale`, else `None`.
fn unit_above_noise(d: &Vector3<f64>, scale: f64) -> Option<Vector3<f64>> {
    let len = d.norm();
    (len > TOUCHING * scale).then(|| d / len)
}

/// A unit vector ⊥ `v` (⊥ `+z`'s basis if `v` is zero).
fn any_perpendicular(v: &Vector3<f64>) -> Vector3<f64> {
    FrictionStencil::basis_for_normal(v).column(0).into_owned()
}

/// `n / d`, clamped to `[0, 1]`; 0 if `d ≤ 0` (a degenerate edge).
fn clamped_ratio(n: f64, d: f64) -> f64 {
    if d > 0.0 {
        (n / d).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Parameter of the point of segment `e0 e1` closest to `p`.
fn closest_on_segment(p: &Vector3<f64>, e0: &Vector3<f64>, e1: &Vector3<f64>) -> f64 {
    let e = e1 - e0;
    clamped_ratio((p - e0).dot(&e), e.norm_squared())
}

/// Barycentrics of the point of triangle `a b c` closest to `p`, and whether it lies inside the
/// face (not on an edge or corner). Ericson, *Real-Time Collision Detection*, §5.1.5, with a
/// fallback to the edges for a degenerate triangle.
fn closest_on_triangle(
    p: &Vector3<f64>,
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    c: &Vector3<f64>,
) -> ([f64; 3], bool) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    if ab.cross(&ac).norm_squared() <= 0.0 {
        // Degenerate: the nearest of the three edges.
        let mut best = ([1.0, 0.0, 0.0], f64::INFINITY);
        for (i, j) in [(0, 1), (1, 2), (2, 0)] {
            let (ei, ej) = ([a, b, c][i], [a, b, c][j]);
            let s = closest_on_segment(p, ei, ej);
            let d = (p - (ei + s * (ej - ei))).norm_squared();
            if d < best.1 {
                let mut bary = [0.0; 3];
                bary[i] = 1.0 - s;
                bary[j] = s;
                best = (bary, d);
            }
        }
        return (best.0, false);
    }
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ([1.0, 0.0, 0.0], false);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return ([0.0, 1.0, 0.0], false);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = clamped_ratio(d1, d1 - d3);
        return ([1.0 - v, v, 0.0], false);
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return ([0.0, 0.0, 1.0], false);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = clamped_ratio(d2, d2 - d6);
        return ([1.0 - w, 0.0, w], false);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let w = clamped_ratio(d4 - d3, (d4 - d3) + (d5 - d6));
        return ([0.0, 1.0 - w, w], false);
    }
    let denom = va + vb + vc;
    let (v, w) = (vb / denom, vc / denom);
    ([1.0 - v - w, v, w], true)
}

/// Parameters `(s, t)` of the closest points of segments `p0 p1` and `q0 q1` (Ericson §5.1.9);
/// parallel segments get one of their closest pairs.
fn closest_between_segments(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> (f64, f64) {
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.norm_squared(), d2.norm_squared(), d2.dot(&r));
    if a <= 0.0 {
        return (0.0, clamped_ratio(f, e));
    }
    let c = d1.dot(&r);
    if e <= 0.0 {
        return (clamped_ratio(-c, a), 0.0);
    }
    let b = d1.dot(&d2);
    let denom = a * e - b * b;
    // Near-parallel (denominator at round-off of a e): any s works, take 0.
    let s = if denom > TOUCHING * a * e {
        ((b * f - c * e) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let t = (b * s + f) / e;
    if t < 0.0 {
        (clamped_ratio(-c, a), 0.0)
    } else if t > 1.0 {
        (clamped_ratio(b - c, a), 1.0)
    } else {
        (s, t)
    }
}

/// Weights for `(p, t0, t1, t2)` and the unit normal (triangle → `p`) of the point–triangle
/// contact, from the closest point on the triangle (clamped barycentrics `β`): `w = (1, −β)`.
/// The normal is the face normal (oriented toward `p`) when the closest point is inside the face
/// or `p` touches the triangle, else the direction from the closest point to `p`.
pub fn point_triangle_weights(
    p: &Vector3<f64>,
    t0: &Vector3<f64>,
    t1: &Vector3<f64>,
    t2: &Vector3<f64>,
) -> ([f64; 4], Vector3<f64>) {
    let (beta, inside) = closest_on_triangle(p, t0, t1, t2);
    let d = p - (beta[0] * t0 + beta[1] * t1 + beta[2] * t2);
    let face = (t1 - t0).cross(&(t2 - t0)).try_normalize(0.0);
    let scale = coordinate_scale(&[p, t0, t1, t2]);
    let normal = match (inside, face, unit_above_noise(&d, scale)) {
        (true, Some(f), _) => {
            if f.dot(&d) < 0.0 {
                -f
            } else {
                f
            }
        }
        (_, _, Some(n)) => n,
        (_, Some(f), None) => f,
        (_, None, None) => any_perpendicular(&(t1 - t0 + (t2 - t0))),
    };
    ([1.0, -beta[0], -beta[1], -beta[2]], normal)
}

/// Weights `(1−α, α, −(1−β), −β)` for `(ea0, ea1, eb0, eb1)` from the closest points of the two
/// segments (clamped), and the unit normal from edge b's closest point to edge a's; for touching
/// edges, the edges' cross product, or for parallel touching ones a direction ⊥ edge a.
pub fn edge_edge_weights(
    ea0: &Vector3<f64>,
    ea1: &Vector3<f64>,
    eb0: &Vector3<f64>,
    eb1: &Vector3<f64>,
) -> ([f64; 4], Vector3<f64>) {
    let (alpha, beta) = closest_between_segments(ea0, ea1, eb0, eb1);
    let d = (ea0 + alpha * (ea1 - ea0)) - (eb0 + beta * (eb1 - eb0));
    let scale = coordinate_scale(&[ea0, ea1, eb0, eb1]);
    let normal = unit_above_noise(&d, scale)
        .or_else(|| (ea1 - ea0).cross(&(eb1 - eb0)).try_normalize(0.0))
        .unwrap_or_else(|| {
            let ea = ea1 - ea0;
            let along = if ea.norm_squared() > 0.0 {
                ea
            } else {
                eb1 - eb0
            };
            any_perpendicular(&along)
        });
    ([1.0 - alpha, alpha, -(1.0 - beta), -beta], normal)
}

/// Weights `(1, −(1−α), −α)` for `(p, e0, e1)` from the closest point of the segment (clamped
/// `α`), and the unit normal from it to `p`; a direction ⊥ the edge if `p` touches it.
pub fn point_edge_weights(
    p: &Vector3<f64>,
    e0: &Vector3<f64>,
    e1: &Vector3<f64>,
) -> ([f64; 3], Vector3<f64>) {
    let alpha = closest_on_segment(p, e0, e1);
    let d = p - (e0 + alpha * (e1 - e0));
    let scale = coordinate_scale(&[p, e0, e1]);
    let normal = unit_above_noise(&d, scale).unwrap_or_else(|| any_perpendicular(&(e1 - e0)));
    ([1.0, -(1.0 - alpha), -alpha], normal)
}

/// Weights `(1, −1)` for `(a, b)` and the unit normal from `b` to `a` (`+z` if they coincide).
pub fn point_point_weights(a: &Vector3<f64>, b: &Vector3<f64>) -> ([f64; 2], Vector3<f64>) {
    let scale = coordinate_scale(&[a, b]);
    let normal = unit_above_noise(&(a - b), scale).unwrap_or_else(Vector3::z);
    ([1.0, -1.0], normal)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector, SymmetricEigen};

    /// Vertices in the test position arrays (the stencils use up to 4 of them).
    const N: usize = 8;

    /// SplitMix64: tiny and deterministic.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        }
        fn range(&mut self, lo: f64, hi: f64) -> f64 {
            lo + (hi - lo) * self.next()
        }
        fn vec(&mut self, r: f64) -> Vector3<f64> {
            Vector3::new(self.range(-r, r), self.range(-r, r), self.range(-r, r))
        }
        fn unit(&mut self) -> Vector3<f64> {
            loop {
                let v = self.vec(1.0);
                if (0.1..=1.0).contains(&v.norm()) {
                    return v.normalize();
                }
            }
        }
        fn below(&mut self, n: usize) -> usize {
            ((self.next() * n as f64) as usize).min(n - 1)
        }
    }

    /// ε_u = 0.01 m.
    fn params() -> FrictionParameters {
        FrictionParameters {
            mu: 0.4,
            epsilon_v: 1.0,
            dt: 0.01,
        }
    }

    struct Case {
        s: FrictionStencil,
        x: Vec<Vector3<f64>>,
        x0: Vec<Vector3<f64>>,
    }

    /// A random stencil of `count` vertices, its lagged geometry (weights, normal) taken from
    /// the start positions, and positions displaced so that `|u| = slip` exactly.
    fn case(rng: &mut Rng, count: usize, slip: f64) -> Case {
        let x0: Vec<Vector3<f64>> = (0..N).map(|_| rng.vec(1.0)).collect();
        let mut ids: [usize; N] = std::array::from_fn(|i| i);
        for i in (1..N).rev() {
            ids.swap(i, rng.below(i + 1));
        }
        let vertices = [ids[0], ids[1], ids[2], ids[3]];
        let g: [&Vector3<f64>; 4] = vertices.map(|v| &x0[v]);
        let (weights, normal) = match count {
            4 if rng.next() < 0.5 => point_triangle_weights(g[0], g[1], g[2], g[3]),
            4 => edge_edge_weights(g[0], g[1], g[2], g[3]),
            3 => {
                let (w, n) = point_edge_weights(g[0], g[1], g[2]);
                ([w[0], w[1], w[2], 0.0], n)
            }
            2 => {
                let (w, n) = point_point_weights(g[0], g[1]);
                ([w[0], w[1], 0.0, 0.0], n)
            }
            _ => ([1.0, 0.0, 0.0, 0.0], rng.unit()),
        };
        let mut s = FrictionStencil {
            vertices,
            count,
            weights,
            basis: FrictionStencil::basis_for_normal(&normal),
            normal_force: rng.range(0.5, 2.0),
            obstacle_offset: if count == 1 {
                rng.vec(0.1)
            } else {
                Vector3::zeros()
            },
        };
        let d: Vec<Vector3<f64>> = (0..N).map(|_| rng.vec(0.1)).collect();
        let x1: Vec<Vector3<f64>> = x0.iter().zip(&d).map(|(a, b)| a + b).collect();
        let k = slip / s.tangential_displacement(&x1, &x0).norm();
        s.obstacle_offset *= k;
        let x = x0.iter().zip(&d).map(|(a, b)| a + k * b).collect();
        Case { s, x, x0 }
    }

    fn gradient(c: &Case, x: &[Vector3<f64>]) -> Vec<Vector3<f64>> {
        let mut g = vec![Vector3::zeros(); N];
        c.s.gradient(&params(), x, &c.x0, &mut |v, b| g[v] += b);
        g
    }

    fn hessian(c: &Case, project: bool) -> DMatrix<f64> {
        let mut h = DMatrix::zeros(3 * N, 3 * N);
        c.s.hessian(&params(), &c.x, &c.x0, project, &mut |i, j, b| {
            let mut view = h.view_mut((3 * i, 3 * j), (3, 3));
            view += b;
        });
        h
    }

    /// `x` with coordinate `k` (vertex k/3, axis k%3) moved by `h`.
    fn nudged(x: &[Vector3<f64>], k: usize, h: f64) -> Vec<Vector3<f64>> {
        let mut y = x.to_vec();
        y[k / 3][k % 3] += h;
        y
    }

    fn flat(g: &[Vector3<f64>]) -> DVector<f64> {
        DVector::from_iterator(3 * N, g.iter().flat_map(|v| v.iter().copied()))
    }

    const SLIPS: [f64; 2] = [0.4, 3.0]; // × ε_u: mollified, sliding

    #[test]
    fn mollifier_pieces_are_consistent() {
        let eps = 0.01;
        let h = 1e-7;
        for i in 1..200 {
            let y = 2.0 * eps * i as f64 / 200.0;
            let df0 = (f0(y + h, eps) - f0(y - h, eps)) / (2.0 * h);
            let df1 = (f1(y + h, eps) - f1(y - h, eps)) / (2.0 * h);
            assert!((df0 - f1(y, eps)).abs() < 1e-7, "f0' = f1 at {y}");
            // f1'' jumps at ε_u, which costs the central difference h/(2ε_u²) there.
            assert!((df1 - f1_derivative(y, eps)).abs() < 1e-3, "f1' at {y}");
            assert!((f1_over_y(y, eps) * y - f1(y, eps)).abs() < 1e-14);
            assert!(f1_derivative(y, eps) >= 0.0 && (0.0..=1.0).contains(&f1(y, eps)));
        }
        assert_eq!(f1_over_y(0.0, eps), 2.0 / eps);
        assert_eq!(f1_derivative(0.0, eps), 2.0 / eps);
        assert_eq!(f0(0.0, eps), eps / 3.0);
        let below = eps * (1.0 - 1e-12);
        assert!((f0(below, eps) - eps).abs() < 1e-13 && (f1(below, eps) - 1.0).abs() < 1e-11);
        assert!(f1_derivative(below, eps).abs() < 1e-8);
        assert_eq!(
            (f0(eps, eps), f1(eps, eps), f1_derivative(eps, eps)),
            (eps, 1.0, 0.0)
        );
    }

    #[test]
    fn gradient_matches_finite_differences_in_both_regimes() {
        let mut rng = Rng(1);
        let eps = params().eps_u();
        let h = 1e-7;
        for count in 1..=4 {
            for slip in SLIPS {
                for _ in 0..6 {
                    let c = case(&mut rng, count, slip * eps);
                    let g = flat(&gradient(&c, &c.x));
                    let e = |x: &[Vector3<f64>]| c.s.energy(&params(), x, &c.x0);
                    for k in 0..3 * N {
                        let fd = (e(&nudged(&c.x, k, h)) - e(&nudged(&c.x, k, -h))) / (2.0 * h);
                        assert!(
                            (fd - g[k]).abs() < 1e-6 * (1.0 + g.amax()),
                            "count {count}, slip {slip} ε_u, coordinate {k}: {fd} vs {}",
                            g[k]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn hessian_matches_finite_differences_in_both_regimes() {
        let mut rng = Rng(2);
        let eps = params().eps_u();
        let h = 1e-7;
        for count in 1..=4 {
            for slip in SLIPS {
                for _ in 0..6 {
                    let c = case(&mut rng, count, slip * eps);
                    let exact = hessian(&c, false);
                    let mut fd = DMatrix::zeros(3 * N, 3 * N);
                    for k in 0..3 * N {
                        let plus = flat(&gradient(&c, &nudged(&c.x, k, h)));
                        let minus = flat(&gradient(&c, &nudged(&c.x, k, -h)));
                        fd.set_column(k, &((plus - minus) / (2.0 * h)));
                    }
                    let err = (&fd - &exact).amax();
                    assert!(
                        err < 1e-5 * exact.amax(),
                        "count {count}, slip {slip} ε_u: error {err} of {}",
                        exact.amax()
                    );
                    assert!((&exact - exact.transpose()).amax() < 1e-12 * exact.amax());
                }
            }
        }
    }

    #[test]
    fn projected_hessian_is_psd_and_equals_the_exact_one() {
        // Sliding: M = (1/y)(I − ûûᵀ) is PSD. Mollified: along-slip eigenvalue f1'(y) ≥ 0 for
        // IPC's f1, so here too the projection only guards round-off.
        let mut rng = Rng(3);
        let eps = params().eps_u();
        for count in 1..=4 {
            for slip in [1e-6, 0.4, 0.999, 1.0, 1.001, 3.0, 1e3] {
                for _ in 0..4 {
                    let c = case(&mut rng, count, slip * eps);
                    let (exact, projected) = (hessian(&c, false), hessian(&c, true));
                    let scale = exact.amax();
                    let lowest = SymmetricEigen::new(projected.clone()).eigenvalues.min();
                    assert!(
                        lowest >= -1e-12 * scale,
                        "count {count}, slip {slip}: {lowest}"
                    );
                    assert!((&projected - &exact).amax() <= 1e-14 * scale);
                }
            }
        }
    }

    #[test]
    fn zero_slip_gives_zero_force_and_the_static_stiffness() {
        let mut rng = Rng(4);
        let p = params();
        for count in 1..=4 {
            let mut c = case(&mut rng, count, p.eps_u());
            // Move every vertex (and the obstacle) by the same normal offset: no tangential slip.
            let n = c.s.basis.column(0).cross(&c.s.basis.column(1));
            c.x = c.x0.iter().map(|a| a + 0.05 * n).collect();
            c.s.obstacle_offset = if count == 1 {
                0.05 * n
            } else {
                Vector3::zeros()
            };
            assert!(c.s.tangential_displacement(&c.x, &c.x0).norm() < 1e-15);
            for g in gradient(&c, &c.x) {
                assert!(g.iter().all(|v| v.is_finite()) && g.norm() < 1e-12);
            }
            let k = c.s.normal_force * p.mu * 2.0 / p.eps_u() * c.s.basis * c.s.basis.transpose();
            let mut expected = DMatrix::zeros(3 * N, 3 * N);
            for (vi, wi) in c.s.used() {
                for (vj, wj) in c.s.used() {
                    let mut view = expected.view_mut((3 * vi, 3 * vj), (3, 3));
                    view += wi * wj * k;
                }
            }
            for project in [false, true] {
                let h = hessian(&c, project);
                assert!(
                    (&h - &expected).amax() < 1e-12 * expected.amax(),
                    "count {count}"
                );
            }
            // Exactly u = 0 (x = x_start) too.
            c.x = c.x0.clone();
            c.s.obstacle_offset = Vector3::zeros();
            assert!(gradient(&c, &c.x).iter().all(|g| *g == Vector3::zeros()));
            assert!((hessian(&c, false) - &expected).amax() < 1e-12 * expected.amax());
        }
    }

    #[test]
    fn sliding_force_saturates_at_coulomb() {
        let mut rng = Rng(5);
        let p = params();
        for count in 1..=4 {
            for slip in [1.5, 1e3] {
                let c = case(&mut rng, count, slip * p.eps_u());
                let u = c.s.tangential_displacement(&c.x, &c.x0);
                let slip_dir = c.s.basis * u.normalize();
                let mu_lambda = p.mu * c.s.normal_force;
                let g = gradient(&c, &c.x);
                let mut total = Vector3::zeros();
                let (mut norm2, mut w2, mut w_sum) = (0.0, 0.0, 0.0);
                for (v, w) in c.s.used() {
                    assert!((g[v].norm() - mu_lambda * w.abs()).abs() < 1e-12);
                    assert!((g[v].dot(&slip_dir) - mu_lambda * w).abs() < 1e-12);
                    total += g[v];
                    norm2 += g[v].norm_squared();
                    w2 += w * w;
                    w_sum += w;
                }
                assert!((norm2.sqrt() - mu_lambda * w2.sqrt()).abs() < 1e-12);
                assert!((total - mu_lambda * w_sum * slip_dir).norm() < 1e-12);
                if count > 1 {
                    // Self-contact: Σ w_i = 0, so friction conserves momentum.
                    assert!(total.norm() < 1e-12, "count {count}: {total}");
                }
            }
        }
    }

    #[test]
    fn moving_with_the_obstacle_is_no_slip() {
        let mut rng = Rng(6);
        let mut c = case(&mut rng, 1, 0.5 * params().eps_u());
        let n = c.s.basis.column(0).cross(&c.s.basis.column(1));
        let v = c.s.vertices[0];
        c.x[v] = c.x0[v] + c.s.obstacle_offset + 0.02 * n;
        assert!(c.s.tangential_displacement(&c.x, &c.x0).norm() < 1e-15);
        assert!(gradient(&c, &c.x)[v].norm() < 1e-12);
    }

    #[test]
    fn friction_does_not_depend_on_the_tangent_basis() {
        let mut rng = Rng(7);
        for count in 1..=4 {
            for slip in SLIPS {
                let c = case(&mut rng, count, slip * params().eps_u());
                let theta = rng.range(0.0, std::f64::consts::TAU);
                let (s, co) = theta.sin_cos();
                let mut r = c;
                let turned = r.s.basis * Matrix2::new(co, -s, s, co);
                let (e, g, h) = (
                    r.s.energy(&params(), &r.x, &r.x0),
                    gradient(&r, &r.x),
                    hessian(&r, false),
                );
                r.s.basis = turned;
                assert!((r.s.energy(&params(), &r.x, &r.x0) - e).abs() < 1e-14);
                assert!((flat(&gradient(&r, &r.x)) - flat(&g)).amax() < 1e-12);
                assert!((hessian(&r, false) - h).amax() < 1e-10);
            }
        }
    }

    /// Asserts `|Σ w_i x_i|` is the distance of the two shapes: a valid point pair (convex
    /// weights on each side) no farther apart than the best of the brute-force samples, which
    /// miss the true distance by at most `resolution`; and the normal is unit and ∥ the pair.
    fn assert_closest(d: &Vector3<f64>, normal: &Vector3<f64>, sampled: f64, resolution: f64) {
        assert!(
            d.norm() <= sampled + 1e-12,
            "{} > sampled {sampled}",
            d.norm()
        );
        assert!(d.norm() >= sampled - resolution - 1e-12);
        assert!((normal.norm() - 1.0).abs() < 1e-12);
        if d.norm() > 1e-9 {
            assert!(
                (normal.dot(d) - d.norm()).abs() < 1e-9,
                "normal {normal} vs {d}"
            );
        }
    }

    fn convex(b: &[f64]) -> bool {
        b.iter().all(|v| (0.0..=1.0).contains(v)) && (b.iter().sum::<f64>() - 1.0).abs() < 1e-12
    }

    #[test]
    fn point_triangle_weights_reproduce_the_closest_point() {
        let mut rng = Rng(8);
        let n = 120;
        for trial in 0..60 {
            let t = [rng.vec(1.0), rng.vec(1.0), rng.vec(1.0)];
            let centroid = (t[0] + t[1] + t[2]) / 3.0;
            let p = if trial % 3 == 0 {
                // Projects inside the face.
                let (a, b) = (rng.next(), rng.next());
                let (a, b) = if a + b > 1.0 {
                    (1.0 - a, 1.0 - b)
                } else {
                    (a, b)
                };
                let face = (t[1] - t[0]).cross(&(t[2] - t[0])).normalize();
                t[0] + a * (t[1] - t[0]) + b * (t[2] - t[0]) + rng.range(-0.5, 0.5) * face
            } else {
                centroid + rng.vec(1.5)
            };
            let (w, normal) = point_triangle_weights(&p, &t[0], &t[1], &t[2]);
            assert!(w[0] == 1.0 && convex(&[-w[1], -w[2], -w[3]]));
            let d = p + w[1] * t[0] + w[2] * t[1] + w[3] * t[2];
            let mut sampled = f64::INFINITY;
            for i in 0..=n {
                for j in 0..=n - i {
                    let (a, b) = (i as f64 / n as f64, j as f64 / n as f64);
                    let q = t[0] + a * (t[1] - t[0]) + b * (t[2] - t[0]);
                    sampled = sampled.min((p - q).norm());
                }
            }
            let longest = (0..3)
                .map(|i| (t[i] - t[(i + 1) % 3]).norm())
                .fold(0.0, f64::max);
            assert_closest(&d, &normal, sampled, 2.0 * longest / n as f64);
        }
    }

    #[test]
    fn edge_edge_weights_reproduce_the_closest_points() {
        let mut rng = Rng(9);
        let n = 300;
        for trial in 0..40 {
            let (a0, a1) = (rng.vec(1.0), rng.vec(1.0));
            let (b0, b1) = match trial % 4 {
                // Parallel, then nearly parallel.
                0 => {
                    let shift = rng.vec(0.5);
                    (a0 + shift, a1 + shift + rng.range(-0.5, 1.0) * (a1 - a0))
                }
                1 => {
                    let shift = rng.vec(0.5);
                    (a0 + shift, a1 + shift + 1e-9 * rng.vec(1.0))
                }
                _ => (rng.vec(1.0), rng.vec(1.0)),
            };
            let (w, normal) = edge_edge_weights(&a0, &a1, &b0, &b1);
            assert!(convex(&[w[0], w[1]]) && convex(&[-w[2], -w[3]]));
            let d = w[0] * a0 + w[1] * a1 + w[2] * b0 + w[3] * b1;
            let mut sampled = f64::INFINITY;
            for i in 0..=n {
                let pa = a0 + (i as f64 / n as f64) * (a1 - a0);
                for j in 0..=n {
                    let pb = b0 + (j as f64 / n as f64) * (b1 - b0);
                    sampled = sampled.min((pa - pb).norm());
                }
            }
            let resolution = ((a1 - a0).norm() + (b1 - b0).norm()) / n as f64;
            assert_closest(&d, &normal, sampled, resolution);
        }
    }

    #[test]
    fn point_edge_and_point_point_weights_reproduce_the_closest_points() {
        let mut rng = Rng(10);
        let n = 4000;
        for _ in 0..60 {
            let (p, e0, e1) = (rng.vec(1.0), rng.vec(1.0), rng.vec(1.0));
            let (w, normal) = point_edge_weights(&p, &e0, &e1);
            assert!(w[0] == 1.0 && convex(&[-w[1], -w[2]]));
            let d = p + w[1] * e0 + w[2] * e1;
            let sampled = (0..=n)
                .map(|i| (p - (e0 + (i as f64 / n as f64) * (e1 - e0))).norm())
                .fold(f64::INFINITY, f64::min);
            assert_closest(&d, &normal, sampled, (e1 - e0).norm() / n as f64);

            let (w, normal) = point_point_weights(&p, &e0);
            let d = w[0] * p + w[1] * e0;
            assert_closest(&d, &normal, (p - e0).norm(), 0.0);
        }
    }

    #[test]
    fn touching_contacts_get_geometric_normals() {
        let (x, y, z) = (Vector3::x(), Vector3::y(), Vector3::z());
        let o = Vector3::zeros();
        // A point on the face, and on an edge: the face normal.
        for p in [Vector3::new(0.2, 0.3, 0.0), Vector3::new(0.5, 0.0, 0.0)] {
            let (w, n) = point_triangle_weights(&p, &o, &x, &y);
            assert!((n.cross(&z)).norm() < 1e-15, "{n}");
            assert!((w[1] * o + w[2] * x + w[3] * y + p).norm() < 1e-15);
        }
        // Crossing edges: their cross product.
        let (_, n) = edge_edge_weights(&(-x), &x, &(-y), &y);
        assert!((n.cross(&z)).norm() < 1e-15);
        // Overlapping parallel edges, a point on an edge: ⊥ the edge.
        let (_, n) = edge_edge_weights(&o, &x, &(0.5 * x), &(2.0 * x));
        assert!(n.dot(&x).abs() < 1e-15 && (n.norm() - 1.0).abs() < 1e-15);
        let (_, n) = point_edge_weights(&(0.3 * y), &o, &y);
        assert!(n.dot(&y).abs() < 1e-15 && (n.norm() - 1.0).abs() < 1e-15);
        // Coincident points: +z.
        assert_eq!(point_point_weights(&x, &x).1, z);
        // Below the face the normal flips toward the point.
        let (_, n) = point_triangle_weights(&Vector3::new(0.2, 0.2, -1.0), &o, &x, &y);
        assert!((n + z).norm() < 1e-15);
    }

    #[test]
    fn basis_is_orthonormal_and_perpendicular_to_the_normal() {
        let mut rng = Rng(11);
        let axes = [
            Vector3::x(),
            -Vector3::x(),
            Vector3::y(),
            -Vector3::y(),
            Vector3::z(),
            -Vector3::z(),
        ];
        let random = (0..500).map(|_| rng.unit());
        for n in axes.into_iter().chain(random) {
            let t = FrictionStencil::basis_for_normal(&n);
            assert!(
                (t.transpose() * t - Matrix2::identity()).amax() < 1e-14,
                "{n}"
            );
            // Deterministic.
            assert_eq!(FrictionStencil::basis_for_normal(&n), t);
            if let Some(unit) = n.try_normalize(0.0) {
                assert!((t.transpose() * unit).amax() < 1e-14, "{n}");
                assert!(
                    (t.column(0).cross(&t.column(1)) - unit).amax() < 1e-14,
                    "right-handed"
                );
                // Blind to the normal's length.
                assert!((FrictionStencil::basis_for_normal(&(3.0 * n)) - t).amax() < 1e-15);
            }
        }
        let z_basis = FrictionStencil::basis_for_normal(&Vector3::z());
        assert_eq!(
            FrictionStencil::basis_for_normal(&Vector3::zeros()),
            z_basis
        );
    }

    #[test]
    fn basis_is_continuous_within_a_hemisphere() {
        let mut rng = Rng(12);
        for _ in 0..500 {
            let n = rng.unit();
            if n.z.abs() < 1e-3 {
                continue;
            }
            let m = (n + 1e-8 * rng.vec(1.0)).normalize();
            let jump = (FrictionStencil::basis_for_normal(&n)
                - FrictionStencil::basis_for_normal(&m))
            .amax();
            assert!(jump < 1e-4, "{n}: {jump}");
        }
    }
}
