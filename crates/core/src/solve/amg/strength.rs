//! Strength of connection between nodes (a vertex's 3 DOFs on the finest level, an
//! aggregate's coarse DOFs below) and the filtered matrix the prolongator is smoothed with.
//!
//! Classical smoothed aggregation (Vaněk, Mandel, Brezina 1996) on blocks: nodes k and m are
//! strongly connected when `‖A_km‖_F ≥ θ √(‖A_kk‖_F ‖A_mm‖_F)`. Aggregates grow along strong
//! connections only, and the prolongator is smoothed with the filtered matrix `A_F`: weak
//! blocks dropped and lumped into the diagonal block (entry (i, j) of a weak block adds to
//! (i, j') of the row's own diagonal block, j' the same local DOF as j), which keeps
//! `A_F t = A t` for the translations t. Without filtering, every neighbour is strong: the
//! smoothed prolongator reaches two rings of nodes, and the Galerkin operators densify level
//! after level (operator complexity grows with the mesh). θ = 0 restores that.

use super::csr::{BUILD_ROWS_PER_TASK, Csr, RowChunk, map_ranges};
use crate::parallel::Parallelism;

/// The strong node graph (CSR over nodes, no self loops) and the filtered matrix.
pub(super) struct Strength {
    pub adj_ptr: Vec<usize>,
    pub adj: Vec<usize>,
    pub filtered: Csr,
}

impl Strength {
    pub fn neighbours(&self, k: usize) -> &[usize] {
        &self.adj[self.adj_ptr[k]..self.adj_ptr[k + 1]]
    }
}

/// Per-task scratch of [`strength`]: `‖A_km‖²_F` accumulated in `block_sq[m]`, the
/// neighbours met in `touched` (`seen` marks them), `strong[m]` for the current node.
struct Scratch {
    block_sq: Vec<f64>,
    strong: Vec<bool>,
    seen: Vec<usize>,
    touched: Vec<usize>,
}

/// Strong connections of `a` over the node ranges `nodes` (`nodes[k]..nodes[k + 1]` are node
/// k's DOFs) at threshold `theta`, and `A_F`. Node ranges on every thread with
/// [`Parallelism::Rayon`] (each node's output is the same whichever task computes it).
pub(super) fn strength(a: &Csr, nodes: &[usize], theta: f64, par: Parallelism) -> Strength {
    let count = nodes.len() - 1;
    let mut node_of = vec![0; a.nrows];
    for k in 0..count {
        node_of[nodes[k]..nodes[k + 1]].fill(k);
    }
    // ‖A_kk‖²_F.
    let mut diag_sq = vec![0.0; count];
    for (k, d) in diag_sq.iter_mut().enumerate() {
        for i in nodes[k]..nodes[k + 1] {
            let (idx, val) = a.row(i);
            *d += idx
                .iter()
                .zip(val)
                .filter(|&(&j, _)| node_of[j] == k)
                .map(|(_, v)| v * v)
                .sum::<f64>();
        }
    }
    let theta_sq = theta * theta;
    let per_task = (BUILD_ROWS_PER_TASK * count / a.nrows.max(1)).max(1);
    let init = || Scratch {
        block_sq: vec![0.0; count],
        strong: vec![false; count],
        seen: vec![usize::MAX; count],
        touched: Vec::new(),
    };
    let chunks = map_ranges(count, per_task, par, init, |range, scratch| {
        let Scratch {
            block_sq,
            strong,
            seen,
            touched,
        } = scratch;
        let (mut graph, mut filtered) = (RowChunk::default(), RowChunk::default());
        for k in range {
            for i in nodes[k]..nodes[k + 1] {
                let (idx, val) = a.row(i);
                for (&j, &v) in idx.iter().zip(val) {
                    let m = node_of[j];
                    if m != k {
                        if seen[m] != k {
                            seen[m] = k;
                            touched.push(m);
                        }
                        block_sq[m] += v * v;
                    }
                }
            }
            touched.sort_unstable();
            for &m in touched.iter() {
                // ‖A_km‖² ≥ θ² ‖A_kk‖ ‖A_mm‖ (θ = 0: every neighbour is strong).
                strong[m] = block_sq[m] >= theta_sq * (diag_sq[k] * diag_sq[m]).sqrt();
                if strong[m] {
                    graph.idx.push(m);
                }
            }
            graph.end_row();
            // Rows of A_F: strong blocks and the diagonal block kept, weak blocks lumped.
            let size = nodes[k + 1] - nodes[k];
            for i in nodes[k]..nodes[k + 1] {
                let start = filtered.idx.len();
                let (idx, val) = a.row(i);
                for (&j, &v) in idx.iter().zip(val) {
                    let m = node_of[j];
                    if m == k || strong[m] {
                        filtered.idx.push(j);
                        filtered.val.push(v);
                    }
                }
                for (&j, &v) in idx.iter().zip(val) {
                    let m = node_of[j];
                    if m == k || strong[m] {
                        continue;
                    }
                    let same_shape = nodes[m + 1] - nodes[m] == size;
                    let target = if same_shape {
                        nodes[k] + (j - nodes[m])
                    } else {
                        i
                    };
                    let row = &filtered.idx[start..];
                    if let Ok(p) = row
                        .binary_search(&target)
                        .or_else(|_| row.binary_search(&i))
                    {
                        filtered.val[start + p] += v;
                    }
                }
                filtered.end_row();
            }
            for &m in touched.iter() {
                block_sq[m] = 0.0;
                strong[m] = false;
            }
            touched.clear();
        }
        (graph, filtered)
    });
    let (graphs, filtered): (Vec<_>, Vec<_>) = chunks.into_iter().unzip();
    let graph = RowChunk::concat(graphs, count).0;
    Strength {
        adj_ptr: graph.ptr,
        adj: graph.idx,
        filtered: RowChunk::concat(filtered, a.ncols).0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1D chain of 3 scalar nodes with one weak link (1–2).
    fn chain() -> Csr {
        // [ 2 -1  0 ; -1 2 -0.01 ; 0 -0.01 2 ]
        Csr {
            nrows: 3,
            ncols: 3,
            ptr: vec![0, 2, 5, 7],
            idx: vec![0, 1, 0, 1, 2, 1, 2],
            val: vec![2.0, -1.0, -1.0, 2.0, -0.01, -0.01, 2.0],
        }
    }

    #[test]
    fn weak_links_are_dropped_and_lumped_keeping_row_sums() {
        let a = chain();
        let s = strength(&a, &[0, 1, 2, 3], 0.1, Parallelism::Sequential);
        assert_eq!(s.neighbours(0), &[1]);
        assert_eq!(s.neighbours(1), &[0]);
        assert!(s.neighbours(2).is_empty());
        let f = &s.filtered;
        for i in 0..3 {
            let sum_a: f64 = a.row(i).1.iter().sum();
            let sum_f: f64 = f.row(i).1.iter().sum();
            assert!((sum_a - sum_f).abs() < 1e-15, "row {i}");
        }
        assert_eq!(f.nnz(), 5);
        // θ = 0 keeps everything.
        let all = strength(&a, &[0, 1, 2, 3], 0.0, Parallelism::Sequential);
        assert_eq!(all.neighbours(1), &[0, 2]);
        assert_eq!(all.filtered.val, a.val);
    }
}
