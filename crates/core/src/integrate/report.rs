//! What a step cost ([`StepReport`]) and why a step failed ([`StepError`]).

use super::State;
use crate::model::{EvalCounters, ModelError};
use crate::solve::SolveError;

/// Wall time per phase of a step, in seconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct PhaseTimes {
    /// Hessian (and system matrix) assembly.
    pub assemble: f64,
    /// Numeric factorization or preconditioner setup.
    pub factor: f64,
    /// Linear solves.
    pub solve: f64,
    /// Quadratic programs (the constrained contact response).
    pub qp: f64,
    /// Force and energy evaluations (gradient, potential, damping force) outside assembly:
    /// the main cost of explicit methods, and the line searches of implicit ones.
    pub forces: f64,
    /// Mass-matrix solves `M^{-1} f` of explicit methods with consistent mass.
    pub mass_solve: f64,
    /// The whole step.
    pub total: f64,
}

/// What one step did and cost.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct StepReport {
    /// The step taken (s).
    pub dt: f64,
    /// Accepted internal steps (adaptive methods and halving retries; 1 otherwise).
    pub substeps: u32,
    /// Rejected internal steps of adaptive methods (error too large, or the attempt failed).
    pub rejected_substeps: u32,
    /// Of those, the attempts that failed (a Newton or linear solve failed or stopped
    /// unconverged, an element inverted, the state overflowed) and were retried smaller.
    pub failed_substeps: u32,
    /// Newton iterations, summed over Newton solves.
    pub newton_iterations: u32,
    /// Newton solves that stopped at the iteration cap without meeting the tolerance.
    pub newton_unconverged: u32,
    /// Newton solves that stopped because their criterion (`integrator.newton.criterion`) was
    /// met, and those that stopped because the predicted decrease fell below round-off.
    pub newton_criterion_stops: u32,
    pub newton_roundoff_stops: u32,
    /// Line-search step reductions.
    pub line_search_backtracks: u32,
    /// Linear solves of a step's system (mass-matrix solves are counted apart).
    pub linear_solves: u32,
    /// Solves with the consistent mass matrix, `a = M^{-1} f`, of explicit methods (and of
    /// the start acceleration of Newmark schemes); 0 with lumped mass (a division).
    pub mass_solves: u32,
    /// Linear-solver iterations (1 per direct solve, CG iterations otherwise).
    pub linear_iterations: u64,
    /// Numeric factorizations (or preconditioner setups).
    pub factorizations: u32,
    /// Largest relative residual `‖b − A x‖/‖b‖` of any linear solve.
    pub max_relative_residual: f64,
    /// Symbolic analyses of a sparsity pattern (orderings, elimination trees): once per
    /// pattern when the analysis is reused, as it should be.
    pub symbolic_analyses: u32,
    /// Entries of the largest sparse factor (nnz(L), or the IC(0) factor for CG) built.
    pub factor_nnz: usize,
    /// Predicted flops of that factor's numeric factorization (Σ c_j² over its column counts).
    pub factor_flops: f64,
    /// The linear solver that did the work (what `auto` chose; empty without a solve).
    pub linear_solver: &'static str,
    /// Its fill-reducing ordering (`amd`, `metis`) or, for CG, its preconditioner.
    pub ordering: &'static str,
    /// Threads of the numeric factorization (1 when kept sequential by the flops rule).
    pub factor_threads: u32,
    /// Who scheduled it: `subtrees`, `faer` or `sequential` (empty without a sparse factor).
    pub factor_scheduler: &'static str,
    /// AMG (CG's preconditioner): Σ nnz(A_l) / nnz(A_0) and Σ n_l / n_0 of the largest
    /// hierarchy in use (0 without AMG).
    pub amg_operator_complexity: f64,
    pub amg_grid_complexity: f64,
    /// AMG setups that built the hierarchy, and setups that kept its structure and
    /// recomputed only its values.
    pub amg_builds: u32,
    pub amg_reuses: u32,
    /// Of the reuses, those that kept the coarse operators (refreshed the finest level only).
    pub amg_lagged: u32,
    /// Times an indefinite system matrix was replaced by its projected (PSD) form.
    pub indefinite_fallbacks: u32,
    /// Element matrices (tets, springs) the Hessian filter changed, summed over every
    /// assembly of the step (`integrator.newton.filter`; fallbacks included).
    pub projected_elements: u64,
    /// Times a failed step was retried as two steps of half the size.
    pub dt_halvings: u32,
    /// Newton solves that stopped at their iteration cap after inexact directions (an
    /// iterative solver at the forcing term) and were redone from the same start with exact
    /// directions, so the accepted state is the one a direct solver gives.
    pub exact_redos: u32,
    /// Trust-region subproblems that stopped at `trust_region_cg_iterations` (their last CG
    /// iterate taken as the step).
    pub capped_subproblems: u32,
    /// Line searches or steps whose first length a step filter capped.
    pub filtered_steps: u32,
    /// Model evaluations during the step.
    pub evaluations: EvalCounters,
    /// Wall time per phase.
    pub times: PhaseTimes,
    /// (vertex, obstacle) pairs in contact (within the contact margin) after the step; 0
    /// without obstacles.
    pub contacts: u32,
    /// The deepest penetration of a vertex into an obstacle after the step (m).
    pub max_penetration: f64,
    /// Quadratic programs solved (the constrained contact response).
    pub qp_solves: u32,
    /// Incremental potential contact: the smallest unsigned distance between contact
    /// primitives (and to analytic obstacles) after the step (m); `None` without it.
    pub min_distance: Option<f64>,
    /// Its barrier stiffness κ in the step (J; the largest over absorbed sub-steps).
    pub barrier_stiffness: f64,
    /// Its continuous-collision-detection queries (primitive pairs tested) in the step.
    pub ccd_queries: u64,
    /// Iterations of a local solver: VBD's Gauss–Seidel sweeps, projective dynamics'
    /// local/global iterations, XPBD's constraint sweeps (substeps × iterations).
    pub local_iterations: u32,
    /// The spectral radius ρ Chebyshev acceleration used (given or estimated; the largest
    /// over absorbed sub-steps); 0 without it or when the step stayed plain.
    pub chebyshev_rho: f64,
    /// Iterations whose Anderson-accelerated iterate was rejected (it raised the incremental
    /// potential above the plain iterate's, or its least-squares problem was singular) and
    /// whose history was restarted.
    pub anderson_fallbacks: u32,
}

impl StepReport {
    /// Add the work of a sub-step (halving retries, adaptive sub-steps); contacts and
    /// penetration take the larger value.
    pub fn absorb(&mut self, other: &StepReport) {
        self.substeps += other.substeps;
        self.rejected_substeps += other.rejected_substeps;
        self.failed_substeps += other.failed_substeps;
        self.newton_iterations += other.newton_iterations;
        self.local_iterations += other.local_iterations;
        self.chebyshev_rho = self.chebyshev_rho.max(other.chebyshev_rho);
        self.anderson_fallbacks += other.anderson_fallbacks;
        self.newton_unconverged += other.newton_unconverged;
        self.newton_criterion_stops += other.newton_criterion_stops;
        self.newton_roundoff_stops += other.newton_roundoff_stops;
        self.line_search_backtracks += other.line_search_backtracks;
        self.linear_solves += other.linear_solves;
        self.mass_solves += other.mass_solves;
        self.linear_iterations += other.linear_iterations;
        self.factorizations += other.factorizations;
        self.max_relative_residual = self.max_relative_residual.max(other.max_relative_residual);
        self.factor_nnz = self.factor_nnz.max(other.factor_nnz);
        self.symbolic_analyses += other.symbolic_analyses;
        self.factor_flops = self.factor_flops.max(other.factor_flops);
        self.amg_operator_complexity = self
            .amg_operator_complexity
            .max(other.amg_operator_complexity);
        self.amg_grid_complexity = self.amg_grid_complexity.max(other.amg_grid_complexity);
        self.amg_builds += other.amg_builds;
        self.amg_reuses += other.amg_reuses;
        self.amg_lagged += other.amg_lagged;
        if !other.linear_solver.is_empty() {
            self.linear_solver = other.linear_solver;
            self.ordering = other.ordering;
            self.factor_threads = other.factor_threads;
            self.factor_scheduler = other.factor_scheduler;
        }
        self.indefinite_fallbacks += other.indefinite_fallbacks;
        self.projected_elements += other.projected_elements;
        self.dt_halvings += other.dt_halvings;
        self.capped_subproblems += other.capped_subproblems;
        self.exact_redos += other.exact_redos;
        self.filtered_steps += other.filtered_steps;
        self.times.assemble += other.times.assemble;
        self.times.factor += other.times.factor;
        self.times.solve += other.times.solve;
        self.times.qp += other.times.qp;
        self.times.forces += other.times.forces;
        self.times.mass_solve += other.times.mass_solve;
        self.contacts = self.contacts.max(other.contacts);
        self.max_penetration = self.max_penetration.max(other.max_penetration);
        self.qp_solves += other.qp_solves;
        self.min_distance = match (self.min_distance, other.min_distance) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        self.barrier_stiffness = self.barrier_stiffness.max(other.barrier_stiffness);
        self.ccd_queries += other.ccd_queries;
    }
}

/// Why a step could not be taken. The state is left as it was before the step.
#[derive(Debug, thiserror::Error)]
pub enum StepError {
    /// The new state has a NaN or infinite entry.
    #[error("non-finite {what} at DOF {index}")]
    NonFinite { what: &'static str, index: usize },
    /// An element inverted where the material is undefined.
    #[error("tet {tet} inverted (det F = {det_f:.3e}); {material} is undefined there")]
    InvertedElement {
        tet: usize,
        det_f: f64,
        material: &'static str,
    },
    /// Newton's method could not make progress or did not converge when required to.
    #[error("Newton failed after {iterations} iteration(s): {reason}")]
    NewtonFailed { iterations: u32, reason: String },
    /// The linear solver failed (and no fallback applied).
    #[error("linear solver failed: {0}")]
    Solver(#[from] SolveError),
    /// Adaptive step control needed a step below its minimum.
    #[error("adaptive step size {dt:.3e} fell below the minimum {min_dt:.3e}")]
    StepTooSmall { dt: f64, min_dt: f64 },
    /// Adaptive step control used up its budget of internal steps for one call.
    #[error(
        "adaptive step control needed more than {substeps} internal steps (last step {dt:.3e} s)"
    )]
    TooManySubsteps { substeps: u64, dt: f64 },
    /// Any other model error.
    #[error(transparent)]
    Model(ModelError),
    /// The run's cost budget (`run.budget`) was passed inside the step (an adaptive method's
    /// internal steps); the step is abandoned and the run ends before its horizon.
    #[error("run.budget.{what} = {limit} was passed inside the step ({spent} spent)")]
    OverBudget {
        what: &'static str,
        limit: f64,
        spent: f64,
    },
    /// A stop was requested (SIGINT or SIGTERM) inside the step's iterations or substeps;
    /// the step is abandoned like any failed step.
    #[error("stopped by {} inside the step", .0.name())]
    Interrupted(crate::interrupt::Signal),
    /// A method's own code refused or failed the step, with its reason (a method registered
    /// from outside the crate, such as a Python step function that raised).
    #[error("the method failed: {0}")]
    Method(String),
}

impl crate::error_class::Classify for StepError {
    /// A step that failed is a result of the method on its scene, never the input's fault.
    fn class(&self) -> crate::error_class::ErrorClass {
        crate::error_class::ErrorClass::Failure
    }
}

impl StepError {
    /// A short cause for tables: "non-finite state", "inverted element", "newton failure",
    /// "solver failure", "step too small", "too many substeps" or "model error".
    pub fn cause(&self) -> &'static str {
        match self {
            Self::NonFinite { .. } => "non-finite state",
            Self::InvertedElement { .. } => "inverted element",
            Self::NewtonFailed { .. } => "newton failure",
            Self::Solver(_) => "solver failure",
            Self::StepTooSmall { .. } => "step too small",
            Self::TooManySubsteps { .. } => "too many substeps",
            Self::Model(_) => "model error",
            Self::OverBudget { .. } => "budget",
            Self::Interrupted(_) => "interrupted",
            Self::Method(_) => "method error",
        }
    }

    /// `Err(OverBudget)` if the run's cost budget is passed, counting the model's evaluations
    /// and this step's `report` so far (see [`super::cost_guard`]).
    pub fn stop_if_over_budget(
        model: &crate::model::Model,
        report: &StepReport,
    ) -> Result<(), Self> {
        let c = model.counters();
        match super::cost_guard::over_budget(
            c.gradient + c.hessian,
            u64::from(report.factorizations),
            report.linear_iterations,
        ) {
            Some((what, limit, spent)) => Err(Self::OverBudget { what, limit, spent }),
            None => Ok(()),
        }
    }

    /// `Err(Interrupted)` if a stop was requested: what every iteration and substep loop
    /// checks, so a step of many iterations never outlives a signal for long.
    pub fn stop_if_requested() -> Result<(), Self> {
        crate::interrupt::requested().map_or(Ok(()), |s| Err(Self::Interrupted(s)))
    }
}

impl From<ModelError> for StepError {
    fn from(e: ModelError) -> Self {
        match e {
            ModelError::InvertedElement {
                tet,
                det_f,
                material,
            } => Self::InvertedElement {
                tet,
                det_f,
                material,
            },
            other => Self::Model(other),
        }
    }
}

/// Fail with [`StepError::NonFinite`] if `q` or `v` has a NaN or infinite entry.
pub(crate) fn check_finite(state: &State) -> Result<(), StepError> {
    for (what, x) in [("position", &state.q), ("velocity", &state.v)] {
        if let Some(index) = x.iter().position(|c| !c.is_finite()) {
            return Err(StepError::NonFinite { what, index });
        }
    }
    Ok(())
}
