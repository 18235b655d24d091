//! Linearly-implicit Euler: backward Euler with the forces linearized at the start of the
//! step, i.e. one Newton step: `(M + dt^2 K(q) + dt D(q)) v' = M v + dt f(q)`, then
//! `q' = q + dt v'` (D the damping matrix, zero without damping).
//! First order; cheap, but it trusts the linearization — the course handout warns that it
//! explodes on the armadillo once it is dragged.

use super::filter::FilterSettings;
use super::system::ImplicitSystem;
use super::{Integrator, State, StepError, StepReport};
use crate::model::Model;
use crate::solve::LinearSolver;

/// A linearly-implicit Euler integrator.
pub struct LinearlyImplicitEuler {
    system: ImplicitSystem,
    rhs: Vec<f64>,
    mv: Vec<f64>,
}

impl LinearlyImplicitEuler {
    /// Linearly-implicit Euler solving its system with `solver`, element Hessians through
    /// `filter` (`integrator.newton.filter`; its one solve per step is iteration 0).
    pub fn new(solver: Box<dyn LinearSolver>, filter: FilterSettings) -> Self {
        Self {
            system: ImplicitSystem::new(solver, filter),
            rhs: Vec::new(),
            mv: Vec::new(),
        }
    }
}

impl Integrator for LinearlyImplicitEuler {
    fn name(&self) -> &'static str {
        "linearly-implicit-euler"
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
        let n = state.q.len();
        self.rhs.resize(n, 0.0);
        self.mv.resize(n, 0.0);
        // Forces linearized at q_t, with time-dependent potentials at the end of the step.
        model.set_time(state.t + dt);
        model.gradient(&state.q, &mut self.rhs)?;
        model.mass().mul_vec(&state.v, &mut self.mv);
        for (r, mv) in self.rhs.iter_mut().zip(&self.mv) {
            *r = mv - dt * *r;
        }
        // (M + dt^2 K + dt D) v' = M v + dt f(q): damping -D v' taken implicitly.
        self.system.set_damping(model, &state.q, dt, report)?;
        self.system.begin_solve();
        self.system.factor(model, &state.q, dt * dt, report)?;
        self.system.solve(model, &state.q, &mut self.rhs, report)?;
        for ((q, v), v_new) in state.q.iter_mut().zip(state.v.iter_mut()).zip(&self.rhs) {
            *v = *v_new;
            *q += dt * v_new;
        }
        report.substeps = 1;
        Ok(())
    }
}
