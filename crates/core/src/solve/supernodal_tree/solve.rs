//! The triangular solves with a subtree-scheduled factor, `L y = b` then `Lᵀ x = y`, in the
//! permuted order: independent subtrees concurrently, like the factorization, and the large
//! supernodes above them (half of L's values on two threads for the 49k box) split over the
//! pool inside.
//!
//! faer's supernodal solve visits the supernodes in one sequential loop and is parallel only
//! inside each supernode's products, which for one right-hand side are matrix-vector products
//! too small to split well.
//!
//! Forward: a supernode `d` solves its diagonal block and subtracts its update `u = L_pd y_d`
//! (row by row a sum over `d`'s columns in ascending order) from the entries of its pattern
//! `p`. A sequential task *pushes* updates into the rows of its own subtree; a supernode above
//! the tasks (split, waiting for its children) instead *pulls* the updates of all its
//! descendants, in ascending order, into its own rows, as pushes from concurrent tasks into it
//! would race. Pushing in ascending order subtracts the same updates in the same order as
//! pulling. Backward: a supernode gathers its pattern's final entries and takes dot products
//! down its columns (`x_s = L_ssᵀ⁻¹ (y_s − L_psᵀ x_p)`), writing only its own entries. The
//! diagonal blocks are solved by blocks of [`DIAGONAL_BLOCK`] columns, the rectangle below
//! (forward) or beside (backward) each block split over the pool when large. Every entry sees
//! the same operations in the same order whatever the schedule, and the kernels multiply and
//! add separately (no fused multiply-adds) in both their builds, so for a given factor the
//! solution has the same bits on any thread count, with or without AVX2.

use faer::Par;
use faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky;

use super::numeric::ScratchPool;
use super::schedule::{TreeSchedule, supernode_pattern};
use crate::parallel::DisjointSlice;

/// Entries of L from which one product of a solve (a supernode's pattern rows, or the
/// rectangle beside a diagonal block) is split over the pool: smaller ones are a few
/// microseconds of work, the cost of a join.
pub const SOLVE_SPLIT_ENTRIES: usize = 1 << 15;

/// Columns of a diagonal block solved as one dense triangle.
pub const DIAGONAL_BLOCK: usize = 64;

/// The read-only inputs of one solve.
struct SolveJob<'a> {
    symbolic: &'a SymbolicSupernodalCholesky<usize>,
    schedule: &'a TreeSchedule,
    pool: &'a ScratchPool,
    l: &'a [f64],
    grain: f64,
    /// The pool's thread count (1: sequential).
    threads: usize,
    /// Whether the kernels may use AVX2 (the same arithmetic, four lanes at a time).
    avx2: bool,
}

impl SolveJob<'_> {
    fn ncols(&self, s: usize) -> usize {
        self.symbolic.supernode_end()[s] - self.symbolic.supernode_begin()[s]
    }

    /// Supernode `s`'s column-major block (`ncols + pattern` rows) and its row count.
    fn block(&self, s: usize) -> (&[f64], usize) {
        let val_ptr = self.symbolic.col_ptr_for_val();
        let block = &self.l[val_ptr[s]..val_ptr[s + 1]];
        (block, block.len() / self.ncols(s).max(1))
    }

    /// Whether a product over `part` of `whole` rows or columns, `entries` of L in all,
    /// splits further: large enough, and not yet one part per thread.
    fn splits(&self, part: usize, whole: usize, entries: usize) -> bool {
        self.threads > 1
            && part >= 2
            && part * self.threads > whole
            && entries >= SOLVE_SPLIT_ENTRIES
    }
}

/// Calls `f(part, first)` on parts of `entries` (whose first entry is number `first`):
/// `entries` itself, or — when the product over it is large (`per_entry` entries of L each)
/// and there are threads left — its halves at once, recursively, down to one part per thread
/// of `whole` entries. Each entry is computed by one call either way.
fn in_parts<F>(
    job: &SolveJob<'_>,
    entries: &mut [f64],
    first: usize,
    whole: usize,
    per_entry: usize,
    f: &F,
) where
    F: Fn(&mut [f64], usize) + Sync,
{
    if job.splits(entries.len(), whole, entries.len() * per_entry) {
        let mid = entries.len() / 2;
        let (left, right) = entries.split_at_mut(mid);
        rayon::join(
            || in_parts(job, left, first, whole, per_entry, f),
            || in_parts(job, right, first + mid, whole, per_entry, f),
        );
        return;
    }
    f(entries, first);
}

/// Solves `L Lᵀ x = b` in place (`x` holds `b` in the permuted order) with the factor
/// `l_values` that [`super::factorize`] wrote for `symbolic`. `Par::Seq` runs on the calling
/// thread, `Par::Rayon` on rayon's current pool; the bits of `x` are the same either way.
pub fn solve_in_place(
    x: &mut [f64],
    l_values: &[f64],
    symbolic: &SymbolicSupernodalCholesky<usize>,
    schedule: &TreeSchedule,
    pool: &ScratchPool,
    par: Par,
) {
    assert_eq!(x.len(), schedule.n, "right-hand side length");
    assert_eq!(l_values.len(), symbolic.len_val(), "factor storage size");
    let threads = par.degree().max(1);
    let job = SolveJob {
        symbolic,
        schedule,
        pool,
        l: l_values,
        grain: schedule.grain(threads),
        threads,
        avx2: kernels::has_avx2(),
    };
    let ns = symbolic.n_supernodes();
    if ns == 0 {
        return;
    }
    if threads > 1 {
        // On a pool thread, entered once rather than at every join.
        crate::parallel::counted_on_pool(|| {
            forward_forest(&job, &schedule.roots, x, 0);
            backward_forest(&job, &schedule.roots, &DisjointSlice::new(x));
        });
    } else {
        pool.with(schedule, |scratch| {
            forward_task(&job, 0..ns, x, 0, &mut scratch.solve);
            let shared = DisjointSlice::new(x);
            for s in (0..ns).rev() {
                backward_supernode(&job, s, &shared, &mut scratch.solve);
            }
        });
    }
}

/// The forward solve of the consecutive subtrees rooted at `roots`, concurrently. `x` starts
/// at column `base` and covers exactly those subtrees' columns.
fn forward_forest(job: &SolveJob<'_>, roots: &[usize], x: &mut [f64], base: usize) {
    match roots {
        [] => {}
        [r] => forward_subtree(job, *r, x, base),
        _ => {
            let mid = roots.len() / 2;
            let split = job.symbolic.supernode_begin()[job.schedule.first_desc[roots[mid]]];
            let (left, right) = x.split_at_mut(split - base);
            rayon::join(
                || forward_forest(job, &roots[..mid], left, base),
                || forward_forest(job, &roots[mid..], right, split),
            );
        }
    }
}

/// The forward solve of `root`'s subtree: one sequential task when small, else its
/// children's subtrees concurrently and then `root`, which pulls its descendants' updates.
fn forward_subtree(job: &SolveJob<'_>, root: usize, x: &mut [f64], base: usize) {
    let schedule = job.schedule;
    let children = schedule.children(root);
    if schedule.subtree_flops[root] <= job.grain || children.is_empty() {
        let supernodes = schedule.first_desc[root]..root + 1;
        job.pool.with(schedule, |scratch| {
            forward_task(job, supernodes, x, base, &mut scratch.solve);
        });
        return;
    }
    let start = job.symbolic.supernode_begin()[root];
    let (below, rest) = x.split_at_mut(start - base);
    forward_forest(job, children, below, base);
    let own = &mut rest[..job.ncols(root)];
    pull_updates(job, root, below, base, own);
    solve_diagonal(job, root, own);
}

/// The supernodes `range` in order, each solving its diagonal block and pushing its update
/// into the rows of `x` (which starts at column `base`) before `x`'s end; rows beyond are
/// the ancestors outside the task, which pull. `tmp` holds an update.
fn forward_task(
    job: &SolveJob<'_>,
    range: std::ops::Range<usize>,
    x: &mut [f64],
    base: usize,
    tmp: &mut [f64],
) {
    let begin = job.symbolic.supernode_begin();
    let hi = base + x.len();
    for s in range {
        let ncols = job.ncols(s);
        let start = begin[s] - base;
        solve_diagonal(job, s, &mut x[start..start + ncols]);
        let pattern = supernode_pattern(job.symbolic, s);
        let m = pattern.partition_point(|&r| r < hi);
        if m == 0 {
            continue;
        }
        let (y, after) = x[start..].split_at_mut(ncols);
        let u = &mut tmp[..m];
        update(job, s, 0, y, u);
        let after_base = begin[s] + ncols;
        for (&v, &row) in u.iter().zip(&pattern[..m]) {
            after[row - after_base] -= v;
        }
    }
}

/// `u = L_pd[first..first + u.len()] · y_d`: rows `first..` of `d`'s pattern, each a sum over
/// `d`'s columns in ascending order (the order pushes and pulls share).
fn update(job: &SolveJob<'_>, d: usize, first: usize, y: &[f64], u: &mut [f64]) {
    let (block, nrows) = job.block(d);
    let at = job.ncols(d) + first;
    u.fill(0.0);
    kernels::accumulate(job.avx2, (block, nrows, at), y, u, 1.0);
}

/// Subtracts from `own` (the entries of `s`'s columns) the update of every descendant, in
/// ascending order. `below` (starting at column `base`) holds the descendants' solved
/// entries. A large supernode splits its rows over the pool ([`in_parts`]); each entry sees
/// the same operations either way.
fn pull_updates(job: &SolveJob<'_>, s: usize, below: &[f64], base: usize, own: &mut [f64]) {
    let ncols = job.ncols(s);
    let (begin, end) = (job.symbolic.supernode_begin(), job.symbolic.supernode_end());
    let schedule = job.schedule;
    // The updates pulled into a row scale with the supernode's width (a proxy: the exact
    // count is a sum over the descendants).
    in_parts(job, own, begin[s], ncols, ncols, &|own, row0| {
        let row_end = row0 + own.len();
        job.pool.with(schedule, |scratch| {
            for &d in &schedule.desc_idx[schedule.desc_ptr[s]..schedule.desc_ptr[s + 1]] {
                let pattern = supernode_pattern(job.symbolic, d);
                let first = pattern.partition_point(|&r| r < row0);
                let k = pattern[first..].partition_point(|&r| r < row_end);
                if k == 0 {
                    continue;
                }
                let u = &mut scratch.solve[..k];
                update(job, d, first, &below[begin[d] - base..end[d] - base], u);
                for (&v, &row) in u.iter().zip(&pattern[first..first + k]) {
                    own[row - row0] -= v;
                }
            }
        });
    });
}

/// `y_s = L_ss⁻¹ y_s` by blocks of [`DIAGONAL_BLOCK`] columns: each block's triangle, then
/// the rows below it minus the block's columns (split over the pool when large).
fn solve_diagonal(job: &SolveJob<'_>, s: usize, own: &mut [f64]) {
    let (block, nrows) = job.block(s);
    let n = own.len();
    let mut j0 = 0;
    while j0 < n {
        let j1 = (j0 + DIAGONAL_BLOCK).min(n);
        for c in j0..j1 {
            let col = &block[c * nrows..c * nrows + j1];
            own[c] /= col[c];
            let yc = own[c];
            for (t, &v) in own[c + 1..j1].iter_mut().zip(&col[c + 1..]) {
                *t -= v * yc;
            }
        }
        let (head, tail) = own.split_at_mut(j1);
        let columns = &block[j0 * nrows..];
        subtract_below(job, columns, nrows, j1, &head[j0..], tail);
        j0 = j1;
    }
}

/// `tail −= L[at.., cols] · y`: `columns` starts at the first of `y.len()` columns of
/// `nrows` rows, `tail` holds rows `at..`; its rows split over the pool when large.
fn subtract_below(
    job: &SolveJob<'_>,
    columns: &[f64],
    nrows: usize,
    at: usize,
    y: &[f64],
    tail: &mut [f64],
) {
    let whole = tail.len();
    in_parts(job, tail, at, whole, y.len(), &|tail, at| {
        kernels::accumulate(job.avx2, (columns, nrows, at), y, tail, -1.0);
    });
}

/// The backward solve of the consecutive subtrees rooted at `roots`, concurrently.
fn backward_forest(job: &SolveJob<'_>, roots: &[usize], x: &DisjointSlice<'_, f64>) {
    match roots {
        [] => {}
        [r] => backward_subtree(job, *r, x),
        _ => {
            let mid = roots.len() / 2;
            rayon::join(
                || backward_forest(job, &roots[..mid], x),
                || backward_forest(job, &roots[mid..], x),
            );
        }
    }
}

/// The backward solve of `root`'s subtree: `root` first, then its children's subtrees
/// concurrently (sequentially, top down, when the subtree is small).
fn backward_subtree(job: &SolveJob<'_>, root: usize, x: &DisjointSlice<'_, f64>) {
    let schedule = job.schedule;
    let children = schedule.children(root);
    let small = schedule.subtree_flops[root] <= job.grain || children.is_empty();
    job.pool.with(schedule, |scratch| {
        let first = if small {
            schedule.first_desc[root]
        } else {
            root
        };
        for s in (first..=root).rev() {
            backward_supernode(job, s, x, &mut scratch.solve);
        }
    });
    if !small {
        backward_forest(job, children, x);
    }
}

/// `x_s = L_ssᵀ⁻¹ (y_s − L_psᵀ x_p)` over `s`'s pattern `p` (its ancestors' entries, all
/// final). `buffer` (a block's rows long) holds `x_p` and then `x_s` contiguously.
///
/// Every task writes only its supernodes' entries and reads those and their ancestors'
/// (finished before the task started: a subtree runs after its root), so no entry is read
/// while another task writes it.
fn backward_supernode(
    job: &SolveJob<'_>,
    s: usize,
    x: &DisjointSlice<'_, f64>,
    buffer: &mut [f64],
) {
    let pattern = supernode_pattern(job.symbolic, s);
    let start = job.symbolic.supernode_begin()[s];
    let ncols = job.ncols(s);
    let (block, nrows) = job.block(s);
    let (xp, rest) = buffer.split_at_mut(pattern.len());
    for (g, &row) in xp.iter_mut().zip(pattern.iter()) {
        // SAFETY: `row` is an ancestor's column, final before this task started.
        *g = unsafe { x.read(row) };
    }
    let own = &mut rest[..ncols];
    for (c, o) in own.iter_mut().enumerate() {
        // SAFETY: `s`'s columns are this task's alone.
        *o = unsafe { x.read(start + c) };
    }
    subtract_dots(job, (block, nrows), ncols, xp, own, 0);
    // The diagonal block by blocks of columns, the last first: each block's columns minus
    // their dot products with the solved rows after the block, then the block's triangle.
    let mut j1 = ncols;
    while j1 > 0 {
        let j0 = j1.saturating_sub(DIAGONAL_BLOCK);
        let (head, solved) = own.split_at_mut(j1);
        subtract_dots(job, (block, nrows), j1, solved, &mut head[j0..], j0);
        for c in (j0..j1).rev() {
            let col = &block[c * nrows..c * nrows + j1];
            let t = head[c] - kernels::dot(job.avx2, &col[c + 1..], &head[c + 1..j1]);
            head[c] = t / col[c];
        }
        j1 = j0;
    }
    for (c, &o) in own.iter().enumerate() {
        // SAFETY: as above.
        unsafe { x.write(start + c, o) };
    }
}

/// `own_c −= L[at..at + xs.len(), c]ᵀ xs` for `s`'s columns `c0..c0 + own.len()` of `block`
/// (dot products down each column, contiguous); the columns split over the pool when large.
fn subtract_dots(
    job: &SolveJob<'_>,
    (block, nrows): (&[f64], usize),
    at: usize,
    xs: &[f64],
    own: &mut [f64],
    c0: usize,
) {
    if xs.is_empty() {
        return;
    }
    let whole = own.len();
    in_parts(job, own, c0, whole, xs.len(), &|own, c0| {
        let column = |c: usize| &block[c * nrows + at..][..xs.len()];
        let mut pairs = own.chunks_exact_mut(2);
        let mut c = c0;
        for pair in &mut pairs {
            let (a, b) = kernels::dot2(job.avx2, column(c), column(c + 1), xs);
            pair[0] -= a;
            pair[1] -= b;
            c += 2;
        }
        for o in pairs.into_remainder() {
            *o -= kernels::dot(job.avx2, column(c), xs);
        }
    });
}

/// The solve's inner loops, each compiled twice on x86-64 (baseline and AVX2) from one body:
/// separate multiplies and adds in a fixed order, so both give the same bits.
mod kernels {
    /// Whether this CPU runs the AVX2 versions.
    pub fn has_avx2() -> bool {
        #[cfg(target_arch = "x86_64")]
        {
            std::arch::is_x86_feature_detected!("avx2")
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            false
        }
    }

    /// Columns of L: a column-major block from its first column, its row count, and the
    /// first row used.
    pub type Columns<'a> = (&'a [f64], usize, usize);

    /// `u[i] += sign · Σ_c L[at + i, c] y[c]`, one term at a time in column order, for the
    /// `y.len()` columns of `block` (column-major, `nrows` rows) from its first. Four columns
    /// per pass over `u`, so four streams of L are read at once.
    pub fn accumulate(avx2: bool, l: Columns<'_>, y: &[f64], u: &mut [f64], sign: f64) {
        #[cfg(target_arch = "x86_64")]
        if avx2 {
            // SAFETY: the CPU has AVX2 (checked by `has_avx2`).
            return unsafe { accumulate_avx2(l, y, u, sign) };
        }
        let _ = avx2;
        accumulate_body(l, y, u, sign)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn accumulate_avx2(l: Columns<'_>, y: &[f64], u: &mut [f64], sign: f64) {
        accumulate_body(l, y, u, sign)
    }

    #[inline(always)]
    fn accumulate_body((block, nrows, at): Columns<'_>, y: &[f64], u: &mut [f64], sign: f64) {
        let m = u.len();
        let column = |c: usize| &block[c * nrows + at..][..m];
        let mut c = 0;
        while c + 4 <= y.len() {
            let (a, b, e, f) = (column(c), column(c + 1), column(c + 2), column(c + 3));
            let (ya, yb, ye, yf) = (
                sign * y[c],
                sign * y[c + 1],
                sign * y[c + 2],
                sign * y[c + 3],
            );
            for i in 0..m {
                let mut t = u[i];
                t += a[i] * ya;
                t += b[i] * yb;
                t += e[i] * ye;
                t += f[i] * yf;
                u[i] = t;
            }
            c += 4;
        }
        while c < y.len() {
            let yc = sign * y[c];
            for (t, &v) in u.iter_mut().zip(column(c)) {
                *t += v * yc;
            }
            c += 1;
        }
    }

    /// `Σ a_i b_i` in four interleaved partial sums.
    pub fn dot(avx2: bool, a: &[f64], b: &[f64]) -> f64 {
        dot2(avx2, a, a, b).0
    }

    /// [`dot`] of `a` and of `b` with `x` in one pass (two streams at once).
    pub fn dot2(avx2: bool, a: &[f64], b: &[f64], x: &[f64]) -> (f64, f64) {
        #[cfg(target_arch = "x86_64")]
        if avx2 {
            // SAFETY: the CPU has AVX2 (checked by `has_avx2`).
            return unsafe { dot2_avx2(a, b, x) };
        }
        let _ = avx2;
        dot2_body(a, b, x)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn dot2_avx2(a: &[f64], b: &[f64], x: &[f64]) -> (f64, f64) {
        dot2_body(a, b, x)
    }

    #[inline(always)]
    fn dot2_body(a: &[f64], b: &[f64], x: &[f64]) -> (f64, f64) {
        let n = x.len();
        let (a, b) = (&a[..n], &b[..n]);
        let whole = n / 4 * 4;
        let (mut p, mut q) = ([0.0; 4], [0.0; 4]);
        for i in (0..whole).step_by(4) {
            for l in 0..4 {
                p[l] += a[i + l] * x[i + l];
                q[l] += b[i + l] * x[i + l];
            }
        }
        let (mut tp, mut tq) = (0.0, 0.0);
        for i in whole..n {
            tp += a[i] * x[i];
            tq += b[i] * x[i];
        }
        (
            (p[0] + p[1]) + (p[2] + p[3]) + tp,
            (q[0] + q[1]) + (q[2] + q[3]) + tq,
        )
    }

    #[cfg(test)]
    mod tests {
        use super::*;

        /// Both builds of each kernel give the same bits (where this CPU has AVX2).
        #[test]
        fn avx2_and_baseline_kernels_agree_bit_for_bit() {
            if !has_avx2() {
                return;
            }
            let value = |i: usize| ((i * 7919 % 1013) as f64 - 506.0) / 97.0;
            let block: Vec<f64> = (0..37 * 11).map(value).collect();
            for cols in [1, 3, 4, 7, 11] {
                let y: Vec<f64> = (0..cols).map(|i| value(i + 500)).collect();
                for sign in [1.0, -1.0] {
                    let (mut u1, mut u2) = (vec![0.5; 30], vec![0.5; 30]);
                    accumulate(false, (&block, 37, 5), &y, &mut u1, sign);
                    accumulate(true, (&block, 37, 5), &y, &mut u2, sign);
                    assert_eq!(u1, u2);
                    assert_ne!(u1, vec![0.5; 30]);
                }
            }
            for n in [0, 1, 5, 8, 33] {
                let (a, b, x) = (&block[..n], &block[40..40 + n], &block[100..100 + n]);
                assert_eq!(dot2(false, a, b, x), dot2(true, a, b, x));
                let exact: f64 = a.iter().zip(x).map(|(p, q)| p * q).sum();
                assert!((dot(false, a, x) - exact).abs() <= 1e-12 * (1.0 + exact.abs()));
            }
        }
    }
}
