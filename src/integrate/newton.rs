//! Newton's method with backtracking (Armijo) line search on the incremental potential
//!
//! `E(x) = 1/2 (x - x_hat)^T M (x - x_hat) + beta V(x) [+ damping term] [+ l^T x]`,
//!
//! whose minimizer is the unknown of every implicit scheme ([`super::scheme`]): the new
//! position of backward Euler (`x_hat = q + dt v`, `beta = dt^2`), BDF-k and the Newmark
//! family, the midpoint of implicit midpoint, the equilibrium of a static solve (no inertial
//! term). This is the one Newton loop; schemes only say what to minimize.
//!
//! With [`StepConstraints`] (the constrained contact response) the direction is chosen by the
//! constraints (a QP where they are active) and the line search rejects infeasible points, so
//! halving retries, damping and every scheme work with contact unchanged.
//!
//! Convergence is tested on the gradient relative to the size of the step's own terms:
//! `‖g‖ <= tolerance * (‖M (x_hat - q)‖ + beta ‖grad V(x0)‖)`, the inertial and force terms at
//! the start, so the tolerance means the same on a 1 m armadillo and a 165-unit bunny.
//!
//! Near convergence the Armijo test compares energies whose difference is below their
//! round-off; once the predicted decrease (the Newton decrement) is below that round-off
//! level, the full step is accepted without the test.

use super::filter::{FilterSettings, HessianFilter};
pub use super::system::ImplicitSystem;
use super::{State, StepError, StepReport};
use crate::fem::FilterSpace;
use crate::model::{Model, ModelError};
use crate::solve::LinearSolver;
use crate::sparse::SymmetricMatrix;

/// Newton and line-search settings. Defaults follow the course handout (initial step 1,
/// shrink 0.5, sufficient decrease 1e-8, at most 5 iterations).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NewtonSettings {
    /// Newton iterations per solve. Default 5.
    pub max_iterations: u32,
    /// Relative gradient tolerance (see the module docs). Default 1e-8.
    pub tolerance: f64,
    /// First line-search step length. Default 1.
    pub initial_step: f64,
    /// Step-length factor per backtrack, in (0, 1). Default 0.5.
    pub shrink: f64,
    /// Armijo constant c in `E(x + a dx) <= E(x) + c a g.dx`. Default 1e-8.
    pub sufficient_decrease: f64,
    /// Backtracks per line search before Newton fails. Default 40.
    pub max_backtracks: u32,
    /// The old switch for `filter = "clamp"`: true projects every element Hessian to PSD.
    /// Kept as an alias; it contradicts any filter other than `none` and `clamp`.
    /// Default false.
    pub project_hessian: bool,
    /// The Hessian filter (see [`super::filter`]): `none` (the default: exact Hessians,
    /// clamped only when the system is indefinite), `clamp`, `abs`, `on-demand`,
    /// `progressive`.
    pub filter: HessianFilter,
    /// `ε` of the filter, >= 0: every filtered eigenvalue is at least this. Default 0.
    pub filter_epsilon: f64,
    /// Where the filter decomposes: `element` (the 12×12 element Hessian, the default) or
    /// `stress` (the material's 9×9 dP/dF).
    pub filter_space: FilterSpace,
    /// Fail the step when the tolerance is not met within `max_iterations` (otherwise the last
    /// iterate is used, as in the course, and counted as unconverged). Default false.
    pub require_convergence: bool,
    /// On failure, retry the step as two steps of dt/2, at most this many times nested.
    /// Default 0 (off).
    pub retry_halvings: u32,
    /// Newton iterations, counted across steps, that share one factorization of the system
    /// matrix. 1 (the default) is full Newton; k > 1 is modified Newton: the matrix is
    /// refactored every k-th iteration, and also when β (the time step) changes or when the
    /// kept factorization does not give a descent direction. Fewer factorizations for more,
    /// linearly converging, iterations.
    pub refactor_every: u32,
}

impl Default for NewtonSettings {
    fn default() -> Self {
        Self {
            max_iterations: 5,
            tolerance: 1e-8,
            initial_step: 1.0,
            shrink: 0.5,
            sufficient_decrease: 1e-8,
            max_backtracks: 40,
            project_hessian: false,
            filter: HessianFilter::None,
            filter_epsilon: 0.0,
            filter_space: FilterSpace::Element,
            require_convergence: false,
            retry_halvings: 0,
            refactor_every: 1,
        }
    }
}

impl NewtonSettings {
    /// The filter the system matrix uses (`project_hessian = true` is `filter = "clamp"`).
    pub fn filter_settings(&self) -> FilterSettings {
        let filter = match (self.project_hessian, self.filter) {
            (true, HessianFilter::None) => HessianFilter::Clamp,
            (_, f) => f,
        };
        FilterSettings {
            filter,
            epsilon: self.filter_epsilon,
            space: self.filter_space,
        }
    }

    /// Check every field's range; the message names the field and the valid range.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.filter_epsilon.is_finite() && self.filter_epsilon >= 0.0) {
            return Err(format!(
                "newton.filter_epsilon must be finite and >= 0 (got {})",
                self.filter_epsilon
            ));
        }
        if self.project_hessian
            && !matches!(self.filter, HessianFilter::None | HessianFilter::Clamp)
        {
            return Err(format!(
                "newton.project_hessian = true means newton.filter = \"clamp\", which contradicts \
                 newton.filter = \"{}\"; set only newton.filter",
                self.filter
            ));
        }
        let checks = [
            (
                self.max_iterations >= 1,
                "newton.max_iterations must be >= 1",
            ),
            (
                self.refactor_every >= 1,
                "newton.refactor_every must be >= 1 (1 = full Newton)",
            ),
            (
                self.tolerance.is_finite() && self.tolerance >= 0.0,
                "newton.tolerance must be >= 0",
            ),
            (
                self.initial_step.is_finite() && self.initial_step > 0.0,
                "newton.initial_step must be > 0",
            ),
            (
                self.shrink > 0.0 && self.shrink < 1.0,
                "newton.shrink must lie in (0, 1)",
            ),
            (
                self.sufficient_decrease >= 0.0 && self.sufficient_decrease < 1.0,
                "newton.sufficient_decrease must lie in [0, 1)",
            ),
        ];
        match checks.iter().find(|(ok, _)| !ok) {
            Some((_, msg)) => Err((*msg).to_string()),
            None => Ok(()),
        }
    }
}

/// One incremental potential to minimize (see the module docs), plus the damping term
/// `1/2 gamma (x - x_d)^T D (x - x_d)` when [`Newton::prepare_damping`] set one for the step,
/// and a constant linear term `l^T x` (a force known at the start of the step, as the
/// generalized-α family has).
#[derive(Clone, Copy, Debug, Default)]
pub struct Problem<'a> {
    /// `x_hat`.
    pub x_hat: &'a [f64],
    /// The start-of-step positions (the convergence scale; the fallback initial guess).
    pub x_ref: &'a [f64],
    /// `beta`.
    pub beta: f64,
    /// `x_d`, where the damping term is zero.
    pub damping_anchor: &'a [f64],
    /// `l`, or empty for none.
    pub linear: &'a [f64],
    /// No inertial term: minimize `beta V(x) + l^T x` alone (a static equilibrium).
    pub quasi_static: bool,
    /// The size of the forces when the scheme knows it better than `‖grad V‖` at the guess
    /// (a static solve that starts at equilibrium); 0 for none.
    pub force_scale: f64,
}

/// Energies whose predicted decrease is below this many ulps of their scale are treated as
/// round-off in the line search.
const ROUNDOFF_ULPS: f64 = 256.0;

/// What the last [`Newton::minimize`] did, for diagnostics and tests.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NewtonTrace {
    /// `‖g‖` at each iterate, starting with the initial guess (and after the last step when
    /// the iteration cap was reached).
    pub gradient_norms: Vec<f64>,
    /// The scale the tolerance is relative to.
    pub scale: f64,
    /// Whether a step was accepted because its predicted decrease was below round-off.
    pub roundoff_accepted: bool,
    /// Whether the tolerance was met.
    pub converged: bool,
}

/// The Newton minimizer with its linear system, optional constraints and preallocated
/// vectors.
pub struct Newton {
    settings: NewtonSettings,
    trace: NewtonTrace,
    system: ImplicitSystem,
    potential: IncrementalPotential,
    constraints: Option<Box<dyn StepConstraints>>,
    dx: Vec<f64>,
    trial: Vec<f64>,
}

/// An objective value with the scale of its round-off.
struct Objective {
    pub value: f64,
    pub roundoff: f64,
}

/// Evaluates the incremental potential `E` of a [`Problem`] and its gradient with reusable
/// buffers.
#[derive(Default)]
struct IncrementalPotential {
    /// The gradient `g` after [`Self::gradient`].
    pub g: Vec<f64>,
    /// `grad V(x)` after [`Self::gradient`].
    pub grad_v: Vec<f64>,
    d: Vec<f64>,
    md: Vec<f64>,
    dd: Vec<f64>,
    trial_d: Vec<f64>,
}

impl IncrementalPotential {
    /// Size the buffers for `n` DOFs (allocates only when `n` grows).
    pub fn resize(&mut self, n: usize) {
        for buf in [
            &mut self.g,
            &mut self.grad_v,
            &mut self.d,
            &mut self.md,
            &mut self.dd,
            &mut self.trial_d,
        ] {
            buf.resize(n, 0.0);
        }
    }

    /// `‖M (x_hat − x_ref)‖ + ‖l‖`, the size of the step's inertial and constant terms.
    pub fn inertial_scale(&mut self, model: &Model, p: &Problem<'_>) -> f64 {
        let linear = norm(p.linear);
        if p.quasi_static {
            return linear;
        }
        for ((d, a), b) in self.d.iter_mut().zip(p.x_hat).zip(p.x_ref) {
            *d = a - b;
        }
        model.mass().mul_vec(&self.d, &mut self.md);
        norm(&self.md) + linear
    }

    /// `1/2 gamma (x - x_d)^T D (x - x_d)` and, into `self.dd`, `gamma D (x - x_d)`.
    fn damping_term(
        &mut self,
        damping: Option<(&SymmetricMatrix, f64)>,
        x: &[f64],
        anchor: &[f64],
    ) -> f64 {
        let Some((d, gamma)) = damping else {
            self.dd.fill(0.0);
            return 0.0;
        };
        for ((t, xi), a) in self.trial_d.iter_mut().zip(x).zip(anchor) {
            *t = xi - a;
        }
        d.mul_vec(&self.trial_d, &mut self.dd);
        let e = 0.5 * gamma * dot(&self.trial_d, &self.dd);
        self.dd.iter_mut().for_each(|v| *v *= gamma);
        e
    }

    /// `E(x)` and the scale of its round-off (which includes the magnitudes of the terms that
    /// cancel in the potential, [`Model::energy_roundoff_scale`]).
    pub fn objective(
        &mut self,
        model: &mut Model,
        damping: Option<(&SymmetricMatrix, f64)>,
        p: &Problem<'_>,
        x: &[f64],
    ) -> Result<Objective, ModelError> {
        let inertia = if p.quasi_static {
            0.0
        } else {
            for ((d, xi), xh) in self.d.iter_mut().zip(x).zip(p.x_hat) {
                *d = xi - xh;
            }
            model.mass().mul_vec(&self.d, &mut self.md);
            0.5 * dot(&self.d, &self.md)
        };
        let parts = model.potential_parts(x)?;
        let damping = self.damping_term(damping, x, p.damping_anchor);
        let linear = if p.linear.is_empty() {
            0.0
        } else {
            dot(p.linear, x)
        };
        let value = inertia + p.beta * parts.total() + damping + linear;
        let terms =
            parts.elastic.abs() + parts.springs.abs() + parts.gravity.abs() + parts.vertex.abs();
        let scale = inertia.abs()
            + p.beta * (terms + model.energy_roundoff_scale())
            + damping.abs()
            + linear.abs();
        Ok(Objective {
            value,
            roundoff: ROUNDOFF_ULPS * f64::EPSILON * scale,
        })
    }

    /// `g = M (x - x_hat) + beta grad V(x) + gamma D (x - x_d) + l` into `self.g`, and
    /// `grad V(x)` into `self.grad_v`.
    pub fn gradient(
        &mut self,
        model: &mut Model,
        damping: Option<(&SymmetricMatrix, f64)>,
        p: &Problem<'_>,
        x: &[f64],
    ) -> Result<(), ModelError> {
        if p.quasi_static {
            self.md.fill(0.0);
        } else {
            for ((d, xi), xh) in self.d.iter_mut().zip(x).zip(p.x_hat) {
                *d = xi - xh;
            }
            model.mass().mul_vec(&self.d, &mut self.md);
        }
        model.gradient(x, &mut self.grad_v)?;
        self.damping_term(damping, x, p.damping_anchor);
        for (((g, md), gv), dd) in self
            .g
            .iter_mut()
            .zip(&self.md)
            .zip(&self.grad_v)
            .zip(&self.dd)
        {
            *g = md + p.beta * gv + dd;
        }
        if !p.linear.is_empty() {
            axpy(1.0, p.linear, &mut self.g);
        }
        Ok(())
    }
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
            dx: Vec::new(),
            trial: Vec::new(),
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

    /// The settings.
    pub fn settings(&self) -> &NewtonSettings {
        &self.settings
    }

    /// What the last minimization did.
    pub fn trace(&self) -> &NewtonTrace {
        &self.trace
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
        self.dx.resize(n, 0.0);
        self.trial.resize(n, 0.0);
        self.trace.gradient_norms.clear();
        self.trace.roundoff_accepted = false;
        self.trace.converged = false;
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
        // The guess may invert elements (a large step); the start-of-step state does not.
        let current = match self.objective(model, p, x) {
            Ok(e) => e,
            Err(ModelError::InvertedElement { .. }) => {
                x.copy_from_slice(p.x_ref);
                self.objective(model, p, x)?
            }
            Err(e) => return Err(e.into()),
        };
        let converged = if self.constraints.is_some() {
            self.iterate_constrained(model, p, x, current, t, report)?
        } else {
            self.iterate(model, p, x, current, report)?
        };
        self.trace.converged = converged;
        if !converged {
            let s = &self.settings;
            if s.require_convergence {
                return Err(StepError::NewtonFailed {
                    iterations: s.max_iterations,
                    reason: format!(
                        "tolerance {:.1e} not met in {} iterations",
                        s.tolerance, s.max_iterations
                    ),
                });
            }
            report.newton_unconverged += 1;
        }
        Ok(())
    }

    /// The convergence scale: the inertial (and constant) terms plus the force term at the
    /// first iterate (call after the first gradient).
    fn scale(&mut self, model: &Model, p: &Problem<'_>) -> f64 {
        let forces = norm(&self.potential.grad_v).max(p.force_scale);
        let scale = self.potential.inertial_scale(model, p) + p.beta * forces;
        self.trace.scale = scale;
        scale
    }

    /// Plain Newton iterations from `x` with objective `current`; returns whether the
    /// tolerance was met.
    fn iterate(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &mut [f64],
        mut current: Objective,
        report: &mut StepReport,
    ) -> Result<bool, StepError> {
        let s = self.settings;
        let mut scale = None;
        let mut iterations = 0;
        while iterations < s.max_iterations {
            StepError::stop_if_requested()?;
            self.gradient(model, p, x)?;
            let scale = match scale {
                Some(v) => v,
                None => *scale.insert(self.scale(model, p)),
            };
            let g_norm = norm(&self.potential.g);
            self.trace.gradient_norms.push(g_norm);
            if g_norm <= s.tolerance * scale {
                return Ok(true);
            }
            let reused = self
                .system
                .factor_or_reuse(model, x, p.beta, s.refactor_every, report)?;
            for (dx, g) in self.dx.iter_mut().zip(&self.potential.g) {
                *dx = -g;
            }
            self.system.solve(model, x, &mut self.dx, report)?;
            let slope = dot(&self.potential.g, &self.dx);
            if reused && (slope.is_nan() || slope >= 0.0) {
                // The kept factorization no longer gives a descent direction: refactor.
                self.system.invalidate();
                continue;
            }
            if slope.is_nan() || slope >= 0.0 {
                return Err(StepError::NewtonFailed {
                    iterations,
                    reason: format!(
                        "the Newton direction is not a descent direction (g.dx = {slope:.3e})"
                    ),
                });
            }
            iterations += 1;
            report.newton_iterations += 1;
            if -slope <= current.roundoff {
                // The decrease is below the energy's round-off: the Armijo test cannot tell,
                // and the iterate is converged to working precision.
                axpy(1.0, &self.dx, x);
                self.trace.roundoff_accepted = true;
                return Ok(true);
            }
            current = self.line_search(model, p, x, &current, slope, None, iterations, report)?;
        }
        // One more gradient tells whether the last iterate met the tolerance.
        self.gradient(model, p, x)?;
        let g_norm = norm(&self.potential.g);
        self.trace.gradient_norms.push(g_norm);
        Ok(g_norm <= s.tolerance * scale.unwrap_or(0.0))
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
                for ((t, x), dx) in self.trial.iter_mut().zip(x.iter()).zip(&self.dx) {
                    *t = x + dx;
                }
                let trial = std::mem::take(&mut self.trial);
                let outcome = self.objective(model, p, &trial);
                self.trial = trial;
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
                    return Ok(true);
                }
                continue;
            }
            current =
                self.line_search(model, p, x, &current, slope, Some(t), iteration + 1, report)?;
        }
        Ok(false)
    }

    /// Backtracking (Armijo) from `x` along `self.dx`; moves `x` to the accepted point and
    /// returns its objective. With `feasible_at`, a trial inside an obstacle at that time is
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
    ) -> Result<Objective, StepError> {
        let s = self.settings;
        let mut alpha = s.initial_step;
        let mut backtracks = 0;
        loop {
            for ((t, xi), dx) in self.trial.iter_mut().zip(x.iter()).zip(&self.dx) {
                *t = xi + alpha * dx;
            }
            let feasible = match (feasible_at, &self.constraints) {
                (Some(t), Some(c)) => c.min_distance(&self.trial, t) >= -PENETRATION_TOLERANCE,
                _ => true,
            };
            if feasible {
                let trial = std::mem::take(&mut self.trial);
                let outcome = self.objective(model, p, &trial);
                self.trial = trial;
                match outcome {
                    Ok(e) if e.value <= current.value + s.sufficient_decrease * alpha * slope => {
                        x.copy_from_slice(&self.trial);
                        return Ok(e);
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

#[inline]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[inline]
pub(crate) fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

#[inline]
fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    y.iter_mut().zip(x).for_each(|(yi, xi)| *yi += a * xi);
}
