//! CG preconditioners: `analyze` finds where their entries live in the pattern and allocates
//! their storage; `setup` refills it from a matrix (no allocation); `apply` computes
//! `z = M⁻¹ r` (no allocation).
//!
//! Every setup first checks the diagonal: an SPD matrix has a positive diagonal, so a
//! non-positive diagonal entry is reported as `NotPositiveDefinite` at that column.

use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

use super::amg::{Amg, AmgSettings, AmgStats};
use super::{FactorReport, SolveError};
use crate::parallel::Parallelism;
use crate::sparse::{SparsityPattern, SymmetricMatrix};

/// CG preconditioners, all SPD when `A` is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Preconditioner {
    /// No preconditioning.
    None,
    /// `M = diag(A)`.
    Jacobi,
    /// `M` = the 3×3 diagonal blocks of `A` (DOFs `3v..3v+3`), each inverted once per factor;
    /// a block that is not SPD falls back to its diagonal. Trailing `n mod 3` DOFs use Jacobi.
    #[default]
    BlockJacobi3,
    /// Zero fill-in incomplete Cholesky IC(0) in the caller's ordering; if it breaks down,
    /// of `A + α·diag(A)` for the smallest α in 1e-3·2^k that works (reported per factor).
    IncompleteCholesky,
    /// Smoothed-aggregation algebraic multigrid, one symmetric V-cycle per application, with
    /// the rigid-body modes at the current positions as the near-null space (translations
    /// only when the solver is given no positions). Iterations stay nearly flat as the mesh
    /// grows.
    Amg,
}

impl Preconditioner {
    /// The name as written in a scene file.
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Jacobi => "jacobi",
            Self::BlockJacobi3 => "block_jacobi3",
            Self::IncompleteCholesky => "incomplete_cholesky",
            Self::Amg => "amg",
        }
    }
}

const NONE: usize = usize::MAX;

/// Diagonal shifts tried, in order, until IC(0) of `A + α·diag(A)` exists.
const IC_SHIFTS: [f64; 13] = [
    0.0, 1e-3, 2e-3, 4e-3, 8e-3, 1.6e-2, 3.2e-2, 6.4e-2, 0.128, 0.256, 0.512, 1.024, 2.048,
];

/// A preconditioner's storage and setup state.
pub(crate) enum PrecondState {
    Identity,
    Jacobi {
        diag_pos: Vec<usize>,
        inv_diag: Vec<f64>,
    },
    BlockJacobi3 {
        diag_pos: Vec<usize>,
        /// Positions of each 3×3 diagonal block's entries, column-major (`NONE` if not stored).
        block_pos: Vec<[usize; 9]>,
        /// Inverse of each block (or of its diagonal, after a fallback), column-major.
        block_inv: Vec<Matrix3<f64>>,
        /// Inverse diagonal for the `n mod 3` trailing DOFs.
        tail_inv: Vec<f64>,
    },
    Ic0(Ic0),
    Amg(Box<Amg>),
}

impl PrecondState {
    /// Allocates the storage of `kind` for `pattern`.
    /// `amg` configures the AMG preconditioner (ignored by the others).
    /// `parallelism` is AMG's (the others run on the calling thread).
    pub fn analyze(
        kind: Preconditioner,
        amg: AmgSettings,
        parallelism: Parallelism,
        pattern: &SparsityPattern,
    ) -> Self {
        let n = pattern.dim();
        let diag_pos = || {
            (0..n)
                .map(|i| pattern.find(i, i).unwrap_or(NONE))
                .collect::<Vec<_>>()
        };
        match kind {
            Preconditioner::None => Self::Identity,
            Preconditioner::Jacobi => Self::Jacobi {
                diag_pos: diag_pos(),
                inv_diag: vec![0.0; n],
            },
            Preconditioner::BlockJacobi3 => {
                let nb = n / 3;
                let block_pos = (0..nb)
                    .map(|v| {
                        let mut pos = [NONE; 9];
                        for j in 0..3 {
                            for i in 0..3 {
                                pos[3 * j + i] = pattern.find(3 * v + i, 3 * v + j).unwrap_or(NONE);
                            }
                        }
                        pos
                    })
                    .collect();
                Self::BlockJacobi3 {
                    diag_pos: diag_pos(),
                    block_pos,
                    block_inv: vec![Matrix3::zeros(); nb],
                    tail_inv: vec![0.0; n - 3 * nb],
                }
            }
            Preconditioner::IncompleteCholesky => Self::Ic0(Ic0::analyze(pattern)),
            Preconditioner::Amg => Self::Amg(Box::new(Amg::new(amg, parallelism))),
        }
    }

    /// Entries of the stored factor (IC(0) only; 0 for the others).
    pub fn factor_nnz(&self) -> usize {
        match self {
            Self::Ic0(ic) => ic.row_idx.len(),
            _ => 0,
        }
    }

    /// AMG's hierarchy shape and build/reuse counts (`None` for the other preconditioners).
    pub fn amg_stats(&self) -> Option<AmgStats> {
        match self {
            Self::Amg(amg) => Some(amg.stats),
            _ => None,
        }
    }

    /// Builds `M` from `a` (whose pattern is the analyzed one). Fills `fallback_blocks` and
    /// `diagonal_shift` of the report.
    pub fn setup(
        &mut self,
        a: &SymmetricMatrix,
        report: &mut FactorReport,
    ) -> Result<(), SolveError> {
        let v = a.values();
        let diag = |pos: &[usize], i: usize| if pos[i] == NONE { 0.0 } else { v[pos[i]] };
        match self {
            Self::Identity => {}
            Self::Jacobi { diag_pos, inv_diag } => {
                for (i, inv) in inv_diag.iter_mut().enumerate() {
                    *inv = positive_inverse(diag(diag_pos, i), i)?;
                }
            }
            Self::BlockJacobi3 {
                diag_pos,
                block_pos,
                block_inv,
                tail_inv,
            } => {
                for i in 0..diag_pos.len() {
                    positive_inverse(diag(diag_pos, i), i)?;
                }
                let mut fallbacks = 0;
                for (pos, inv) in block_pos.iter().zip(block_inv.iter_mut()) {
                    let m = Matrix3::from_fn(|i, j| diag(pos, 3 * j + i));
                    // Average the triangles so the block is exactly symmetric.
                    let m = 0.5 * (m + m.transpose());
                    *inv = match m.cholesky() {
                        Some(c) => c.inverse(),
                        None => {
                            fallbacks += 1;
                            Matrix3::from_diagonal(&m.diagonal().map(|d| 1.0 / d))
                        }
                    };
                }
                let first_tail = 3 * block_pos.len();
                for (k, inv) in tail_inv.iter_mut().enumerate() {
                    *inv = 1.0 / diag(diag_pos, first_tail + k);
                }
                report.fallback_blocks = fallbacks;
            }
            Self::Ic0(ic) => report.diagonal_shift = ic.setup(a)?,
            Self::Amg(amg) => amg.setup(a)?,
        }
        Ok(())
    }

    /// Positions of the DOFs (stacked xyz) for preconditioners that build rigid-body modes.
    pub fn set_coordinates(&mut self, positions: &[f64]) {
        if let Self::Amg(amg) = self {
            amg.set_coordinates(positions);
        }
    }

    /// `z = M⁻¹ r`.
    pub fn apply(&mut self, r: &[f64], z: &mut [f64]) {
        match self {
            Self::Identity => z.copy_from_slice(r),
            Self::Jacobi { inv_diag, .. } => {
                for ((zi, ri), d) in z.iter_mut().zip(r).zip(inv_diag) {
                    *zi = *ri * *d;
                }
            }
            Self::BlockJacobi3 {
                block_inv,
                tail_inv,
                ..
            } => {
                for (b, inv) in block_inv.iter().enumerate() {
                    let rb = nalgebra::Vector3::new(r[3 * b], r[3 * b + 1], r[3 * b + 2]);
                    let zb = inv * rb;
                    z[3 * b..3 * b + 3].copy_from_slice(zb.as_slice());
                }
                let first_tail = 3 * block_inv.len();
                for (k, d) in tail_inv.iter().enumerate() {
                    z[first_tail + k] = r[first_tail + k] * d;
                }
            }
            Self::Ic0(ic) => ic.apply(r, z),
            Self::Amg(amg) => amg.apply(r, z),
        }
    }
}

/// `1/d`, or `NotPositiveDefinite` at `column` if `d ≤ 0`.
fn positive_inverse(d: f64, column: usize) -> Result<f64, SolveError> {
    if d > 0.0 {
        Ok(1.0 / d)
    } else {
        Err(SolveError::NotPositiveDefinite { column })
    }
}

/// Zero fill-in incomplete Cholesky `A ≈ L Lᵀ` on the lower triangle of the pattern, in the
/// caller's ordering. Storage: L in CSC with the diagonal first in each column (inserted if
/// the pattern lacks it), the position of each entry in `A`'s values, and a marker array.
pub(crate) struct Ic0 {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Position in `A`'s values of each entry of L (`NONE` for an inserted diagonal).
    src: Vec<usize>,
    values: Vec<f64>,
    /// Scratch: position of row `i` in the column being updated, or `NONE`.
    marker: Vec<usize>,
}

impl Ic0 {
    fn analyze(pattern: &SparsityPattern) -> Self {
        let n = pattern.dim();
        let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        let mut src = Vec::new();
        col_ptr.push(0);
        for c in 0..n {
            let rows = &ri[cp[c]..cp[c + 1]];
            let first = rows.partition_point(|&r| r < c);
            if rows.get(first) != Some(&c) {
                row_idx.push(c);
                src.push(NONE);
            }
            for (k, &r) in rows.iter().enumerate().skip(first) {
                row_idx.push(r);
                src.push(cp[c] + k);
            }
            col_ptr.push(row_idx.len());
        }
        let values = vec![0.0; row_idx.len()];
        Self {
            col_ptr,
            row_idx,
            src,
            values,
            marker: vec![NONE; n],
        }
    }

    /// Factors `A + α·diag(A)` for the first shift α in [`IC_SHIFTS`] for which IC(0) exists;
    /// returns α.
    fn setup(&mut self, a: &SymmetricMatrix) -> Result<f64, SolveError> {
        let v = a.values();
        let n = self.col_ptr.len() - 1;
        for c in 0..n {
            let k = self.src[self.col_ptr[c]];
            positive_inverse(if k == NONE { 0.0 } else { v[k] }, c)?;
        }
        let mut last_failure = 0;
        for &alpha in &IC_SHIFTS {
            for (val, &k) in self.values.iter_mut().zip(&self.src) {
                *val = if k == NONE { 0.0 } else { v[k] };
            }
            for c in 0..n {
                self.values[self.col_ptr[c]] *= 1.0 + alpha;
            }
            match self.factor_in_place() {
                Ok(()) => return Ok(alpha),
                Err(c) => last_failure = c,
            }
        }
        Err(SolveError::NotPositiveDefinite {
            column: last_failure,
        })
    }

    /// Right-looking IC(0): updates only entries already in the pattern. `Err(k)` on a
    /// non-positive pivot at column `k`.
    fn factor_in_place(&mut self) -> Result<(), usize> {
        let n = self.col_ptr.len() - 1;
        let (cp, ri, l, marker) = (
            &self.col_ptr,
            &self.row_idx,
            &mut self.values,
            &mut self.marker,
        );
        for k in 0..n {
            let (s, e) = (cp[k], cp[k + 1]);
            let d = l[s];
            if !(d > 0.0 && d.is_finite()) {
                return Err(k);
            }
            let d = d.sqrt();
            l[s] = d;
            for x in &mut l[s + 1..e] {
                *x /= d;
            }
            // L[i, j] -= L[i, k] L[j, k] for i ≥ j > k where (i, j) is in the pattern.
            for p in s + 1..e {
                let j = ri[p];
                let ljk = l[p];
                for q in cp[j]..cp[j + 1] {
                    marker[ri[q]] = q;
                }
                for p2 in p..e {
                    let q = marker[ri[p2]];
                    if q != NONE {
                        l[q] -= l[p2] * ljk;
                    }
                }
                for q in cp[j]..cp[j + 1] {
                    marker[ri[q]] = NONE;
                }
            }
        }
        Ok(())
    }

    /// `z = (L Lᵀ)⁻¹ r`.
    fn apply(&self, r: &[f64], z: &mut [f64]) {
        let (cp, ri, l) = (&self.col_ptr, &self.row_idx, &self.values);
        z.copy_from_slice(r);
        let n = z.len();
        for c in 0..n {
            let zc = z[c] / l[cp[c]];
            z[c] = zc;
            for p in cp[c] + 1..cp[c + 1] {
                z[ri[p]] -= l[p] * zc;
            }
        }
        for c in (0..n).rev() {
            let mut s = z[c];
            for p in cp[c] + 1..cp[c + 1] {
                s -= l[p] * z[ri[p]];
            }
            z[c] = s / l[cp[c]];
        }
    }
}
