//! Dense Cholesky `A = L Lᵀ` in an nalgebra matrix: a reference independent of faer for
//! tests, and the cheapest choice for tiny systems (a few hundred DOFs at most: O(n³)).
//!
//! The factorization loop is written out (the same left-looking column algorithm as
//! `nalgebra::Cholesky`) so that a failure names its column and refactoring reuses the n×n
//! buffer allocated by `analyze`; the triangular solves are nalgebra's.

use std::sync::Arc;
use std::time::Instant;

use nalgebra::{DMatrix, DVectorViewMut};

use super::{
    Analyzed, FactorReport, LinearSolver, ResidualCheck, SolveError, SolveReport, SolverStats,
    check_rhs, finish_direct_solve, record_factor,
};
use crate::parallel::Parallelism;
use crate::sparse::{SparsityPattern, SymmetricMatrix};

/// Dense LLᵀ (no reordering, so a failing column is already in the original ordering).
pub struct DenseCholeskySolver {
    analyzed: Analyzed,
    /// L in the lower triangle after a successful `factor` (upper triangle unused).
    l: DMatrix<f64>,
    b: Vec<f64>,
    ax: Vec<f64>,
    stats: SolverStats,
}

impl Default for DenseCholeskySolver {
    fn default() -> Self {
        Self::new()
    }
}

impl DenseCholeskySolver {
    /// Largest dimension `analyze` accepts (an n×n buffer of 8 n² bytes: 128 MB here).
    pub const MAX_DIM: usize = 4096;

    /// A solver; the n×n buffer is allocated by `analyze`.
    pub fn new() -> Self {
        Self {
            analyzed: Analyzed::default(),
            l: DMatrix::zeros(0, 0),
            b: Vec::new(),
            ax: Vec::new(),
            stats: SolverStats::default(),
        }
    }

    fn factor_inner(&mut self, a: &SymmetricMatrix) -> Result<(), SolveError> {
        let a = self.analyzed.load(a)?;
        let l = &mut self.l;
        l.fill(0.0);
        let p = a.pattern();
        for c in 0..a.dim() {
            for k in p.col_ptr()[c]..p.col_ptr()[c + 1] {
                l[(p.row_idx()[k], c)] = a.values()[k];
            }
        }
        cholesky_in_place(l).map_err(|column| SolveError::NotPositiveDefinite { column })?;
        self.analyzed.factored = true;
        Ok(())
    }
}

/// Left-looking LLᵀ on the lower triangle of `m`; `Err(j)` if pivot `j` is not positive.
fn cholesky_in_place(m: &mut DMatrix<f64>) -> Result<(), usize> {
    let n = m.nrows();
    for j in 0..n {
        for k in 0..j {
            let factor = -m[(j, k)];
            let (mut col_j, col_k) = m.columns_range_pair_mut(j, k);
            col_j
                .rows_range_mut(j..)
                .axpy(factor, &col_k.rows_range(j..), 1.0);
        }
        let d = m[(j, j)];
        if !(d > 0.0 && d.is_finite()) {
            return Err(j);
        }
        let d = d.sqrt();
        m[(j, j)] = d;
        m.view_range_mut(j + 1.., j).unscale_mut(d);
    }
    Ok(())
}

impl LinearSolver for DenseCholeskySolver {
    fn name(&self) -> &'static str {
        "dense"
    }

    fn analyze(&mut self, pattern: &Arc<SparsityPattern>) -> Result<(), SolveError> {
        let start = Instant::now();
        if self.analyzed.is_current(pattern) {
            self.stats.analyses_reused += 1;
        } else {
            let n = pattern.dim();
            if n > Self::MAX_DIM {
                return Err(SolveError::Analysis(format!(
                    "dense solver is for tiny systems: dimension {n} exceeds {}",
                    Self::MAX_DIM
                )));
            }
            self.l = DMatrix::zeros(n, n);
            self.analyzed.set(pattern);
            self.b = vec![0.0; n];
            self.ax = vec![0.0; n];
            self.stats.factor_nnz = n * (n + 1) / 2;
            self.stats.factor_storage = n * n;
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
        self.b.copy_from_slice(x);
        let n = x.len();
        let mut v = DVectorViewMut::from_slice(x, n);
        // The diagonal of L is positive (checked by `factor`), so the unchecked solves are safe.
        self.l.solve_lower_triangular_unchecked_mut(&mut v);
        self.l.tr_solve_lower_triangular_unchecked_mut(&mut v);
        let check = ResidualCheck {
            a,
            b: &self.b,
            x,
            ax: &mut self.ax,
            parallelism: Parallelism::Sequential,
        };
        Ok(finish_direct_solve(check, start, &mut self.stats))
    }

    fn stats(&self) -> &SolverStats {
        &self.stats
    }
}
