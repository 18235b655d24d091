//! BDF-k, the backward differentiation formulas of order k = 1…6, for `q' = v`, `v' = a(q, v)`:
//!
//! `q_{n+1} = Σ_i a_i q_{n-i} + b dt v_{n+1}`, `v_{n+1} = Σ_i a_i v_{n-i} + b dt a(q_{n+1}, v_{n+1})`.
//!
//! Eliminating `v_{n+1}` gives a minimization like backward Euler's with `q̄ = Σ a_i q_{n-i}`,
//! `x_hat = q̄ + b dt Σ a_i v_{n-i}` and `beta = b² dt²`; then `v_{n+1} = (x - q̄)/(b dt)`. BDF1
//! is backward Euler. BDF1 and BDF2 are A-stable; BDF3…6 are only A(α)-stable (α = 86°, 73°,
//! 52°, 18°): they damp stiff modes but can amplify lightly damped oscillations whose
//! `ω dt` lies near the imaginary axis, and BDF ≥ 7 is not zero-stable at all.
//!
//! The formulas need `k - 1` earlier states at the same step. They are started by
//! (see [`BdfStartup`]):
//! - `lower-orders` (as PolyFEM does): BDF1, BDF2, … until enough history exists. The first
//!   step's O(dt²) error stays in the solution, so the observed order is at most 2;
//! - `extrapolated-midpoint`: the first `k - 1` steps are implicit midpoint steps improved by
//!   Richardson extrapolation (the midpoint rule is symmetric, so its error over a step
//!   expands in even powers of dt). For k ≤ 5 one level: a step of dt and two of dt/2,
//!   `(4 y_{dt/2} - y_dt)/3`, accurate to O(dt⁵) per step — three solves per start-up step,
//!   stiff components amplified by up to 5/3 per step (the extrapolation is not A-stable).
//!   For BDF6 a start-up error of O(dt⁵) caps the order at 5 once the steps are small enough,
//!   so a second level adds four steps of dt/4 (Romberg's table in dt²): O(dt⁷) per step,
//!   seven solves, stiff components scaled by at most 43/45. (BDF6's observed order of 5.5 on
//!   the test block is not the start-up's: its pairwise orders climb to 5.8 before the errors
//!   reach the reference's floor, with either start-up.)
//!
//! `auto` (the default) uses lower orders for k ≤ 2 (whose order they do not limit) and the
//! extrapolated midpoint above. A change of dt restarts the formulas (constant-step BDF needs
//! equal steps).

use super::implicit_midpoint::ImplicitMidpoint;
use super::newton::{NewtonContact, NewtonSettings, with_halving};
use super::scheme::{NewtonIntegrator, Scheme, StepProblem};
use super::{Integrator, State, StepError, StepReport};
use crate::model::Model;
use crate::solve::LinearSolver;
use std::collections::VecDeque;

/// `(a_0, …, a_{k-1}; b)` of BDF-k, normalized so the new value's coefficient is 1.
const COEFFICIENTS: [(&[f64], f64); 6] = [
    (&[1.0], 1.0),
    (&[4.0 / 3.0, -1.0 / 3.0], 2.0 / 3.0),
    (&[18.0 / 11.0, -9.0 / 11.0, 2.0 / 11.0], 6.0 / 11.0),
    (
        &[48.0 / 25.0, -36.0 / 25.0, 16.0 / 25.0, -3.0 / 25.0],
        12.0 / 25.0,
    ),
    (
        &[
            300.0 / 137.0,
            -300.0 / 137.0,
            200.0 / 137.0,
            -75.0 / 137.0,
            12.0 / 137.0,
        ],
        60.0 / 137.0,
    ),
    (
        &[
            360.0 / 147.0,
            -450.0 / 147.0,
            400.0 / 147.0,
            -225.0 / 147.0,
            72.0 / 147.0,
            -10.0 / 147.0,
        ],
        60.0 / 147.0,
    ),
];

/// The highest order implemented (BDF-7 and up are not zero-stable).
pub const MAX_ORDER: u32 = 6;

/// How BDF-k computes its first `k - 1` steps (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BdfStartup {
    /// Lower orders for k ≤ 2, the extrapolated midpoint above.
    #[default]
    Auto,
    /// BDF1, BDF2, … (observed order at most 2).
    LowerOrders,
    /// Richardson-extrapolated implicit midpoint steps.
    ExtrapolatedMidpoint,
}

/// The `[integrator.bdf]` settings.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BdfSettings {
    /// How the first `k - 1` steps are computed. Default `auto`.
    pub startup: BdfStartup,
}

/// Which formula the next solve uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Bdf,
    Midpoint,
}

/// The BDF scheme of one order over its history of earlier states.
pub struct BdfScheme {
    name: &'static str,
    order: usize,
    mode: Mode,
    /// Earlier `(q, v)`, most recent first, at most `order - 1` of them.
    history: VecDeque<(Vec<f64>, Vec<f64>)>,
    spare: Vec<(Vec<f64>, Vec<f64>)>,
}

impl BdfScheme {
    fn new(name: &'static str, order: u32) -> Self {
        Self {
            name,
            order: order as usize,
            mode: Mode::Bdf,
            history: VecDeque::new(),
            spare: Vec::new(),
        }
    }

    /// The order the next BDF solve uses: `k`, or less while the history is short.
    fn current_order(&self) -> usize {
        self.order.min(self.history.len() + 1)
    }

    /// Remember `(q, v)` as the most recent earlier state (reusing the oldest buffers).
    fn push(&mut self, q: &[f64], v: &[f64]) {
        if self.order < 2 {
            return;
        }
        let mut slot = if self.history.len() == self.order - 1 {
            self.history.pop_back().expect("full history")
        } else {
            self.spare.pop().unwrap_or_default()
        };
        slot.0.clear();
        slot.0.extend_from_slice(q);
        slot.1.clear();
        slot.1.extend_from_slice(v);
        self.history.push_front(slot);
    }

    fn clear(&mut self) {
        self.spare.extend(self.history.drain(..));
    }
}

impl Scheme for BdfScheme {
    fn name(&self) -> &'static str {
        self.name
    }

    fn order(&self) -> u32 {
        self.order as u32
    }

    fn prepare(
        &mut self,
        model: &mut Model,
        state: &State,
        dt: f64,
        p: &mut StepProblem,
    ) -> Result<(), StepError> {
        if self.mode == Mode::Midpoint {
            return ImplicitMidpoint.prepare(model, state, dt, p);
        }
        let (a, b) = COEFFICIENTS[self.current_order() - 1];
        // q̄ into the damping anchor (where BDF's velocity, and so its damping, vanishes),
        // Σ a_i v_{n-i} into the guess for now.
        for i in 0..state.q.len() {
            let (mut q_bar, mut v_bar) = (a[0] * state.q[i], a[0] * state.v[i]);
            for (ai, (q, v)) in a[1..].iter().zip(&self.history) {
                q_bar += ai * q[i];
                v_bar += ai * v[i];
            }
            p.damping_anchor[i] = q_bar;
            p.x_hat[i] = q_bar + b * dt * v_bar;
        }
        p.beta = b * b * dt * dt;
        p.force_time = state.t + dt;
        // Damping -D v' with v' = (x - q̄)/(b dt): the term (b dt)/2 (x - q̄)^T D (x - q̄).
        p.damping_weight = b * dt;
        p.damping_at.copy_from_slice(&p.x_hat);
        p.guess.copy_from_slice(&p.x_hat);
        Ok(())
    }

    fn finish(&mut self, state: &mut State, dt: f64, x: &[f64], p: &StepProblem) {
        if self.mode == Mode::Midpoint {
            return ImplicitMidpoint.finish(state, dt, x, p);
        }
        let b = COEFFICIENTS[self.current_order() - 1].1;
        self.push(&state.q, &state.v);
        for (((q, v), x), q_bar) in state
            .q
            .iter_mut()
            .zip(state.v.iter_mut())
            .zip(x)
            .zip(&p.damping_anchor)
        {
            *v = (x - q_bar) / (b * dt);
            *q = *x;
        }
    }

    fn reset(&mut self) {
        self.clear();
    }
}

/// BDF-k with its start-up (see the module docs).
pub struct Bdf {
    inner: NewtonIntegrator<BdfScheme>,
    extrapolated_startup: bool,
    /// Richardson levels of the start-up: 1 for k ≤ 5, 2 for BDF6.
    levels: usize,
    /// The step the history was taken with.
    step: Option<f64>,
    start: State,
    /// Romberg's table of the start-up step, one row per level (reused).
    table: Vec<State>,
}

impl Bdf {
    /// BDF of `order` (1…6) called `name`, solving with `solver`, optionally constrained.
    pub fn new(
        name: &'static str,
        order: u32,
        settings: BdfSettings,
        solver: Box<dyn LinearSolver>,
        newton: NewtonSettings,
        constraints: Option<NewtonContact>,
    ) -> Self {
        assert!((1..=MAX_ORDER).contains(&order), "BDF order {order}");
        // A constrained start-up would constrain the midpoint, not the end of the step.
        let extrapolated_startup = constraints.is_none()
            && match settings.startup {
                BdfStartup::Auto => order >= 3,
                BdfStartup::LowerOrders => false,
                BdfStartup::ExtrapolatedMidpoint => order >= 2,
            };
        Self {
            inner: NewtonIntegrator::new(BdfScheme::new(name, order), solver, newton)
                .constrained(constraints),
            extrapolated_startup,
            levels: if order >= 6 { 2 } else { 1 },
            step: None,
            start: State::default(),
            table: Vec::new(),
        }
    }

    /// Whether the kept history was made with steps of `dt` (else a step clears it first).
    fn history_is_for(&self, dt: f64) -> bool {
        matches!(self.step, Some(h) if (h - dt).abs() <= 1e-12 * dt)
    }

    /// Whether the next step is an extrapolated start-up step (the history is still short).
    fn extrapolating_startup(&self) -> bool {
        let scheme = self.inner.scheme();
        self.extrapolated_startup && scheme.history.len() + 1 < scheme.order
    }

    /// One step of `dt` without retries; leaves `state` unchanged on error.
    fn single(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        if !self.history_is_for(dt) {
            self.inner.scheme_mut().clear();
            self.step = Some(dt);
        }
        if !self.extrapolating_startup() {
            self.inner.scheme_mut().mode = Mode::Bdf;
            return self.inner.solve_step(model, state, dt, report);
        }
        // Start-up: implicit midpoint over dt with 1, 2, 4, ... substeps, extrapolated.
        self.inner.scheme_mut().mode = Mode::Midpoint;
        self.start.clone_from(state);
        if let Err(e) = self.romberg(model, dt, report) {
            state.clone_from(&self.start);
            return Err(e);
        }
        state.q.copy_from_slice(&self.table[self.levels].q);
        state.v.copy_from_slice(&self.table[self.levels].v);
        let scheme = self.inner.scheme_mut();
        scheme.mode = Mode::Bdf;
        scheme.push(&self.start.q, &self.start.v);
        Ok(())
    }
}

impl Bdf {
    /// Fill `table[j]` with the midpoint solution over `dt` in `2^j` substeps from `start`,
    /// then extrapolate in place: after column `m`, `table[j]` eliminates the dt^2 ... dt^(2m)
    /// terms (`T_j += (T_j - T_{j-1}) / (4^m - 1)`), so `table[levels]` is the start-up step.
    fn romberg(
        &mut self,
        model: &mut Model,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.table.resize_with(self.levels + 1, State::default);
        let t0 = self.start.t;
        for j in 0..=self.levels {
            let n = 1usize << j;
            let h = dt / n as f64;
            let y = &mut self.table[j];
            y.clone_from(&self.start);
            for i in 0..n {
                y.t = t0 + i as f64 * h;
                self.inner.solve_step(model, y, h, report)?;
            }
            y.t = t0;
        }
        for m in 1..=self.levels {
            let factor = 1.0 / (4f64.powi(m as i32) - 1.0);
            for j in (m..=self.levels).rev() {
                let (lower, upper) = self.table.split_at_mut(j);
                let (prev, cur) = (&lower[j - 1], &mut upper[0]);
                for (y, p) in cur.q.iter_mut().zip(&prev.q) {
                    *y += (*y - p) * factor;
                }
                for (y, p) in cur.v.iter_mut().zip(&prev.v) {
                    *y += (*y - p) * factor;
                }
            }
        }
        Ok(())
    }
}

impl Integrator for Bdf {
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn order(&self) -> u32 {
        self.inner.order()
    }

    fn is_explicit(&self) -> bool {
        false
    }

    fn drain_iteration_log(&mut self, out: &mut Vec<super::newton::IterationRecord>) {
        self.inner.drain_iteration_log(out);
    }

    fn reset(&mut self) {
        self.inner.reset();
        self.step = None;
    }

    /// The BDF step's potential with the history kept for this `dt` (none at the start);
    /// `None` for an extrapolated start-up step (several solves, not one minimization) or a
    /// history made with another `dt` (the step would clear it first).
    fn freeze_step(
        &mut self,
        model: &mut Model,
        state: &State,
        dt: f64,
    ) -> Option<Result<super::FrozenStep, StepError>> {
        let history_kept = self.history_is_for(dt) || self.inner.scheme().history.is_empty();
        if !history_kept || self.extrapolating_startup() {
            return None;
        }
        self.inner.scheme_mut().mode = Mode::Bdf;
        self.inner.freeze_step(model, state, dt)
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let halvings = self.inner.newton().settings().retry_halvings;
        let result = with_halving(halvings, state, dt, report, &mut |s, h, r| {
            self.single(model, s, h, r)
        });
        if result.is_err() {
            self.reset();
        }
        result?;
        self.inner.record_contacts(state, dt, report);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::COEFFICIENTS;

    /// Where the boundary of BDF-k's stability region crosses the imaginary axis, `|Im z|`
    /// with `z(φ) = (1 − Σ a_i e^{−i(j+1)φ}) / b` over `φ` in `(0, π]` (the boundary locus:
    /// a root of modulus one), to 1e-6, leaving out the origin itself.
    fn imaginary_axis_crossings(k: usize) -> Vec<f64> {
        let (a, b) = COEFFICIENTS[k - 1];
        let z = |phi: f64| {
            let (mut re, mut im) = (1.0, 0.0);
            for (j, aj) in a.iter().enumerate() {
                let angle = -((j + 1) as f64) * phi;
                re -= aj * angle.cos();
                im -= aj * angle.sin();
            }
            (re / b, im / b)
        };
        // The locus leaves the origin tangent to the axis: its real part is O(phi^(k+1)),
        // round-off (~1e-14 after the sum's cancellation) below phi ~ 0.003 for BDF4 and
        // ~0.016 for BDF6. The scan starts at phi = 0.1 (where that part is 1e-8 or more for
        // every k), well below the first crossing away from the origin (BDF5's, at phi = 0.73,
        // where |Im z| = 0.71).
        let steps = 100_000;
        let first = (0.1 / std::f64::consts::PI * steps as f64).ceil() as usize;
        let mut crossings = Vec::new();
        for i in first..steps {
            let (lo, hi) = (
                std::f64::consts::PI * i as f64 / steps as f64,
                std::f64::consts::PI * (i + 1) as f64 / steps as f64,
            );
            if z(lo).0.signum() != z(hi).0.signum() {
                let (mut l, mut h) = (lo, hi);
                for _ in 0..60 {
                    let m = 0.5 * (l + h);
                    if z(m).0.signum() == z(l).0.signum() {
                        l = m;
                    } else {
                        h = m;
                    }
                }
                crossings.push(z(l).1.abs());
            }
        }
        crossings
    }

    /// The ranges of ω·dt where BDF3–6 amplify an undamped mode, as docs/integrators.md
    /// states them: BDF3 (0, 1.94), BDF4 (0, 4.71), BDF5 (0.71, 9.39), BDF6 (0.84, 17.6);
    /// BDF1 and BDF2 keep the whole imaginary axis (A-stable).
    #[test]
    fn bdf_stability_boundaries_cross_the_imaginary_axis_where_the_docs_say() {
        assert!(imaginary_axis_crossings(1).is_empty());
        assert!(imaginary_axis_crossings(2).is_empty());
        for (k, expected) in [
            (3, vec![1.94]),
            (4, vec![4.71]),
            (5, vec![0.71, 9.39]),
            (6, vec![0.84, 17.6]),
        ] {
            let mut found = imaginary_axis_crossings(k);
            found.sort_by(f64::total_cmp);
            assert_eq!(found.len(), expected.len(), "BDF{k}: {found:?}");
            for (f, e) in found.iter().zip(&expected) {
                // The docs round to three significant digits.
                assert!(
                    (f / e - 1.0).abs() <= 0.01,
                    "BDF{k}: {found:?}, docs say {expected:?}"
                );
            }
        }
    }
}
