//! Backward Euler as minimization (the course's formulation):
//! `x = argmin 1/2 (x - (q + dt v))^T M (x - (q + dt v)) + dt^2 V(x)`, then `v = (x - q)/dt`,
//! `q = x`. First order, unconditionally stable, dissipative. Newton starts from `q + dt v`
//! (the course's guess: the new velocity equals the old one).

use super::scheme::{Scheme, StepProblem};
use super::{State, StepError};
use crate::model::Model;

/// The backward Euler scheme.
#[derive(Clone, Copy, Debug, Default)]
pub struct BackwardEuler;

impl Scheme for BackwardEuler {
    fn name(&self) -> &'static str {
        "backward-euler"
    }

    fn order(&self) -> u32 {
        1
    }

    fn prepare(
        &mut self,
        _model: &mut Model,
        state: &State,
        dt: f64,
        p: &mut StepProblem,
    ) -> Result<(), StepError> {
        for (i, (q, v)) in state.q.iter().zip(&state.v).enumerate() {
            p.x_hat[i] = q + dt * v;
        }
        p.beta = dt * dt;
        p.force_time = state.t + dt;
        // Damping -D v' with v' = (x - q)/dt: the term dt/2 (x - q)^T D (x - q).
        p.damping_weight = dt;
        p.damping_anchor.copy_from_slice(&state.q);
        p.damping_at.copy_from_slice(&p.x_hat);
        p.guess.copy_from_slice(&p.x_hat);
        Ok(())
    }

    fn finish(&mut self, state: &mut State, dt: f64, x: &[f64], _p: &StepProblem) {
        for ((q, v), x) in state.q.iter_mut().zip(state.v.iter_mut()).zip(x) {
            *v = (x - *q) / dt;
            *q = *x;
        }
    }
}
