//! Implicit midpoint: `q' = q + dt (v + v')/2`, `v' = v + dt a((q + q')/2)`. Second order,
//! symplectic, no numerical damping.
//!
//! Written for the midpoint `y = (q + q')/2` it is a minimization like backward Euler's:
//! `y = argmin 1/2 (y - (q + dt/2 v))^T M (y - (q + dt/2 v)) + dt^2/4 V(y)`, then
//! `q' = 2y - q` and `v' = 4 (y - q)/dt - v`; so it runs on the same Newton solver.

use super::newton::{Newton, NewtonSettings, Problem, with_halving};
use super::{Integrator, State, StepError, StepReport};
use crate::model::Model;
use crate::solve::LinearSolver;

/// An implicit midpoint integrator.
pub struct ImplicitMidpoint {
    newton: Newton,
    y: Vec<f64>,
    y_hat: Vec<f64>,
}

impl ImplicitMidpoint {
    /// Implicit midpoint solving its Newton systems with `solver`.
    pub fn new(solver: Box<dyn LinearSolver>, settings: NewtonSettings) -> Self {
        Self {
            newton: Newton::new(solver, settings),
            y: Vec::new(),
            y_hat: Vec::new(),
        }
    }

    fn single(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.y_hat.clear();
        self.y_hat
            .extend(state.q.iter().zip(&state.v).map(|(q, v)| q + 0.5 * dt * v));
        self.y.clone_from(&self.y_hat);
        // Damping at the midpoint velocity 2 (y - q)/dt: the term dt/4 (y - q)^T D (y - q).
        self.newton
            .prepare_damping(model, &self.y_hat, &state.q, 0.5 * dt, report)?;
        model.set_time(state.t + 0.5 * dt);
        let problem = Problem {
            x_hat: &self.y_hat,
            x_ref: &state.q,
            beta: 0.25 * dt * dt,
            damping_anchor: &state.q,
        };
        self.newton.minimize(model, &problem, &mut self.y, report)?;
        for ((q, v), y) in state.q.iter_mut().zip(state.v.iter_mut()).zip(&self.y) {
            *v = 4.0 * (y - *q) / dt - *v;
            *q = 2.0 * y - *q;
        }
        report.substeps += 1;
        Ok(())
    }
}

impl Integrator for ImplicitMidpoint {
    fn name(&self) -> &'static str {
        "implicit-midpoint"
    }

    fn order(&self) -> u32 {
        2
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
