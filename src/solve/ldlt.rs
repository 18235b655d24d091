//! Sparse `A = L D Lᵀ` without pivoting (faer, AMD ordering, supernodal when it pays): for
//! symmetric systems that may be indefinite.
//!
//! LDLᵀ succeeds on indefinite matrices without saying so, so every `factor` counts the
//! negative entries of D ([`FactorReport::negative_pivots`]): by Sylvester's law of inertia
//! that is the number of negative eigenvalues of `A`. The solver's contract is to factor any
//! symmetric nonsingular matrix and report its inertia; a caller that needs `A` positive
//! definite acts on the count (the implicit integrators' system falls back to projected
//! Hessians, as on a failed Cholesky pivot). Without pivoting the factorization can
//! be unstable on strongly indefinite matrices; the residual in each [`SolveReport`] shows it.
//! Storage is allocated by `analyze` as for [`super::cholesky`].

use std::sync::Arc;
use std::time::Instant;

use faer::dyn_stack::MemStack;
use faer::linalg::cholesky::ldlt::factor::{LdltError, LdltRegularization};
use faer::sparse::linalg::cholesky::supernodal::SupernodalLdltRef;
use faer::sparse::linalg::cholesky::{LdltRef, SymbolicCholeskyRaw};
use faer::{Conj, MatMut, Side};

use super::faer_common::{Factorization, FaerFactor};
use super::{
    Analyzed, DirectSettings, FactorReport, LinearSolver, ResidualCheck, SolveError, SolveReport,
    SolverStats, check_rhs, finish_direct_solve, record_factor,
};
use crate::sparse::{SparsityPattern, SymmetricMatrix};

/// Sparse LDLᵀ. An exactly zero (or non-finite) pivot is `SingularMatrix` with the column in
/// the original ordering.
pub struct LdltSolver {
    settings: DirectSettings,
    analyzed: Analyzed,
    factor: Option<FaerFactor>,
    b: Vec<f64>,
    ax: Vec<f64>,
    stats: SolverStats,
}

impl LdltSolver {
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

    /// Factors and returns the number of negative pivots.
    fn factor_inner(&mut self, a: &SymmetricMatrix) -> Result<usize, SolveError> {
        let a = self.analyzed.load(a)?;
        let f = self
            .factor
            .as_mut()
            .expect("load succeeds only after an analysis");
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
        self.analyzed.factored = true;
        Ok(negative_pivots(f))
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

impl LinearSolver for LdltSolver {
    fn name(&self) -> &'static str {
        "ldlt"
    }

    fn analyze(&mut self, pattern: &Arc<SparsityPattern>) -> Result<(), SolveError> {
        let start = Instant::now();
        if self.analyzed.is_current(pattern) {
            self.stats.analyses_reused += 1;
        } else {
            let f = FaerFactor::analyze(pattern, &self.settings, Factorization::Ldlt)?;
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
        let result = self.factor_inner(a).map(|negative| FactorReport {
            negative_pivots: Some(negative),
            ..Default::default()
        });
        record_factor(&mut self.stats, start.elapsed(), result)
    }

    fn solve(&mut self, x: &mut [f64]) -> Result<SolveReport, SolveError> {
        let start = Instant::now();
        let a = self.analyzed.factored_matrix()?;
        check_rhs(x, a.dim())?;
        let f = self.factor.as_mut().expect("factored implies analyzed");
        self.b.copy_from_slice(x);
        let n = x.len();
        LdltRef::new(&f.symbolic, &f.values).solve_in_place_with_conj(
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
