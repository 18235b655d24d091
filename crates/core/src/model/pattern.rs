//! The Hessian's sparsity pattern over free vertices (3×3 blocks), built once, and the gather
//! lists that sum element matrices and vectors into it.
//!
//! Assembly is "compute elements into a buffer, then gather": each destination block (or free
//! vertex) sums its contributions in element order, so the result is bitwise identical however
//! the work is split across threads, and no per-call sort or triplet list is needed.

use crate::parallel::{Parallelism, split_columns};
use crate::sparse::SparsityPattern;
use std::sync::Arc;

/// Block sparsity over free vertices: column j (a free vertex) holds the sorted free vertices
/// it couples to. The scalar pattern stores block column j as scalar columns 3j, 3j+1, 3j+2,
/// each listing its block rows' three scalar rows, so block column j occupies the contiguous
/// value range `9 * block_ptr[j] .. 9 * block_ptr[j + 1]`.
#[derive(Debug)]
pub struct BlockPattern {
    block_ptr: Vec<usize>,
    block_row: Vec<usize>,
    scalar: Arc<SparsityPattern>,
}

impl BlockPattern {
    /// From the free-vertex lists of every element (`FIXED` entries skipped). Every element
    /// couples all its free vertices pairwise; the diagonal is always present.
    pub fn new<'a>(num_free: usize, elements: impl Iterator<Item = &'a [u32]> + Clone) -> Self {
        let mut neighbours: Vec<Vec<usize>> = (0..num_free).map(|j| vec![j]).collect();
        for el in elements {
            for &a in el.iter().filter(|&&a| a != super::dofs::FIXED) {
                for &b in el.iter().filter(|&&b| b != super::dofs::FIXED) {
                    neighbours[b as usize].push(a as usize);
                }
            }
        }
        let mut block_ptr = Vec::with_capacity(num_free + 1);
        let mut block_row = Vec::new();
        block_ptr.push(0);
        for list in &mut neighbours {
            list.sort_unstable();
            list.dedup();
            block_row.extend_from_slice(list);
            block_ptr.push(block_row.len());
        }
        drop(neighbours);
        let n = 3 * num_free;
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::with_capacity(9 * block_row.len());
        col_ptr.push(0);
        for j in 0..num_free {
            let rows = &block_row[block_ptr[j]..block_ptr[j + 1]];
            for _k in 0..3 {
                for &r in rows {
                    row_idx.extend_from_slice(&[3 * r, 3 * r + 1, 3 * r + 2]);
                }
                col_ptr.push(row_idx.len());
            }
        }
        let scalar = Arc::new(SparsityPattern::from_csc(n, col_ptr, row_idx));
        Self {
            block_ptr,
            block_row,
            scalar,
        }
    }

    /// The scalar pattern (shared by every Hessian and the consistent mass matrix).
    pub fn scalar(&self) -> &Arc<SparsityPattern> {
        &self.scalar
    }

    /// Number of free vertices (block columns).
    pub fn num_block_columns(&self) -> usize {
        self.block_ptr.len() - 1
    }

    /// Number of stored 3×3 blocks.
    pub fn num_blocks(&self) -> usize {
        self.block_row.len()
    }

    /// Index of block (row, col) among all blocks; `None` if not stored.
    pub fn block_index(&self, row: usize, col: usize) -> Option<usize> {
        let start = self.block_ptr[col];
        let rows = &self.block_row[start..self.block_ptr[col + 1]];
        rows.binary_search(&row).ok().map(|k| start + k)
    }
}

/// For each destination, the buffer offsets that sum into it, in element order (CSR layout).
#[derive(Debug, Default)]
pub struct GatherList {
    ptr: Vec<usize>,
    src: Vec<u32>,
}

impl GatherList {
    /// From `(destination, source)` pairs produced in element order by `emit`, which is called
    /// twice (count, then fill), so no pair list is materialized.
    fn build(num_dest: usize, emit: impl Fn(&mut dyn FnMut(usize, usize))) -> Self {
        let mut ptr = vec![0usize; num_dest + 1];
        emit(&mut |d, _| ptr[d + 1] += 1);
        for d in 0..num_dest {
            ptr[d + 1] += ptr[d];
        }
        let mut fill = ptr.clone();
        let mut src = vec![0u32; ptr[num_dest]];
        emit(&mut |d, s| {
            src[fill[d]] = u32::try_from(s).expect("element buffer offset exceeds u32");
            fill[d] += 1;
        });
        Self { ptr, src }
    }

    /// Sources of destination `d`.
    #[inline]
    fn sources(&self, d: usize) -> &[u32] {
        match self.ptr.get(d..d + 2) {
            Some(&[start, end]) => &self.src[start..end],
            _ => &[], // an empty list (a family with no elements)
        }
    }
}

/// One family of elements (tets, springs) as it enters assembly: each element has `nodes`
/// vertices; its gradient occupies `3 * nodes` buffer entries and its Hessian `(3 nodes)²`
/// entries, block-major (see [`crate::fem`]).
#[derive(Debug, Default)]
pub struct ElementGather {
    /// Per free vertex: offsets of the element gradient triples.
    vector: GatherList,
    /// Per block: offsets of element block (a, b), 9 contiguous values.
    matrix: GatherList,
}

impl ElementGather {
    /// Build the gather lists of elements given by their free-vertex lists (`FIXED` skipped).
    pub fn new<'a>(
        pattern: &BlockPattern,
        nodes: usize,
        elements: impl Iterator<Item = &'a [u32]> + Clone,
    ) -> Self {
        let num_free = pattern.num_block_columns();
        let vsize = 3 * nodes;
        let msize = vsize * vsize;
        let vector = GatherList::build(num_free, |push| {
            for (e, el) in elements.clone().enumerate() {
                for (a, &fa) in el.iter().enumerate() {
                    if fa != super::dofs::FIXED {
                        push(fa as usize, e * vsize + 3 * a);
                    }
                }
            }
        });
        let matrix = GatherList::build(pattern.num_blocks(), |push| {
            for (e, el) in elements.clone().enumerate() {
                for (b, &fb) in el.iter().enumerate() {
                    if fb == super::dofs::FIXED {
                        continue;
                    }
                    for (a, &fa) in el.iter().enumerate() {
                        if fa == super::dofs::FIXED {
                            continue;
                        }
                        let block = pattern
                            .block_index(fa as usize, fb as usize)
                            .expect("element coupling missing from the pattern");
                        push(block, e * msize + crate::fem::block_offset(nodes, a, b));
                    }
                }
            }
        });
        Self { vector, matrix }
    }
}

/// Sum element gradients (`buffers[k]` for family `families[k]`) into `g` over free DOFs,
/// overwriting `g`.
pub fn gather_vector(par: Parallelism, families: &[(&ElementGather, &[f64])], g: &mut [f64]) {
    let n = g.len() / 3;
    split_columns(par, 0..n, &|j| 3 * j, g, &|cols, out| {
        for (local, j) in cols.enumerate() {
            let mut acc = [0.0; 3];
            for (fam, buf) in families {
                for &s in fam.vector.sources(j) {
                    let s = s as usize;
                    acc[0] += buf[s];
                    acc[1] += buf[s + 1];
                    acc[2] += buf[s + 2];
                }
            }
            out[3 * local..3 * local + 3].copy_from_slice(&acc);
        }
    });
}

/// Sum element matrices into the values of a matrix over `pattern`, overwriting them.
pub fn gather_matrix(
    par: Parallelism,
    pattern: &BlockPattern,
    families: &[(&ElementGather, &[f64])],
    values: &mut [f64],
) {
    let bp = &pattern.block_ptr;
    split_columns(
        par,
        0..pattern.num_block_columns(),
        &|j| 9 * bp[j],
        values,
        &|cols, out| {
            let base = 9 * bp[cols.start];
            for j in cols {
                let nb = bp[j + 1] - bp[j];
                let col0 = 9 * bp[j] - base;
                for r in 0..nb {
                    let block = bp[j] + r;
                    let mut acc = [0.0; 9];
                    for (fam, buf) in families {
                        for &s in fam.matrix.sources(block) {
                            let src = &buf[s as usize..s as usize + 9];
                            for (a, v) in acc.iter_mut().zip(src) {
                                *a += v;
                            }
                        }
                    }
                    for k in 0..3 {
                        let dst = col0 + 3 * k * nb + 3 * r;
                        out[dst..dst + 3].copy_from_slice(&acc[3 * k..3 * k + 3]);
                    }
                }
            }
        },
    );
}
