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

/// Fewer chunks than this run sequentially: waking the pool costs more than it saves
/// (measured: 627 tets, 3 chunks, ran 10-40% slower in parallel).
const MIN_PARALLEL_CHUNKS: usize = 8;

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
/// [`Parallelism::Rayon`]. Returns the error of the lowest-indexed failing chunk (the same
/// error whatever the thread count), or `Ok` when every chunk succeeded.
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
    use rayon::prelude::*;
    let chunks = out.len().div_ceil(chunk_len.max(1));
    let par = if chunks < MIN_PARALLEL_CHUNKS {
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
