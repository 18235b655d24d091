//! What the subtree-parallel numeric phase needs beyond faer's symbolic structure, computed
//! once per symbolic analysis: the supernodal elimination tree, each supernode's descendants
//! that update it, flop estimates that size the tasks, and where each entry of `A` lands in L.

use faer::Par;
use faer::dyn_stack::StackReq;
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;

use super::{NONE, exclusive_prefix_sum};
use crate::sparse::SparsityPattern;

/// A subtree with fewer estimated flops than this is one sequential task: splitting it
/// further costs more in task overhead than it can gain.
pub const MIN_TASK_FLOPS: f64 = 2.0e6;

/// Tasks per thread the schedule aims for: a subtree with more than `total / (threads ×
/// TASKS_PER_THREAD)` flops is split into its children, so work stealing can balance uneven
/// subtrees.
pub const TASKS_PER_THREAD: f64 = 8.0;

/// Why a symbolic analysis cannot be scheduled by subtrees.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ScheduleError {
    /// The supernodes are not in a postorder of their elimination tree, so a subtree is not a
    /// contiguous range of the value storage. Compose the ordering with a postorder
    /// ([`postorder_permutation`](super::postorder_permutation)) before the symbolic analysis.
    #[error(
        "supernode {supernode}'s subtree is not a contiguous range (supernodes not postordered)"
    )]
    NotPostordered { supernode: usize },
}

impl crate::error_class::Classify for ScheduleError {
    fn class(&self) -> crate::error_class::ErrorClass {
        crate::error_class::ErrorClass::Failure
    }
}

/// Everything the subtree-parallel numeric phase needs beyond faer's symbolic structure,
/// computed once per symbolic analysis.
#[derive(Debug)]
pub struct TreeSchedule {
    pub(super) n: usize,
    /// Children of each supernode (ascending, hence consecutive subtree ranges), CSR.
    pub(super) child_ptr: Vec<usize>,
    pub(super) child_idx: Vec<usize>,
    /// Supernodes without a parent (the roots of the forest), ascending.
    pub(super) roots: Vec<usize>,
    /// First supernode of each subtree: the subtree of `s` is `first_desc[s]..=s`.
    pub(super) first_desc: Vec<usize>,
    /// Supernodes whose pattern has a row in `s`'s columns (they update `s`), ascending, CSR.
    pub(super) desc_ptr: Vec<usize>,
    pub(super) desc_idx: Vec<usize>,
    /// Estimated flops of each supernode, and of each subtree.
    pub(super) node_flops: Vec<f64>,
    pub(super) subtree_flops: Vec<f64>,
    /// Entries of `A`'s lower triangle per supernode (CSR): the slot in `A`'s value array
    /// and the offset in the supernode's block.
    pub(super) assembly_ptr: Vec<usize>,
    pub(super) assembly_slot: Vec<usize>,
    pub(super) assembly_offset: Vec<usize>,
    /// Scratch sizes: the largest update block (rows × columns), the longest row map and the
    /// dense LLᵀ scratch of the widest supernode.
    pub(super) max_update: usize,
    pub(super) max_update_rows: usize,
    /// The most rows of any supernode's block (columns plus pattern): the solve's scratch.
    pub(super) max_block_rows: usize,
    pub(super) cholesky_scratch: StackReq,
}

impl TreeSchedule {
    /// The schedule of faer's supernodal `symbolic` analysis of `pattern` (read as its lower
    /// triangle) permuted by `perm` (`fwd[new] = old`, `inv[old] = new`; `None`: identity).
    pub fn new(
        symbolic: &SymbolicSupernodalCholesky<usize>,
        pattern: &SparsityPattern,
        perm: Option<(&[usize], &[usize])>,
    ) -> Result<Self, ScheduleError> {
        let n = symbolic.nrows();
        let ns = symbolic.n_supernodes();
        let begin = symbolic.supernode_begin();
        let end = symbolic.supernode_end();
        let mut col_to_super = vec![0usize; n];
        for s in 0..ns {
            col_to_super[begin[s]..end[s]].fill(s);
        }
        let pattern_of = |s: usize| supernode_pattern(symbolic, s);

        // Elimination tree, descendant lists (d ascending), flops.
        let mut parent = vec![NONE; ns];
        let mut desc_count = vec![0usize; ns + 1];
        let mut node_flops = vec![0.0; ns];
        for d in 0..ns {
            let p = pattern_of(d);
            if let Some(&first) = p.first() {
                parent[d] = col_to_super[first];
            }
            let mut last = NONE;
            for &row in p {
                let s = col_to_super[row];
                if s != last {
                    desc_count[s] += 1;
                    last = s;
                }
            }
            let (c, r) = ((end[d] - begin[d]) as f64, p.len() as f64);
            node_flops[d] = c * c * c / 3.0 + c * c * r + c * r * r;
        }
        let desc_ptr = exclusive_prefix_sum(&desc_count[..ns]);
        let mut desc_idx = vec![0usize; desc_ptr[ns]];
        let mut fill = desc_ptr[..ns].to_vec();
        let (mut max_update, mut max_update_rows) = (0usize, 0usize);
        for d in 0..ns {
            let p = pattern_of(d);
            let mut i = 0;
            while i < p.len() {
                let s = col_to_super[p[i]];
                let k = p[i..].partition_point(|&r| r < end[s]);
                desc_idx[fill[s]] = d;
                fill[s] += 1;
                let m = p.len() - i;
                max_update = max_update.max(m * k);
                max_update_rows = max_update_rows.max(m);
                i += k;
            }
        }

        // Children, roots, subtree ranges; check the postorder.
        let mut child_count = vec![0usize; ns];
        for &p in &parent {
            if p != NONE {
                child_count[p] += 1;
            }
        }
        let child_ptr = exclusive_prefix_sum(&child_count);
        let mut child_idx = vec![0usize; child_ptr[ns]];
        let mut fill = child_ptr[..ns].to_vec();
        let mut roots = Vec::new();
        let mut first_desc: Vec<usize> = (0..ns).collect();
        let mut subtree_size = vec![1usize; ns];
        let mut subtree_flops = node_flops.clone();
        for s in 0..ns {
            match parent[s] {
                NONE => roots.push(s),
                p => {
                    child_idx[fill[p]] = s;
                    fill[p] += 1;
                    first_desc[p] = first_desc[p].min(first_desc[s]);
                    subtree_size[p] += subtree_size[s];
                    subtree_flops[p] += subtree_flops[s];
                }
            }
            if subtree_size[s] != s + 1 - first_desc[s] {
                return Err(ScheduleError::NotPostordered { supernode: s });
            }
        }

        // Where each entry of A's lower triangle (in the permuted order) lands in L.
        let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
        let new_index = |old: usize| perm.map_or(old, |(_, inv)| inv[old]);
        let val_ptr = symbolic.col_ptr_for_val();
        let mut entries: Vec<(usize, usize, usize)> = Vec::with_capacity(ri.len() / 2 + n);
        for j in 0..n {
            for (slot, &i) in ri.iter().enumerate().take(cp[j + 1]).skip(cp[j]) {
                if i < j {
                    continue;
                }
                let (a, b) = (new_index(i), new_index(j));
                let (row, col) = (a.max(b), a.min(b));
                let s = col_to_super[col];
                let s_ncols = end[s] - begin[s];
                let s_nrows = val_ptr[s + 1] - val_ptr[s];
                let s_nrows = s_nrows / s_ncols;
                let local_row = if row < end[s] {
                    row - begin[s]
                } else {
                    s_ncols + pattern_of(s).partition_point(|&r| r < row)
                };
                entries.push((s, slot, local_row + (col - begin[s]) * s_nrows));
            }
        }
        entries.sort_unstable();
        let mut assembly_count = vec![0usize; ns];
        for &(s, _, _) in &entries {
            assembly_count[s] += 1;
        }
        let assembly_ptr = exclusive_prefix_sum(&assembly_count);
        let assembly_slot = entries.iter().map(|e| e.1).collect();
        let assembly_offset = entries.iter().map(|e| e.2).collect();

        let widest = (0..ns).map(|s| end[s] - begin[s]).max().unwrap_or(0);
        let max_block_rows = (0..ns)
            .map(|s| end[s] - begin[s] + pattern_of(s).len())
            .max()
            .unwrap_or(0);
        let cholesky_scratch = StackReq::or(
            faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<f64>(
                widest,
                Par::rayon(0),
                Default::default(),
            ),
            faer::linalg::cholesky::llt::factor::cholesky_in_place_scratch::<f64>(
                widest,
                Par::Seq,
                Default::default(),
            ),
        );
        Ok(Self {
            n,
            child_ptr,
            child_idx,
            roots,
            first_desc,
            desc_ptr,
            desc_idx,
            node_flops,
            subtree_flops,
            assembly_ptr,
            assembly_slot,
            assembly_offset,
            max_update,
            max_update_rows,
            max_block_rows,
            cholesky_scratch,
        })
    }

    /// The matrix dimension.
    pub fn dim(&self) -> usize {
        self.n
    }

    /// Estimated flops of one factorization (sum over supernodes).
    pub fn total_flops(&self) -> f64 {
        self.roots.iter().map(|&r| self.subtree_flops[r]).sum()
    }

    /// The work of one factorization by where it runs with `threads`: estimated flops in
    /// sequential subtree tasks, and in the supernodes above them that wait for their
    /// children (split nodes, [`Self::split_supernodes`]), whose dense kernels are the only
    /// parallelism left when their subtree has no concurrent sibling. Returns `(in_tasks,
    /// in_split_nodes, tasks, split_nodes)`.
    pub fn split_profile(&self, threads: usize) -> (f64, f64, usize, usize) {
        let split = self.split_supernodes(threads);
        let is_split = |s: usize| split.binary_search(&s).is_ok();
        let in_split: f64 = split.iter().map(|&s| self.node_flops[s]).sum();
        // Every root and every child of a split node heads a task unless split itself.
        let heads: Vec<usize> = self
            .roots
            .iter()
            .chain(split.iter().flat_map(|&s| self.children(s)))
            .copied()
            .filter(|&h| !is_split(h))
            .collect();
        let in_tasks = heads.iter().map(|&h| self.subtree_flops[h]).sum();
        (in_tasks, in_split, heads.len(), split.len())
    }

    /// The split supernodes (those above the sequential subtree tasks on `threads`: a subtree
    /// with children and more than the grain's flops), ascending.
    pub fn split_supernodes(&self, threads: usize) -> Vec<usize> {
        let grain = self.grain(threads);
        let mut split = Vec::new();
        let mut stack: Vec<usize> = self.roots.clone();
        while let Some(r) = stack.pop() {
            if self.subtree_flops[r] > grain && !self.children(r).is_empty() {
                split.push(r);
                stack.extend_from_slice(self.children(r));
            }
        }
        split.sort_unstable();
        split
    }

    /// Subtrees with at most this many flops run as one sequential task on `threads`.
    pub(super) fn grain(&self, threads: usize) -> f64 {
        (self.total_flops() / (threads as f64 * TASKS_PER_THREAD)).max(MIN_TASK_FLOPS)
    }

    pub(super) fn children(&self, s: usize) -> &[usize] {
        &self.child_idx[self.child_ptr[s]..self.child_ptr[s + 1]]
    }
}

/// Whether every subtree of the supernodal elimination tree is a contiguous range of
/// supernodes ending at its root (what [`TreeSchedule::new`] requires).
pub fn is_postordered(symbolic: &SymbolicSupernodalCholesky<usize>) -> bool {
    let ns = symbolic.n_supernodes();
    let begin = symbolic.supernode_begin();
    let end = symbolic.supernode_end();
    let mut first_desc: Vec<usize> = (0..ns).collect();
    let mut size = vec![1usize; ns];
    for s in 0..ns {
        if size[s] != s + 1 - first_desc[s] {
            return false;
        }
        if let Some(&first) = supernode_pattern(symbolic, s).first() {
            // The parent: the supernode holding the first row below the diagonal block.
            let p = end.partition_point(|&e| e <= first);
            debug_assert!(begin[p] <= first);
            first_desc[p] = first_desc[p].min(first_desc[s]);
            size[p] += size[s];
        }
    }
    true
}

/// The rows of supernode `s` below its diagonal block (ascending).
pub(super) fn supernode_pattern(
    symbolic: &SymbolicSupernodalCholesky<usize>,
    s: usize,
) -> &[usize] {
    let start = symbolic.col_ptr_for_row_idx()[s];
    &symbolic.row_idx()[start..start + symbolic.nnz_per_super()[s]]
}
