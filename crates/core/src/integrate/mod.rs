//! Time integrators behind one trait, [`Integrator`], listed in one table ([`methods`]).
//!
//! The state is `(q, v)` over the model's free DOFs. Each step returns a [`StepReport`] (what
//! the step cost) or a typed [`StepError`] (why it could not be taken). Methods, one file each:
//! - explicit: [`explicit_euler`], [`symplectic_euler`], [`verlet`] (velocity Verlet),
//!   [`midpoint`] (the seeds' RK2), [`rk4`], the Runge-Kutta ones as Butcher tableaus run by
//!   [`runge_kutta`];
//! - adaptive: [`adaptive`] step control (step doubling around any explicit method, or the
//!   embedded error of an [`embedded`] pair: [`dopri5`] and the DIRK pairs below), with a
//!   step-size [`controller`] (I, PI, PID);
//! - implicit: [`linearly_implicit_euler`] (one linear solve), the [`rosenbrock`] methods (one
//!   factorization per step, a solve per stage: [`ros2`], [`rodas3`]), and the [`scheme`]s run by the
//!   one Newton loop ([`newton`]): [`backward_euler`], [`implicit_midpoint`], [`bdf`] (BDF-k,
//!   k = 1…6), [`newmark`] (Newmark, generalized-α, HHT-α) and [`static_equilibrium`]; the
//!   multi-stage [`dirk`] methods, a tableau each ([`tr_bdf2`], [`esdirk32`], [`esdirk43`]),
//!   every implicit stage one solve of the same loop; [`radau_iia`] (coupled stages by
//!   simplified Newton, a real and a [`complex_shifted`] factor per step);
//!   [`energy_momentum`] (the midpoint rule on the discrete gradient, Newton on its residual);
//! - local solvers on the backward Euler step: [`vbd`] (vertex block descent, parallel over a
//!   vertex [`crate::colouring`]) and [`projective_dynamics`] (local/global, on its projective
//!   energy, corotated elasticity); [`xpbd`] (substepped constraints, on its constraint
//!   energy).

pub mod acceleration;
pub mod adaptive;
pub mod backward_euler;
pub mod bdf;
mod complex_shifted;
pub mod controller;
pub mod cost_guard;
pub mod dirk;
pub mod dopri5;
pub mod embedded;
pub mod energy_momentum;
pub mod esdirk32;
pub mod esdirk43;
pub mod explicit_euler;
pub mod filter;
pub mod implicit_midpoint;
pub mod linearly_implicit_euler;
mod mass_inverse;
pub mod methods;
pub mod midpoint;
pub mod newmark;
pub mod newton;
mod pattern_extension;
pub mod peer;
pub mod projective_dynamics;
pub mod radau_iia;
mod report;
pub mod rk4;
pub mod rodas3;
pub mod ros2;
pub mod rosenbrock;
pub mod runge_kutta;
pub mod scheme;
pub mod static_equilibrium;
pub mod symplectic_euler;
pub mod system;
pub mod tr_bdf2;
pub mod vbd;
pub mod verlet;
pub mod xpbd;

pub use adaptive::{Adaptive, AdaptiveSettings};
pub use controller::{Controller, StepController, UnknownController};
pub use dirk::{Dirk, DirkTableau};
pub use embedded::{EmbeddedPair, FixedStep, NextState, StageOutput};
pub use filter::{FilterSettings, HessianFilter, UnknownHessianFilter};
pub use mass_inverse::Dynamics;
pub use methods::{IntegratorSettings, Method, MethodEntry, register_method};
pub use newton::NewtonSettings;
pub use report::{PhaseTimes, StepError, StepReport};
pub use scheme::{FrozenStep, NewtonIntegrator, Scheme, StepProblem, solve_frozen};

use crate::model::Model;
use std::time::Instant;

/// The dynamic state over free DOFs: positions `q`, velocities `v`, time `t`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct State {
    pub q: Vec<f64>,
    pub v: Vec<f64>,
    pub t: f64,
}

impl State {
    /// The model's rest configuration with zero velocity at t = 0.
    pub fn at_rest(model: &Model) -> Self {
        let q = model.rest_state();
        let v = vec![0.0; q.len()];
        Self { q, v, t: 0.0 }
    }
}

/// Runs `f` on a thread of rayon's pool (the caller waits) with the caller's per-thread state:
/// the run's cost guard goes in ([`cost_guard::carry`]), and what `f` counted there (obstacle
/// queries) comes back ([`crate::parallel::counted_on_pool`]), as if it had run on the caller.
pub(crate) fn on_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    let guard = cost_guard::carry();
    crate::parallel::counted_on_pool(|| guard.run(f))
}

/// A time integrator. One instance serves one model (it may cache the model's mass
/// factorization and sparsity analysis).
pub trait Integrator: Send {
    /// Name as written in scene files.
    fn name(&self) -> &'static str;

    /// Formal order of accuracy.
    fn order(&self) -> u32;

    /// Whether the method never asks for a Hessian.
    fn is_explicit(&self) -> bool;

    /// Refuse a model this method cannot integrate (a material, potential or force it has no
    /// form for), with the reason. Called when a scene is built, so a study fails at load
    /// instead of at its first step; `advance` may check again.
    fn check_model(&self, _model: &Model) -> Result<(), StepError> {
        Ok(())
    }

    /// Advance `state.q` and `state.v` by `dt` (not `state.t`), recording work in `report`.
    /// On error the state must be left as it was.
    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError>;

    /// Forget history (multistep methods, adaptive step size), e.g. after the state was
    /// changed from outside.
    fn reset(&mut self) {}

    /// For a peer method ([`peer`]): what the peer's own code says of its problem at every
    /// vertex's `positions` (its masses, fixed set, elastic energy or forces), so a study can
    /// check its conventions against the model's before comparing trajectories. `None` (the
    /// default) for softbench's own methods.
    fn peer_conventions(
        &mut self,
        _model: &mut Model,
        _positions: &[nalgebra::Vector3<f64>],
        _dt: f64,
    ) -> Option<Result<peer::PeerConventions, StepError>> {
        None
    }

    /// The accepted internal step sizes of the last successful `advance`, in order (s):
    /// adaptive methods' controller steps. Empty for fixed-step methods (default).
    fn internal_steps(&self) -> &[f64] {
        &[]
    }

    /// Move the Newton iteration records of the last step into `out` (methods on the Newton
    /// loop with `integrator.newton.log_iterations`; nothing by default).
    fn drain_iteration_log(&mut self, _out: &mut Vec<newton::IterationRecord>) {}

    /// Whether `state` is free of intersections, by an exact check independent of the
    /// method and of its contact response (answered by the contact wrappers; `None`, the
    /// default, without contact).
    fn intersection_free(&self, _model: &Model, _state: &State) -> Option<bool> {
        None
    }

    /// For a method on the Newton loop: the incremental potential its next step of `dt` from
    /// `state` minimizes, frozen so another Newton can solve it ([`scheme::solve_frozen`]);
    /// `None` (the default) for a method that minimizes none (explicit methods, local
    /// solvers). Takes no step; may evaluate the model, as the step's preparation would.
    fn freeze_step(
        &mut self,
        _model: &mut Model,
        _state: &State,
        _dt: f64,
    ) -> Option<Result<scheme::FrozenStep, StepError>> {
        None
    }

    /// One step of `dt`: [`Integrator::advance`] plus the shared bookkeeping — evaluation
    /// counts, wall time, the check that the new state is finite, and the clock.
    fn step(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
    ) -> Result<StepReport, StepError> {
        let start = Instant::now();
        let before = model.counters();
        let force_seconds = model.force_seconds();
        let mut report = StepReport {
            dt,
            ..StepReport::default()
        };
        if model.element_loops_split(!self.is_explicit()) && rayon::current_num_threads() > 1 {
            // One entry into rayon's pool per step rather than one per parallel call (tens of
            // µs each: the caller queues the job, wakes a worker and sleeps until it is done,
            // hundreds of times per Newton iteration in the factorization's kernels). On a
            // pool thread the step's parallel calls are pushes onto its own queue.
            on_pool(|| self.advance(model, state, dt, &mut report))?;
        } else {
            self.advance(model, state, dt, &mut report)?;
        }
        let after = model.counters();
        report.evaluations.potential = after.potential - before.potential;
        report.evaluations.gradient = after.gradient - before.gradient;
        report.evaluations.hessian = after.hessian - before.hessian;
        report.times.forces = model.force_seconds() - force_seconds;
        report.times.total = start.elapsed().as_secs_f64();
        report::check_finite(state)?;
        state.t += dt;
        Ok(report)
    }
}
