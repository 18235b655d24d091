//! BDF2, the second-order backward differentiation formula:
//! `q' - 4/3 q + 1/3 q_prev = 2/3 dt v'` and `v' - 4/3 v + 1/3 v_prev = 2/3 dt a(q')`.
//! Eliminating `v'` gives a minimization like backward Euler's with
//! `x_hat = 4/3 q - 1/3 q_prev + 2/3 dt (4/3 v - 1/3 v_prev)` and `beta = 4/9 dt^2`, on the
//! same Newton solver. The first step, and any step whose dt differs from the previous one,
//! is a backward Euler step (constant-step BDF2 needs equal steps).

use super::newton::{Newton, NewtonSettings, Problem, with_halving};
use super::{Integrator, State, StepError, StepReport};
use crate::model::Model;
use crate::solve::LinearSolver;

/// A BDF2 integrator.
pub struct Bdf2 {
    newton: Newton,
    /// The previous step's start state and its dt, when there is one.
    history: Option<f64>,
    q_prev: Vec<f64>,
    v_prev: Vec<f64>,
    x: Vec<f64>,
    x_hat: Vec<f64>,
    /// `4/3 q - 1/3 q_prev`, where BDF2's velocity (and so its damping term) is zero.
    x_base: Vec<f64>,
}

impl Bdf2 {
    /// BDF2 solving its Newton systems with `solver`.
    pub fn new(solver: Box<dyn LinearSolver>, settings: NewtonSettings) -> Self {
        Self {
            newton: Newton::new(solver, settings),
            history: None,
            q_prev: Vec::new(),
            v_prev: Vec::new(),
            x: Vec::new(),
            x_hat: Vec::new(),
            x_base: Vec::new(),
        }
    }

    fn single(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let bdf = matches!(self.history, Some(h) if (h - dt).abs() <= 1e-12 * dt);
        self.x_hat.clear();
        let beta = if bdf {
            let (qp, vp) = (&self.q_prev, &self.v_prev);
            self.x_hat.extend((0..state.q.len()).map(|i| {
                4.0 / 3.0 * state.q[i] - 1.0 / 3.0 * qp[i]
                    + 2.0 / 3.0 * dt * (4.0 / 3.0 * state.v[i] - 1.0 / 3.0 * vp[i])
            }));
            4.0 / 9.0 * dt * dt
        } else {
            self.x_hat
                .extend(state.q.iter().zip(&state.v).map(|(q, v)| q + dt * v));
            dt * dt
        };
        self.x.clone_from(&self.x_hat);
        // Damping -D v' with v' = 3/(2 dt) (x - x_base): the term dt/3 (x - x_base)^T D (..).
        self.x_base.clear();
        if bdf {
            self.x_base.extend(
                state
                    .q
                    .iter()
                    .zip(&self.q_prev)
                    .map(|(q, qp)| 4.0 / 3.0 * q - 1.0 / 3.0 * qp),
            );
        } else {
            self.x_base.extend_from_slice(&state.q);
        }
        let gamma = if bdf { 2.0 / 3.0 * dt } else { dt };
        self.newton
            .prepare_damping(model, &self.x_hat, &state.q, gamma, report)?;
        model.set_time(state.t + dt);
        let problem = Problem {
            x_hat: &self.x_hat,
            x_ref: &state.q,
            beta,
            damping_anchor: &self.x_base,
        };
        self.newton.minimize(model, &problem, &mut self.x, report)?;
        // The new state; the old one becomes the history.
        self.q_prev.resize(state.q.len(), 0.0);
        self.v_prev.resize(state.q.len(), 0.0);
        for i in 0..state.q.len() {
            let v_new = if bdf {
                1.5 / dt * (self.x[i] - 4.0 / 3.0 * state.q[i] + 1.0 / 3.0 * self.q_prev[i])
            } else {
                (self.x[i] - state.q[i]) / dt
            };
            self.q_prev[i] = state.q[i];
            self.v_prev[i] = state.v[i];
            state.q[i] = self.x[i];
            state.v[i] = v_new;
        }
        self.history = Some(dt);
        report.substeps += 1;
        Ok(())
    }
}

impl Integrator for Bdf2 {
    fn name(&self) -> &'static str {
        "bdf2"
    }

    fn order(&self) -> u32 {
        2
    }

    fn is_explicit(&self) -> bool {
        false
    }

    fn reset(&mut self) {
        self.history = None;
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let halvings = self.newton.settings().retry_halvings;
        with_halving(halvings, state, dt, report, &mut |s, h, r| {
            self.single(model, s, h, r)
        })
    }
}
