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
//!   one Richardson extrapolation (one step of dt and two of dt/2; the midpoint rule's error
//!   expands in even powers of dt), accurate to O(dt⁵) per step, enough for order k ≤ 5 —
//!   at the price of three solves per start-up step and a start-up that amplifies stiff
//!   components by up to 5/3 per step (the extrapolation is not A-stable).
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
    /// The step the history was taken with.
    step: Option<f64>,
    start: State,
    full: State,
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
            step: None,
            start: State::default(),
            full: State::default(),
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
        // Start-up: (4 y_{dt/2} - y_dt)/3 from implicit midpoint.
        self.inner.scheme_mut().mode = Mode::Midpoint;
        self.start.clone_from(state);
        self.full.clone_from(state);
        self.inner.solve_step(model, &mut self.full, dt, report)?;
        let t0 = state.t;
        let half = self
            .inner
            .solve_step(model, state, 0.5 * dt, report)
            .and_then(|()| {
                state.t = t0 + 0.5 * dt;
                self.inner.solve_step(model, state, 0.5 * dt, report)
            });
        state.t = t0;
        if let Err(e) = half {
            state.clone_from(&self.start);
            return Err(e);
        }
        for (y, f) in state.q.iter_mut().zip(&self.full.q) {
            *y = (4.0 * *y - f) / 3.0;
        }
        for (y, f) in state.v.iter_mut().zip(&self.full.v) {
            *y = (4.0 * *y - f) / 3.0;
        }
        let scheme = self.inner.scheme_mut();
        scheme.mode = Mode::Bdf;
        scheme.push(&self.start.q, &self.start.v);
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
    /// `None` for an extrapolated start-up step (three solves, not one minimization) or a
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
