//! Backward Euler as minimization (the course's formulation):
//! `x = argmin 1/2 (x - (q + dt v))^T M (x - (q + dt v)) + dt^2 V(x)`, then `v = (x - q)/dt`,
//! `q = x`. First order, unconditionally stable, dissipative. Newton starts from `q + dt v`
//! (the course's guess: the new velocity equals the old one).

use super::newton::{Newton, NewtonSettings, Problem, with_halving};
use super::{Integrator, State, StepError, StepReport};
use crate::model::Model;
use crate::solve::LinearSolver;

/// A backward Euler integrator.
pub struct BackwardEuler {
    newton: Newton,
    x: Vec<f64>,
    x_hat: Vec<f64>,
}

impl BackwardEuler {
    /// Backward Euler solving its Newton systems with `solver`.
    pub fn new(solver: Box<dyn LinearSolver>, settings: NewtonSettings) -> Self {
        Self {
            newton: Newton::new(solver, settings),
            x: Vec::new(),
            x_hat: Vec::new(),
        }
    }

    /// One step without retries; leaves `state` unchanged on error.
    fn single(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.x_hat.clear();
        self.x_hat
            .extend(state.q.iter().zip(&state.v).map(|(q, v)| q + dt * v));
        self.x.clone_from(&self.x_hat);
        // Damping -D v' with D = D(q): the term dt/2 (x - q)^T D (x - q).
        self.newton
            .prepare_damping(model, &self.x_hat, &state.q, dt, report)?;
        model.set_time(state.t + dt);
        let problem = Problem {
            x_hat: &self.x_hat,
            x_ref: &state.q,
            beta: dt * dt,
            damping_anchor: &state.q,
        };
        self.newton.minimize(model, &problem, &mut self.x, report)?;
        for ((q, v), x) in state.q.iter_mut().zip(state.v.iter_mut()).zip(&self.x) {
            *v = (x - *q) / dt;
            *q = *x;
        }
        report.substeps += 1;
        Ok(())
    }
}

impl Integrator for BackwardEuler {
    fn name(&self) -> &'static str {
        "backward-euler"
    }

    fn order(&self) -> u32 {
        1
    }

    fn is_explicit(&self) -> bool {
        false
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
