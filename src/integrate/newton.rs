//! Newton's method with backtracking (Armijo) line search on the incremental potential
//!
//! `E(x) = 1/2 (x - x_hat)^T M (x - x_hat) + beta V(x)`,
//!
//! whose minimizer is the new position of backward Euler (`x_hat = q + dt v`, `beta = dt^2`),
//! implicit midpoint (the midpoint, `x_hat = q + dt/2 v`, `beta = dt^2 / 4`) and BDF2
//! (`beta = 4/9 dt^2`). One loop serves all three.
//!
//! Convergence is tested on the gradient relative to the size of the step's own terms:
//! `‖g‖ <= tolerance * (‖M (x_hat - q)‖ + beta ‖grad V(x0)‖)`, the inertial and force terms at
//! the start, so the tolerance means the same on a 1 m armadillo and a 165-unit bunny.
//!
//! Near convergence the Armijo test compares energies whose difference is below their
//! round-off; once the predicted decrease (the Newton decrement) is below that round-off
//! level, the full step is accepted without the test.

use super::system::ImplicitSystem;
use super::{State, StepError, StepReport};
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
    /// Project every element Hessian to PSD (otherwise only as a fallback when the system
    /// matrix is indefinite). Default false.
    pub project_hessian: bool,
    /// Fail the step when the tolerance is not met within `max_iterations` (otherwise the last
    /// iterate is used, as in the course, and counted as unconverged). Default false.
    pub require_convergence: bool,
    /// On failure, retry the step as two steps of dt/2, at most this many times nested.
    /// Default 0 (off).
    pub retry_halvings: u32,
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
            require_convergence: false,
            retry_halvings: 0,
        }
    }
}

impl NewtonSettings {
    /// Check every field's range; the message names the field and the valid range.
    pub fn validate(&self) -> Result<(), String> {
        let checks = [
            (
                self.max_iterations >= 1,
                "newton.max_iterations must be >= 1",
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
/// `1/2 gamma (x - x_d)^T D (x - x_d)` when [`Newton::prepare_damping`] set one for the step.
pub struct Problem<'a> {
    /// `x_hat`.
    pub x_hat: &'a [f64],
    /// The start-of-step positions (the convergence scale; the fallback initial guess).
    pub x_ref: &'a [f64],
    /// `beta`.
    pub beta: f64,
    /// `x_d`, where the damping term is zero.
    pub damping_anchor: &'a [f64],
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

/// The Newton minimizer with its linear system and preallocated vectors.
pub struct Newton {
    settings: NewtonSettings,
    trace: NewtonTrace,
    system: ImplicitSystem,
    potential: IncrementalPotential,
    dx: Vec<f64>,
    trial: Vec<f64>,
}

/// An objective value with the scale of its round-off.
pub(crate) struct Objective {
    pub value: f64,
    pub roundoff: f64,
}

/// Evaluates the incremental potential `E` of a [`Problem`] and its gradient with reusable
/// buffers; Newton and the constrained contact step share it.
#[derive(Default)]
pub(crate) struct IncrementalPotential {
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

    /// `‖M (x_hat − x_ref)‖`, the size of the step's inertial term.
    pub fn inertial_scale(&mut self, model: &Model, p: &Problem<'_>) -> f64 {
        for ((d, a), b) in self.d.iter_mut().zip(p.x_hat).zip(p.x_ref) {
            *d = a - b;
        }
        model.mass().mul_vec(&self.d, &mut self.md);
        norm(&self.md)
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
        for ((d, xi), xh) in self.d.iter_mut().zip(x).zip(p.x_hat) {
            *d = xi - xh;
        }
        model.mass().mul_vec(&self.d, &mut self.md);
        let inertia = 0.5 * dot(&self.d, &self.md);
        let parts = model.potential_parts(x)?;
        let damping = self.damping_term(damping, x, p.damping_anchor);
        let value = inertia + p.beta * parts.total() + damping;
        let terms =
            parts.elastic.abs() + parts.springs.abs() + parts.gravity.abs() + parts.vertex.abs();
        let scale =
            inertia.abs() + p.beta * (terms + model.energy_roundoff_scale()) + damping.abs();
        Ok(Objective {
            value,
            roundoff: ROUNDOFF_ULPS * f64::EPSILON * scale,
        })
    }

    /// `g = M (x - x_hat) + beta grad V(x) + gamma D (x - x_d)` into `self.g`, and `grad V(x)`
    /// into `self.grad_v`.
    pub fn gradient(
        &mut self,
        model: &mut Model,
        damping: Option<(&SymmetricMatrix, f64)>,
        p: &Problem<'_>,
        x: &[f64],
    ) -> Result<(), ModelError> {
        for ((d, xi), xh) in self.d.iter_mut().zip(x).zip(p.x_hat) {
            *d = xi - xh;
        }
        model.mass().mul_vec(&self.d, &mut self.md);
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
        Ok(())
    }
}

impl Newton {
    /// A minimizer solving its systems with `solver`.
    pub fn new(solver: Box<dyn LinearSolver>, settings: NewtonSettings) -> Self {
        Self {
            settings,
            trace: NewtonTrace::default(),
            system: ImplicitSystem::new(solver, settings.project_hessian),
            potential: IncrementalPotential::default(),
            dx: Vec::new(),
            trial: Vec::new(),
        }
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
    /// start-of-step position that sets the convergence scale. On success `x` holds the
    /// minimizer; on error its content is unspecified.
    pub fn minimize(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &mut [f64],
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let (x_ref, beta) = (p.x_ref, p.beta);
        let n = x.len();
        self.potential.resize(n);
        self.dx.resize(n, 0.0);
        self.trial.resize(n, 0.0);
        let s = self.settings;
        self.trace.gradient_norms.clear();
        self.trace.roundoff_accepted = false;
        self.trace.converged = false;
        // The guess may invert elements (a large step); the start-of-step state does not.
        let mut current = match self.objective(model, p, x) {
            Ok(e) => e,
            Err(ModelError::InvertedElement { .. }) => {
                x.copy_from_slice(x_ref);
                self.objective(model, p, x)?
            }
            Err(e) => return Err(e.into()),
        };
        // Scale of the convergence test: the inertial term M (x_hat - x_ref) ...
        let inertial = self.potential.inertial_scale(model, p);
        let mut scale = None;
        let mut converged = false;
        let mut iterations = 0;
        while iterations < s.max_iterations {
            self.gradient(model, p, x)?;
            // ... plus the force term at the first iterate.
            let scale = *scale.get_or_insert(inertial + beta * norm(&self.potential.grad_v));
            self.trace.scale = scale;
            self.trace.gradient_norms.push(norm(&self.potential.g));
            if norm(&self.potential.g) <= s.tolerance * scale {
                converged = true;
                break;
            }
            self.system.factor(model, x, beta, report)?;
            for (dx, g) in self.dx.iter_mut().zip(&self.potential.g) {
                *dx = -g;
            }
            self.system.solve(model, x, &mut self.dx, report)?;
            let slope = dot(&self.potential.g, &self.dx);
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
                converged = true;
                break;
            }
            let mut alpha = s.initial_step;
            let mut backtracks = 0;
            loop {
                for ((t, xi), dx) in self.trial.iter_mut().zip(x.iter()).zip(&self.dx) {
                    *t = xi + alpha * dx;
                }
                let trial = std::mem::take(&mut self.trial);
                let outcome = self.objective(model, p, &trial);
                self.trial = trial;
                match outcome {
                    Ok(e) if e.value <= current.value + s.sufficient_decrease * alpha * slope => {
                        current = e;
                        break;
                    }
                    Ok(_) | Err(ModelError::InvertedElement { .. }) => {}
                    Err(e) => return Err(e.into()),
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
            x.copy_from_slice(&self.trial);
        }
        if !converged {
            // One more gradient tells whether the last iterate met the tolerance.
            self.gradient(model, p, x)?;
            self.trace.gradient_norms.push(norm(&self.potential.g));
            converged = norm(&self.potential.g) <= s.tolerance * scale.unwrap_or(0.0);
        }
        self.trace.converged = converged;
        if !converged {
            if s.require_convergence {
                return Err(StepError::NewtonFailed {
                    iterations,
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
