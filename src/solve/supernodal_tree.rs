//! Subtree-parallel supernodal numeric LLᵀ over faer's symbolic analysis.
//!
//! faer 0.24's supernodal numeric factorization walks the supernodes in one sequential
//! left-looking loop and parallelizes only inside each supernode's dense kernels, so the many
//! small supernodes of the elimination tree's lower levels get no parallelism. Here the
//! supernodal elimination tree is factored subtree by subtree: independent subtrees run
//! concurrently (`rayon::join` over disjoint, contiguous ranges of the value storage), each
//! one sequentially; a supernode whose subtree is split waits for its children and then runs
//! its own dense kernels, on the pool when its front is large (the separators near the root).
//!
//! The values are written in exactly faer's layout (each supernode a column-major block of
//! `ncols + pattern` rows), so faer's solve reads them unchanged. Every supernode applies its
//! descendants' updates in ascending order with the same kernels whatever the schedule, so
//! the factor is bit-identical for any thread count.
//!
//! [`TreeSchedule`] is built once per symbolic analysis (elimination tree, descendant lists,
//! flop estimates, where each entry of `A` lands in L); [`ScratchPool`] holds per-worker
//! buffers that persist across factorizations, so the numeric phase allocates nothing once
//! every worker has run.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering as AtomicOrdering};

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization, cholesky_in_place};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::{Accum, MatMut, MatRef, Par};

use crate::sparse::SparsityPattern;

const NONE: usize = usize::MAX;

/// Flops of one dense kernel call (an update product, the LLᵀ of a diagonal block, a
/// triangular solve) from which it runs on rayon's pool; smaller calls run sequentially,
/// where splitting costs more than it gains. Decided by sizes alone, so the arithmetic does
/// not depend on the schedule.
pub const KERNEL_PARALLEL_FLOPS: f64 = 1.0e7;

/// The parallelism of a dense kernel call of `flops` in a factorization that may (`parallel`)
/// use the pool.
fn kernel_par(parallel: bool, flops: f64) -> Par {
    if parallel && flops >= KERNEL_PARALLEL_FLOPS {
        Par::rayon(0)
    } else {
        Par::Seq
    }
}

/// Entries from which a memory-bound pass over a block (zeroing it, scatter-subtracting an
/// update) is split over the pool in a parallel factorization.
pub const PARALLEL_MEMORY_ENTRIES: usize = 1 << 18;

/// A subtree with fewer estimated flops than this is one sequential task: splitting it
/// further costs more in task overhead than it can gain.
pub const MIN_TASK_FLOPS: f64 = 2.0e6;

/// Tasks per thread the schedule aims for: a subtree with more than `total / (threads ×
/// TASKS_PER_THREAD)` flops is split into its children, so work stealing can balance uneven
/// subtrees.
pub const TASKS_PER_THREAD: f64 = 8.0;

/// The failing pivot of a factorization: the column in faer's permuted order, as
/// `LltError::NonPositivePivot` reports it from faer's supernodal path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NonPositivePivot {
    pub index: usize,
}

/// Why a symbolic analysis cannot be scheduled by subtrees.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ScheduleError {
    /// The supernodes are not in a postorder of their elimination tree, so a subtree is not a
    /// contiguous range of the value storage. Compose the ordering with a postorder
    /// ([`postorder_permutation`]) before the symbolic analysis.
    #[error(
        "supernode {supernode}'s subtree is not a contiguous range (supernodes not postordered)"
    )]
    NotPostordered { supernode: usize },
}

/// Everything the subtree-parallel numeric phase needs beyond faer's symbolic structure,
/// computed once per symbolic analysis.
#[derive(Debug)]
pub struct TreeSchedule {
    n: usize,
    /// Children of each supernode (ascending, hence consecutive subtree ranges), CSR.
    child_ptr: Vec<usize>,
    child_idx: Vec<usize>,
    /// Supernodes without a parent (the roots of the forest), ascending.
    roots: Vec<usize>,
    /// First supernode of each subtree: the subtree of `s` is `first_desc[s]..=s`.
    first_desc: Vec<usize>,
    /// Supernodes whose pattern has a row in `s`'s columns (they update `s`), ascending, CSR.
    desc_ptr: Vec<usize>,
    desc_idx: Vec<usize>,
    /// Estimated flops of each supernode, and of each subtree.
    node_flops: Vec<f64>,
    subtree_flops: Vec<f64>,
    /// Entries of `A`'s lower triangle per supernode (CSR): the slot in `A`'s value array
    /// and the offset in the supernode's block.
    assembly_ptr: Vec<usize>,
    assembly_slot: Vec<usize>,
    assembly_offset: Vec<usize>,
    /// Scratch sizes: the largest update block (rows × columns), the longest row map and the
    /// dense LLᵀ scratch of the widest supernode.
    max_update: usize,
    max_update_rows: usize,
    cholesky_scratch: StackReq,
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
            cholesky_scratch,
        })
    }

    /// Estimated flops of one factorization (sum over supernodes).
    pub fn total_flops(&self) -> f64 {
        self.roots.iter().map(|&r| self.subtree_flops[r]).sum()
    }

    /// The work of one factorization by where it runs with `threads`: estimated flops in
    /// sequential subtree tasks, and in the supernodes above them that wait for their
    /// children (split nodes), whose dense kernels are the only parallelism left when their
    /// subtree has no concurrent sibling. Returns `(in_tasks, in_split_nodes, tasks,
    /// split_nodes)`.
    pub fn split_profile(&self, threads: usize) -> (f64, f64, usize, usize) {
        let grain = self.grain(threads);
        let (mut in_tasks, mut in_split, mut tasks, mut split) = (0.0, 0.0, 0, 0);
        let mut stack: Vec<usize> = self.roots.clone();
        while let Some(r) = stack.pop() {
            if self.subtree_flops[r] <= grain || self.children(r).is_empty() {
                in_tasks += self.subtree_flops[r];
                tasks += 1;
            } else {
                in_split += self.node_flops[r];
                split += 1;
                stack.extend_from_slice(self.children(r));
            }
        }
        (in_tasks, in_split, tasks, split)
    }

    /// Subtrees with at most this many flops run as one sequential task on `threads`.
    fn grain(&self, threads: usize) -> f64 {
        (self.total_flops() / (threads as f64 * TASKS_PER_THREAD)).max(MIN_TASK_FLOPS)
    }

    fn children(&self, s: usize) -> &[usize] {
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
fn supernode_pattern(symbolic: &SymbolicSupernodalCholesky<usize>, s: usize) -> &[usize] {
    let start = symbolic.col_ptr_for_row_idx()[s];
    &symbolic.row_idx()[start..start + symbolic.nnz_per_super()[s]]
}

/// `[0, c0, c0 + c1, …]`, one longer than `counts`.
fn exclusive_prefix_sum(counts: &[usize]) -> Vec<usize> {
    let mut ptr = Vec::with_capacity(counts.len() + 1);
    ptr.push(0);
    let mut sum = 0;
    for &c in counts {
        sum += c;
        ptr.push(sum);
    }
    ptr
}

/// One worker's buffers: the global-to-local row map of the supernode being factored, an
/// update block, its row map and the dense LLᵀ scratch.
struct Scratch {
    global_to_local: Vec<usize>,
    update: Vec<f64>,
    rows: Vec<usize>,
    stack: MemBuffer,
}

impl Scratch {
    fn new(schedule: &TreeSchedule) -> Self {
        Self {
            global_to_local: vec![NONE; schedule.n],
            update: vec![0.0; schedule.max_update],
            rows: vec![0; schedule.max_update_rows],
            stack: MemBuffer::new(schedule.cholesky_scratch),
        }
    }
}

/// Per-worker scratch kept across factorizations. A task takes one for as long as it factors
/// (a supernode, or a whole sequential subtree) and gives it back; a thread that steals a
/// task while its own supernode waits in a parallel kernel takes a second one, so the pool
/// may grow past the thread count during the first factorizations and then stays put.
pub struct ScratchPool {
    free: Mutex<Vec<Scratch>>,
}

impl ScratchPool {
    /// A pool with `workers` scratches sized for `schedule`.
    pub fn new(schedule: &TreeSchedule, workers: usize) -> Self {
        Self {
            free: Mutex::new((0..workers).map(|_| Scratch::new(schedule)).collect()),
        }
    }

    /// Scratches currently held by the pool (all of them between factorizations).
    pub fn len(&self) -> usize {
        self.free.lock().map_or(0, |f| f.len())
    }

    /// Whether the pool holds no scratch.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn with<R>(&self, schedule: &TreeSchedule, f: impl FnOnce(&mut Scratch) -> R) -> R {
        let taken = self.free.lock().ok().and_then(|mut free| free.pop());
        let mut scratch = taken.unwrap_or_else(|| Scratch::new(schedule));
        let result = f(&mut scratch);
        if let Ok(mut free) = self.free.lock() {
            free.push(scratch);
        }
        result
    }
}

/// The read-only inputs shared by every task of one factorization.
struct Job<'a> {
    symbolic: &'a SymbolicSupernodalCholesky<usize>,
    schedule: &'a TreeSchedule,
    pool: &'a ScratchPool,
    a_values: &'a [f64],
    /// Subtrees with at most this many flops run as one sequential task.
    grain: f64,
    /// Whether dense kernels and subtrees may use rayon's pool at all.
    parallel: bool,
    /// Smallest failing pivot column so far (`NONE`: none): supernodes that start after it
    /// are skipped, since the reported failure is the first in elimination order.
    failed: AtomicUsize,
}

/// Numeric LLᵀ of `A` (values `a_values` over the pattern the schedule was built from, read
/// as its lower triangle) into `l_values` (`symbolic.len_val()` entries, faer's layout).
/// `Par::Seq` runs everything on the calling thread; `Par::Rayon` on rayon's current pool
/// (the thread count of `par` sizes the tasks). The factor's bits are the same either way.
/// On a non-positive pivot, the first one in elimination order (the one faer's sequential
/// loop would report) is returned and `l_values` is unspecified.
pub fn factorize(
    l_values: &mut [f64],
    a_values: &[f64],
    symbolic: &SymbolicSupernodalCholesky<usize>,
    schedule: &TreeSchedule,
    pool: &ScratchPool,
    par: Par,
) -> Result<(), NonPositivePivot> {
    assert_eq!(l_values.len(), symbolic.len_val(), "factor storage size");
    let threads = par.degree();
    let job = Job {
        symbolic,
        schedule,
        pool,
        a_values,
        grain: schedule.grain(threads),
        parallel: threads > 1,
        failed: AtomicUsize::new(NONE),
    };
    if threads <= 1 {
        let ns = symbolic.n_supernodes();
        if ns > 0 {
            factor_sequential(&job, 0..ns, l_values, 0);
        }
    } else {
        factor_forest(&job, &schedule.roots, l_values, 0);
    }
    match job.failed.load(AtomicOrdering::Relaxed) {
        NONE => Ok(()),
        index => Err(NonPositivePivot { index }),
    }
}

/// Factors the consecutive subtrees rooted at `roots` (ascending), concurrently. `values`
/// starts at the value offset `base` and covers exactly those subtrees.
fn factor_forest(job: &Job<'_>, roots: &[usize], values: &mut [f64], base: usize) {
    match roots {
        [] => {}
        [r] => factor_subtree(job, *r, values, base),
        _ => {
            let mid = roots.len() / 2;
            let split = job.symbolic.col_ptr_for_val()[job.schedule.first_desc[roots[mid]]];
            let (left, right) = values.split_at_mut(split - base);
            rayon::join(
                || factor_forest(job, &roots[..mid], left, base),
                || factor_forest(job, &roots[mid..], right, split),
            );
        }
    }
}

/// Factors the subtree of `root`: one sequential task when small, else its children's
/// subtrees concurrently and then `root` itself.
fn factor_subtree(job: &Job<'_>, root: usize, values: &mut [f64], base: usize) {
    let schedule = job.schedule;
    let children = schedule.children(root);
    if schedule.subtree_flops[root] <= job.grain || children.is_empty() {
        factor_sequential(job, schedule.first_desc[root]..root + 1, values, base);
        return;
    }
    let own = job.symbolic.col_ptr_for_val()[root] - base;
    let (below, _) = values.split_at_mut(own);
    factor_forest(job, children, below, base);
    factor_sequential(job, root..root + 1, values, base);
}

/// Factors the supernodes `range` in order with one scratch. `values` starts at value offset
/// `base`, holds every descendant of the range and ends with the range's last block.
fn factor_sequential(
    job: &Job<'_>,
    range: std::ops::Range<usize>,
    values: &mut [f64],
    base: usize,
) {
    job.pool.with(job.schedule, |scratch| {
        for s in range {
            let start = job.symbolic.supernode_begin()[s];
            if job.failed.load(AtomicOrdering::Relaxed) < start {
                return;
            }
            if let Err(index) = factor_supernode(job, s, values, base, scratch) {
                job.failed.fetch_min(index, AtomicOrdering::Relaxed);
                return;
            }
        }
    });
}

/// Assembles, updates and factors supernode `s` (left-looking): its block of `A`, minus the
/// update of every descendant in ascending order, then dense LLᵀ of the diagonal block and a
/// triangular solve for the rows below. Returns the failing pivot column (permuted order).
fn factor_supernode(
    job: &Job<'_>,
    s: usize,
    values: &mut [f64],
    base: usize,
    scratch: &mut Scratch,
) -> Result<(), usize> {
    let (symbolic, schedule) = (job.symbolic, job.schedule);
    let val_ptr = symbolic.col_ptr_for_val();
    let begin = symbolic.supernode_begin();
    let end = symbolic.supernode_end();
    let (s_start, s_end) = (begin[s], end[s]);
    let s_ncols = s_end - s_start;
    let s_pattern = supernode_pattern(symbolic, s);
    let s_nrows = s_ncols + s_pattern.len();

    let (head, tail) = values.split_at_mut(val_ptr[s] - base);
    let block = &mut tail[..val_ptr[s + 1] - val_ptr[s]];
    if job.parallel && block.len() >= PARALLEL_MEMORY_ENTRIES {
        use rayon::prelude::*;
        block
            .par_chunks_mut(PARALLEL_MEMORY_ENTRIES / 4)
            .for_each(|c| c.fill(0.0));
    } else {
        block.fill(0.0);
    }
    let assembly = schedule.assembly_ptr[s]..schedule.assembly_ptr[s + 1];
    for (&slot, &offset) in schedule.assembly_slot[assembly.clone()]
        .iter()
        .zip(&schedule.assembly_offset[assembly])
    {
        block[offset] = job.a_values[slot];
    }

    let g2l = &mut scratch.global_to_local;
    for (i, &row) in s_pattern.iter().enumerate() {
        g2l[row] = s_ncols + i;
    }
    for &d in &schedule.desc_idx[schedule.desc_ptr[s]..schedule.desc_ptr[s + 1]] {
        let d_pattern = supernode_pattern(symbolic, d);
        let d_ncols = end[d] - begin[d];
        let first = d_pattern.partition_point(|&r| r < s_start);
        let k = d_pattern[first..].partition_point(|&r| r < s_end);
        let m = d_pattern.len() - first;
        let ld = MatRef::from_column_major_slice(
            &head[val_ptr[d] - base..val_ptr[d + 1] - base],
            d_ncols + d_pattern.len(),
            d_ncols,
        );
        let ld_mid_bot = ld.subrows(d_ncols + first, m);
        let (ld_mid, ld_bot) = ld_mid_bot.split_at_row(k);
        // W = L_d[mid∪bot] · L_d[mid]ᵀ, lower triangle of its top k×k block only.
        let mut w = MatMut::from_column_major_slice_mut(&mut scratch.update[..m * k], m, k);
        let (w_top, w_bot) = w.rb_mut().split_at_row_mut(k);
        let par = kernel_par(job.parallel, 2.0 * (m * k * d_ncols) as f64);
        triangular::matmul(
            w_top,
            BlockStructure::TriangularLower,
            Accum::Replace,
            ld_mid,
            BlockStructure::Rectangular,
            ld_mid.transpose(),
            BlockStructure::Rectangular,
            1.0,
            par,
        );
        matmul(w_bot, Accum::Replace, ld_bot, ld_mid.transpose(), 1.0, par);
        // Scatter-subtract into the block: rows through the supernode's row map.
        let rows = &mut scratch.rows[..m];
        for (i, (local, &row)) in rows.iter_mut().zip(&d_pattern[first..]).enumerate() {
            *local = if i < k { row - s_start } else { g2l[row] };
        }
        let update = Update {
            w: &scratch.update[..m * k],
            rows,
            m,
            s_nrows,
        };
        update.subtract(job.parallel, 0..k, block, 0);
    }
    for &row in s_pattern {
        g2l[row] = NONE;
    }

    let mut ls = MatMut::from_column_major_slice_mut(block, s_nrows, s_ncols);
    let (mut top, bot) = ls.rb_mut().split_at_row_mut(s_ncols);
    let stack = MemStack::new(&mut scratch.stack);
    let c = s_ncols as f64;
    match cholesky_in_place(
        top.rb_mut(),
        LltRegularization::default(),
        kernel_par(job.parallel, c * c * c / 3.0),
        stack,
        Default::default(),
    ) {
        Ok(_) => {}
        Err(LltError::NonPositivePivot { index }) => return Err(s_start + index),
    }
    let trsm_flops = c * c * (s_nrows - s_ncols) as f64;
    solve_lower_triangular_in_place(
        top.rb(),
        bot.transpose_mut(),
        kernel_par(job.parallel, trsm_flops),
    );
    Ok(())
}

/// One descendant's update `W` (m × k, column-major, lower triangle of its top k × k block)
/// and where its rows go in the target supernode's block.
struct Update<'a> {
    w: &'a [f64],
    rows: &'a [usize],
    m: usize,
    s_nrows: usize,
}

impl Update<'_> {
    /// Subtracts columns `cols` of `W` from the block; `block` starts at the target column
    /// `first_col` (= `rows[cols.start]` at the top call, 0 there) and covers every column
    /// that `cols` writes. Large updates split their columns in halves over the pool: each
    /// entry is written once, so the split does not change the result.
    fn subtract(
        &self,
        parallel: bool,
        cols: std::ops::Range<usize>,
        block: &mut [f64],
        first_col: usize,
    ) {
        let (m, rows, n) = (self.m, self.rows, self.s_nrows);
        if parallel && cols.len() >= 2 && cols.len() * m >= PARALLEL_MEMORY_ENTRIES {
            let mid = cols.start + cols.len() / 2;
            let (left, right) = block.split_at_mut((rows[mid] - first_col) * n);
            rayon::join(
                || self.subtract(parallel, cols.start..mid, left, first_col),
                || self.subtract(parallel, mid..cols.end, right, rows[mid]),
            );
            return;
        }
        for j in cols {
            let c = rows[j] - first_col;
            let dst = &mut block[c * n..(c + 1) * n];
            let src = &self.w[j * m..(j + 1) * m];
            for i in j..m {
                dst[rows[i]] -= src[i];
            }
        }
    }
}

/// The elimination tree of `P A Pᵀ` (`fwd[new] = old`, `inv[old] = new`; `pattern` read as
/// its lower triangle): `parent[k]`, or `NONE` at a root. Liu's algorithm with path
/// compression, O(nnz(A) log n) time, O(n) memory.
pub fn elimination_tree(pattern: &SparsityPattern, fwd: &[usize], inv: &[usize]) -> Vec<usize> {
    let n = pattern.dim();
    let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
    let mut parent = vec![NONE; n];
    let mut ancestor = vec![NONE; n];
    for (k, &old) in fwd.iter().enumerate() {
        for &r in &ri[cp[old]..cp[old + 1]] {
            let mut i = inv[r];
            while i != NONE && i < k {
                let next = ancestor[i];
                ancestor[i] = k;
                if next == NONE {
                    parent[i] = k;
                }
                i = next;
            }
        }
    }
    parent
}

/// A postorder of the elimination tree of `P A Pᵀ` composed with `perm` (`perm[new] = old`):
/// the same fill and flops, with every subtree a contiguous range of columns (and so of
/// supernodes). `pattern` is read as its lower triangle.
pub fn postorder_permutation(pattern: &SparsityPattern, perm: &[usize]) -> Vec<usize> {
    let n = pattern.dim();
    let mut inv = vec![0usize; n];
    for (new, &old) in perm.iter().enumerate() {
        inv[old] = new;
    }
    let parent = elimination_tree(pattern, perm, &inv);
    // Children lists in ascending order, then an iterative depth-first postorder.
    let mut child_count = vec![0usize; n];
    for &p in &parent {
        if p != NONE {
            child_count[p] += 1;
        }
    }
    let child_ptr = exclusive_prefix_sum(&child_count);
    let mut child_idx = vec![0usize; n];
    let mut fill = child_ptr[..n].to_vec();
    for (j, &p) in parent.iter().enumerate() {
        if p != NONE {
            child_idx[fill[p]] = j;
            fill[p] += 1;
        }
    }
    let mut post = Vec::with_capacity(n);
    let mut stack: Vec<(usize, usize)> = Vec::new();
    for root in (0..n).filter(|&j| parent[j] == NONE) {
        stack.push((root, child_ptr[root]));
        while let Some(top) = stack.last_mut() {
            let (node, next) = *top;
            if next < child_ptr[node + 1] {
                top.1 += 1;
                let c = child_idx[next];
                stack.push((c, child_ptr[c]));
            } else {
                post.push(node);
                stack.pop();
            }
        }
    }
    post.iter().map(|&k| perm[k]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefix_sum_is_one_longer() {
        assert_eq!(exclusive_prefix_sum(&[2, 0, 3]), vec![0, 2, 2, 5]);
    }
}
