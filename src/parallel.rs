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
