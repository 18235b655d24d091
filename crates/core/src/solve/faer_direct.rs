//! faer's sparse direct solvers, one backend over both factorizations: `A = L Lᵀ`
//! ([`Llt`], the workhorse for the SPD systems of implicit integrators with projected
//! Hessians) and `A = L D Lᵀ` without pivoting ([`Ldlt`], for symmetric systems that may be
//! indefinite). AMD ordering, supernodal when it pays.
//!
//! `analyze` orders and symbolically factors the pattern once and allocates the factor's
//! values, the scratch memory (sized from faer's `*_scratch` functions) and the residual
//! buffers; `factor` and `solve` then allocate nothing (the very first numeric factorization
//! on a thread lets faer's dense kernels set up per-thread state once). What differs between
//! the two is a [`Factorization`]: the numeric phase, how a failed pivot is reported and the
//! triangular solves.
//!
//! LDLᵀ succeeds on indefinite matrices without saying so, so every LDLᵀ `factor` counts the
//! negative entries of D ([`FactorReport::negative_pivots`]): by Sylvester's law of inertia
//! that is the number of negative eigenvalues of `A`. Its contract is to factor any symmetric
//! nonsingular matrix and report its inertia; a caller that needs `A` positive definite acts
//! on the count (the implicit integrators' system falls back to projected Hessians, as on a
//! failed Cholesky pivot). Without pivoting the factorization can be unstable on strongly
//! indefinite matrices; the residual in each [`SolveReport`] shows it.

use std::marker::PhantomData;
use std::sync::Arc;
use std::time::Instant;

use faer::dyn_stack::MemStack;
use faer::linalg::cholesky::ldlt::factor::{LdltError, LdltRegularization};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization};
use faer::reborrow::ReborrowMut;
use faer::sparse::linalg::cholesky::supernodal::SupernodalLdltRef;
use faer::sparse::linalg::cholesky::{LdltRef, LltRef, SymbolicCholeskyRaw};
use faer::{Conj, MatMut, Side};

use super::faer_common::{FaerFactor, ScratchKind, SymbolicAnalysis};
use super::{
    Analyzed, DirectSettings, FactorReport, LinearSolver, ResidualCheck, SolveError, SolveReport,
    SolverStats, check_rhs, finish_direct_solve, record_factor,
};
use crate::sparse::{SparsityPattern, SymmetricMatrix};

/// Tasks of a triangular solve. faer's parallel supernodal solve splits its sums by the task
/// count it is given, so a count tied to the pool (`Par::rayon(0)`) changed the last bits of
/// 15,593 of the 49k-tet box's 27,744 solution entries between one thread and two. A fixed
/// count gives the same bits on any pool and in sequential runs (on one thread the tasks run
/// one after the other; a sequential run of `--jobs` > 1 lends its solves to the pool) and
/// keeps what a second thread gives faer's solve (1.15-1.18x on that box in the `solve` table of
/// `cargo bench --bench thread_crossover` at f591ffd, before the subtree-scheduled factor got
/// its own solve). Used by LDLᵀ and factors on faer's loop.
const SOLVE_TASKS: usize = 2;

fn solve_par() -> faer::Par {
    faer::Par::rayon(SOLVE_TASKS)
}

/// A numeric factorization of faer's symbolic Cholesky structure.
pub trait Factorization: Send + 'static {
    /// The solver's name (as in the registry).
    const NAME: &'static str;
    /// Which numeric phase the scratch memory must fit.
    const SCRATCH: ScratchKind;
    /// Numeric factorization of `a` into `f`'s storage; the report of a success (LDLᵀ: the
    /// inertia), or the typed failure with the column in the original ordering.
    fn factor(f: &mut FaerFactor, a: &SymmetricMatrix) -> Result<FactorReport, SolveError>;
    /// Solves in place with the factor in `f`.
    fn solve(f: &mut FaerFactor, x: MatMut<'_, f64>);
}

/// `A = L Lᵀ`. A non-positive pivot is `NotPositiveDefinite` with the column in the original
/// ordering.
pub struct Llt;

impl Factorization for Llt {
    const NAME: &'static str = "cholesky";
    const SCRATCH: ScratchKind = ScratchKind::Llt;

    fn factor(f: &mut FaerFactor, a: &SymmetricMatrix) -> Result<FactorReport, SolveError> {
        if let Some(result) = f.factor_subtrees(a.values()) {
            return match result {
                Ok(()) => Ok(FactorReport::default()),
                Err(index) => Err(SolveError::NotPositiveDefinite {
                    column: f.original_column(index),
                }),
            };
        }
        let result = f.symbolic.factorize_numeric_llt(
            &mut f.values,
            a.as_faer(),
            Side::Lower,
            LltRegularization::default(),
            f.par,
            MemStack::new(&mut f.mem),
            Default::default(),
        );
        match result {
            Ok(_) => Ok(FactorReport::default()),
            Err(LltError::NonPositivePivot { index }) => Err(SolveError::NotPositiveDefinite {
                column: f.original_column(index),
            }),
        }
    }

    fn solve(f: &mut FaerFactor, mut x: MatMut<'_, f64>) {
        // A subtree-scheduled factor has its own solve (parallel over subtrees, the same bits
        // on any thread count); faer's otherwise.
        if f.solve_subtrees(x.rb_mut()) {
            return;
        }
        LltRef::new(&f.symbolic, &f.values).solve_in_place_with_conj(
            Conj::No,
            x,
            solve_par(),
            MemStack::new(&mut f.mem),
        );
    }
}

/// `A = L D Lᵀ` without pivoting, reporting the inertia. An exactly zero (or non-finite)
/// pivot is `SingularMatrix` with the column in the original ordering.
pub struct Ldlt;

impl Factorization for Ldlt {
    const NAME: &'static str = "ldlt";
    const SCRATCH: ScratchKind = ScratchKind::Ldlt;

    fn factor(f: &mut FaerFactor, a: &SymmetricMatrix) -> Result<FactorReport, SolveError> {
        let result = f.symbolic.factorize_numeric_ldlt(
            &mut f.values,
            a.as_faer(),
            Side::Lower,
            LdltRegularization::default(),
            f.par,
            MemStack::new(&mut f.mem),
            Default::default(),
        );
        if let Err(LdltError::ZeroPivot { index }) = result {
            return Err(SolveError::SingularMatrix {
                column: f.original_column(index),
            });
        }
        Ok(FactorReport {
            negative_pivots: Some(negative_pivots(f)),
            ..Default::default()
        })
    }

    fn solve(f: &mut FaerFactor, x: MatMut<'_, f64>) {
        LdltRef::new(&f.symbolic, &f.values).solve_in_place_with_conj(
            Conj::No,
            x,
            solve_par(),
            MemStack::new(&mut f.mem),
        );
    }
}

/// Negative entries of D. D sits on the diagonal of L's storage: first entry of each column
/// (simplicial), diagonal of each supernode's leading block (supernodal).
fn negative_pivots(f: &FaerFactor) -> usize {
    match f.symbolic.raw() {
        SymbolicCholeskyRaw::Simplicial(s) => s.col_ptr()[..s.ncols()]
            .iter()
            .filter(|&&p| f.values[p] < 0.0)
            .count(),
        SymbolicCholeskyRaw::Supernodal(s) => {
            let l = SupernodalLdltRef::new(s, &f.values);
            (0..s.n_supernodes())
                .map(|k| {
                    let block = l.supernode(k).val();
                    (0..block.ncols()).filter(|&j| block[(j, j)] < 0.0).count()
                })
                .sum()
        }
    }
}

/// A faer sparse direct solver with the factorization `F`.
pub struct FaerDirectSolver<F: Factorization> {
    settings: DirectSettings,
    analyzed: Analyzed,
    factor: Option<FaerFactor>,
    /// Copy of `b` and `A x` for the residual check.
    b: Vec<f64>,
    ax: Vec<f64>,
    stats: SolverStats,
    factorization: PhantomData<F>,
}

/// Sparse LLᵀ (`cholesky`).
pub type CholeskySolver = FaerDirectSolver<Llt>;

/// Sparse LDLᵀ (`ldlt`), reporting the inertia.
pub type LdltSolver = FaerDirectSolver<Ldlt>;

impl<F: Factorization> FaerDirectSolver<F> {
    /// A solver with the given settings; nothing is allocated before `analyze`.
    pub fn new(settings: DirectSettings) -> Self {
        Self {
            settings,
            analyzed: Analyzed::default(),
            factor: None,
            b: Vec::new(),
            ax: Vec::new(),
            stats: SolverStats::default(),
            factorization: PhantomData,
        }
    }

    /// `analyze`, with the symbolic analysis already done by the caller (`Some`) or done here.
    pub(crate) fn analyze_with(
        &mut self,
        pattern: &Arc<SparsityPattern>,
        analysis: Option<SymbolicAnalysis>,
    ) -> Result<(), SolveError> {
        let start = Instant::now();
        if self.analyzed.is_current(pattern) {
            self.stats.analyses_reused += 1;
        } else {
            let analysis = match analysis {
                Some(a) => a,
                None => SymbolicAnalysis::new(pattern, &self.settings)?,
            };
            let f = FaerFactor::allocate(pattern, analysis, &self.settings, F::SCRATCH)?;
            self.stats.factor_nnz = f.nnz;
            self.stats.factor_storage = f.values.len();
            self.stats.factor_flops = f.flops;
            self.stats.ordering = f.ordering.name();
            self.stats.parallel_factor = f.is_parallel();
            self.stats.factor_scheduler = f.scheduler_name();
            self.stats.chosen = F::NAME;
            self.factor = Some(f);
            self.analyzed.set(pattern);
            self.b = vec![0.0; pattern.dim()];
            self.ax = vec![0.0; pattern.dim()];
            self.stats.analyses += 1;
        }
        self.stats.analyze_time += start.elapsed();
        Ok(())
    }

    fn factor_inner(&mut self, a: &SymmetricMatrix) -> Result<FactorReport, SolveError> {
        let a = self.analyzed.load(a)?;
        let f = self
            .factor
            .as_mut()
            .expect("load succeeds only after an analysis");
        let report = F::factor(f, a)?;
        self.analyzed.factored = true;
        Ok(report)
    }
}

impl<F: Factorization> LinearSolver for FaerDirectSolver<F> {
    fn name(&self) -> &'static str {
        F::NAME
    }

    fn analyze(&mut self, pattern: &Arc<SparsityPattern>) -> Result<(), SolveError> {
        self.analyze_with(pattern, None)
    }

    fn factor(&mut self, a: &SymmetricMatrix) -> Result<FactorReport, SolveError> {
        let start = Instant::now();
        let result = self.factor_inner(a);
        record_factor(&mut self.stats, start.elapsed(), result)
    }

    fn solve(&mut self, x: &mut [f64]) -> Result<SolveReport, SolveError> {
        let start = Instant::now();
        let a = self.analyzed.factored_matrix()?;
        check_rhs(x, a.dim())?;
        let f = self.factor.as_mut().expect("factored implies analyzed");
        self.b.copy_from_slice(x);
        let n = x.len();
        F::solve(f, MatMut::from_column_major_slice_mut(x, n, 1));
        let check = ResidualCheck {
            a,
            b: &self.b,
            x,
            ax: &mut self.ax,
            parallelism: self.settings.parallelism,
        };
        Ok(finish_direct_solve(check, start, &mut self.stats))
    }

    fn stats(&self) -> &SolverStats {
        &self.stats
    }
}
