//! Implicit schemes on the one Newton loop: a [`Scheme`] says what one step minimizes and how
//! the new state follows from the minimizer; [`NewtonIntegrator`] owns everything else —
//! the Newton solve with its line search and convergence test, damping, halving retries,
//! constrained contact and reporting.
//!
//! Each step minimizes (see [`super::newton`])
//!
//! `E(x) = 1/2 |x - x_hat|²_M + beta V(x) + 1/2 w |x - x_d|²_D + l^T x`
//!
//! with the potential and its time-dependent loads evaluated at the scheme's force time. A
//! scheme fills a [`StepProblem`]: `x_hat`, `beta`, the damping weight `w` and anchor `x_d`
//! (the term that turns `-D v'` into a potential, for the `v'` the scheme recovers from `x`),
//! the constant force term `l`, the initial guess and the force time; then
//! [`Scheme::finish`] turns the minimizer into the new positions and velocities.

use super::newton::{Newton, NewtonContact, NewtonSettings, Problem, with_halving};
use super::{Integrator, State, StepError, StepReport};
use crate::model::Model;
use crate::solve::LinearSolver;

/// What one implicit step minimizes (see the module docs). Buffers are reused between steps.
#[derive(Clone, Debug, Default)]
pub struct StepProblem {
    /// `x_hat`, the inertial target (ignored when `quasi_static`).
    pub x_hat: Vec<f64>,
    /// `beta`, the weight of the potential.
    pub beta: f64,
    /// The time at which the potential's loads are evaluated.
    pub force_time: f64,
    /// `w`, the weight of the damping term (0: none).
    pub damping_weight: f64,
    /// `x_d`, where the damping term vanishes.
    pub damping_anchor: Vec<f64>,
    /// Where the damping matrix `D(x)` is evaluated (within O(dt²) of where the scheme
    /// evaluates forces, so second-order schemes stay second order).
    pub damping_at: Vec<f64>,
    /// `l`, a force term known before the solve; empty for none.
    pub linear: Vec<f64>,
    /// Newton's initial guess.
    pub guess: Vec<f64>,
    /// No inertial term: a static equilibrium.
    pub quasi_static: bool,
    /// The size of the forces, when the scheme knows it better than the gradient at the
    /// guess (see [`Problem::force_scale`]); 0 for none.
    pub force_scale: f64,
    /// Work the scheme did while preparing (a start-up acceleration's mass solve), added to
    /// the step's report.
    pub work: StepReport,
}

impl StepProblem {
    /// Size every vector for `n` DOFs and clear the optional parts.
    pub fn reset(&mut self, n: usize) {
        for v in [
            &mut self.x_hat,
            &mut self.damping_anchor,
            &mut self.damping_at,
            &mut self.guess,
        ] {
            v.resize(n, 0.0);
        }
        self.linear.clear();
        self.damping_weight = 0.0;
        self.quasi_static = false;
        self.force_scale = 0.0;
        self.work = StepReport::default();
    }
}

/// An implicit time-stepping scheme: the predictor, the weights and the velocity recovery of
/// one step, run by [`NewtonIntegrator`].
pub trait Scheme: Send {
    /// Name as written in scene files.
    fn name(&self) -> &'static str;

    /// Formal order of accuracy.
    fn order(&self) -> u32;

    /// Whether the minimizer `x` is the end-of-step position (so constraints on `x` hold at
    /// the end of the step; false for implicit midpoint, whose unknown is the midpoint).
    fn solves_for_end_position(&self) -> bool {
        true
    }

    /// Fill `problem` (already sized, optional parts cleared) for a step of `dt` from `state`.
    /// May evaluate the model (a start-up acceleration, the force at the start of the step).
    fn prepare(
        &mut self,
        model: &mut Model,
        state: &State,
        dt: f64,
        problem: &mut StepProblem,
    ) -> Result<(), StepError>;

    /// The new state from the minimizer `x` of `problem` (a step of `dt`; `state` holds the
    /// start of the step on entry). Called only after a successful solve.
    fn finish(&mut self, state: &mut State, dt: f64, x: &[f64], problem: &StepProblem);

    /// Forget history (multistep schemes, stored accelerations).
    fn reset(&mut self) {}
}

impl<S: Scheme + ?Sized> Scheme for Box<S> {
    fn name(&self) -> &'static str {
        (**self).name()
    }
    fn order(&self) -> u32 {
        (**self).order()
    }
    fn solves_for_end_position(&self) -> bool {
        (**self).solves_for_end_position()
    }
    fn prepare(
        &mut self,
        model: &mut Model,
        state: &State,
        dt: f64,
        problem: &mut StepProblem,
    ) -> Result<(), StepError> {
        (**self).prepare(model, state, dt, problem)
    }
    fn finish(&mut self, state: &mut State, dt: f64, x: &[f64], problem: &StepProblem) {
        (**self).finish(state, dt, x, problem)
    }
    fn reset(&mut self) {
        (**self).reset()
    }
}

/// A [`Scheme`] run by the one Newton loop: an [`Integrator`].
pub struct NewtonIntegrator<S: Scheme> {
    scheme: S,
    newton: Newton,
    problem: StepProblem,
    x: Vec<f64>,
}

impl<S: Scheme> NewtonIntegrator<S> {
    /// `scheme` solving its Newton systems with `solver`.
    pub fn new(scheme: S, solver: Box<dyn LinearSolver>, settings: NewtonSettings) -> Self {
        Self {
            scheme,
            newton: Newton::new(solver, settings),
            problem: StepProblem::default(),
            x: Vec::new(),
        }
    }

    /// The same, with a contact response inside the Newton loop: constraints that keep every
    /// iterate feasible, or a barrier's step filter (continuous collision detection).
    pub fn constrained(mut self, contact: Option<NewtonContact>) -> Self {
        match contact {
            Some(NewtonContact::Constraints(c)) => self.newton.set_constraints(c),
            Some(NewtonContact::Barrier(f)) => self.newton.set_step_filter(f),
            None => {}
        }
        self
    }

    /// The scheme.
    pub fn scheme(&self) -> &S {
        &self.scheme
    }

    /// The scheme, to change its mode between steps (start-up, load level).
    pub fn scheme_mut(&mut self) -> &mut S {
        &mut self.scheme
    }

    /// The Newton solver (its settings and the trace of the last solve).
    pub fn newton(&self) -> &Newton {
        &self.newton
    }

    /// Record the contacts of the end-of-step state in `report` (a no-op without constraints);
    /// `state.t` is still the start of the step.
    pub fn record_contacts(&self, state: &State, dt: f64, report: &mut StepReport) {
        if let Some(c) = self.newton.constraints() {
            c.record_contacts(&state.q, state.t + dt, report);
        }
    }

    /// One step of `dt` without retries; leaves `state` (and the scheme's history) unchanged
    /// on error. `state.t` is the start of the step and is not advanced.
    pub fn solve_step(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let p = &mut self.problem;
        p.reset(state.q.len());
        let prepared = self.scheme.prepare(model, state, dt, p);
        report.absorb(&p.work);
        prepared?;
        minimize_problem(&mut self.newton, model, p, &state.q, &mut self.x, report)?;
        self.scheme.finish(state, dt, &self.x, p);
        report.substeps += 1;
        Ok(())
    }
}

/// One step's incremental potential, frozen from a trajectory so that any [`Newton`] can
/// solve it ([`solve_frozen`]): the solver study solves the same steps with every
/// combination of the loop's components.
#[derive(Clone, Debug, Default)]
pub struct FrozenStep {
    /// What the step minimizes, as its scheme prepared it.
    pub problem: StepProblem,
    /// The start-of-step positions.
    pub start: Vec<f64>,
}

/// Solve `frozen` with `newton` from its guess into `x`: the minimization a step of its
/// scheme makes, with `newton`'s components. The model's clock is set to the force time.
pub fn solve_frozen(
    newton: &mut Newton,
    model: &mut Model,
    frozen: &FrozenStep,
    x: &mut Vec<f64>,
    report: &mut StepReport,
) -> Result<(), StepError> {
    minimize_problem(newton, model, &frozen.problem, &frozen.start, x, report)
}

/// The minimization of a prepared step: damping set up, the clock at the force time, `x`
/// from the guess to the minimizer.
pub(super) fn minimize_problem(
    newton: &mut Newton,
    model: &mut Model,
    p: &StepProblem,
    start: &[f64],
    x: &mut Vec<f64>,
    report: &mut StepReport,
) -> Result<(), StepError> {
    // Damping D evaluated at the scheme's point, or at the start-of-step positions if that
    // point inverts an element.
    if p.damping_weight > 0.0 {
        newton.prepare_damping(model, &p.damping_at, start, p.damping_weight, report)?;
    } else {
        newton.clear_damping();
    }
    model.set_time(p.force_time);
    x.clone_from(&p.guess);
    let problem = Problem {
        x_hat: &p.x_hat,
        x_ref: start,
        beta: p.beta,
        damping_anchor: &p.damping_anchor,
        linear: &p.linear,
        quasi_static: p.quasi_static,
        force_scale: p.force_scale,
    };
    newton.minimize(model, &problem, x, report)
}

impl<S: Scheme> Integrator for NewtonIntegrator<S> {
    fn name(&self) -> &'static str {
        self.scheme.name()
    }

    fn order(&self) -> u32 {
        self.scheme.order()
    }

    fn is_explicit(&self) -> bool {
        false
    }

    fn reset(&mut self) {
        self.scheme.reset();
    }

    fn drain_iteration_log(&mut self, out: &mut Vec<super::newton::IterationRecord>) {
        self.newton.drain_log(out);
    }

    fn freeze_step(
        &mut self,
        model: &mut Model,
        state: &State,
        dt: f64,
    ) -> Option<Result<FrozenStep, StepError>> {
        let mut frozen = FrozenStep {
            start: state.q.clone(),
            ..FrozenStep::default()
        };
        frozen.problem.reset(state.q.len());
        Some(
            self.scheme
                .prepare(model, state, dt, &mut frozen.problem)
                .map(|()| frozen),
        )
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let halvings = self.newton.settings().retry_halvings;
        let result = with_halving(halvings, state, dt, report, &mut |s, h, r| {
            self.solve_step(model, s, h, r)
        });
        if result.is_err() {
            // A retry may have advanced the history over a half step that was then undone.
            self.scheme.reset();
        }
        result?;
        self.record_contacts(state, dt, report);
        Ok(())
    }
}
