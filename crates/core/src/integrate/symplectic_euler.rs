//! Symplectic (semi-implicit) Euler: `v += dt a(q)`, then `q += dt v` with the new velocity.
//! First order, explicit, and symplectic: its energy error stays bounded at a stable step.

use super::mass_inverse::Dynamics;
use super::{Integrator, State, StepError, StepReport};
use crate::model::Model;

/// A symplectic Euler integrator.
#[derive(Default)]
pub struct SymplecticEuler {
    dynamics: Dynamics,
    a: Vec<f64>,
}

impl SymplecticEuler {
    /// A new integrator.
    pub fn new() -> Self {
        Self::default()
    }
}

impl Integrator for SymplecticEuler {
    fn name(&self) -> &'static str {
        "symplectic-euler"
    }

    fn order(&self) -> u32 {
        1
    }

    fn is_explicit(&self) -> bool {
        true
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.a.resize(state.q.len(), 0.0);
        model.set_time(state.t);
        self.dynamics
            .acceleration(model, &state.q, &state.v, &mut self.a, report)?;
        for ((q, v), a) in state.q.iter_mut().zip(state.v.iter_mut()).zip(&self.a) {
            *v += dt * a;
            *q += dt * *v;
        }
        report.substeps = 1;
        Ok(())
    }
}
