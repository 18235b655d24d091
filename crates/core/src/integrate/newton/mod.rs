//! The one Newton loop: it minimizes the incremental potential
//!
//! `E(x) = 1/2 (x - x_hat)^T M (x - x_hat) + beta V(x) [+ damping term] [+ l^T x]`,
//!
//! whose minimizer is the unknown of every implicit scheme ([`super::scheme`]): the new
//! position of backward Euler (`x_hat = q + dt v`, `beta = dt^2`), BDF-k and the Newmark
//! family, the midpoint of implicit midpoint, the equilibrium of a static solve (no inertial
//! term). Schemes only say what to minimize.
//!
//! Its parts are swappable components, named in [`settings`] (`[integrator.newton]`): the
//! **direction** (Newton with a factored system, modified Newton with a kept one, L-BFGS over
//! an initial Hessian in [`lbfgs`], gradient descent in the mass metric), the
//! **globalization** (Armijo backtracking, a trust region solved by Steihaug-CG in
//! [`trust_region`], or the full step), and the **convergence criterion** ([`log`]: gradient
//! norms absolute or relative to the step's terms, the first iterate or the body's weight; the
//! Newton decrement; the step; the energy decrease). Every iteration can be recorded
//! ([`IterationRecord`]) with the scales of every criterion, so a logged run can be re-scored
//! under another one ([`log::rescore`]). A [`StepFilter`] can cap the step length (continuous
//! collision detection of a barrier contact response).
//!
//! With [`StepConstraints`] (the constrained contact response) the direction is chosen by the
//! constraints (a QP where they are active) and the line search rejects infeasible points, so
//! halving retries, damping and every scheme work with contact unchanged.
//!
//! The default criterion (`scaled-gradient`) is relative to the size of the step's own terms:
//! `‖g‖ <= tolerance * (‖M (x_hat - q)‖ + beta ‖grad V(x0)‖)`, the inertial and force terms
//! at the start, so the tolerance means the same on a 1 m armadillo and a 165-unit bunny.
//!
//! Near convergence the Armijo test compares energies whose difference is below their
//! round-off; once the predicted decrease (the Newton decrement) is below that round-off
//! level, the full step is accepted and the solve ends, whatever the criterion (logged as a
//! `roundoff` stop).

pub mod lbfgs;
pub mod log;
mod settings;
pub mod trust_region;

pub use log::{IterationRecord, Rescored, Stop, rescore};
pub use settings::{
    Criterion, Direction, Globalization, LbfgsInitial, NewtonSettings, UnknownCriterion,
    UnknownDirection, UnknownGlobalization, UnknownLbfgsInitial,
};

mod potential;
mod vectors;

use super::filter::HessianFilter;
pub use super::system::ImplicitSystem;
use super::{State, StepError, StepReport};
use crate::model::{Model, ModelError};
use crate::solve::LinearSolver;
use lbfgs::Lbfgs;
pub use potential::Problem;
use potential::{IncrementalPotential, Objective};
use std::time::Instant;
use trust_region::{Steihaug, SubproblemEnd};
pub(crate) use vectors::{axpy, dot, norm};

/// What the last [`Newton::minimize`] did, for diagnostics and tests.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NewtonTrace {
    /// `‖g‖` at each iterate, starting with the initial guess (and after the last step when
    /// the iteration cap was reached).
    pub gradient_norms: Vec<f64>,
    /// The scale `scaled-gradient` is relative to.
    pub scale: f64,
    /// Whether a step was accepted because its predicted decrease was below round-off.
    pub roundoff_accepted: bool,
    /// Whether the criterion was met (or the round-off stop taken).
    pub converged: bool,
    /// Why the solve stopped.
    pub stop: Stop,
    /// The first step length each line search tried (after a [`StepFilter`]).
    pub first_step_lengths: Vec<f64>,
}

/// A contact response inside the Newton loop of a method whose unknown is the end-of-step
/// position.
pub enum NewtonContact {
    /// Constraints that choose the direction and keep every iterate feasible (the
    /// constrained response).
    Constraints(Box<dyn StepConstraints>),
    /// The step filter of a barrier potential in the model (incremental potential contact):
    /// continuous collision detection caps every step, and the solve starts from the
    /// start-of-step positions moved toward the guess as far as the filter allows.
    Barrier(Box<dyn StepFilter>),
}

/// Caps the length of a step before it is tried: the largest `alpha` such that `x + alpha
/// dx` is safe (continuous collision detection of a barrier contact response). The line
/// search starts at `min(initial_step, alpha)`; a trust-region or full step is scaled to it.
pub trait StepFilter: Send {
    /// The largest allowed step length along `dx` from `x` at time `t` (> 0; `f64::INFINITY`
    /// for no cap).
    fn max_step(&mut self, x: &[f64], dx: &[f64], t: f64) -> f64;

    /// A solve starts from `x_ref` (the start-of-step positions) at time `t`: fix what the
    /// filter's potential lags over a solve (a barrier's stiffness, friction's normal forces
    /// and tangent bases). Default: nothing.
    fn begin_solve(
        &mut self,
        _model: &mut Model,
        _x_ref: &[f64],
        _t: f64,
    ) -> Result<(), StepError> {
        Ok(())
    }

    /// A start other than `x_ref` that [`Self::begin_solve`] chose (written into `start`,
    /// which holds `x_ref` on entry), e.g. vertices carried along by a moving obstacle;
    /// `false` (the default) to start from `x_ref`.
    fn start_point(&mut self, _start: &mut [f64]) -> bool {
        false
    }

    /// The solve converged at `x`: update the lagged quantities there and return `true` to
    /// minimize again from `x` (lagged friction's further iterations). Default: `false`.
    fn relag(&mut self, _x: &[f64], _t: f64) -> bool {
        false
    }
}

/// The scales every criterion of a solve is relative to (set at its first iterate).
#[derive(Clone, Copy, Debug)]
struct Scales {
    scaled_gradient: f64,
    initial_gradient: f64,
    gravity: f64,
}

/// What a globalized step starts from: the objective at `x`, the slope `g·dx` of the
/// direction, the Newton iteration and the time at which a step filter checks it.
#[derive(Clone, Copy)]
struct Trial<'a> {
    current: &'a Objective,
    slope: f64,
    iteration: u32,
    t: f64,
}

/// How the current iterate was reached (NaN at the initial guess).
#[derive(Clone, Copy, Debug)]
struct Reached {
    step_length: f64,
    step_norm: f64,
    energy_decrease: f64,
    backtracks: u32,
}

impl Reached {
    const START: Self = Self {
        step_length: f64::NAN,
        step_norm: f64::NAN,
        energy_decrease: f64::NAN,
        backtracks: 0,
    };
}

/// The Newton minimizer with its linear system, its components' state, optional
/// constraints and step filter, and preallocated vectors.
pub struct Newton {
    settings: NewtonSettings,
    trace: NewtonTrace,
    system: ImplicitSystem,
    potential: IncrementalPotential,
    constraints: Option<Box<dyn StepConstraints>>,
    step_filter: Option<Box<dyn StepFilter>>,
    dx: Vec<f64>,
    trial: Vec<f64>,
    /// L-BFGS: the memory, the previous iterate and gradient, the rest shape and the `beta`
    /// its initial Hessian was factored for (`rest`), the first iterate (`step-start`).
    lbfgs: Lbfgs,
    x_prev: Vec<f64>,
    g_prev: Vec<f64>,
    rest: Vec<f64>,
    rest_factored_beta: Option<f64>,
    x_first: Vec<f64>,
    /// The lumped mass over free DOFs (gradient descent's metric, the trust region's norm).
    mass_diagonal: Vec<f64>,
    /// The trust region's subproblem solver, scratch, and the automatic first radius.
    steihaug: Steihaug,
    hp: Vec<f64>,
    auto_radius: Option<f64>,
    /// Iteration records since the last [`Self::drain_log`] (with `log_iterations`).
    log: Vec<IterationRecord>,
    solves: u64,
    /// The solve's start (after the guess was made feasible), for an exact redo.
    start: Vec<f64>,
    /// A direction of this solve stopped at the forcing term, not the solver's tolerance.
    inexact: bool,
    /// Solve every direction to the solver's tolerance (the redo of a capped solve).
    exact: bool,
}

impl Newton {
    /// A minimizer solving its systems with `solver`.
    pub fn new(solver: Box<dyn LinearSolver>, settings: NewtonSettings) -> Self {
        Self {
            settings,
            trace: NewtonTrace::default(),
            system: ImplicitSystem::new(solver, settings.filter_settings()),
            potential: IncrementalPotential::default(),
            constraints: None,
            step_filter: None,
            dx: Vec::new(),
            trial: Vec::new(),
            lbfgs: Lbfgs::default(),
            x_prev: Vec::new(),
            g_prev: Vec::new(),
            rest: Vec::new(),
            rest_factored_beta: None,
            x_first: Vec::new(),
            mass_diagonal: Vec::new(),
            steihaug: Steihaug::default(),
            hp: Vec::new(),
            auto_radius: None,
            log: Vec::new(),
            solves: 0,
            start: Vec::new(),
            inexact: false,
            exact: false,
        }
    }

    /// Keep every iterate feasible for `constraints` (the constrained contact response).
    pub fn set_constraints(&mut self, constraints: Box<dyn StepConstraints>) {
        self.constraints = Some(constraints);
    }

    /// The constraints, if any.
    pub fn constraints(&self) -> Option<&dyn StepConstraints> {
        self.constraints.as_deref()
    }

    /// Cap every step's length with `filter` (see [`StepFilter`]).
    pub fn set_step_filter(&mut self, filter: Box<dyn StepFilter>) {
        self.step_filter = Some(filter);
    }

    /// The settings.
    pub fn settings(&self) -> &NewtonSettings {
        &self.settings
    }

    /// What the last minimization did.
    pub fn trace(&self) -> &NewtonTrace {
        &self.trace
    }

    /// Move the iteration records kept since the last call into `out` (none unless
    /// `log_iterations`).
    pub fn drain_log(&mut self, out: &mut Vec<IterationRecord>) {
        out.append(&mut self.log);
    }

    /// Assemble the damping matrix for this step with weight `gamma` (a no-op for a model
    /// without damping). `D` is evaluated at the `predictor` — the method's initial guess,
    /// within O(dt^2) of where the method evaluates forces, so second-order methods stay second
    /// order — or at the start-of-step `q` if the predictor inverts an element.
    pub fn prepare_damping(
        &mut self,
        model: &mut Model,
        predictor: &[f64],
        q: &[f64],
        gamma: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        match self.system.set_damping(model, predictor, gamma, report) {
            Err(StepError::InvertedElement { .. }) => {
                self.system.set_damping(model, q, gamma, report)
            }
            other => other,
        }
    }

    /// No damping term for this step.
    pub fn clear_damping(&mut self) {
        self.system.clear_damping();
    }

    /// `E(x)` with this step's damping term.
    fn objective(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &[f64],
    ) -> Result<Objective, ModelError> {
        self.potential.objective(model, self.system.damping(), p, x)
    }

    /// The gradient of `E` at `x` into `self.potential.g`.
    fn gradient(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &[f64],
    ) -> Result<(), ModelError> {
        self.potential.gradient(model, self.system.damping(), p, x)
    }

    /// `self.trial = x + alpha dx`.
    fn set_trial(&mut self, x: &[f64], alpha: f64) {
        for ((t, xi), dx) in self.trial.iter_mut().zip(x).zip(&self.dx) {
            *t = xi + alpha * dx;
        }
    }

    /// `E` at `self.trial`.
    fn trial_objective(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
    ) -> Result<Objective, ModelError> {
        let trial = std::mem::take(&mut self.trial);
        let outcome = self.objective(model, p, &trial);
        self.trial = trial;
        outcome
    }

    /// Minimize `E` (see the module docs) starting from the guess in `x`; `x_ref` is the
    /// start-of-step position that sets the convergence scale. With [`Self::set_constraints`],
    /// the direction and the line search keep the iterates feasible (see
    /// [`StepConstraints`]). On success `x` holds the minimizer; on error its content is
    /// unspecified.
    pub fn minimize(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &mut [f64],
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let n = x.len();
        self.potential.resize(n);
        for v in [&mut self.dx, &mut self.trial, &mut self.hp] {
            v.resize(n, 0.0);
        }
        self.trace.gradient_norms.clear();
        self.trace.first_step_lengths.clear();
        self.trace.roundoff_accepted = false;
        self.trace.converged = false;
        self.trace.stop = Stop::Running;
        self.solves += 1;
        let t = model.time();
        self.system.set_mass_term(!p.quasi_static);
        self.system.begin_solve();
        // A constrained solve starts feasible when it can: at the guess if it is outside every
        // obstacle, else at the start-of-step positions.
        if let Some(c) = &self.constraints
            && c.min_distance(x, t) < 0.0
        {
            x.copy_from_slice(p.x_ref);
        }
        // A barrier's solve starts intersection-free: from the start-of-step positions as far
        // toward the guess as the step filter allows (the guess itself may have tunnelled).
        if let Some(filter) = self.step_filter.as_mut() {
            filter.begin_solve(model, p.x_ref, t)?;
            let from = &mut self.trial;
            from.copy_from_slice(p.x_ref);
            filter.start_point(from);
            for ((d, g), r) in self.dx.iter_mut().zip(x.iter()).zip(from.iter()) {
                *d = g - r;
            }
            let alpha = filter.max_step(from, &self.dx, t).clamp(0.0, 1.0);
            for ((xi, r), d) in x.iter_mut().zip(from.iter()).zip(&self.dx) {
                *xi = r + alpha * d;
            }
        }
        // The guess may invert elements (a large step); the start-of-step state does not.
        let current = match self.objective(model, p, x) {
            Ok(e) => e,
            Err(ModelError::InvertedElement { .. }) => {
                x.copy_from_slice(p.x_ref);
                self.objective(model, p, x)?
            }
            Err(e) => return Err(e.into()),
        };
        self.start.clear();
        self.start.extend_from_slice(x);
        self.inexact = false;
        self.exact = false;
        let mut converged = if self.constraints.is_some() {
            self.iterate_constrained(model, p, x, current, t, report)?
        } else {
            self.iterate(model, p, x, current, t, report)?
        };
        if !converged && self.inexact && self.constraints.is_none() {
            // The cap ended a solve whose directions an iterative solver left inexact: its
            // end would depend on the linear solver. Redo it from the same start exactly.
            x.copy_from_slice(&self.start);
            self.exact = true;
            self.trace.gradient_norms.clear();
            self.trace.first_step_lengths.clear();
            report.exact_redos += 1;
            let current = self.objective(model, p, x)?;
            converged = self.iterate(model, p, x, current, t, report)?;
        }
        // Lagged quantities updated at the solution change the potential: minimize again.
        while converged && self.step_filter.as_mut().is_some_and(|f| f.relag(x, t)) {
            let current = self.objective(model, p, x)?;
            converged = self.iterate(model, p, x, current, t, report)?;
        }
        self.trace.converged = converged;
        match self.trace.stop {
            Stop::Criterion => report.newton_criterion_stops += 1,
            Stop::Roundoff => report.newton_roundoff_stops += 1,
            Stop::Cap | Stop::Running => {}
        }
        if !converged {
            let s = &self.settings;
            if s.require_convergence {
                return Err(StepError::NewtonFailed {
                    iterations: s.max_iterations,
                    reason: format!(
                        "{} tolerance {:.1e} not met in {} iterations",
                        s.criterion, s.tolerance, s.max_iterations
                    ),
                });
            }
            report.newton_unconverged += 1;
        }
        Ok(())
    }

    /// The `scaled-gradient` scale: the inertial (and constant) terms plus the force term at
    /// the first iterate (call after the first gradient).
    fn scale(&mut self, model: &Model, p: &Problem<'_>) -> f64 {
        let forces = norm(&self.potential.grad_v).max(p.force_scale);
        let scale = self.potential.inertial_scale(model, p) + p.beta * forces;
        self.trace.scale = scale;
        scale
    }

    /// Every criterion's scale at the first iterate (call after its gradient).
    fn scales(&mut self, model: &Model, p: &Problem<'_>) -> Scales {
        let gravity = model.gravity().map_or(0.0, |a| {
            let masses = model.vertex_masses();
            let sum: f64 = model
                .dofs()
                .free_vertices()
                .iter()
                .map(|&v| masses[v] * masses[v])
                .sum();
            p.beta * a.norm() * sum.sqrt()
        });
        Scales {
            scaled_gradient: self.scale(model, p),
            initial_gradient: norm(&self.potential.g),
            gravity,
        }
    }

    /// The lumped mass over free DOFs, computed once per model size.
    fn ensure_mass_diagonal(&mut self, model: &Model) {
        if self.mass_diagonal.len() == model.num_dofs() {
            return;
        }
        let masses = model.vertex_masses();
        self.mass_diagonal = model
            .dofs()
            .free_vertices()
            .iter()
            .flat_map(|&v| [masses[v]; 3])
            .collect();
    }

    /// Keep `record` if iterations are logged; record why the solve stopped.
    fn record(&mut self, mut record: IterationRecord, stop: Stop, start: Instant) {
        record.stop = stop;
        record.seconds = start.elapsed().as_secs_f64();
        if stop != Stop::Running {
            self.trace.stop = stop;
        }
        if self.settings.log_iterations {
            self.log.push(record);
        }
    }

    /// Iterations from `x` with objective `current`: the criterion tested at every iterate,
    /// the direction and the globalization of the settings. Returns whether the criterion was
    /// met (or the round-off stop taken).
    fn iterate(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &mut [f64],
        mut current: Objective,
        t: f64,
        report: &mut StepReport,
    ) -> Result<bool, StepError> {
        let s = self.settings;
        let start = Instant::now();
        self.ensure_mass_diagonal(model);
        if s.direction == Direction::Lbfgs {
            self.lbfgs.reset(s.lbfgs_history as usize, x.len());
            self.x_prev.resize(x.len(), 0.0);
            self.g_prev.resize(x.len(), 0.0);
        }
        let mut scales = None;
        let mut reached = Reached::START;
        let mut radius = 0.0;
        let mut iteration = 0;
        // Past the round-off point (`roundoff_stop = false`): the gradient norm there.
        let mut past_roundoff: Option<f64> = None;
        loop {
            StepError::stop_if_requested()?;
            self.gradient(model, p, x)?;
            let sc = match scales {
                Some(v) => v,
                None => *scales.insert(self.scales(model, p)),
            };
            let g_norm = norm(&self.potential.g);
            self.trace.gradient_norms.push(g_norm);
            let mut record = IterationRecord {
                solve: self.solves - 1,
                iteration,
                gradient_norm: g_norm,
                decrement: f64::NAN,
                energy: current.value,
                energy_decrease: reached.energy_decrease,
                step_norm: reached.step_norm,
                step_length: reached.step_length,
                backtracks: reached.backtracks,
                scaled_gradient_scale: sc.scaled_gradient,
                initial_gradient: sc.initial_gradient,
                gravity_scale: sc.gravity,
                energy_scale: current.scale,
                ..IterationRecord::default()
            };
            if s.criterion == Criterion::GravityGradient && sc.gravity == 0.0 {
                return Err(StepError::NewtonFailed {
                    iterations: 0,
                    reason: "criterion `gravity-gradient` needs gravity, and the model has none"
                        .into(),
                });
            }
            if s.direction == Direction::Lbfgs && iteration > 0 {
                self.lbfgs
                    .push(x, &self.x_prev, &self.potential.g, &self.g_prev);
            }
            if !s.criterion.needs_direction() && s.criterion.met(s.tolerance, &record) {
                self.record(record, Stop::Criterion, start);
                return Ok(true);
            }
            // Past the round-off, a full step that did not lower the gradient ends the solve:
            // the iterate is at working precision.
            if let Some(previous) = past_roundoff
                && g_norm.partial_cmp(&previous) != Some(std::cmp::Ordering::Less)
            {
                self.record(record, Stop::Roundoff, start);
                return Ok(true);
            }
            if iteration == s.max_iterations {
                self.record(record, Stop::Cap, start);
                return Ok(false);
            }
            let before = (
                report.linear_iterations,
                report.factorizations,
                report.projected_elements,
            );
            if iteration == 0 && s.globalization == Globalization::TrustRegion {
                radius = self.first_radius(model);
            }
            let slope = self.globalized_direction(model, p, x, radius, &sc, iteration, report)?;
            record.decrement = -slope;
            record.linear_iterations = report.linear_iterations - before.0;
            record.factorizations = report.factorizations - before.1;
            record.projected_elements = report.projected_elements - before.2;
            if s.criterion.needs_direction() && s.criterion.met(s.tolerance, &record) {
                self.record(record, Stop::Criterion, start);
                return Ok(true);
            }
            iteration += 1;
            report.newton_iterations += 1;
            if s.direction == Direction::Lbfgs {
                self.x_prev.copy_from_slice(x);
                self.g_prev.copy_from_slice(&self.potential.g);
            }
            let previous = current.value;
            // `None`: the predicted decrease is below the energy's round-off, where the Armijo
            // test cannot tell a decrease from noise, and the full step was taken.
            let accepted = if -slope <= current.roundoff {
                // The full step, capped by the step filter (collision detection) if any.
                let alpha = if self.step_filter.is_some() {
                    self.filtered_length(x, 1.0, t, report)?
                } else {
                    1.0
                };
                axpy(alpha, &self.dx, x);
                None
            } else {
                let trial = Trial {
                    current: &current,
                    slope,
                    iteration,
                    t,
                };
                self.globalized_step(model, p, x, trial, &mut radius, &sc, report)?
            };
            let (next, alpha, backtracks) = match accepted {
                Some(accepted) => accepted,
                None => {
                    // Converged to working precision; with `roundoff_stop = false`, go on with
                    // full steps judged by the criterion and the gradient alone.
                    self.trace.roundoff_accepted = true;
                    if s.roundoff_stop {
                        self.record(record, Stop::Roundoff, start);
                        return Ok(true);
                    }
                    past_roundoff = Some(g_norm);
                    (self.objective(model, p, x)?, 1.0, 0)
                }
            };
            current = next;
            let step_norm = self.dx.iter().fold(0.0f64, |m, d| m.max((alpha * d).abs()));
            reached = Reached {
                step_length: alpha,
                step_norm,
                energy_decrease: previous - current.value,
                backtracks,
            };
            self.record(record, Stop::Running, start);
        }
    }

    /// The direction of the settings' globalization into `self.dx`; returns `g·dx` (< 0).
    /// A trust region solves its subproblem; inexact Newton stops an iterative solve at the
    /// forcing term (relative to the first gradient, capped by `forcing_max`).
    #[allow(clippy::too_many_arguments)]
    fn globalized_direction(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &[f64],
        radius: f64,
        sc: &Scales,
        iteration: u32,
        report: &mut StepReport,
    ) -> Result<f64, StepError> {
        let s = self.settings;
        match s.globalization {
            Globalization::TrustRegion => {
                self.trust_region_direction(model, p, x, radius, sc, report)
            }
            _ if s.direction == Direction::Newton && s.forcing_max > 0.0 && !self.exact => {
                self.inexact |= self.system.honours_forcing();
                let forcing = (norm(&self.potential.g)
                    / sc.initial_gradient.max(f64::MIN_POSITIVE))
                .sqrt()
                .min(s.forcing_max);
                self.system.set_forcing(Some(forcing));
                let slope = self.direction(model, p, x, iteration, report);
                self.system.set_forcing(None);
                slope
            }
            _ => self.direction(model, p, x, iteration, report),
        }
    }

    /// Moves `x` along `self.dx` by the settings' globalization (line search, full step or
    /// trust region); returns the new objective, the step length and the backtracks (or
    /// rejections), or `None` when a trust region's predicted decrease is below round-off and
    /// its full step was taken.
    #[allow(clippy::too_many_arguments)]
    fn globalized_step(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &mut [f64],
        trial: Trial<'_>,
        radius: &mut f64,
        sc: &Scales,
        report: &mut StepReport,
    ) -> Result<Option<(Objective, f64, u32)>, StepError> {
        let Trial {
            current,
            slope,
            iteration,
            t,
        } = trial;
        Ok(match self.settings.globalization {
            Globalization::Backtracking => {
                Some(self.line_search(model, p, x, current, slope, None, iteration, report)?)
            }
            Globalization::FullStep => Some(self.full_step(model, p, x, iteration, t, report)?),
            Globalization::TrustRegion => {
                self.trust_region_step(model, p, x, current, radius, sc, t, iteration, report)?
            }
        })
    }

    /// The direction of `settings.direction` from `x` into `self.dx`; returns `g·dx` (< 0).
    fn direction(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &[f64],
        iteration: u32,
        report: &mut StepReport,
    ) -> Result<f64, StepError> {
        let s = self.settings;
        let g = &self.potential.g;
        match s.direction {
            Direction::Newton => {
                // At most twice: a kept factorization that no longer descends is refactored.
                loop {
                    let reused =
                        self.system
                            .factor_or_reuse(model, x, p.beta, s.refactor_every, report)?;
                    for (dx, g) in self.dx.iter_mut().zip(&self.potential.g) {
                        *dx = -g;
                    }
                    self.system.solve(model, x, &mut self.dx, report)?;
                    let slope = dot(&self.potential.g, &self.dx);
                    if reused && (slope.is_nan() || slope >= 0.0) {
                        self.system.invalidate();
                        continue;
                    }
                    return descent(slope, iteration, "Newton");
                }
            }
            Direction::GradientDescent => {
                for ((dx, g), m) in self.dx.iter_mut().zip(g).zip(&self.mass_diagonal) {
                    *dx = -g / m;
                }
                descent(dot(g, &self.dx), iteration, "gradient-descent")
            }
            Direction::Lbfgs => {
                if iteration == 0 && s.lbfgs_initial == LbfgsInitial::StepStart {
                    self.x_first.clear();
                    self.x_first.extend_from_slice(x);
                    self.system.factor(model, x, p.beta, report)?;
                }
                if s.lbfgs_initial == LbfgsInitial::Rest && self.rest_factored_beta != Some(p.beta)
                {
                    if self.rest.len() != x.len() {
                        self.rest = model.rest_state();
                    }
                    self.system.factor(model, &self.rest, p.beta, report)?;
                    self.rest_factored_beta = Some(p.beta);
                }
                let slope = self.lbfgs_direction(model, report)?;
                if slope < 0.0 {
                    return Ok(slope);
                }
                // Not a descent direction: forget the pairs and start from the initial
                // Hessian alone.
                self.lbfgs.clear();
                let slope = self.lbfgs_direction(model, report)?;
                descent(slope, iteration, "L-BFGS")
            }
        }
    }

    /// `dx = -H_k g` by the two-loop recursion over `lbfgs_initial`; returns `g·dx`.
    fn lbfgs_direction(
        &mut self,
        model: &mut Model,
        report: &mut StepReport,
    ) -> Result<f64, StepError> {
        let initial = self.settings.lbfgs_initial;
        for (dx, g) in self.dx.iter_mut().zip(&self.potential.g) {
            *dx = -g;
        }
        let gamma = self.lbfgs.shanno_scale().unwrap_or_else(|| {
            let n = self.mass_diagonal.len().max(1) as f64;
            n / self.mass_diagonal.iter().sum::<f64>()
        });
        let (system, mass, rest, first) = (
            &mut self.system,
            &self.mass_diagonal,
            &self.rest,
            &self.x_first,
        );
        self.lbfgs.apply(
            &mut self.dx,
            &mut |v: &mut [f64]| -> Result<(), StepError> {
                match initial {
                    LbfgsInitial::Identity => v.iter_mut().for_each(|x| *x *= gamma),
                    LbfgsInitial::Mass => v.iter_mut().zip(mass).for_each(|(x, m)| *x /= m),
                    LbfgsInitial::Rest => system.solve(model, rest, v, report)?,
                    LbfgsInitial::StepStart => system.solve(model, first, v, report)?,
                }
                Ok(())
            },
        )?;
        Ok(dot(&self.potential.g, &self.dx))
    }

    /// The trust region's first radius: `trust_radius`, or a tenth of the body's size in the
    /// mass norm, `0.1 sqrt(free mass) L`.
    fn first_radius(&mut self, model: &Model) -> f64 {
        if self.settings.trust_radius > 0.0 {
            return self.settings.trust_radius;
        }
        *self.auto_radius.get_or_insert_with(|| {
            let rest = model.rest_positions();
            let (mut lo, mut hi) = (rest[0], rest[0]);
            for v in rest {
                lo = lo.inf(v);
                hi = hi.sup(v);
            }
            let mass: f64 = self.mass_diagonal.iter().sum::<f64>() / 3.0;
            0.1 * mass.sqrt() * (hi - lo).norm()
        })
    }

    /// Assemble the (filtered) system matrix at `x` and solve the trust-region subproblem of
    /// `radius` into `self.dx`; returns `g·dx`.
    fn trust_region_direction(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &[f64],
        radius: f64,
        scales: &Scales,
        report: &mut StepReport,
    ) -> Result<f64, StepError> {
        let project = self.settings.filter_settings().filter != HessianFilter::None;
        self.system
            .assemble_matrix(model, x, p.beta, project, report)?;
        self.subproblem(radius, scales, report);
        Ok(dot(&self.potential.g, &self.dx))
    }

    /// Steihaug-CG on the assembled matrix into `self.dx`, with the forcing term
    /// `min(1/2, sqrt(‖g‖ / ‖g0‖))`.
    fn subproblem(&mut self, radius: f64, scales: &Scales, report: &mut StepReport) {
        let g = &self.potential.g;
        let forcing = (norm(g) / scales.initial_gradient.max(f64::MIN_POSITIVE))
            .sqrt()
            .min(0.5);
        let start = Instant::now();
        let h = self.system.matrix().expect("assembled");
        let solved = self.steihaug.solve(
            h,
            g,
            &self.mass_diagonal,
            radius,
            forcing,
            self.settings.trust_region_cg_iterations,
            &mut self.dx,
        );
        report.times.solve += start.elapsed().as_secs_f64();
        report.linear_solves += 1;
        report.linear_iterations += u64::from(solved.iterations);
        if solved.end == SubproblemEnd::Capped {
            report.capped_subproblems += 1;
        }
    }

    /// The trust-region test of the step `self.dx`: accept it (moving `x`) when the actual
    /// decrease is at least 1e-4 of the predicted one, shrinking or growing `radius` by the
    /// ratio; otherwise shrink and solve the subproblem again. Returns the accepted point's
    /// objective, its step length (1, or the step filter's cap) and the rejections, or
    /// `None` when the predicted decrease is below round-off (the step is then taken).
    #[allow(clippy::too_many_arguments)]
    fn trust_region_step(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &mut [f64],
        current: &Objective,
        radius: &mut f64,
        scales: &Scales,
        t: f64,
        iterations: u32,
        report: &mut StepReport,
    ) -> Result<Option<(Objective, f64, u32)>, StepError> {
        let s = self.settings;
        let mut rejections = 0;
        loop {
            let alpha = self.filtered_length(x, 1.0, t, report)?;
            if alpha < 1.0 {
                self.dx.iter_mut().for_each(|d| *d *= alpha);
            }
            let h = self.system.matrix().expect("assembled");
            let predicted =
                -trust_region::model_value(h, &self.potential.g, &self.dx, &mut self.hp);
            if predicted <= current.roundoff {
                axpy(1.0, &self.dx, x);
                return Ok(None);
            }
            self.set_trial(x, 1.0);
            let outcome = self.trial_objective(model, p);
            let (ratio, next) = match outcome {
                Ok(e) => ((current.value - e.value) / predicted, Some(e)),
                Err(ModelError::InvertedElement { .. }) => (f64::NEG_INFINITY, None),
                Err(e) => return Err(e.into()),
            };
            let step = trust_region::norm_d_squared(&self.mass_diagonal, &self.dx).sqrt();
            if ratio < 0.25 {
                *radius = 0.25 * step;
            } else if ratio > 0.75 && step >= 0.99 * *radius {
                *radius *= 2.0;
            }
            if let Some(e) = next
                && ratio > 1e-4
            {
                x.copy_from_slice(&self.trial);
                return Ok(Some((e, 1.0, rejections)));
            }
            rejections += 1;
            report.line_search_backtracks += 1;
            if rejections > s.max_backtracks || radius.is_nan() || *radius <= 0.0 {
                return Err(StepError::NewtonFailed {
                    iterations,
                    reason: format!(
                        "the trust region rejected {rejections} steps (radius {:.3e})",
                        radius
                    ),
                });
            }
            self.subproblem(*radius, scales, report);
        }
    }

    /// `initial` capped by the step filter along `self.dx` from `x` (counted when it caps).
    fn filtered_length(
        &mut self,
        x: &[f64],
        initial: f64,
        t: f64,
        report: &mut StepReport,
    ) -> Result<f64, StepError> {
        let Some(filter) = self.step_filter.as_mut() else {
            self.trace.first_step_lengths.push(initial);
            return Ok(initial);
        };
        let cap = filter.max_step(x, &self.dx, t);
        if cap.is_nan() || cap <= 0.0 {
            return Err(StepError::NewtonFailed {
                iterations: 0,
                reason: format!("the step filter allows no step (cap {cap:.3e})"),
            });
        }
        if cap < initial {
            report.filtered_steps += 1;
        }
        let alpha = initial.min(cap);
        self.trace.first_step_lengths.push(alpha);
        Ok(alpha)
    }

    /// The full step `initial_step * dx` (capped by the step filter), unchecked but for
    /// inverted elements.
    fn full_step(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &mut [f64],
        iterations: u32,
        t: f64,
        report: &mut StepReport,
    ) -> Result<(Objective, f64, u32), StepError> {
        let alpha = self.filtered_length(x, self.settings.initial_step, t, report)?;
        self.set_trial(x, alpha);
        let outcome = self.trial_objective(model, p);
        match outcome {
            Ok(e) => {
                x.copy_from_slice(&self.trial);
                Ok((e, alpha, 0))
            }
            Err(ModelError::InvertedElement { tet, .. }) => Err(StepError::NewtonFailed {
                iterations,
                reason: format!("the full step inverts tet {tet} (globalization `none`)"),
            }),
            Err(e) => Err(e.into()),
        }
    }

    /// Newton iterations whose direction comes from the constraints (a QP where they are
    /// active) and whose line search keeps feasible iterates feasible. An infeasible iterate
    /// (a start inside an obstacle) takes the full step, which restores feasibility.
    /// Convergence is tested on the Lagrangian gradient at a feasible iterate.
    fn iterate_constrained(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &mut [f64],
        mut current: Objective,
        t: f64,
        report: &mut StepReport,
    ) -> Result<bool, StepError> {
        let s = self.settings;
        let mut scale = None;
        for iteration in 0..s.max_iterations {
            self.gradient(model, p, x)?;
            let scale = match scale {
                Some(v) => v,
                None => *scale.insert(self.scale(model, p)),
            };
            self.trace.gradient_norms.push(norm(&self.potential.g));
            let constraints = self.constraints.as_mut().expect("constrained iteration");
            let feasible = constraints.min_distance(x, t) >= -PENETRATION_TOLERANCE;
            let linearization = Linearization {
                x,
                gradient: &self.potential.g,
                beta: p.beta,
                quasi_static: p.quasi_static,
                t,
            };
            let residual = constraints.direction(
                model,
                &mut self.system,
                &linearization,
                &mut self.dx,
                report,
            )?;
            report.newton_iterations += 1;
            let slope = dot(&self.potential.g, &self.dx);
            let small = residual <= s.tolerance * scale || -slope <= current.roundoff;
            if !feasible || small || slope >= 0.0 {
                // Restoration, convergence or no predicted decrease: the full step.
                self.set_trial(x, 1.0);
                let outcome = self.trial_objective(model, p);
                match outcome {
                    Ok(e) => current = e,
                    Err(ModelError::InvertedElement { .. }) if feasible => {
                        return Err(StepError::NewtonFailed {
                            iterations: iteration + 1,
                            reason: "the constrained step inverts an element".into(),
                        });
                    }
                    Err(e) => return Err(e.into()),
                }
                x.copy_from_slice(&self.trial);
                if small && feasible {
                    self.trace.stop = Stop::Criterion;
                    return Ok(true);
                }
                continue;
            }
            current = self
                .line_search(model, p, x, &current, slope, Some(t), iteration + 1, report)?
                .0;
        }
        self.trace.stop = Stop::Cap;
        Ok(false)
    }

    /// Backtracking (Armijo) from `x` along `self.dx`, from `initial_step` capped by the
    /// step filter; moves `x` to the accepted point and returns its objective, step length
    /// and backtracks. With `feasible_at`, a trial inside an obstacle at that time is
    /// rejected like one that inverts an element.
    #[allow(clippy::too_many_arguments)]
    fn line_search(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &mut [f64],
        current: &Objective,
        slope: f64,
        feasible_at: Option<f64>,
        iterations: u32,
        report: &mut StepReport,
    ) -> Result<(Objective, f64, u32), StepError> {
        let s = self.settings;
        let t = feasible_at.unwrap_or_else(|| model.time());
        let mut alpha = self.filtered_length(x, s.initial_step, t, report)?;
        let mut backtracks = 0;
        loop {
            self.set_trial(x, alpha);
            let feasible = match (feasible_at, &self.constraints) {
                (Some(t), Some(c)) => c.min_distance(&self.trial, t) >= -PENETRATION_TOLERANCE,
                _ => true,
            };
            if feasible {
                let outcome = self.trial_objective(model, p);
                match outcome {
                    Ok(e) if e.value <= current.value + s.sufficient_decrease * alpha * slope => {
                        x.copy_from_slice(&self.trial);
                        return Ok((e, alpha, backtracks));
                    }
                    Ok(_) | Err(ModelError::InvertedElement { .. }) => {}
                    Err(e) => return Err(e.into()),
                }
            }
            backtracks += 1;
            report.line_search_backtracks += 1;
            if backtracks > s.max_backtracks {
                return Err(StepError::NewtonFailed {
                    iterations,
                    reason: format!(
                        "line search found no sufficient decrease in {} backtracks",
                        s.max_backtracks
                    ),
                });
            }
            alpha *= s.shrink;
        }
    }
}

/// `Ok(slope)` if the direction descends (`g·dx < 0`), else the failure naming it.
fn descent(slope: f64, iterations: u32, what: &str) -> Result<f64, StepError> {
    if slope < 0.0 {
        Ok(slope)
    } else {
        Err(StepError::NewtonFailed {
            iterations,
            reason: format!("the {what} direction is not a descent direction (g.dx = {slope:.3e})"),
        })
    }
}

/// Penetration (m) below which an iterate counts as feasible (a QP meets its constraints to
/// about its solver's tolerance, not exactly).
pub const PENETRATION_TOLERANCE: f64 = 1e-8;

/// Where a constrained Newton iteration linearizes: the iterate, the gradient of `E` there,
/// and the weights of the system matrix `M + beta K` (`beta K` alone when quasi-static).
pub struct Linearization<'a> {
    /// The iterate.
    pub x: &'a [f64],
    /// The gradient of `E` at `x`.
    pub gradient: &'a [f64],
    /// `beta`.
    pub beta: f64,
    /// Whether the system has no mass term.
    pub quasi_static: bool,
    /// The time at which obstacles are evaluated.
    pub t: f64,
}

/// Inequality constraints on the positions a Newton solve seeks (non-penetration of
/// obstacles): they choose the Newton direction and tell the line search which points are
/// feasible. Implemented by the constrained contact response.
pub trait StepConstraints: Send {
    /// The smallest signed distance of any constrained point at `x` (negative inside).
    fn min_distance(&self, x: &[f64], t: f64) -> f64;

    /// The search direction at `at.x` into `dx`, assembling or factoring `system` as needed;
    /// returns the norm of the Lagrangian gradient (`‖g‖` when no constraint is active).
    fn direction(
        &mut self,
        model: &mut Model,
        system: &mut ImplicitSystem,
        at: &Linearization<'_>,
        dx: &mut [f64],
        report: &mut StepReport,
    ) -> Result<f64, StepError>;

    /// Record the contacts of the end-of-step positions `q` at time `t` in `report`.
    fn record_contacts(&self, q: &[f64], t: f64, report: &mut StepReport);
}

/// Run `step(state, dt)`; if it fails and `halvings > 0`, retry from the same state as two
/// steps of dt/2 (recursively, counting each retry). `step` must leave the state unchanged
/// when it fails; so does this function.
pub(crate) fn with_halving<F>(
    halvings: u32,
    state: &mut State,
    dt: f64,
    report: &mut StepReport,
    step: &mut F,
) -> Result<(), StepError>
where
    F: FnMut(&mut State, f64, &mut StepReport) -> Result<(), StepError>,
{
    match step(state, dt, report) {
        Ok(()) => Ok(()),
        Err(StepError::Model(e)) => Err(StepError::Model(e)),
        Err(e) if halvings == 0 => Err(e),
        Err(_) => {
            report.dt_halvings += 1;
            let backup = state.clone();
            let result = with_halving(halvings - 1, state, 0.5 * dt, report, step).and_then(|()| {
                // The second half starts half a step later (the caller advances t by dt).
                state.t = backup.t + 0.5 * dt;
                with_halving(halvings - 1, state, 0.5 * dt, report, step)
            });
            if result.is_err() {
                *state = backup;
            } else {
                state.t = backup.t;
            }
            result
        }
    }
}
