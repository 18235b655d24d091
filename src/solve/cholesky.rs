//! Sparse Cholesky `A = L Lᵀ` (faer, AMD ordering, supernodal when it pays): the workhorse
//! for the SPD systems of implicit integrators with projected Hessians.
//!
//! `analyze` orders and symbolically factors the pattern once and allocates the factor's
//! values, the scratch memory (sized from faer's `*_scratch` functions) and the residual
//! buffers; `factor` and `solve` then allocate nothing (the very first numeric factorization
//! on a thread lets faer's dense kernels set up per-thread state once).

use std::sync::Arc;
use std::time::Instant;

use faer::dyn_stack::MemStack;
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization};
use faer::sparse::linalg::cholesky::LltRef;
use faer::{Conj, MatMut, Side};

use super::faer_common::{Factorization, FaerFactor};
use super::{
    Analyzed, DirectSettings, FactorReport, LinearSolver, ResidualCheck, SolveError, SolveReport,
    SolverStats, check_rhs, finish_direct_solve, record_factor,
};
use crate::sparse::{SparsityPattern, SymmetricMatrix};

/// Sparse LLᵀ. A non-positive pivot is `NotPositiveDefinite` with the column in the original
/// ordering.
pub struct CholeskySolver {
    settings: DirectSettings,
    analyzed: Analyzed,
    factor: Option<FaerFactor>,
    /// Copy of `b` and `A x` for the residual check.
    b: Vec<f64>,
    ax: Vec<f64>,
    stats: SolverStats,
}

impl CholeskySolver {
    /// A solver with the given settings; nothing is allocated before `analyze`.
    pub fn new(settings: DirectSettings) -> Self {
        Self {
            settings,
            analyzed: Analyzed::default(),
            factor: None,
            b: Vec::new(),
            ax: Vec::new(),
            stats: SolverStats::default(),
        }
    }

    fn factor_inner(&mut self, a: &SymmetricMatrix) -> Result<(), SolveError> {
        let a = self.analyzed.load(a)?;
        let f = self
            .factor
            .as_mut()
            .expect("load succeeds only after an analysis");
        let stack = MemStack::new(&mut f.mem);
        let result = f.symbolic.factorize_numeric_llt(
            &mut f.values,
            a.as_faer(),
            Side::Lower,
            LltRegularization::default(),
            f.par,
            stack,
            Default::default(),
        );
        match result {
            Ok(_) => {
                self.analyzed.factored = true;
                Ok(())
            }
            Err(LltError::NonPositivePivot { index }) => Err(SolveError::NotPositiveDefinite {
                column: f.original_column(index),
            }),
        }
    }
}

impl LinearSolver for CholeskySolver {
    fn name(&self) -> &'static str {
        "cholesky"
    }

    fn analyze(&mut self, pattern: &Arc<SparsityPattern>) -> Result<(), SolveError> {
        let start = Instant::now();
        if self.analyzed.is_current(pattern) {
            self.stats.analyses_reused += 1;
        } else {
            let f = FaerFactor::analyze(pattern, &self.settings, Factorization::Llt)?;
            self.stats.factor_nnz = f.nnz;
            self.stats.factor_storage = f.values.len();
            self.factor = Some(f);
            self.analyzed.set(pattern);
            self.b = vec![0.0; pattern.dim()];
            self.ax = vec![0.0; pattern.dim()];
            self.stats.analyses += 1;
        }
        self.stats.analyze_time += start.elapsed();
        Ok(())
    }

    fn factor(&mut self, a: &SymmetricMatrix) -> Result<FactorReport, SolveError> {
        let start = Instant::now();
        let result = self.factor_inner(a).map(|()| FactorReport::default());
        record_factor(&mut self.stats, start.elapsed(), result)
    }

    fn solve(&mut self, x: &mut [f64]) -> Result<SolveReport, SolveError> {
        let start = Instant::now();
        let a = self.analyzed.factored_matrix()?;
        check_rhs(x, a.dim())?;
        let f = self.factor.as_mut().expect("factored implies analyzed");
        self.b.copy_from_slice(x);
        let n = x.len();
        LltRef::new(&f.symbolic, &f.values).solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(x, n, 1),
            f.par,
            MemStack::new(&mut f.mem),
        );
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
