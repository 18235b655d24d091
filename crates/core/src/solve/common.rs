//! Helpers every backend shares: pattern bookkeeping with the copy of the factored matrix,
//! input checks, the symmetric mat-vec and the residual check.

use std::sync::Arc;

use super::SolveError;
use crate::parallel::Parallelism;
use crate::sparse::{SparsityPattern, SymmetricMatrix};

/// The analyzed pattern and a copy of the last factored matrix's values.
#[derive(Debug, Default)]
pub(crate) struct Analyzed {
    /// The pattern of the last analysis, and the matrix copy (values over it).
    matrix: Option<SymmetricMatrix>,
    /// True after a successful `factor`, false after a failed one or a new analysis.
    pub factored: bool,
}

impl Analyzed {
    /// True if `pattern` is the analyzed one (same `Arc` or same content); adopts the new `Arc`.
    pub fn is_current(&mut self, pattern: &Arc<SparsityPattern>) -> bool {
        let Some(m) = &self.matrix else { return false };
        if Arc::ptr_eq(m.pattern(), pattern) {
            return true;
        }
        if **m.pattern() == **pattern {
            let values = m.values().to_vec();
            let mut adopted = SymmetricMatrix::zeros(pattern.clone());
            adopted.values_mut().copy_from_slice(&values);
            self.matrix = Some(adopted);
            return true;
        }
        false
    }

    /// Records a new analysis of `pattern` (allocates the matrix copy).
    pub fn set(&mut self, pattern: &Arc<SparsityPattern>) {
        self.matrix = Some(SymmetricMatrix::zeros(pattern.clone()));
        self.factored = false;
    }

    /// Checks `a` against the analyzed pattern and for non-finite values, then copies its
    /// values. Marks the solver unfactored until the caller succeeds.
    pub fn load(&mut self, a: &SymmetricMatrix) -> Result<&SymmetricMatrix, SolveError> {
        self.factored = false;
        let Some(m) = &mut self.matrix else {
            return Err(SolveError::OutOfOrder {
                call: "factor",
                missing: "analyze",
            });
        };
        let (p, q) = (m.pattern(), a.pattern());
        if !Arc::ptr_eq(p, q) && **p != **q {
            return Err(SolveError::PatternMismatch {
                expected_dim: p.dim(),
                expected_nnz: p.nnz(),
                found_dim: q.dim(),
                found_nnz: q.nnz(),
            });
        }
        check_matrix_finite(a)?;
        m.values_mut().copy_from_slice(a.values());
        Ok(m)
    }

    /// The last factored matrix, if `factor` succeeded since the last analysis.
    pub fn factored_matrix(&self) -> Result<&SymmetricMatrix, SolveError> {
        match (&self.matrix, self.factored) {
            (Some(m), true) => Ok(m),
            _ => Err(SolveError::OutOfOrder {
                call: "solve",
                missing: "factor",
            }),
        }
    }
}

/// `NonFiniteInput` with the column of the first NaN/∞ value of `a`.
pub(crate) fn check_matrix_finite(a: &SymmetricMatrix) -> Result<(), SolveError> {
    if let Some(k) = a.values().iter().position(|v| !v.is_finite()) {
        let col = a.pattern().col_ptr().partition_point(|&p| p <= k) - 1;
        return Err(SolveError::NonFiniteInput {
            input: "matrix",
            index: col,
        });
    }
    Ok(())
}

/// Checks a right-hand side's length and values.
pub(crate) fn check_rhs(b: &[f64], n: usize) -> Result<(), SolveError> {
    if b.len() != n {
        return Err(SolveError::DimensionMismatch {
            expected: n,
            found: b.len(),
        });
    }
    if let Some(i) = b.iter().position(|v| !v.is_finite()) {
        return Err(SolveError::NonFiniteInput {
            input: "right-hand side",
            index: i,
        });
    }
    Ok(())
}

/// `y = A x` for a symmetric `A` stored with both triangles: row `c` equals column `c`, so
/// each `y[c]` is a gather over column `c` (written once, no scatter, bitwise identical for
/// every [`Parallelism`]). Panics if the lengths of `x` or `y` differ from `A`'s dimension.
pub fn symmetric_mul_vec(a: &SymmetricMatrix, x: &[f64], y: &mut [f64], parallelism: Parallelism) {
    let p = a.pattern();
    let (col_ptr, row_idx, vals) = (p.col_ptr(), p.row_idx(), a.values());
    assert_eq!(x.len(), p.dim());
    assert_eq!(y.len(), p.dim());
    let column = |c: usize| -> f64 {
        let (s, e) = (col_ptr[c], col_ptr[c + 1]);
        row_idx[s..e]
            .iter()
            .zip(&vals[s..e])
            .map(|(&r, &v)| v * x[r])
            .sum()
    };
    // Rows below which one thread is faster (`cargo bench --bench thread_crossover -- matvec`:
    // 0.82–1.00x at 2688 rows, 0.98–1.63x at 7260 and 1.42–1.68x at 27744 in three runs, called
    // from outside rayon's pool).
    const MIN_PARALLEL_ROWS: usize = 4096;
    let parallelism = if y.len() < MIN_PARALLEL_ROWS {
        Parallelism::Sequential
    } else {
        parallelism
    };
    match parallelism {
        Parallelism::Sequential => y.iter_mut().enumerate().for_each(|(c, yc)| *yc = column(c)),
        Parallelism::Rayon => {
            use rayon::prelude::*;
            const CHUNK: usize = 2048;
            y.par_chunks_mut(CHUNK).enumerate().for_each(|(k, chunk)| {
                for (i, yc) in chunk.iter_mut().enumerate() {
                    *yc = column(k * CHUNK + i);
                }
            });
        }
    }
}

/// Euclidean dot product (sequential, so results are reproducible).
pub(crate) fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}

/// Euclidean norm.
pub(crate) fn norm(x: &[f64]) -> f64 {
    dot(x, x).sqrt()
}

/// `‖b − A x‖ / ‖b‖` (absolute residual when `b = 0`), using `ax` as scratch.
pub(crate) fn relative_residual(
    a: &SymmetricMatrix,
    b: &[f64],
    x: &[f64],
    ax: &mut [f64],
    parallelism: Parallelism,
) -> f64 {
    symmetric_mul_vec(a, x, ax, parallelism);
    let r2: f64 = b
        .iter()
        .zip(ax.iter())
        .map(|(bi, ai)| (bi - ai) * (bi - ai))
        .sum();
    let bn = norm(b);
    if bn > 0.0 { r2.sqrt() / bn } else { r2.sqrt() }
}

/// Record a `factor` call that took `time` in `stats`: counts and time, and the time in the
/// report (every backend's `factor` ends this way).
pub(crate) fn record_factor(
    stats: &mut super::SolverStats,
    time: std::time::Duration,
    result: Result<super::FactorReport, SolveError>,
) -> Result<super::FactorReport, SolveError> {
    stats.factor_time += time;
    match result {
        Ok(report) => {
            stats.factorizations += 1;
            Ok(super::FactorReport { time, ..report })
        }
        Err(e) => {
            stats.failed_factorizations += 1;
            Err(e)
        }
    }
}

/// The end of a direct solve started at `start`: the residual `‖b − A x‖ / ‖b‖` (one
/// mat-vec into `ax`), the report (1 iteration) and the stats.
pub(crate) fn finish_direct_solve(
    residual: ResidualCheck<'_>,
    start: std::time::Instant,
    stats: &mut super::SolverStats,
) -> super::SolveReport {
    let residual_start = std::time::Instant::now();
    let relative_residual = relative_residual(
        residual.a,
        residual.b,
        residual.x,
        residual.ax,
        residual.parallelism,
    );
    let report = super::SolveReport {
        iterations: 1,
        relative_residual,
        time: start.elapsed(),
        residual_time: residual_start.elapsed(),
    };
    stats.solves += 1;
    stats.linear_iterations += 1;
    stats.solve_time += report.time;
    report
}

/// What a residual check reads: `A`, the right-hand side, the solution and a buffer.
pub(crate) struct ResidualCheck<'a> {
    pub a: &'a SymmetricMatrix,
    pub b: &'a [f64],
    pub x: &'a [f64],
    pub ax: &'a mut [f64],
    pub parallelism: Parallelism,
}
