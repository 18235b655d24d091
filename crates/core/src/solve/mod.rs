//! Linear solvers for the symmetric systems `A x = b` of implicit integrators
//! (`A = M + dt² K`, assembled into a fixed [`SparsityPattern`] every Newton iteration).
//!
//! Every backend follows the same three phases, so reuse is visible in the API:
//! 1. [`LinearSolver::analyze`] once per pattern (ordering, symbolic factorization, scratch
//!    sizing; a no-op when the pattern is the one analyzed last);
//! 2. [`LinearSolver::factor`] once per matrix (numeric factorization or preconditioner setup,
//!    into storage allocated by `analyze`);
//! 3. [`LinearSolver::solve`] per right-hand side.
//!
//! Backends, one file each: [`faer_direct`] (faer sparse LLᵀ and LDLᵀ, one backend over both
//! factorizations; LDLᵀ reports the inertia), [`cg`] (preconditioned conjugate gradient;
//! preconditioners in `precond.rs`), [`dense`] (dense LLᵀ for tiny systems and tests).
//! [`LinearSolverKind`] picks one by name from the registry in `kind.rs`, where a new backend
//! adds its line (or a program registers its own with [`LINEAR_SOLVERS`]`.register`).
//!
//! Failures are values, never panics: a matrix that is not positive definite, a pattern that
//! differs from the analyzed one, NaN input, or CG running out of iterations each come back as
//! a [`SolveError`] the caller can act on.

mod amg;
pub mod auto;
pub mod cg;
mod common;
pub mod dense;
mod faer_common;
pub mod faer_direct;
pub mod gmres;
mod kind;
pub mod ordering;
mod precond;
pub mod supernodal_tree;

use std::sync::Arc;
use std::time::Duration;

use crate::sparse::{SparsityPattern, SymmetricMatrix};

pub use amg::{AmgSettings, AmgSmoother, AmgStats, PARALLEL_MIN_ROWS as AMG_PARALLEL_MIN_ROWS};
pub use auto::{AutoPrediction, AutoSolver};
pub use cg::{CgSettings, CgSolver, Preconditioner};
pub use common::symmetric_mul_vec;
pub(crate) use common::{
    Analyzed, ResidualCheck, check_rhs, dot, finish_direct_solve, norm, record_factor,
};
pub use dense::DenseCholeskySolver;
pub use faer_common::{FAER_LOOP_PARALLEL_MIN_FLOPS, PARALLEL_MIN_FLOPS};
pub use faer_direct::{CholeskySolver, FaerDirectSolver, LdltSolver};
pub use gmres::{Gmres, GmresReport};
pub use kind::{
    DirectSettings, LINEAR_SOLVERS, LinearSolverKind, Scheduler, SolverEntry, SolverSettings,
    Supernodal,
};
pub use ordering::Ordering;

/// A solver for symmetric systems over a fixed sparsity pattern: analyze once, factor per
/// matrix, solve per right-hand side.
pub trait LinearSolver: Send {
    /// Short name, as accepted by [`LinearSolverKind::from_name`].
    fn name(&self) -> &'static str;

    /// Symbolic analysis of `pattern` (ordering, fill, scratch sizes) and allocation of all
    /// factor and work storage. A no-op when `pattern` is the same `Arc` as last time, or has
    /// equal content (compared in O(nnz), far cheaper than an analysis).
    fn analyze(&mut self, pattern: &Arc<SparsityPattern>) -> Result<(), SolveError>;

    /// Numeric factorization (or preconditioner setup) of `a`, whose pattern must be the
    /// analyzed one. Allocates nothing. Fails with `PatternMismatch`, `NonFiniteInput`,
    /// `NotPositiveDefinite` (Cholesky, dense, CG preconditioners), `SingularMatrix` (LDLᵀ) or
    /// `OutOfOrder` (no analysis yet); after a failure, `solve` refuses until the next
    /// successful `factor`. The solver keeps a copy of `a`'s values (for the residual check,
    /// and for CG's mat-vecs).
    fn factor(&mut self, a: &SymmetricMatrix) -> Result<FactorReport, SolveError>;

    /// Solves `A x = b` in place for the last factored `A`: `rhs_and_solution` holds `b` on
    /// entry and `x` on success. The report carries the relative residual `‖b − A x‖ / ‖b‖`
    /// (one extra mat-vec). On `NotConverged` the buffer holds CG's last iterate; after any
    /// other error its content is unspecified.
    fn solve(&mut self, rhs_and_solution: &mut [f64]) -> Result<SolveReport, SolveError>;

    /// Solves `A x = rhs` with `x` as the initial guess (used by iterative solvers; direct
    /// solvers ignore it). `x` holds the solution on success.
    fn solve_with_guess(&mut self, rhs: &[f64], x: &mut [f64]) -> Result<SolveReport, SolveError> {
        if rhs.len() != x.len() {
            return Err(SolveError::DimensionMismatch {
                expected: rhs.len(),
                found: x.len(),
            });
        }
        x.copy_from_slice(rhs);
        self.solve(x)
    }

    /// The relative residual at which the next solves may stop when it is larger than the
    /// solver's own tolerance (an inexact Newton's forcing term); `None` restores the own
    /// tolerance. Iterative solvers only: a direct solver solves exactly and ignores it.
    fn set_forcing(&mut self, _forcing: Option<f64>) {}

    /// Whether [`Self::set_forcing`] loosens the next solves (an iterative solver). A Newton
    /// solve that stops at its iteration cap after such inexact directions is redone with
    /// exact ones, so the accepted state does not depend on the linear solver.
    fn honours_forcing(&self) -> bool {
        false
    }

    /// The current positions of the unknowns (stacked xyz per vertex), for preconditioners
    /// that build the rigid-body modes (AMG); called before `factor`. Default: ignored.
    fn set_coordinates(&mut self, _positions: &[f64]) {}

    /// Cumulative counters and timers since construction.
    fn stats(&self) -> &SolverStats;
}

/// Why a linear solve could not be done. Indices are in the caller's (original) ordering.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SolveError {
    /// A pivot was not positive: `A` is not (numerically) positive definite. `column` is in
    /// the original ordering (mapped back through the fill-reducing permutation): the first
    /// column, in elimination order, whose Schur complement pivot was ≤ 0. CG reports the
    /// column of a non-positive diagonal entry, if any.
    #[error("matrix is not positive definite (non-positive pivot at column {column})")]
    NotPositiveDefinite { column: usize },
    /// CG met a direction with `pᵀ A p ≤ 0`: `A` is not positive definite.
    #[error(
        "matrix is not positive definite (CG found pᵀAp = {curvature:e} at iteration {iteration})"
    )]
    NegativeCurvature { iteration: usize, curvature: f64 },
    /// An inertia-revealing factorization (LDLᵀ) succeeded, but `A` has `negative_pivots`
    /// negative eigenvalues where the caller needs it positive definite (a Newton step must
    /// be a descent direction). The solver never returns this itself; callers that require
    /// positive definiteness turn a [`FactorReport::negative_pivots`] into it.
    #[error("matrix is indefinite (LDLᵀ found {negative_pivots} negative pivot(s))")]
    Indefinite { negative_pivots: usize },
    /// LDLᵀ met an exactly zero pivot: `A` is singular. `column` in the original ordering.
    #[error("matrix is singular (zero pivot at column {column})")]
    SingularMatrix { column: usize },
    /// The matrix's pattern is not the analyzed one: call `analyze` with the new pattern.
    #[error(
        "matrix pattern ({found_dim}×{found_dim}, {found_nnz} entries) differs from the analyzed \
         pattern ({expected_dim}×{expected_dim}, {expected_nnz} entries); call analyze first"
    )]
    PatternMismatch {
        expected_dim: usize,
        expected_nnz: usize,
        found_dim: usize,
        found_nnz: usize,
    },
    /// A vector has the wrong length.
    #[error("vector has length {found}, expected {expected}")]
    DimensionMismatch { expected: usize, found: usize },
    /// CG did not reach its tolerance within its iteration cap.
    #[error(
        "CG did not converge: relative residual {relative_residual:e} after {iterations} iterations"
    )]
    NotConverged {
        iterations: usize,
        relative_residual: f64,
    },
    /// NaN or infinity in the input. `index` is the column for a matrix, the entry for a vector.
    #[error("non-finite value in the {input} at index {index}")]
    NonFiniteInput { input: &'static str, index: usize },
    /// A phase was called before the one it depends on (e.g. `solve` before a successful
    /// `factor`).
    #[error("{call} called before a successful {missing}")]
    OutOfOrder {
        call: &'static str,
        missing: &'static str,
    },
    /// The symbolic analysis failed (out of memory or index overflow).
    #[error("symbolic analysis failed: {0}")]
    Analysis(String),
}

impl crate::error_class::Classify for SolveError {
    /// A linear solve that failed (an indefinite matrix, no convergence) is a result.
    fn class(&self) -> crate::error_class::ErrorClass {
        crate::error_class::ErrorClass::Failure
    }
}

/// What one `factor` call did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FactorReport {
    /// Wall time of the numeric factorization or preconditioner setup.
    pub time: Duration,
    /// LDLᵀ only: negative entries of D, which by Sylvester's law of inertia is the number of
    /// negative eigenvalues of `A`. `Some(0)` means `A` is positive definite.
    pub negative_pivots: Option<usize>,
    /// CG with block-Jacobi: 3×3 diagonal blocks that were not SPD and fell back to their
    /// diagonal.
    pub fallback_blocks: usize,
    /// CG with IC(0): the shift `α` such that the incomplete factor of `A + α·diag(A)` exists
    /// (0 when the plain IC(0) exists).
    pub diagonal_shift: f64,
}

/// What one `solve` call did.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SolveReport {
    /// Iterations (1 for direct solvers).
    pub iterations: usize,
    /// `‖b − A x‖₂ / ‖b‖₂` from one symmetric mat-vec after the solve (0 when `b = 0`).
    pub relative_residual: f64,
    /// Wall time of the solve, residual check included.
    pub time: Duration,
    /// Wall time of the residual check alone.
    pub residual_time: Duration,
}

/// Cumulative counters and timers of one solver.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SolverStats {
    /// Symbolic analyses actually performed.
    pub analyses: usize,
    /// `analyze` calls answered by the previous analysis (same pattern).
    pub analyses_reused: usize,
    /// Successful numeric factorizations (or preconditioner setups).
    pub factorizations: usize,
    /// `factor` calls that failed.
    pub failed_factorizations: usize,
    /// Successful solves.
    pub solves: usize,
    /// Linear iterations summed over all solves (1 per direct solve).
    pub linear_iterations: usize,
    /// Time in `analyze`, `factor` and `solve`.
    pub analyze_time: Duration,
    pub factor_time: Duration,
    pub solve_time: Duration,
    /// Entries of the current factor's lower triangle, diagonal included: nnz(L) for direct
    /// solvers, the IC(0) factor for CG, 0 for other preconditioners.
    pub factor_nnz: usize,
    /// f64 values stored for the current factor (≥ `factor_nnz`: supernodes are stored as
    /// dense blocks).
    pub factor_storage: usize,
    /// Predicted flops of one numeric factorization (Σ c_j² over the factor's column counts;
    /// 0 for solvers without a factor).
    pub factor_flops: f64,
    /// The fill-reducing ordering of the current factor (`amd`, `metis`, `identity`), or the
    /// preconditioner of an iterative solver; empty before the first analysis.
    pub ordering: &'static str,
    /// Whether the current factorization runs on several threads.
    pub parallel_factor: bool,
    /// Who schedules the current numeric factorization: `subtrees`, `faer` or `sequential`
    /// (empty for solvers without a sparse factor).
    pub factor_scheduler: &'static str,
    /// What `auto` chose (the solver that did the work), or this solver's own name.
    pub chosen: &'static str,
    /// CG with AMG: the current hierarchy's shape and its builds and reuses (default
    /// otherwise).
    pub amg: AmgStats,
}
