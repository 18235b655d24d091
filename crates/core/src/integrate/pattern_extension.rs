//! The system matrix on an extended pattern: the element pattern plus the 3×3 blocks a
//! contact potential couples that no element does (self-contact between far-apart surface
//! points). The extension is rebuilt only when a block it lacks appears, and keeps the blocks
//! it has, so a contact set that flickers between Newton iterations does not re-analyze the
//! factorization each time; values are copied from the element-pattern matrix (one O(nnz)
//! pass) and the extra blocks added.

use crate::model::OffPatternBlock;
use crate::sparse::{SparsityPattern, SymmetricMatrix};
use std::sync::Arc;

/// An extension of one base pattern by extra blocks, with its matrix.
#[derive(Debug)]
pub struct PatternExtension {
    base: Arc<SparsityPattern>,
    /// The extra blocks, as sorted (block column, block row) pairs.
    blocks: Vec<(u32, u32)>,
    /// Where each base value sits among the extended values.
    base_slots: Vec<usize>,
    matrix: SymmetricMatrix,
}

impl PatternExtension {
    /// Whether this extension extends `base` and stores every block of `needed`.
    pub fn covers(&self, base: &Arc<SparsityPattern>, needed: &[OffPatternBlock]) -> bool {
        Arc::ptr_eq(&self.base, base)
            && needed
                .iter()
                .all(|b| self.blocks.binary_search(&(b.col, b.row)).is_ok())
    }

    /// The extension of `base` by the blocks of `needed` and, when it extends the same base,
    /// those of `previous`.
    pub fn new(
        base: &Arc<SparsityPattern>,
        needed: &[OffPatternBlock],
        previous: Option<&Self>,
    ) -> Self {
        let mut blocks: Vec<(u32, u32)> = needed.iter().map(|b| (b.col, b.row)).collect();
        if let Some(p) = previous.filter(|p| Arc::ptr_eq(&p.base, base)) {
            blocks.extend_from_slice(&p.blocks);
        }
        blocks.sort_unstable();
        blocks.dedup();
        let n = base.dim();
        let (bp, br) = (base.col_ptr(), base.row_idx());
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::with_capacity(br.len() + 9 * blocks.len());
        let mut base_slots = Vec::with_capacity(br.len());
        col_ptr.push(0);
        let mut next = 0;
        let mut extra = Vec::new();
        for c in 0..n {
            let block_col = (c / 3) as u32;
            while next < blocks.len() && blocks[next].0 < block_col {
                next += 1;
            }
            extra.clear();
            let mut k = next;
            while k < blocks.len() && blocks[k].0 == block_col {
                let r = 3 * blocks[k].1 as usize;
                extra.extend_from_slice(&[r, r + 1, r + 2]);
                k += 1;
            }
            // Merge the base rows (sorted) with the extra rows (sorted, disjoint from them).
            let base_rows = &br[bp[c]..bp[c + 1]];
            let (mut i, mut j) = (0, 0);
            while i < base_rows.len() || j < extra.len() {
                if j == extra.len() || (i < base_rows.len() && base_rows[i] < extra[j]) {
                    base_slots.push(row_idx.len());
                    row_idx.push(base_rows[i]);
                    i += 1;
                } else {
                    row_idx.push(extra[j]);
                    j += 1;
                }
            }
            col_ptr.push(row_idx.len());
        }
        let pattern = Arc::new(SparsityPattern::from_csc(n, col_ptr, row_idx));
        Self {
            base: base.clone(),
            blocks,
            base_slots,
            matrix: SymmetricMatrix::zeros(pattern),
        }
    }

    /// Fill the extended matrix with `base`'s values plus `scale` times the `extra` blocks
    /// (each must be stored: see [`Self::covers`]); `scale` is the weight the base matrix
    /// gave the potential's Hessian (`beta` in `M + beta K`).
    pub fn fill(&mut self, base: &SymmetricMatrix, extra: &[OffPatternBlock], scale: f64) {
        let pattern = self.matrix.pattern().clone();
        let values = self.matrix.values_mut();
        values.fill(0.0);
        for (v, &slot) in base.values().iter().zip(&self.base_slots) {
            values[slot] = *v;
        }
        for b in extra {
            let (r, c) = (3 * b.row as usize, 3 * b.col as usize);
            for j in 0..3 {
                for i in 0..3 {
                    let k = pattern
                        .find(r + i, c + j)
                        .expect("the extension stores every covered block");
                    values[k] += scale * b.block[(i, j)];
                }
            }
        }
    }

    /// The extended matrix.
    pub fn matrix(&self) -> &SymmetricMatrix {
        &self.matrix
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    #[test]
    fn the_extended_matrix_is_the_base_plus_the_extra_blocks() {
        // Two free vertices that no element couples: block-diagonal base.
        let col_ptr = vec![0, 3, 6, 9, 12, 15, 18];
        let row_idx = vec![0, 1, 2, 0, 1, 2, 0, 1, 2, 3, 4, 5, 3, 4, 5, 3, 4, 5];
        let base = Arc::new(SparsityPattern::from_csc(6, col_ptr, row_idx));
        let mut a = SymmetricMatrix::zeros(base.clone());
        for (k, v) in a.values_mut().iter_mut().enumerate() {
            *v = 1.0 + k as f64;
        }
        let block = Matrix3::from_fn(|i, j| 10.0 * (i + 1) as f64 + j as f64);
        let extra = [
            OffPatternBlock {
                row: 1,
                col: 0,
                block,
            },
            OffPatternBlock {
                row: 0,
                col: 1,
                block: block.transpose(),
            },
        ];
        let mut e = PatternExtension::new(&base, &extra, None);
        assert!(e.covers(&base, &extra));
        assert!(!e.covers(&Arc::new((*base).clone()), &extra));
        e.fill(&a, &extra, 1.0);
        let dense = e.matrix().to_dense();
        let mut expected = a.to_dense();
        for i in 0..3 {
            for j in 0..3 {
                expected[(3 + i, j)] += block[(i, j)];
                expected[(j, 3 + i)] += block[(i, j)];
            }
        }
        assert_eq!(dense, expected);
        // A rebuild keeps the blocks it had.
        let again = PatternExtension::new(&base, &extra[..1], Some(&e));
        assert!(again.covers(&base, &extra));
    }
}
