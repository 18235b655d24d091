//! Parallelism as a run setting (not a global): element loops take a [`Parallelism`].

/// How element loops are executed. Results are bitwise identical for every choice: work is
/// split into fixed-size chunks whose partial results are combined in a fixed order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Parallelism {
    /// Run on the calling thread.
    Sequential,
    /// Run on rayon's global pool (its size is set by `RAYON_NUM_THREADS` or the CLI).
    #[default]
    Rayon,
}

use std::ops::Range;

/// Columns per task below which work is not split further.
const MIN_COLUMNS_PER_TASK: usize = 2048;

/// Fewer chunks than this run sequentially in [`for_each_chunk`]: waking the pool costs more
/// than it saves (measured: 627 tets, 3 chunks, ran 10-40% slower in parallel). The loops
/// without a rule of their own use it (springs, damping, ...); the elastic element loops have
/// theirs, from `cargo bench --bench thread_crossover -- elements`.
pub const MIN_PARALLEL_CHUNKS: usize = 8;

/// Call `f(columns, values)` on disjoint contiguous column ranges covering `cols`, where column
/// `c` owns `values[offset(c) - offset(cols.start) .. offset(c + 1) - offset(cols.start)]`.
/// With [`Parallelism::Rayon`] the ranges run in parallel (split in halves with `rayon::join`,
/// no allocation); each column is written by exactly one task, so results do not depend on the
/// split.
pub fn split_columns<O, F>(
    par: Parallelism,
    cols: Range<usize>,
    offset: &O,
    values: &mut [f64],
    f: &F,
) where
    O: Fn(usize) -> usize + Sync,
    F: Fn(Range<usize>, &mut [f64]) + Sync,
{
    if par == Parallelism::Sequential || cols.len() <= MIN_COLUMNS_PER_TASK {
        f(cols, values);
        return;
    }
    let mid = cols.start + cols.len() / 2;
    let (left, right) = values.split_at_mut(offset(mid) - offset(cols.start));
    rayon::join(
        || split_columns(par, cols.start..mid, offset, left, f),
        || split_columns(par, mid..cols.end, offset, right, f),
    );
}

/// Run `f(chunk_index, chunk)` over `out.chunks_mut(chunk_len)`, in parallel with
/// [`Parallelism::Rayon`] from [`MIN_PARALLEL_CHUNKS`] chunks. Returns the error of the
/// lowest-indexed failing chunk (the same error whatever the thread count), or `Ok` when every
/// chunk succeeded.
pub fn for_each_chunk<T, E, F>(
    par: Parallelism,
    out: &mut [T],
    chunk_len: usize,
    f: F,
) -> Result<(), E>
where
    T: Send,
    E: Send,
    F: Fn(usize, &mut [T]) -> Result<(), E> + Sync,
{
    for_each_chunk_from(par, out, chunk_len, MIN_PARALLEL_CHUNKS, f)
}

/// [`for_each_chunk`] in parallel from `min_chunks` chunks (benches measure the rule with it).
pub fn for_each_chunk_from<T, E, F>(
    par: Parallelism,
    out: &mut [T],
    chunk_len: usize,
    min_chunks: usize,
    f: F,
) -> Result<(), E>
where
    T: Send,
    E: Send,
    F: Fn(usize, &mut [T]) -> Result<(), E> + Sync,
{
    use rayon::prelude::*;
    let chunks = out.len().div_ceil(chunk_len.max(1));
    let par = if chunks < min_chunks {
        Parallelism::Sequential
    } else {
        par
    };
    match par {
        Parallelism::Sequential => {
            for (i, c) in out.chunks_mut(chunk_len).enumerate() {
                f(i, c)?;
            }
            Ok(())
        }
        Parallelism::Rayon => out
            .par_chunks_mut(chunk_len)
            .enumerate()
            .map(|(i, c)| f(i, c).map_err(|e| (i, e)))
            .reduce(
                || Ok(()),
                |a, b| match (a, b) {
                    (Err(x), Err(y)) => Err(if x.0 <= y.0 { x } else { y }),
                    (Err(x), _) | (_, Err(x)) => Err(x),
                    _ => Ok(()),
                },
            )
            .map_err(|(_, e)| e),
    }
}

/// Split `range` into `tasks` nearly equal parts run with `rayon::join` (no allocation).
fn split_range<F>(range: Range<usize>, tasks: usize, f: &F)
where
    F: Fn(Range<usize>) + Sync,
{
    if tasks <= 1 {
        f(range);
        return;
    }
    let left_tasks = tasks / 2;
    let mid = range.start + range.len() * left_tasks / tasks;
    rayon::join(
        || split_range(range.start..mid, left_tasks, f),
        || split_range(mid..range.end, tasks - left_tasks, f),
    );
}

/// Per-thread event counts that follow work moved onto rayon's pool by [`counted_on_pool`]:
/// what the work counted on the pool thread is added to the caller's count, as if it had run
/// there. Kept here, below every module that counts or moves work.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ThreadCount {
    /// Obstacle queries (`contact::query_count`): whether a run touched contact code.
    ObstacleQueries,
}

const THREAD_COUNTS: usize = 1;

thread_local! {
    static COUNTS: [std::cell::Cell<u64>; THREAD_COUNTS] = const { [std::cell::Cell::new(0)] };
}

/// This thread's count of `which`.
pub fn thread_count(which: ThreadCount) -> u64 {
    COUNTS.with(|c| c[which as usize].get())
}

/// Adds `n` to this thread's count of `which`.
pub fn add_to_thread_count(which: ThreadCount, n: u64) {
    COUNTS.with(|c| c[which as usize].set(c[which as usize].get() + n));
}

/// Runs `f` on a thread of rayon's pool: right here on a pool thread, else by entering the
/// pool once (the caller waits), so `f`'s parallel calls start at the cost of a join rather
/// than each waking the pool from outside. What `f` counted on the pool thread
/// ([`ThreadCount`]) is added to the caller's counts.
pub fn counted_on_pool<R: Send>(f: impl FnOnce() -> R + Send) -> R {
    if rayon::current_thread_index().is_some() {
        return f();
    }
    let all = |c: &[std::cell::Cell<u64>; THREAD_COUNTS]| c.each_ref().map(|x| x.get());
    let (result, counted) = rayon::scope(|_| {
        let before = COUNTS.with(all);
        let result = f();
        let after = COUNTS.with(all);
        (
            result,
            std::array::from_fn::<u64, THREAD_COUNTS, _>(|i| after[i] - before[i]),
        )
    });
    COUNTS.with(|c| {
        for (cell, n) in c.iter().zip(counted) {
            cell.set(cell.get() + n);
        }
    });
    result
}

/// A slice that parallel tasks read and write in place at indices the caller keeps disjoint:
/// for a colour of a graph colouring, no two items of one colour touch the same entry, so
/// they can all update it at once without a buffer (see [`crate::colouring`]).
pub struct DisjointSlice<'a, T> {
    ptr: *mut T,
    len: usize,
    _borrow: std::marker::PhantomData<&'a mut [T]>,
}

// SAFETY: the slice is borrowed mutably for 'a, and access goes through the unsafe methods,
// whose callers promise that no entry is written by one task while another reads or writes it.
unsafe impl<T: Send + Sync> Sync for DisjointSlice<'_, T> {}
unsafe impl<T: Send> Send for DisjointSlice<'_, T> {}

impl<'a, T: Copy> DisjointSlice<'a, T> {
    /// Wrap `slice` for the duration of a parallel sweep.
    pub fn new(slice: &'a mut [T]) -> Self {
        Self {
            ptr: slice.as_mut_ptr(),
            len: slice.len(),
            _borrow: std::marker::PhantomData,
        }
    }

    /// Entry `i`.
    ///
    /// # Safety
    /// No other task may write entry `i` during the sweep.
    #[inline]
    pub unsafe fn read(&self, i: usize) -> T {
        assert!(i < self.len, "index {i} out of {}", self.len);
        // SAFETY: in bounds (checked); no concurrent writer (the caller's promise).
        unsafe { *self.ptr.add(i) }
    }

    /// Set entry `i` to `value`.
    ///
    /// # Safety
    /// No other task may read or write entry `i` during the sweep.
    #[inline]
    pub unsafe fn write(&self, i: usize, value: T) {
        assert!(i < self.len, "index {i} out of {}", self.len);
        // SAFETY: in bounds (checked); the entry is this task's alone (the caller's promise).
        unsafe { *self.ptr.add(i) = value }
    }
}

/// A Gauss–Seidel sweep's schedule over the groups of a colouring: group `c`'s items split
/// into chunks of at most `chunk` items. [`Self::run`] sweeps the groups in order on every
/// thread of the pool at once: a thread starts group `c` once every chunk of the groups before
/// it has finished, first claims the chunks of its own share of the group (the same share in
/// every group, so with items numbered by place a thread keeps to its part of the body and
/// its caches), then any chunk still unclaimed. The result is that of a sequential sweep in
/// group order, whatever the thread count or who ran which chunk. One join per sweep, not one
/// per group: a group of a few hundred items is a few microseconds of work, the cost of waking
/// a sleeping thread. A thread that arrives late finds its share taken and is never waited
/// for, so the sweep cannot deadlock on a busy pool.
#[derive(Debug, Default)]
pub struct OrderedChunks {
    chunk: usize,
    /// `first[c]`: the number of the first chunk of group `c` (`first[groups]` = all chunks).
    first: Vec<usize>,
    /// The number of items in each group.
    lens: Vec<usize>,
    /// Whether some group has two chunks (else no two threads could ever work at once).
    splits: bool,
    /// Per chunk, the number of the last sweep that claimed it.
    claimed: Vec<std::sync::atomic::AtomicU64>,
    sweeps: std::sync::atomic::AtomicU64,
}

impl OrderedChunks {
    /// The schedule of groups of `lens` items, chunks of `chunk` items (at least 1).
    pub fn new(lens: impl IntoIterator<Item = usize>, chunk: usize) -> Self {
        let chunk = chunk.max(1);
        let lens: Vec<usize> = lens.into_iter().collect();
        let mut first = vec![0];
        for (c, &len) in lens.iter().enumerate() {
            first.push(first[c] + len.div_ceil(chunk));
        }
        let total = first[lens.len()];
        Self {
            chunk,
            splits: lens.iter().any(|&len| len > chunk),
            first,
            lens,
            claimed: (0..total).map(|_| Default::default()).collect(),
            sweeps: Default::default(),
        }
    }

    /// Whether some group has more than one chunk: else [`Self::run`] stays on the calling
    /// thread.
    pub fn splits(&self) -> bool {
        self.splits
    }

    /// Call `f(group, items)` for every chunk, `items` a range within the group, in group
    /// order: on the calling thread, or with [`Parallelism::Rayon`] when some group has more
    /// than one chunk, on every thread of the pool at once. No allocation.
    pub fn run<F>(&self, par: Parallelism, f: &F)
    where
        F: Fn(usize, Range<usize>) + Sync,
    {
        use std::sync::atomic::{AtomicUsize, Ordering};
        let groups = self.lens.len();
        let threads = rayon::current_num_threads();
        if par == Parallelism::Sequential || threads <= 1 || !self.splits {
            for c in 0..groups {
                for k in 0..self.first[c + 1] - self.first[c] {
                    f(c, self.items(c, k));
                }
            }
            return;
        }
        let sweep = self.sweeps.fetch_add(1, Ordering::Relaxed) + 1;
        let done = AtomicUsize::new(0);
        let worker = |share: Range<usize>| {
            for c in 0..groups {
                // Every chunk before group c's was claimed by a thread now running it, so
                // this wait ends without any help from this one.
                let mut spins = 0u32;
                while done.load(Ordering::Acquire) < self.first[c] {
                    spins += 1;
                    if spins < 1 << 12 {
                        std::hint::spin_loop();
                    } else {
                        std::thread::yield_now();
                    }
                }
                let n = self.first[c + 1] - self.first[c];
                let own = n * share.start / threads;
                for k in (own..n).chain(0..own) {
                    let g = self.first[c] + k;
                    if self.claimed[g].fetch_max(sweep, Ordering::Relaxed) < sweep {
                        f(c, self.items(c, k));
                        done.fetch_add(1, Ordering::Release);
                    }
                }
            }
        };
        split_range(0..threads, threads, &worker);
    }

    /// The item range of chunk `k` of group `c`.
    fn items(&self, c: usize, k: usize) -> Range<usize> {
        let start = k * self.chunk;
        start..(start + self.chunk).min(self.lens[c])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// Every item of every group exactly once, and no item of group c before every item of
    /// the groups before it has finished: on 1–4 threads, chunk sizes 1–64, a group of 0.
    #[test]
    fn ordered_chunks_visit_every_item_once_in_group_order() {
        let lens = [70, 3, 0, 129, 64, 65, 1];
        for threads in 1..=4 {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for chunk in [1, 7, 32, 64] {
                let schedule = OrderedChunks::new(lens, chunk);
                for _sweep in 0..3 {
                    let finished: Vec<AtomicUsize> = lens.iter().map(|_| 0.into()).collect();
                    let seen = Mutex::new(vec![Vec::new(); lens.len()]);
                    pool.install(|| {
                        schedule.run(Parallelism::Rayon, &|c, items| {
                            for earlier in 0..c {
                                assert_eq!(
                                    finished[earlier].load(Ordering::SeqCst),
                                    lens[earlier],
                                    "group {c} started before group {earlier} finished"
                                );
                            }
                            seen.lock().unwrap()[c].extend(items.clone());
                            finished[c].fetch_add(items.len(), Ordering::SeqCst);
                        })
                    });
                    for (c, mut items) in seen.into_inner().unwrap().into_iter().enumerate() {
                        items.sort_unstable();
                        assert_eq!(items, (0..lens[c]).collect::<Vec<_>>());
                    }
                }
            }
        }
    }

    /// Two sweeps at once on a two-thread pool (a study running two runs) both finish: a
    /// thread never waits for another to join it.
    #[test]
    fn ordered_chunks_finish_when_the_pool_is_busy() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let a = OrderedChunks::new([500; 40], 8);
        let b = OrderedChunks::new([300; 30], 4);
        let count = AtomicUsize::new(0);
        let work = |_: usize, items: Range<usize>| {
            count.fetch_add(items.len(), Ordering::Relaxed);
        };
        pool.install(|| {
            rayon::join(
                || (0..20).for_each(|_| a.run(Parallelism::Rayon, &work)),
                || (0..20).for_each(|_| b.run(Parallelism::Rayon, &work)),
            )
        });
        assert_eq!(count.into_inner(), 20 * (500 * 40 + 300 * 30));
    }
}
