//! Symmetric sparse matrices over the free DOFs: the pattern is built once per scene and the
//! values are refilled in place on every assembly.
//!
//! Storage is compressed sparse column with *both* triangles and sorted row indices, so the
//! same matrix serves mat-vec and CG directly, and Cholesky reads its lower triangle through a
//! zero-copy faer view.

use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};

/// The sparsity pattern of a symmetric `n × n` matrix (both triangles, rows sorted per column).
#[derive(Clone, Debug, PartialEq)]
pub struct SparsityPattern {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
}

impl SparsityPattern {
    /// From CSC arrays. Panics if they are inconsistent (a programming error, not user input).
    pub fn from_csc(n: usize, col_ptr: Vec<usize>, row_idx: Vec<usize>) -> Self {
        assert_eq!(col_ptr.len(), n + 1, "col_ptr must have n + 1 entries");
        assert_eq!(*col_ptr.last().unwrap(), row_idx.len());
        for c in 0..n {
            let rows = &row_idx[col_ptr[c]..col_ptr[c + 1]];
            assert!(
                rows.windows(2).all(|w| w[0] < w[1]),
                "rows must be sorted and unique"
            );
            assert!(rows.iter().all(|&r| r < n), "row index out of range");
        }
        Self {
            n,
            col_ptr,
            row_idx,
        }
    }

    /// Matrix dimension.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Number of stored entries (both triangles).
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// Column pointers (`dim() + 1` entries).
    pub fn col_ptr(&self) -> &[usize] {
        &self.col_ptr
    }

    /// Row indices, sorted within each column.
    pub fn row_idx(&self) -> &[usize] {
        &self.row_idx
    }

    /// Position of entry (row, col) in the value array, if stored.
    pub fn find(&self, row: usize, col: usize) -> Option<usize> {
        let start = self.col_ptr[col];
        let rows = &self.row_idx[start..self.col_ptr[col + 1]];
        rows.binary_search(&row).ok().map(|k| start + k)
    }

    /// A zero-copy faer view of the pattern.
    pub fn as_faer(&self) -> SymbolicSparseColMatRef<'_, usize> {
        SymbolicSparseColMatRef::new_checked(self.n, self.n, &self.col_ptr, None, &self.row_idx)
    }
}

/// A symmetric sparse matrix: a shared pattern plus one value per stored entry.
#[derive(Clone, Debug, PartialEq)]
pub struct SymmetricMatrix {
    pattern: std::sync::Arc<SparsityPattern>,
    values: Vec<f64>,
}

impl SymmetricMatrix {
    /// A zero matrix over `pattern`.
    pub fn zeros(pattern: std::sync::Arc<SparsityPattern>) -> Self {
        let values = vec![0.0; pattern.nnz()];
        Self { pattern, values }
    }

    /// The pattern (shared with every matrix assembled over it).
    pub fn pattern(&self) -> &std::sync::Arc<SparsityPattern> {
        &self.pattern
    }

    /// Matrix dimension.
    pub fn dim(&self) -> usize {
        self.pattern.n
    }

    /// Stored values, in pattern order.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Stored values, in pattern order, for refilling in place.
    pub fn values_mut(&mut self) -> &mut [f64] {
        &mut self.values
    }

    /// Entry (row, col), zero when not stored.
    pub fn get(&self, row: usize, col: usize) -> f64 {
        self.pattern.find(row, col).map_or(0.0, |k| self.values[k])
    }

    /// `y = A x`.
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) {
        assert_eq!(x.len(), self.dim());
        assert_eq!(y.len(), self.dim());
        y.fill(0.0);
        let p = &self.pattern;
        for (c, &xc) in x.iter().enumerate() {
            for k in p.col_ptr[c]..p.col_ptr[c + 1] {
                y[p.row_idx[k]] += self.values[k] * xc;
            }
        }
    }

    /// `self = a * self + b * other` over the same pattern (e.g. M + dt² K).
    pub fn axpby(&mut self, a: f64, b: f64, other: &SymmetricMatrix) {
        assert!(
            std::sync::Arc::ptr_eq(&self.pattern, &other.pattern) || self.pattern == other.pattern
        );
        for (s, o) in self.values.iter_mut().zip(&other.values) {
            *s = a * *s + b * *o;
        }
    }

    /// A dense copy (for tests and tiny systems).
    pub fn to_dense(&self) -> nalgebra::DMatrix<f64> {
        let n = self.dim();
        let mut d = nalgebra::DMatrix::zeros(n, n);
        let p = &self.pattern;
        for c in 0..n {
            for k in p.col_ptr[c]..p.col_ptr[c + 1] {
                d[(p.row_idx[k], c)] = self.values[k];
            }
        }
        d
    }

    /// Writes the matrix in Matrix Market coordinate format (`real symmetric`, the lower
    /// triangle, 1-based, values with 17 significant digits so they read back exactly), for
    /// other programs (CHOLMOD, SciPy) to factor the very matrix softbench solves.
    pub fn write_matrix_market(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        let p = &self.pattern;
        let lower: usize = (0..self.dim())
            .map(|c| {
                let rows = &p.row_idx[p.col_ptr[c]..p.col_ptr[c + 1]];
                rows.len() - rows.partition_point(|&r| r < c)
            })
            .sum();
        writeln!(w, "%%MatrixMarket matrix coordinate real symmetric")?;
        writeln!(w, "% written by softbench {}", env!("CARGO_PKG_VERSION"))?;
        writeln!(w, "{} {} {}", self.dim(), self.dim(), lower)?;
        for c in 0..self.dim() {
            for k in p.col_ptr[c]..p.col_ptr[c + 1] {
                let r = p.row_idx[k];
                if r >= c {
                    writeln!(w, "{} {} {:.16e}", r + 1, c + 1, self.values[k])?;
                }
            }
        }
        Ok(())
    }

    /// A zero-copy faer view (both triangles).
    pub fn as_faer(&self) -> SparseColMatRef<'_, usize, f64> {
        SparseColMatRef::new(self.pattern.as_faer(), &self.values)
    }

    /// A [`nalgebra_sparse::CscMatrix`] with the same entries (both triangles, rows sorted).
    ///
    /// One copy: `CscMatrix` owns its arrays, so the column offsets, row indices and values
    /// are copied once (O(nnz), no sorting or checking beyond nalgebra-sparse's own). The
    /// model's Hessian, damping and consistent mass matrices are `SymmetricMatrix`es, so
    /// `model.hessian(q, &mut h, options)` then `h.to_csc()` exports the Hessian; see
    /// [`crate::model::MassMatrix::to_csc`] for the mass.
    pub fn to_csc(&self) -> nalgebra_sparse::CscMatrix<f64> {
        nalgebra_sparse::CscMatrix::try_from_pattern_and_values(
            csc_pattern(&self.pattern),
            self.values.clone(),
        )
        .expect("one value per entry of a valid pattern")
    }
}

/// The nalgebra-sparse form of a pattern (one copy of its arrays).
pub(crate) fn csc_pattern(p: &SparsityPattern) -> nalgebra_sparse::pattern::SparsityPattern {
    nalgebra_sparse::pattern::SparsityPattern::try_from_offsets_and_indices(
        p.n,
        p.n,
        p.col_ptr.clone(),
        p.row_idx.clone(),
    )
    .expect("a SparsityPattern has sorted, in-range, unique rows per column")
}
