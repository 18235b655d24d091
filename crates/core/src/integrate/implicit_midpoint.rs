//! Implicit midpoint: `q' = q + dt (v + v')/2`, `v' = v + dt a((q + q')/2)`. Second order,
//! symplectic, no numerical damping.
//!
//! Written for the midpoint `y = (q + q')/2` it is a minimization like backward Euler's:
//! `y = argmin 1/2 (y - (q + dt/2 v))^T M (y - (q + dt/2 v)) + dt^2/4 V(y)`, then
//! `q' = 2y - q` and `v' = 4 (y - q)/dt - v`; so it runs on the same Newton loop.

use super::scheme::{Scheme, StepProblem};
use super::{State, StepError};
use crate::model::Model;

/// The implicit midpoint scheme.
#[derive(Clone, Copy, Debug, Default)]
pub struct ImplicitMidpoint;

impl Scheme for ImplicitMidpoint {
    fn name(&self) -> &'static str {
        "implicit-midpoint"
    }

    fn order(&self) -> u32 {
        2
    }

    fn solves_for_end_position(&self) -> bool {
        false
    }

    fn prepare(
        &mut self,
        _model: &mut Model,
        state: &State,
        dt: f64,
        p: &mut StepProblem,
    ) -> Result<(), StepError> {
        for (i, (q, v)) in state.q.iter().zip(&state.v).enumerate() {
            p.x_hat[i] = q + 0.5 * dt * v;
        }
        p.beta = 0.25 * dt * dt;
        p.force_time = state.t + 0.5 * dt;
        // Damping at the midpoint velocity 2 (y - q)/dt: the term dt/4 (y - q)^T D (y - q).
        p.damping_weight = 0.5 * dt;
        p.damping_anchor.copy_from_slice(&state.q);
        p.damping_at.copy_from_slice(&p.x_hat);
        p.guess.copy_from_slice(&p.x_hat);
        Ok(())
    }

    fn finish(&mut self, state: &mut State, dt: f64, y: &[f64], _p: &StepProblem) {
        for ((q, v), y) in state.q.iter_mut().zip(state.v.iter_mut()).zip(y) {
            *v = 4.0 * (y - *q) / dt - *v;
            *q = 2.0 * y - *q;
        }
    }
}
