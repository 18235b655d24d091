//! Conservative continuous collision detection (CCD) for linear trajectories: the step filter
//! of the IPC Newton line search.
//!
//! # Method
//! Additive CCD (ACCD) from Li, Kaufman and Jiang, "Codimensional Incremental Potential
//! Contact", ACM TOG 40(4), SIGGRAPH 2021, Section 4 and its Algorithm 1. Every vertex moves
//! linearly, `x_i(τ) = x_i + τ Δx_i`. The distance `D(τ)` between the two primitives is
//! Lipschitz in `τ` with a constant `l_p`. So if the clearance `D − ξ` is `c_k` at a time
//! `τ_k`, there is no contact (`D ≤ ξ`) before `τ_k + c_k / l_p`. ACCD steps a fraction `η`
//! of that distance, measures `D` again and repeats. It stops once the clearance falls below
//! the target gap `g = s (D(0) − ξ)` and returns the last time whose clearance was still
//! `≥ g`. As in the paper, the first step goes `1 − s` of the way (at most 0.9), so in exact
//! arithmetic it always lands at or above the gap. It is kept unless round-off leaves it
//! with no clearance at all. Later steps use `η = 0.9`.
//!
//! For `l_p`, ACCD removes the mean displacement and takes `|Δp| + max|Δt_i|`. We use the
//! pairwise bound `max_i |Δp − Δt_i|` (point–triangle) and `max_ij |Δa_i − Δb_j|`
//! (edge–edge). The distance is the minimum over convex weights `w` of `|p − Σ w_i t_i|`.
//! For fixed `w`, that vector moves with velocity `Σ w_i (Δp − Δt_i)`, whose length is at
//! most the largest `|Δp − Δt_i|` by convexity. A minimum of functions that share a
//! Lipschitz constant has the same constant. This bound is never larger than ACCD's,
//! because `|Δp − Δt_i|` stays the same after the mean is removed and is then at most
//! `|Δp| + |Δt_i|`. So our steps are never shorter than ACCD's. We still remove the mean position and mean displacement, but only to keep the
//! positions where distances are measured small: their rounding then scales with the
//! primitives' size and relative motion, not with where they sit in the world. For a point
//! against a 1-Lipschitz signed distance field, `l_p = |Δp|` (conservative advancement).
//!
//! # Guarantee: what `t` means
//! [`Toi::t`] is a fraction of the step. For every `α ∈ [0, t]`, the primitives at
//! `x + α Δx` are more than `ξ` apart. `t = t_max` means no contact before `t_max`. `t = 0`
//! means no step is allowed: the initial distance is already `≤ ξ` (or within round-off of
//! it), an input is not finite, or the iteration cap was zero. When `0 < t < t_max`, the
//! clearance at `t` is about `≥ s (D(0) − ξ)`. The step filter takes the minimum over all
//! pairs and may scale it further (IPC uses 0.8).
//!
//! The argument: at each kept time `τ_k` with measured clearance `c_k > 0`, and for
//! `τ ∈ [τ_k, τ_k + η c_k / l_p]`, we have
//! `D(τ) ≥ D(τ_k) − l_p (τ − τ_k) ≥ ξ + (1 − η) c_k > ξ`.
//! These intervals chain from 0 to `t`. A time is returned only if an interval starting at a
//! kept time covers it, and the cap returns the last kept time. So no output, capped or not,
//! lies past a contact.
//!
//! # Round-off
//! Measured distances have rounding error. Every comparison is made against `ξ' = ξ + δ`,
//! where `δ = 256 ε (max_i |x_i| + max_i |Δx_i|)`. `δ` bounds (i) the rounding of the positions
//! where distances are measured, (ii) the distance routine's own error, and (iii) the
//! caller's rounding when it forms `x + α Δx` in world coordinates. For (ii) we assume the
//! error stays within about a hundred ulps of that scale. This holds for closed-form
//! point/segment/plane formulas, not for an ill-conditioned routine. A measured clearance
//! is therefore off by less than `δ/2`, and the argument above still gives `D > ξ + δ/2`.
//! An initial distance `≤ ξ'` returns `t = 0`. `η < 1` absorbs the relative rounding of
//! `l_p` and of `τ_k + step`. Non-finite inputs return `t = 0`. A NaN from a distance or an
//! SDF fails every comparison, and each comparison is written so that failing it stops the
//! query without accepting the new time. An SDF closure is measured in world coordinates:
//! if its own error can exceed `δ/2` (say, a huge sphere far from the origin), add that
//! error to `min_separation`.
//!
//! # Cost
//! Memory is O(1): a fixed handful of 3-vectors on the stack, and nothing is allocated.
//! Time is one distance evaluation per iteration. Each kept step advances `τ` by at least
//! `0.9 s (D(0) − ξ') / l_p`. So without the cap, a query ends within
//! `2 + l_p t_max / (0.9 s (D(0) − ξ'))` iterations, and with it, within `max_iterations`.
//! A capped query returns its last kept time with `capped = true`. That time is still
//! conservative, only short.

use super::distance::{edge_edge_distance_squared, point_triangle_distance_squared};
use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// Fraction of the certified clearance covered by each step after the first (ACCD's 0.9).
const STEP_FRACTION: f64 = 0.9;

/// Round-off floor per unit of world scale: `δ = ROUNDOFF · (max|x_i| + max|Δx_i|)`.
const ROUNDOFF: f64 = 256.0 * f64::EPSILON;

/// Settings of additive CCD.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CcdSettings {
    /// ACCD's `s`, in (0, 1): stop once the clearance `D − ξ` falls below this fraction of
    /// its starting value. Default 0.1, ipc-toolkit's choice (its rescaling is 0.9 = 1 − s).
    /// The returned time then keeps about 10% of the starting clearance, which keeps the
    /// barrier finite and leaves the next Newton iteration room to move. The cost is
    /// `≈ ln(1/s)` iterations for a head-on approach.
    pub gap_fraction: f64,
    /// Minimum separation `ξ` (m), `≥ 0`: the distance counted as contact (a thickness).
    /// Default 0.
    pub min_separation: f64,
    /// Iteration cap: each iteration costs one distance evaluation. Default 10 000. Each
    /// kept step advances by at least `0.9 s (D(0) − ξ)/l_p`. So only relative motion of
    /// more than ~900× the starting clearance within one step can reach the cap, and a
    /// capped query still returns a safe (short) time.
    pub max_iterations: u32,
}

impl Default for CcdSettings {
    fn default() -> Self {
        Self {
            gap_fraction: 0.1,
            min_separation: 0.0,
            max_iterations: 10_000,
        }
    }
}

/// The outcome of one query: the largest safe fraction of the step, in `[0, t_max]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Toi {
    /// The primitives stay more than `ξ` apart at every fraction `α ∈ [0, t]` of the step;
    /// `t = t_max` when no contact happens before `t_max`; `0` allows no step.
    pub t: f64,
    /// Advancement steps taken (each costs at most one distance evaluation).
    pub iterations: u32,
    /// The iteration cap stopped the query; `t` is still safe but may be far from contact.
    pub capped: bool,
}

/// Point `p` moving by `dp` against the triangle `(t0, t1, t2)` moving by `(dt0, dt1, dt2)`,
/// over the step fraction `[0, t_max]` (`t_max ∈ [0, 1]`); `t = t_max` when no contact
/// happens before `t_max`.
///
/// # Panics
/// If `t_max` is outside `[0, 1]` or the settings are invalid (see [`CcdSettings`]).
#[allow(clippy::too_many_arguments)]
pub fn point_triangle_ccd(
    p: &V3,
    t0: &V3,
    t1: &V3,
    t2: &V3,
    dp: &V3,
    dt0: &V3,
    dt1: &V3,
    dt2: &V3,
    t_max: f64,
    settings: &CcdSettings,
) -> Toi {
    check_arguments(settings, t_max);
    let Some(frame) = Frame::new([p, t0, t1, t2], [dp, dt0, dt1, dt2]) else {
        return NO_STEP;
    };
    let lipschitz = [dt0, dt1, dt2]
        .iter()
        .map(|d| (dp - *d).norm())
        .fold(0.0, f64::max);
    advance(
        |tau| {
            let [a, b, c, d] = frame.at(tau);
            point_triangle_distance_squared(&a, &b, &c, &d).sqrt()
        },
        lipschitz,
        frame.floor,
        t_max,
        settings,
    )
}

/// Edge `(ea0, ea1)` moving by `(dea0, dea1)` against edge `(eb0, eb1)` moving by
/// `(deb0, deb1)`, over the step fraction `[0, t_max]` (`t_max ∈ [0, 1]`); `t = t_max` when
/// no contact happens before `t_max`.
///
/// # Panics
/// If `t_max` is outside `[0, 1]` or the settings are invalid (see [`CcdSettings`]).
#[allow(clippy::too_many_arguments)]
pub fn edge_edge_ccd(
    ea0: &V3,
    ea1: &V3,
    eb0: &V3,
    eb1: &V3,
    dea0: &V3,
    dea1: &V3,
    deb0: &V3,
    deb1: &V3,
    t_max: f64,
    settings: &CcdSettings,
) -> Toi {
    check_arguments(settings, t_max);
    let Some(frame) = Frame::new([ea0, ea1, eb0, eb1], [dea0, dea1, deb0, deb1]) else {
        return NO_STEP;
    };
    let mut lipschitz: f64 = 0.0;
    for da in [dea0, dea1] {
        for db in [deb0, deb1] {
            lipschitz = lipschitz.max((da - db).norm());
        }
    }
    advance(
        |tau| {
            let [a0, a1, b0, b1] = frame.at(tau);
            edge_edge_distance_squared(&a0, &a1, &b0, &b1).sqrt()
        },
        lipschitz,
        frame.floor,
        t_max,
        settings,
    )
}

/// A point `p` moving by `dp` against a static signed distance field, given as a closure
/// `sdf(x)` returning the signed distance (negative inside). The closure must be
/// 1-Lipschitz, as the distance of every analytic obstacle is. This is conservative
/// advancement with `l_p = |dp|`. Contact means `sdf ≤ ξ`. `t = t_max` when no contact
/// happens before `t_max`.
///
/// # Panics
/// If `t_max` is outside `[0, 1]` or the settings are invalid (see [`CcdSettings`]).
pub fn point_sdf_ccd(
    p: &V3,
    dp: &V3,
    sdf: &mut dyn FnMut(&V3) -> f64,
    t_max: f64,
    settings: &CcdSettings,
) -> Toi {
    check_arguments(settings, t_max);
    if !all_finite(&[p, dp]) {
        return NO_STEP;
    }
    let floor = ROUNDOFF * (p.norm() + dp.norm());
    advance(
        |tau| sdf(&(p + dp * tau)),
        dp.norm(),
        floor,
        t_max,
        settings,
    )
}

/// Four vertices in a frame centred on their mean position and moving with their mean
/// displacement (distances are invariant under both), plus the round-off floor `δ`.
struct Frame {
    y: [V3; 4],
    r: [V3; 4],
    floor: f64,
}

impl Frame {
    /// `None` if an input is not finite.
    fn new(x: [&V3; 4], dx: [&V3; 4]) -> Option<Self> {
        if !all_finite(&x) || !all_finite(&dx) {
            return None;
        }
        let c = (x[0] + x[1] + x[2] + x[3]) * 0.25;
        let m = (dx[0] + dx[1] + dx[2] + dx[3]) * 0.25;
        let largest = |v: [&V3; 4]| v.iter().map(|a| a.norm()).fold(0.0, f64::max);
        Some(Self {
            y: x.map(|a| a - c),
            r: dx.map(|a| a - m),
            floor: ROUNDOFF * (largest(x) + largest(dx)),
        })
    }

    /// The four positions at the step fraction `tau`, in this frame.
    fn at(&self, tau: f64) -> [V3; 4] {
        std::array::from_fn(|i| self.y[i] + self.r[i] * tau)
    }
}

/// The answer that allows no step.
const NO_STEP: Toi = Toi {
    t: 0.0,
    iterations: 0,
    capped: false,
};

fn all_finite(vs: &[&V3]) -> bool {
    vs.iter().all(|v| v.iter().all(|c| c.is_finite()))
}

/// Panics on settings or a `t_max` outside their documented ranges.
fn check_arguments(settings: &CcdSettings, t_max: f64) {
    let s = settings.gap_fraction;
    assert!(
        s > 0.0 && s < 1.0,
        "CcdSettings: gap_fraction must lie in (0, 1), got {s}"
    );
    assert!(
        settings.min_separation >= 0.0 && settings.min_separation.is_finite(),
        "CcdSettings: min_separation must be finite and >= 0, got {}",
        settings.min_separation
    );
    assert!(
        (0.0..=1.0).contains(&t_max),
        "CCD: t_max must lie in [0, 1], got {t_max}"
    );
}

/// ACCD's loop on a distance `distance(τ)` that is `lipschitz`-Lipschitz in `τ`.
fn advance(
    mut distance: impl FnMut(f64) -> f64,
    lipschitz: f64,
    floor: f64,
    t_max: f64,
    settings: &CcdSettings,
) -> Toi {
    let s = settings.gap_fraction;
    let done = |t, iterations, capped| Toi {
        t,
        iterations,
        capped,
    };
    let xi = settings.min_separation + floor;
    let mut clearance = distance(0.0) - xi;
    // Written so that NaN (non-finite input) allows no step.
    if !(clearance > 0.0 && lipschitz.is_finite() && xi.is_finite()) {
        return NO_STEP;
    }
    if lipschitz == 0.0 || t_max == 0.0 {
        // No relative motion (the distance stays what it is) or nothing to check.
        return done(t_max, 0, false);
    }
    let gap = s * clearance;
    let mut eta = STEP_FRACTION.min(1.0 - s);
    let mut t = 0.0;
    for k in 1..=settings.max_iterations {
        let next = t + eta * clearance / lipschitz;
        if next >= t_max {
            return done(t_max, k, false);
        }
        let next_clearance = distance(next) - xi;
        let above_gap = next_clearance >= gap; // false for NaN
        if !above_gap {
            // The gap is reached. `next` is covered by the bound at `t`, but only the first
            // step is kept below the gap (as in ACCD), and only if its clearance is positive.
            let keep = k == 1 && next_clearance > 0.0;
            return done(if keep { next } else { t }, k, false);
        }
        t = next;
        clearance = next_clearance;
        eta = STEP_FRACTION;
    }
    done(t, settings.max_iterations, true)
}

#[cfg(test)]
mod tests {
    //! Every query is checked against references that share no code with the module. The
    //! pair references run on their own small vector type, apart from nalgebra and
    //! `distance.rs`. Distances come from brute force over the faces of the closest-point
    //! problem. The first contact is the first root of the coplanarity cubic
    //! (or, for motion inside one plane, of the in-plane collinearity quadratics) at which the
    //! primitives touch, plus a few dense samples. Then a Lipschitz branch and bound finds the
    //! first time the distance comes within round-off of `ξ`, and so proves that the distance
    //! stays above `ξ` at every time before it, not only at sampled ones. A query passes only
    //! if its `t` is before both.

    use super::*;

    type V = Vector3<f64>;

    /// SplitMix64: a tiny deterministic generator, good enough to scatter test cases.
    struct Rng(u64);

    impl Rng {
        fn next_u64(&mut self) -> u64 {
            self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            z ^ (z >> 31)
        }
        fn unit(&mut self) -> f64 {
            (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
        }
        fn range(&mut self, a: f64, b: f64) -> f64 {
            a + (b - a) * self.unit()
        }
        fn coin(&mut self) -> bool {
            self.next_u64() & 1 == 1
        }
        fn vec(&mut self, r: f64) -> V {
            V::new(self.range(-r, r), self.range(-r, r), self.range(-r, r))
        }
        fn dir(&mut self) -> V {
            loop {
                let v = self.vec(1.0);
                let n = v.norm();
                if n > 0.1 && n <= 1.0 {
                    return v / n;
                }
            }
        }
        /// An orthonormal frame (columns e1, e2, n).
        fn frame(&mut self) -> [V; 3] {
            let n = self.dir();
            let e1 = n.cross(&self.dir()).normalize();
            [e1, n.cross(&e1), n]
        }
    }

    // ---------- reference geometry, on its own small vector type ----------

    /// A plain 3-vector: keeps the references apart from nalgebra, and fast in debug builds.
    #[derive(Clone, Copy, Debug, PartialEq)]
    struct P([f64; 3]);

    impl P {
        fn from(v: &V) -> P {
            P([v.x, v.y, v.z])
        }
        fn v(self) -> V {
            V::new(self.0[0], self.0[1], self.0[2])
        }
        fn dot(self, o: P) -> f64 {
            self.0[0] * o.0[0] + self.0[1] * o.0[1] + self.0[2] * o.0[2]
        }
        fn cross(self, o: P) -> P {
            let (a, b) = (self.0, o.0);
            P([
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ])
        }
        fn norm(self) -> f64 {
            self.dot(self).sqrt()
        }
    }

    impl std::ops::Add for P {
        type Output = P;
        fn add(self, o: P) -> P {
            P([self.0[0] + o.0[0], self.0[1] + o.0[1], self.0[2] + o.0[2]])
        }
    }

    impl std::ops::Sub for P {
        type Output = P;
        fn sub(self, o: P) -> P {
            P([self.0[0] - o.0[0], self.0[1] - o.0[1], self.0[2] - o.0[2]])
        }
    }

    impl std::ops::Mul<f64> for P {
        type Output = P;
        fn mul(self, s: f64) -> P {
            P([self.0[0] * s, self.0[1] * s, self.0[2] * s])
        }
    }

    // Reference distances: brute force over the faces of each closest-point problem. Each
    // candidate is a real pair of points, so rounding never makes a distance look smaller.

    fn ref_point_segment(p: P, a: P, b: P) -> f64 {
        let mut best = (p - a).norm().min((p - b).norm());
        let ab = b - a;
        let l2 = ab.dot(ab);
        if l2 > 0.0 {
            let s = (p - a).dot(ab) / l2;
            if (0.0..=1.0).contains(&s) {
                best = best.min((p - (a + ab * s)).norm());
            }
        }
        best
    }

    fn ref_point_triangle(p: P, a: P, b: P, c: P) -> f64 {
        let mut best = ref_point_segment(p, a, b)
            .min(ref_point_segment(p, b, c))
            .min(ref_point_segment(p, c, a));
        let (e1, e2, w) = (b - a, c - a, p - a);
        let (g11, g12, g22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let (r1, r2) = (w.dot(e1), w.dot(e2));
        let det = g11 * g22 - g12 * g12;
        if det > 0.0 {
            let u = (g22 * r1 - g12 * r2) / det;
            let v = (g11 * r2 - g12 * r1) / det;
            if u >= 0.0 && v >= 0.0 && u + v <= 1.0 {
                best = best.min((w - e1 * u - e2 * v).norm());
            }
        }
        best
    }

    fn ref_segment_segment(a0: P, a1: P, b0: P, b1: P) -> f64 {
        let mut best = ref_point_segment(a0, b0, b1)
            .min(ref_point_segment(a1, b0, b1))
            .min(ref_point_segment(b0, a0, a1))
            .min(ref_point_segment(b1, a0, a1));
        let (u, v, w) = (a1 - a0, b1 - b0, a0 - b0);
        let (uu, uv, vv) = (u.dot(u), u.dot(v), v.dot(v));
        let det = uu * vv - uv * uv;
        if det > 0.0 {
            let (ru, rv) = (-u.dot(w), v.dot(w));
            let s = (vv * ru + uv * rv) / det;
            let t = (uv * ru + uu * rv) / det;
            if (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t) {
                best = best.min((w + u * s - v * t).norm());
            }
        }
        best
    }

    // ---------- cases ----------

    #[derive(Clone, Copy, Debug, PartialEq)]
    enum Kind {
        PointTriangle,
        EdgeEdge,
    }

    /// One query: vertices `[p, t0, t1, t2]` or `[ea0, ea1, eb0, eb1]`. The module sees
    /// `offset + y`; `y` is rebuilt from those world inputs exactly (Sterbenz), so the
    /// references check the very trajectory that the module was given.
    #[derive(Clone, Debug)]
    struct Case {
        kind: Kind,
        label: &'static str,
        offset: V,
        y: [P; 4],
        dx: [P; 4],
        xi: f64,
        /// Normal of a plane that holds the whole motion (then the cubic vanishes).
        plane: Option<P>,
    }

    impl Case {
        fn new(kind: Kind, label: &'static str, y: [V; 4], dx: [V; 4]) -> Self {
            Case {
                kind,
                label,
                offset: V::zeros(),
                y: y.map(|v| P::from(&v)),
                dx: dx.map(|v| P::from(&v)),
                xi: 0.0,
                plane: None,
            }
        }

        fn world(&self) -> [V; 4] {
            self.y.map(|y| y.v() + self.offset)
        }

        /// Moves the case to `offset`, keeping `y` equal to what the module will see.
        fn at_offset(mut self, offset: V) -> Self {
            self.offset = offset;
            let x = self.world();
            self.y = x.map(|x| P::from(&(x - offset)));
            self
        }

        fn run(&self, settings: &CcdSettings, t_max: f64) -> Toi {
            let x = self.world();
            let d = self.dx.map(P::v);
            let settings = CcdSettings {
                min_separation: self.xi,
                ..*settings
            };
            match self.kind {
                Kind::PointTriangle => point_triangle_ccd(
                    &x[0], &x[1], &x[2], &x[3], &d[0], &d[1], &d[2], &d[3], t_max, &settings,
                ),
                Kind::EdgeEdge => edge_edge_ccd(
                    &x[0], &x[1], &x[2], &x[3], &d[0], &d[1], &d[2], &d[3], t_max, &settings,
                ),
            }
        }

        /// Reference distance at the step fraction `t`.
        fn distance(&self, t: f64) -> f64 {
            let [a, b, c, d]: [P; 4] = std::array::from_fn(|i| self.y[i] + self.dx[i] * t);
            match self.kind {
                Kind::PointTriangle => ref_point_triangle(a, b, c, d),
                Kind::EdgeEdge => ref_segment_segment(a, b, c, d),
            }
        }

        /// A Lipschitz constant of `distance` (largest relative speed of two vertices on
        /// opposite primitives), slightly inflated for its own rounding.
        fn lipschitz(&self) -> f64 {
            let split = if self.kind == Kind::PointTriangle {
                1
            } else {
                2
            };
            let mut l: f64 = 0.0;
            for i in 0..split {
                for j in split..4 {
                    l = l.max((self.dx[i] - self.dx[j]).norm());
                }
            }
            l * (1.0 + 1e-12)
        }

        fn scale(&self) -> f64 {
            let m = |v: &[P; 4]| v.iter().map(|a| a.norm()).fold(0.0, f64::max);
            m(&self.y) + m(&self.dx)
        }

        /// The pairs (point, segment) whose collinearity bounds an in-plane contact.
        fn in_plane_events(&self) -> Vec<[usize; 3]> {
            match self.kind {
                Kind::PointTriangle => vec![[0, 1, 2], [0, 2, 3], [0, 3, 1]],
                Kind::EdgeEdge => vec![[0, 2, 3], [1, 2, 3], [2, 0, 1], [3, 0, 1]],
            }
        }

        /// The exact first time in `[0, 1]` at which the primitives touch (`ξ = 0`), or
        /// infinity. Every contact is a root of the coplanarity cubic (or, when the motion
        /// stays in one plane, of a collinearity quadratic); each root is kept if the
        /// distance there vanishes. A few samples catch what rounding hides.
        fn first_contact(&self) -> f64 {
            let tol = 1e-12 * self.scale();
            let lin = |i: usize, j: usize| Lin(self.y[i] - self.y[j], self.dx[i] - self.dx[j]);
            let mut candidates = vec![0.0];
            let (u, v, w) = match self.kind {
                Kind::PointTriangle => (lin(2, 1), lin(3, 1), lin(0, 1)),
                Kind::EdgeEdge => (lin(1, 0), lin(3, 2), lin(2, 0)),
            };
            cubic_roots(triple(&u, &v, &w), &mut candidates);
            if let Some(n) = self.plane {
                for [p, a, b] in self.in_plane_events() {
                    let q = cross(&lin(b, a), &lin(p, a));
                    let c = [n.dot(q[0]), n.dot(q[1]), n.dot(q[2]), 0.0];
                    cubic_roots(c, &mut candidates);
                }
            }
            let n = 64;
            candidates.extend((0..=n).map(|k| k as f64 / n as f64));
            candidates
                .into_iter()
                .filter(|t| (0.0..=1.0).contains(t) && self.distance(*t) <= tol)
                .fold(f64::INFINITY, f64::min)
        }
    }

    /// A vector linear in t: `.0 + t .1`.
    struct Lin(P, P);

    fn cross(a: &Lin, b: &Lin) -> [P; 3] {
        [
            a.0.cross(b.0),
            a.0.cross(b.1) + a.1.cross(b.0),
            a.1.cross(b.1),
        ]
    }

    /// Coefficients (constant first) of `(u × v) · w`.
    fn triple(u: &Lin, v: &Lin, w: &Lin) -> [f64; 4] {
        let q = cross(u, v);
        [
            q[0].dot(w.0),
            q[1].dot(w.0) + q[0].dot(w.1),
            q[2].dot(w.0) + q[1].dot(w.1),
            q[2].dot(w.1),
        ]
    }

    /// Pushes the critical points of the cubic `c` in [0, 1] and every root found by
    /// bisection on its monotone pieces.
    fn cubic_roots(c: [f64; 4], out: &mut Vec<f64>) {
        let f = |t: f64| ((c[3] * t + c[2]) * t + c[1]) * t + c[0];
        let mut breaks = vec![0.0, 1.0];
        let (a, b, cc) = (3.0 * c[3], 2.0 * c[2], c[1]);
        if a == 0.0 {
            if b != 0.0 {
                breaks.push(-cc / b);
            }
        } else {
            let disc = b * b - 4.0 * a * cc;
            if disc >= 0.0 {
                let q = -0.5 * (b + b.signum() * disc.sqrt());
                breaks.push(q / a);
                if q != 0.0 {
                    breaks.push(cc / q);
                }
            }
        }
        breaks.retain(|t| (0.0..=1.0).contains(t));
        breaks.sort_by(f64::total_cmp);
        out.extend_from_slice(&breaks);
        for w in breaks.windows(2) {
            let (mut lo, mut hi) = (w[0], w[1]);
            let flo = f(lo);
            if flo * f(hi) >= 0.0 {
                continue;
            }
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                if f(mid) * flo > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            out.extend([lo, hi]);
        }
    }

    /// Checks one query's answer: in `[0, t_max]`, zero when the primitives start within
    /// `ξ`, before every contact root of the cubic, and before the first time the distance
    /// comes within round-off of `ξ`. Returns that time (infinity if none before `t_max`).
    fn check(case: &Case, toi: &Toi, t_max: f64) -> Result<f64, String> {
        let t = toi.t;
        let fail = |why: String| Err(format!("{}: {why}; {toi:?}, {case:?}", case.label));
        if !(0.0..=t_max).contains(&t) {
            return fail("t outside [0, t_max]".into());
        }
        if case.distance(0.0) <= case.xi && t != 0.0 {
            return fail("starts within ξ but allows a step".into());
        }
        let t_cubic = case.first_contact();
        if t > 0.0 && t >= t_cubic {
            return fail(format!("the cubic's contact at {t_cubic} is not after t"));
        }
        let t_touch = first_touch(case, case.xi + 4.0 * f64::EPSILON * case.scale(), t_max)?;
        if t > 0.0 && t >= t_touch {
            return fail(format!("the distance reaches ξ at {t_touch}, not after t"));
        }
        Ok(t_touch)
    }

    /// The first time in `[0, t_end]` at which the reference distance is `≤ level`, or
    /// infinity, by branch and bound: on `[a, b]` the distance is at least
    /// `(D(a) + D(b) − L (b − a)) / 2` for the Lipschitz constant `L`, so such an interval
    /// holds no touch once that bound exceeds `level`. Leftmost intervals go first, so every
    /// time before the answer is proven clear.
    fn first_touch(case: &Case, level: f64, t_end: f64) -> Result<f64, String> {
        let l = case.lipschitz();
        let d = |s: f64| case.distance(s);
        let (d0, d1) = (d(0.0), d(t_end));
        if d0 <= level {
            return Ok(0.0);
        }
        let mut best = if d1 <= level { t_end } else { f64::INFINITY };
        let mut stack = vec![(0.0, d0, t_end, d1)];
        let mut budget = 2_000_000;
        while let Some((a, da, b, db)) = stack.pop() {
            if a >= best || (da - level) + (db - level) > l * (b - a) {
                continue;
            }
            let m = 0.5 * (a + b);
            if m <= a || m >= b {
                continue; // no float strictly inside
            }
            budget -= 1;
            if budget == 0 {
                return Err(format!("reference ran out of budget near t = {a}"));
            }
            let dm = d(m);
            if dm <= level {
                best = m;
            } else {
                stack.push((m, dm, b, db));
            }
            stack.push((a, da, m, dm));
        }
        Ok(best)
    }

    // ---------- generators ----------

    fn pt_case(rng: &mut Rng, category: usize) -> Case {
        use Kind::PointTriangle as K;
        let tri = |rng: &mut Rng, r: f64| [rng.vec(r), rng.vec(r), rng.vec(r)];
        let motion = |rng: &mut Rng, r: f64| [rng.vec(r), rng.vec(r), rng.vec(r), rng.vec(r)];
        let xi = |rng: &mut Rng| {
            if rng.coin() {
                0.0
            } else {
                rng.range(0.0, 0.05)
            }
        };
        match category {
            0 => {
                let [a, b, c] = tri(rng, 1.0);
                let s = rng.range(0.0, 2.0);
                let mut k = Case::new(K, "generic", [rng.vec(1.0), a, b, c], motion(rng, s));
                k.xi = xi(rng);
                k
            }
            1 => {
                // Everything inside one plane.
                let [e1, e2, n] = rng.frame();
                let mut in_plane = || e1 * rng.range(-1.0, 1.0) + e2 * rng.range(-1.0, 1.0);
                let y = [in_plane(), in_plane(), in_plane(), in_plane()];
                let dx = [in_plane(), in_plane(), in_plane(), in_plane()];
                let mut k = Case::new(K, "coplanar", y, dx);
                k.plane = Some(P::from(&n));
                k
            }
            2 => {
                // A common translation, exactly or up to a tiny relative motion.
                let [a, b, c] = tri(rng, 1.0);
                let v = rng.vec(3.0);
                let jitter = if rng.coin() { 0.0 } else { 1e-10 };
                let dx = std::array::from_fn(|_| v + rng.vec(jitter));
                let mut k = Case::new(K, "parallel motion", [rng.vec(1.0), a, b, c], dx);
                k.xi = xi(rng);
                k
            }
            3 => {
                // The point starts within ξ of the triangle.
                let [a, b, c] = tri(rng, 1.0);
                let (u, v) = (rng.unit(), rng.unit());
                let (u, v) = if u + v > 1.0 {
                    (1.0 - u, 1.0 - v)
                } else {
                    (u, v)
                };
                let xi = rng.range(1e-3, 0.1);
                let p = a + (b - a) * u + (c - a) * v + rng.dir() * rng.range(0.0, 0.999 * xi);
                let mut k = Case::new(K, "within ξ at start", [p, a, b, c], motion(rng, 1.0));
                k.xi = xi;
                k
            }
            4 => {
                let [a, b, c] = tri(rng, 1.0);
                let mut k = Case::new(
                    K,
                    "tiny motion",
                    [rng.vec(1.0), a, b, c],
                    motion(rng, 1e-12),
                );
                k.xi = xi(rng);
                k
            }
            5 => {
                // Small features far from the origin.
                let h = 10f64.powf(rng.range(-4.0, -1.0));
                let [a, b, c] = tri(rng, h);
                let offset = rng.vec(1.0).map(|x| 1e3 * x.signum());
                let k = Case::new(
                    K,
                    "large offset",
                    [rng.vec(h), a, b, c],
                    motion(rng, 2.0 * h),
                );
                k.at_offset(offset)
            }
            _ => {
                // The point hits a vertex, an edge or the face exactly at t_c.
                let [a, b, c] = tri(rng, 1.0);
                let t_c = rng.range(0.05, 1.2);
                let dx = motion(rng, 1.5);
                let q = match category {
                    6 => a,
                    7 => a + (b - a) * rng.unit(),
                    _ => {
                        let (u, v) = (rng.range(0.0, 0.5), rng.range(0.0, 0.5));
                        a + (b - a) * u + (c - a) * v
                    }
                };
                let label = ["hits a vertex", "hits an edge", "hits the face"][category - 6];
                let z = [q, a, b, c];
                Case::new(K, label, std::array::from_fn(|i| z[i] - dx[i] * t_c), dx)
            }
        }
    }

    fn ee_case(rng: &mut Rng, category: usize) -> Case {
        use Kind::EdgeEdge as K;
        let motion = |rng: &mut Rng, r: f64| [rng.vec(r), rng.vec(r), rng.vec(r), rng.vec(r)];
        let xi = |rng: &mut Rng| {
            if rng.coin() {
                0.0
            } else {
                rng.range(0.0, 0.05)
            }
        };
        let four = |rng: &mut Rng, r: f64| [rng.vec(r), rng.vec(r), rng.vec(r), rng.vec(r)];
        match category {
            0 => {
                let s = rng.range(0.0, 2.0);
                let mut k = Case::new(K, "generic", four(rng, 1.0), motion(rng, s));
                k.xi = xi(rng);
                k
            }
            1 => {
                let [e1, e2, n] = rng.frame();
                let mut in_plane = || e1 * rng.range(-1.0, 1.0) + e2 * rng.range(-1.0, 1.0);
                let y = [in_plane(), in_plane(), in_plane(), in_plane()];
                let dx = [in_plane(), in_plane(), in_plane(), in_plane()];
                let mut k = Case::new(K, "coplanar", y, dx);
                k.plane = Some(P::from(&n));
                k
            }
            2 => {
                let v = rng.vec(3.0);
                let jitter = if rng.coin() { 0.0 } else { 1e-10 };
                let dx = std::array::from_fn(|_| v + rng.vec(jitter));
                let mut k = Case::new(K, "parallel motion", four(rng, 1.0), dx);
                k.xi = xi(rng);
                k
            }
            3 => {
                let (a0, a1, b) = (rng.vec(1.0), rng.vec(1.0), rng.vec(1.0));
                let xi = rng.range(1e-3, 0.1);
                let q = a0 + (a1 - a0) * rng.unit() + rng.dir() * rng.range(0.0, 0.999 * xi);
                let (b0, b1) = if rng.coin() {
                    (q, b)
                } else {
                    (q - b * 0.3, q + b)
                };
                let mut k = Case::new(K, "within ξ at start", [a0, a1, b0, b1], motion(rng, 1.0));
                k.xi = xi;
                k
            }
            4 => {
                let mut k = Case::new(K, "tiny motion", four(rng, 1.0), motion(rng, 1e-12));
                k.xi = xi(rng);
                k
            }
            5 => {
                let h = 10f64.powf(rng.range(-4.0, -1.0));
                let offset = rng.vec(1.0).map(|x| 1e3 * x.signum());
                let k = Case::new(K, "large offset", four(rng, h), motion(rng, 2.0 * h));
                k.at_offset(offset)
            }
            6 | 7 => {
                // The edges cross (6) or an endpoint hits the other edge (7) exactly at t_c.
                let t_c = rng.range(0.05, 1.2);
                let q = rng.vec(1.0);
                let (da, db) = (
                    rng.dir() * rng.range(0.2, 1.0),
                    rng.dir() * rng.range(0.2, 1.0),
                );
                let (la, lb) = if category == 6 {
                    (rng.unit(), rng.unit())
                } else {
                    (if rng.coin() { 0.0 } else { 1.0 }, rng.unit())
                };
                let z = [
                    q - da * la,
                    q + da * (1.0 - la),
                    q - db * lb,
                    q + db * (1.0 - lb),
                ];
                let dx = motion(rng, 1.5);
                let label = if category == 6 {
                    "edges cross"
                } else {
                    "endpoint hits edge"
                };
                Case::new(K, label, std::array::from_fn(|i| z[i] - dx[i] * t_c), dx)
            }
            8 => {
                // Nearly parallel edges approaching each other.
                let [e1, e2, n] = rng.frame();
                let tilt = 10f64.powf(rng.range(-12.0, -4.0));
                let gap = rng.range(0.01, 0.5);
                let y = [
                    -e1,
                    e1,
                    n * gap - e1 * rng.range(0.0, 1.5) + e2 * tilt,
                    n * gap + e1 * rng.range(0.0, 1.5) - e2 * tilt,
                ];
                let closing = -n * rng.range(0.0, 2.0 * gap) + e1 * rng.range(-1.0, 1.0);
                let w = e2 * rng.range(-1e-3, 1e-3);
                if rng.coin() {
                    let dx = [V::zeros(), w, closing, closing - w];
                    let mut k = Case::new(K, "near-parallel", y, dx);
                    k.xi = xi(rng);
                    return k;
                }
                // Or: nearly parallel edges that cross each other exactly at t_c.
                let t_c = rng.range(0.05, 1.2);
                let (q, b) = (e1 * rng.range(-0.9, 0.9), e1 + e2 * tilt);
                let (l0, l1) = (rng.range(0.1, 1.0), rng.range(0.1, 1.0));
                let z = [-e1, e1, q - b * l0, q + b * l1];
                let dx = [closing * 0.1, closing * 0.1 + w, closing, closing - w];
                Case::new(
                    K,
                    "near-parallel",
                    std::array::from_fn(|i| z[i] - dx[i] * t_c),
                    dx,
                )
            }
            _ => {
                // Parallel edges in one plane closing in on each other, maybe overlapping.
                let [e1, n, normal] = rng.frame();
                let gap = rng.range(0.01, 0.5);
                let slide = rng.range(-2.0, 2.0);
                let y = [-e1, e1, n * gap + e1 * slide, n * gap + e1 * (slide + 1.0)];
                let closing = -n * rng.range(0.0, 2.0 * gap) + e1 * rng.range(-1.0, 1.0);
                let dx = [V::zeros(), V::zeros(), closing, closing];
                let mut k = Case::new(K, "parallel in a plane", y, dx);
                k.plane = Some(P::from(&normal));
                k
            }
        }
    }

    /// What a randomized run saw.
    struct Stats {
        /// Worst `t / t_true` over the uncapped cases that start clear of `ξ` and reach it
        /// inside the step.
        worst: f64,
        /// Per category: its label and how many cases reach `ξ` inside the step.
        contacts: Vec<(&'static str, usize)>,
        /// Queries stopped by the iteration cap.
        capped: usize,
    }

    /// Runs and checks `count` cases of each category (a quarter of them with a random
    /// `t_max < 1`).
    fn randomized(
        generate: fn(&mut Rng, usize) -> Case,
        categories: usize,
        count: usize,
        settings: &CcdSettings,
        seed: u64,
    ) -> Stats {
        let mut rng = Rng(seed);
        let mut stats = Stats {
            worst: f64::INFINITY,
            contacts: vec![("", 0); categories],
            capped: 0,
        };
        for i in 0..categories * count {
            let case = generate(&mut rng, i % categories);
            let t_max = if rng.next_u64().is_multiple_of(4) {
                rng.unit()
            } else {
                1.0
            };
            let toi = case.run(settings, t_max);
            let t_true = check(&case, &toi, t_max).unwrap_or_else(|e| panic!("case {i}: {e}"));
            stats.capped += usize::from(toi.capped);
            stats.contacts[i % categories].0 = case.label;
            if t_true <= t_max {
                stats.contacts[i % categories].1 += 1;
                if !toi.capped && case.distance(0.0) - case.xi > 1e-6 * case.scale() {
                    stats.worst = stats.worst.min(toi.t / t_true);
                }
            }
        }
        stats
    }

    #[test]
    fn point_triangle_never_reaches_the_reference_contact() {
        let stats = randomized(pt_case, 9, 1000, &CcdSettings::default(), 1);
        eprintln!("point-triangle: worst t / t_true = {}", stats.worst);
        eprintln!("  cases reaching ξ: {:?}", stats.contacts);
        for (label, n) in &stats.contacts[5..] {
            assert!(*n >= 25, "{label}: only {n} cases reach ξ");
        }
        assert!(stats.worst > 0.1, "uselessly conservative: {}", stats.worst);
    }

    #[test]
    fn edge_edge_never_reaches_the_reference_contact() {
        let stats = randomized(ee_case, 10, 1000, &CcdSettings::default(), 2);
        eprintln!("edge-edge: worst t / t_true = {}", stats.worst);
        eprintln!("  cases reaching ξ: {:?}", stats.contacts);
        for (label, n) in &stats.contacts[5..] {
            assert!(*n >= 25, "{label}: only {n} cases reach ξ");
        }
        assert!(stats.worst > 0.1, "uselessly conservative: {}", stats.worst);
    }

    #[test]
    fn a_capped_query_still_stops_before_contact() {
        for max_iterations in [0, 1, 2, 3, 5] {
            let settings = CcdSettings {
                max_iterations,
                ..CcdSettings::default()
            };
            let capped = randomized(pt_case, 9, 60, &settings, 10 + u64::from(max_iterations))
                .capped
                + randomized(ee_case, 10, 60, &settings, 20 + u64::from(max_iterations)).capped;
            assert!(
                capped > 50,
                "cap {max_iterations}: only {capped} capped queries"
            );
        }
        // A point sliding 1 m over a triangle 1 mm below it, landing at t = 0.9.
        let case = Case::new(
            Kind::PointTriangle,
            "slide",
            [
                V::new(-1.0, 0.1, 1e-3),
                V::new(-2.0, -2.0, 0.0),
                V::new(4.0, -2.0, 0.0),
                V::new(0.0, 4.0, 0.0),
            ],
            [
                V::new(1.0, 0.0, -1e-3 / 0.9),
                V::zeros(),
                V::zeros(),
                V::zeros(),
            ],
        );
        let settings = CcdSettings {
            max_iterations: 5,
            ..CcdSettings::default()
        };
        let toi = case.run(&settings, 1.0);
        assert!(toi.capped && toi.iterations == 5 && toi.t > 0.0, "{toi:?}");
        check(&case, &toi, 1.0).unwrap();
        let full = case.run(&CcdSettings::default(), 1.0);
        assert!(!full.capped && full.t > 0.8 && full.t < 0.9, "{full:?}");
        check(&case, &full, 1.0).unwrap();
    }

    #[test]
    fn the_checker_rejects_a_step_past_contact() {
        let mut rng = Rng(3);
        let mut rejected = 0;
        for i in 0..400 {
            let case = if i % 2 == 0 {
                pt_case(&mut rng, 6 + i % 3)
            } else {
                ee_case(&mut rng, 6)
            };
            let t_true = check(
                &case,
                &Toi {
                    t: 0.0,
                    iterations: 0,
                    capped: false,
                },
                1.0,
            )
            .unwrap();
            if t_true > 0.0 && t_true < 1.0 {
                for t in [t_true, (t_true + 1e-9).min(1.0), 1.0] {
                    let toi = Toi {
                        t,
                        iterations: 1,
                        capped: false,
                    };
                    assert!(
                        check(&case, &toi, 1.0).is_err(),
                        "accepted {t} past {t_true}"
                    );
                }
                rejected += 1;
            }
        }
        assert!(rejected > 200, "{rejected}");
    }

    #[test]
    fn a_clear_approach_stops_close_to_contact() {
        let s = CcdSettings::default();
        let tri = [
            V::new(0.0, 0.0, 0.0),
            V::new(1.0, 0.0, 0.0),
            V::new(0.0, 1.0, 0.0),
        ];
        let at = |p: V, dp: V, t_max: f64| {
            let case = Case::new(
                Kind::PointTriangle,
                "clear",
                [p, tri[0], tri[1], tri[2]],
                [dp, V::zeros(), V::zeros(), V::zeros()],
            );
            let toi = case.run(&s, t_max);
            check(&case, &toi, t_max).unwrap();
            toi
        };
        // Falling from height 1 at 2 per step: contact at 0.5.
        let head_on = at(V::new(0.2, 0.2, 1.0), V::new(0.0, 0.0, -2.0), 1.0);
        assert!(
            head_on.t >= 0.9 * (1.0 - s.gap_fraction) * 0.5 && head_on.t < 0.5,
            "{head_on:?}"
        );
        // The same at 45 degrees: contact still at 0.5.
        let oblique = at(V::new(0.0, 0.2, 1.0), V::new(0.8, 0.0, -2.0), 1.0);
        assert!(
            oblique.t >= 0.5 * (1.0 - s.gap_fraction) * 0.5 && oblique.t < 0.5,
            "{oblique:?}"
        );
        // A cap below the first step is returned as is.
        let short = at(V::new(0.2, 0.2, 1.0), V::new(0.0, 0.0, -2.0), 0.3);
        assert_eq!((short.t, short.iterations), (0.3, 1));
        // Never close: one step reaches t_max; no relative motion: no step at all.
        let away = at(V::new(0.2, 0.2, 1.0), V::new(0.5, -0.3, 0.2), 1.0);
        assert!(away.t == 1.0 && away.iterations <= 2, "{away:?}");
        let case = Case::new(
            Kind::EdgeEdge,
            "rigid",
            [tri[0], tri[1], tri[2], V::new(0.0, 0.0, 1.0)],
            [V::new(5.0, 1.0, -3.0); 4],
        );
        assert_eq!(
            case.run(&s, 1.0),
            Toi {
                t: 1.0,
                iterations: 0,
                capped: false
            }
        );
        // Two edges crossing head-on at 0.5.
        let case = Case::new(
            Kind::EdgeEdge,
            "crossing",
            [
                V::new(-1.0, 0.0, 1.0),
                V::new(1.0, 0.0, 1.0),
                V::new(0.0, -1.0, 0.0),
                V::new(0.0, 1.0, 0.0),
            ],
            [
                V::new(0.0, 0.0, -1.0),
                V::new(0.0, 0.0, -1.0),
                V::new(0.0, 0.0, 1.0),
                V::new(0.0, 0.0, 1.0),
            ],
        );
        let toi = case.run(&s, 1.0);
        check(&case, &toi, 1.0).unwrap();
        assert!(
            toi.t >= 0.9 * (1.0 - s.gap_fraction) * 0.5 && toi.t < 0.5,
            "{toi:?}"
        );
    }

    #[test]
    fn a_start_within_separation_or_bad_input_allows_no_step() {
        let z = V::zeros();
        let s = CcdSettings {
            min_separation: 0.01,
            ..CcdSettings::default()
        };
        let (a, b, c) = (
            V::new(0.0, 0.0, 0.0),
            V::new(1.0, 0.0, 0.0),
            V::new(0.0, 1.0, 0.0),
        );
        let p = V::new(0.2, 0.2, 0.009);
        let up = V::new(0.0, 0.0, 1.0);
        assert_eq!(
            point_triangle_ccd(&p, &a, &b, &c, &up, &z, &z, &z, 1.0, &s).t,
            0.0
        );
        let p = V::new(0.2, 0.2, 0.5);
        let nan = V::new(f64::NAN, 0.0, 0.0);
        let inf = V::new(f64::INFINITY, 0.0, 0.0);
        for d in [nan, inf] {
            assert_eq!(
                point_triangle_ccd(&p, &a, &b, &c, &d, &z, &z, &z, 1.0, &s).t,
                0.0
            );
            assert_eq!(
                edge_edge_ccd(&p, &a, &b, &c, &z, &z, &d, &z, 1.0, &s).t,
                0.0
            );
            assert_eq!(point_sdf_ccd(&p, &d, &mut |x| x.z, 1.0, &s).t, 0.0);
        }
        assert_eq!(point_sdf_ccd(&p, &up, &mut |_| f64::NAN, 1.0, &s).t, 0.0);
    }

    #[test]
    #[should_panic(expected = "gap_fraction")]
    fn a_gap_fraction_outside_the_unit_interval_is_refused() {
        let s = CcdSettings {
            gap_fraction: 1.0,
            ..CcdSettings::default()
        };
        let z = V::zeros();
        point_sdf_ccd(&z, &z, &mut |_| 1.0, 1.0, &s);
    }

    /// An analytic obstacle: its signed distance, the exact lowest value of it on a
    /// segment, and the exact first time a moving point comes within `xi` of it.
    enum Obstacle {
        Plane { n: V, h: f64 },
        Sphere { c: V, r: f64 },
    }

    impl Obstacle {
        fn sdf(&self, x: &V) -> f64 {
            match self {
                Obstacle::Plane { n, h } => n.dot(x) - h,
                Obstacle::Sphere { c, r } => (x - c).norm() - r,
            }
        }

        fn lowest(&self, p: &V, dp: &V, t: f64) -> f64 {
            match self {
                Obstacle::Plane { .. } => self.sdf(p).min(self.sdf(&(p + dp * t))),
                Obstacle::Sphere { c, .. } => {
                    let l2 = dp.norm_squared();
                    let s = if l2 > 0.0 {
                        ((c - p).dot(dp) / l2).clamp(0.0, t)
                    } else {
                        0.0
                    };
                    self.sdf(&(p + dp * s))
                }
            }
        }

        fn toi(&self, p: &V, dp: &V, xi: f64) -> f64 {
            match self {
                Obstacle::Plane { n, .. } => {
                    let rate = n.dot(dp);
                    if rate < 0.0 {
                        (xi - self.sdf(p)) / rate
                    } else {
                        f64::INFINITY
                    }
                }
                Obstacle::Sphere { c, r } => {
                    // |w + t dp| = r + xi, w = p - c: the smaller root of a quadratic.
                    let w = p - c;
                    let (qa, qb, qc) = (
                        dp.norm_squared(),
                        w.dot(dp),
                        w.norm_squared() - (r + xi).powi(2),
                    );
                    let disc = qb * qb - qa * qc;
                    if qc <= 0.0 {
                        0.0
                    } else if qb < 0.0 && disc >= 0.0 {
                        qc / (-qb + disc.sqrt())
                    } else {
                        f64::INFINITY
                    }
                }
            }
        }
    }

    /// A point against random planes and spheres: the exact lowest signed distance over the
    /// swept segment `[p, p + t dp]` stays above `ξ`, and `t` comes before the analytic
    /// time of impact, and close to it for a head-on approach.
    #[test]
    fn point_sdf_never_crosses_a_plane_or_sphere() {
        let mut rng = Rng(4);
        let (mut worst_head_on, mut worst, mut hits) = (f64::INFINITY, f64::INFINITY, 0);
        for i in 0..4000 {
            let xi = if rng.coin() {
                0.0
            } else {
                rng.range(0.0, 0.05)
            };
            let settings = CcdSettings {
                min_separation: xi,
                ..CcdSettings::default()
            };
            let head_on = i % 4 < 2;
            let (obstacle, p, dp) = if i % 2 == 0 {
                let (n, h) = (rng.dir(), rng.range(-2.0, 2.0));
                let p = n * (h + rng.range(0.0, 1.0)) + n.cross(&rng.dir()) * 3.0;
                let dp = if head_on {
                    -n * rng.range(0.0, 3.0)
                } else {
                    rng.vec(2.0)
                };
                (Obstacle::Plane { n, h }, p, dp)
            } else {
                let (c, r) = (rng.vec(3.0), rng.range(0.1, 2.0));
                let p = c + rng.dir() * (r + rng.range(0.0, 1.0));
                let dp = if head_on {
                    (c - p) * rng.range(0.0, 2.0)
                } else {
                    rng.vec(2.0)
                };
                (Obstacle::Sphere { c, r }, p, dp)
            };
            let t_max = if i % 8 == 7 { rng.unit() } else { 1.0 };
            let toi = point_sdf_ccd(&p, &dp, &mut |x| obstacle.sdf(x), t_max, &settings);
            let t_true = obstacle.toi(&p, &dp, xi);
            let ok = (0.0..=t_max).contains(&toi.t)
                && (toi.t == 0.0 || (toi.t < t_true && obstacle.lowest(&p, &dp, toi.t) > xi))
                && (t_true > t_max || toi.t < t_max)
                && !toi.capped;
            assert!(
                ok,
                "case {i}: {toi:?}, t_true {t_true}, xi {xi}, p {p:?}, dp {dp:?}"
            );
            if t_true <= t_max && obstacle.sdf(&p) - xi > 1e-6 {
                hits += 1;
                let ratio = toi.t / t_true;
                worst = worst.min(ratio);
                if head_on {
                    worst_head_on = worst_head_on.min(ratio);
                }
            }
        }
        eprintln!("point-sdf: {hits} hits, worst t / t_true = {worst}, head-on {worst_head_on}");
        assert!(hits > 1000, "{hits}");
        let s = CcdSettings::default().gap_fraction;
        assert!(worst_head_on >= 0.9 * (1.0 - s), "{worst_head_on}");
        assert!(worst >= 0.5 * (1.0 - s), "{worst}");
    }
}
