//! Static (quasi-static) solves: at each time, the equilibrium `grad V(q) = 0` under the loads
//! of that time — no inertia, no velocity — by the one Newton loop on `V` alone. A study can
//! so compare a dynamic method's sag with the static answer.
//!
//! Load stepping: when the first solve (from an unloaded start, under full gravity) fails,
//! gravity is ramped: the equilibrium is sought for gravity scaled by λ = 1/2, 1/4, … until
//! Newton succeeds, then λ grows back (doubling its increment) to 1, at most
//! `static.max_load_steps` attempts. Loads that change with time (drag springs, moving
//! obstacles) are stepped in time by the usual `newton.retry_halvings`.
//!
//! The matrix is `K` alone: a body that nothing holds (no fixed vertex, no obstacle) has no
//! equilibrium and fails with the solver's message about a singular matrix.

use super::newton::{NewtonContact, NewtonSettings};
use super::scheme::{NewtonIntegrator, Scheme, StepProblem};
use super::{Integrator, State, StepError, StepReport};
use crate::model::Model;
use crate::solve::LinearSolver;

/// `[integrator.static]`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StaticSettings {
    /// Newton solves the gravity ramp may take (failed ones included) before the step fails.
    /// Default 32.
    pub max_load_steps: u32,
}

impl Default for StaticSettings {
    fn default() -> Self {
        Self { max_load_steps: 32 }
    }
}

/// The static scheme: minimize `V` at the step's end time with gravity scaled by `load`.
pub struct StaticScheme {
    /// The gravity factor λ of the next solve.
    load: f64,
    rest: Vec<f64>,
    load_gradient: Vec<f64>,
}

impl Scheme for StaticScheme {
    fn name(&self) -> &'static str {
        "static"
    }

    fn order(&self) -> u32 {
        // No time discretization error: the answer at each time is exact up to Newton.
        0
    }

    fn prepare(
        &mut self,
        model: &mut Model,
        state: &State,
        dt: f64,
        p: &mut StepProblem,
    ) -> Result<(), StepError> {
        let n = state.q.len();
        p.quasi_static = true;
        p.beta = 1.0;
        p.force_time = state.t + dt;
        p.guess.copy_from_slice(&state.q);
        p.x_hat.copy_from_slice(&state.q);
        // The size of the loads: the forces on the rest shape at the end time (which
        // does not vanish at an equilibrium, unlike the gradient at the guess).
        model.set_time(p.force_time);
        if self.rest.len() != n {
            self.rest = model.rest_state();
        }
        self.load_gradient.resize(n, 0.0);
        model.gradient(&self.rest, &mut self.load_gradient)?;
        p.force_scale = super::newton::norm(&self.load_gradient);
        if self.load < 1.0
            && let Some(g) = model.gravity()
        {
            // (λ - 1) V_gravity = (1 - λ) Σ m g·x: a linear term.
            p.linear.resize(n, 0.0);
            let masses = model.vertex_masses();
            for (f, &v) in model.dofs().free_vertices().iter().enumerate() {
                for i in 0..3 {
                    p.linear[3 * f + i] = (1.0 - self.load) * masses[v] * g[i];
                }
            }
        }
        Ok(())
    }

    fn finish(&mut self, state: &mut State, _dt: f64, x: &[f64], _p: &StepProblem) {
        state.q.copy_from_slice(x);
        state.v.iter_mut().for_each(|v| *v = 0.0);
    }
}

/// Static solves with the gravity ramp (see the module docs).
pub struct Static {
    inner: NewtonIntegrator<StaticScheme>,
    settings: StaticSettings,
    /// Whether the full load has been reached once.
    loaded: bool,
    backup: State,
}

impl Static {
    /// Static solves with `solver`, optionally constrained.
    pub fn new(
        settings: StaticSettings,
        solver: Box<dyn LinearSolver>,
        newton: NewtonSettings,
        constraints: Option<NewtonContact>,
    ) -> Self {
        let scheme = StaticScheme {
            load: 1.0,
            rest: Vec::new(),
            load_gradient: Vec::new(),
        };
        Self {
            inner: NewtonIntegrator::new(scheme, solver, newton).constrained(constraints),
            settings,
            loaded: false,
            backup: State::default(),
        }
    }

    /// Ramp gravity from λ = 0 to 1 (see the module docs); `first` is the failed full-load
    /// attempt's error.
    fn ramp(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
        first: StepError,
    ) -> Result<(), StepError> {
        self.backup.clone_from(state);
        let (mut reached, mut increment) = (0.0, 0.5);
        let mut last = first;
        let mut attempts = 1;
        while reached < 1.0 {
            StepError::stop_if_requested()?;
            if attempts >= self.settings.max_load_steps {
                state.clone_from(&self.backup);
                self.inner.scheme_mut().load = 1.0;
                return Err(StepError::NewtonFailed {
                    iterations: report.newton_iterations,
                    reason: format!(
                        "the gravity ramp reached λ = {reached:.3} in {attempts} load steps \
                         (static.max_load_steps); last failure: {last}"
                    ),
                });
            }
            let target = f64::min(1.0, reached + increment);
            self.inner.scheme_mut().load = target;
            attempts += 1;
            match self.inner.solve_step(model, state, dt, report) {
                Ok(()) => {
                    reached = target;
                    increment *= 2.0;
                }
                Err(StepError::Model(e)) => {
                    state.clone_from(&self.backup);
                    self.inner.scheme_mut().load = 1.0;
                    return Err(StepError::Model(e));
                }
                Err(e) => {
                    report.rejected_substeps += 1;
                    increment *= 0.5;
                    last = e;
                }
            }
        }
        self.inner.scheme_mut().load = 1.0;
        Ok(())
    }
}

impl Integrator for Static {
    fn name(&self) -> &'static str {
        "static"
    }

    fn order(&self) -> u32 {
        0
    }

    fn is_explicit(&self) -> bool {
        false
    }

    fn reset(&mut self) {
        self.loaded = false;
    }

    /// The equilibrium under the full loads at the end of the step (what a step solves when
    /// no ramp is needed).
    fn freeze_step(
        &mut self,
        model: &mut Model,
        state: &State,
        dt: f64,
    ) -> Option<Result<super::FrozenStep, StepError>> {
        self.inner.freeze_step(model, state, dt)
    }

    fn drain_iteration_log(&mut self, out: &mut Vec<super::newton::IterationRecord>) {
        self.inner.drain_iteration_log(out);
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let result = match self.inner.advance(model, state, dt, report) {
            Err(e)
                if !self.loaded
                    && model.gravity().is_some()
                    && !matches!(e, StepError::Model(_)) =>
            {
                report.rejected_substeps += 1;
                self.ramp(model, state, dt, report, e)
            }
            other => other,
        };
        result?;
        self.loaded = true;
        self.inner.record_contacts(state, dt, report);
        Ok(())
    }
}
