//! The numeric LLᵀ itself: independent subtrees concurrently (`rayon::join` over disjoint,
//! contiguous ranges of the value storage), each one sequentially, and large fronts with
//! parallel dense kernels.

use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering as AtomicOrdering};

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization, cholesky_in_place};
use faer::linalg::matmul::matmul;
use faer::linalg::matmul::triangular::{self, BlockStructure};
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;
use faer::{Accum, MatMut, MatRef, Par};

use super::NONE;
use super::schedule::{TreeSchedule, supernode_pattern};

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

/// The failing pivot of a factorization: the column in faer's permuted order, as
/// `LltError::NonPositivePivot` reports it from faer's supernodal path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NonPositivePivot {
    pub index: usize,
}

/// One worker's buffers: the global-to-local row map of the supernode being factored, an
/// update block, its row map, the dense LLᵀ scratch and the solve's buffer.
pub(super) struct Scratch {
    global_to_local: Vec<usize>,
    update: Vec<f64>,
    rows: Vec<usize>,
    stack: MemBuffer,
    /// The solve's: a supernode's update of its pattern rows, or its pattern's entries and
    /// its own.
    pub(super) solve: Vec<f64>,
}

impl Scratch {
    fn new(schedule: &TreeSchedule) -> Self {
        Self {
            global_to_local: vec![NONE; schedule.n],
            update: vec![0.0; schedule.max_update],
            rows: vec![0; schedule.max_update_rows],
            stack: MemBuffer::new(schedule.cholesky_scratch),
            solve: vec![0.0; schedule.max_block_rows],
        }
    }
}

/// Per-worker scratch kept across factorizations and solves. A task takes one for as long as
/// it factors or solves (a supernode, or a whole sequential subtree) and gives it back; a thread that steals a
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

    pub(super) fn with<R>(&self, schedule: &TreeSchedule, f: impl FnOnce(&mut Scratch) -> R) -> R {
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
        // On a pool thread, so the kernels of the supernodes after the last join (the
        // root's) do not each enter the pool from outside.
        crate::parallel::counted_on_pool(|| factor_forest(&job, &schedule.roots, l_values, 0));
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
