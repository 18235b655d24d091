//! A thread count as a value: the pool a run, a study or a Python call does its parallel work
//! in. Results are the same bits on any thread count ([`crate::parallel`]); the count only
//! decides the speed, so two runs of one process (a notebook, a program) may use different
//! counts side by side. Without a count, work runs in the caller's pool: rayon's global pool
//! (sized by `RAYON_NUM_THREADS`, else one thread per core), or the pool the caller is in.

use std::fmt;
use std::sync::Arc;

/// The most threads a pool may have: far above any machine's cores, low enough that a typo
/// (`threads = 1e9`) is refused rather than spawning threads until the system refuses.
pub const MAX_THREADS: usize = 4096;

/// Where parallel work runs: a pool of its own, or the caller's.
#[derive(Clone, Default)]
pub struct Threads {
    pool: Option<Arc<rayon::ThreadPool>>,
}

/// Why a pool was not made.
#[derive(Debug, thiserror::Error)]
pub enum ThreadsError {
    /// The count is 0 or above [`MAX_THREADS`].
    #[error("threads = {0}: must be at least 1 and at most {MAX_THREADS}")]
    Count(usize),
    /// The system refused the threads.
    #[error("cannot start a pool of {threads} threads: {error}")]
    Start {
        threads: usize,
        error: rayon::ThreadPoolBuildError,
    },
}

impl crate::error_class::Classify for ThreadsError {
    fn class(&self) -> crate::error_class::ErrorClass {
        crate::error_class::ErrorClass::bad_input_if(matches!(self, Self::Count(_)))
    }
}

impl Threads {
    /// A pool of `threads` threads, or (`None`) the caller's pool.
    pub fn new(threads: Option<usize>) -> Result<Self, ThreadsError> {
        let Some(n) = threads else {
            return Ok(Self::default());
        };
        if !(1..=MAX_THREADS).contains(&n) {
            return Err(ThreadsError::Count(n));
        }
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .thread_name(|i| format!("softbench-{i}"))
            .build()
            .map_err(|error| ThreadsError::Start { threads: n, error })?;
        Ok(Self {
            pool: Some(Arc::new(pool)),
        })
    }

    /// Run `f` in the pool (on one of its threads, so every parallel loop inside uses it), or
    /// on the calling thread when there is no pool of its own.
    pub fn install<R: Send>(&self, f: impl FnOnce() -> R + Send) -> R {
        match &self.pool {
            Some(pool) => pool.install(f),
            None => f(),
        }
    }

    /// How many threads parallel work gets: the pool's, or the caller's pool's.
    pub fn count(&self) -> usize {
        self.pool
            .as_ref()
            .map_or_else(rayon::current_num_threads, |p| p.current_num_threads())
    }

    /// Whether this is a pool of its own (a count was given).
    pub fn is_own(&self) -> bool {
        self.pool.is_some()
    }
}

impl fmt::Debug for Threads {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.pool {
            Some(p) => write!(f, "Threads({})", p.current_num_threads()),
            None => f.write_str("Threads(caller's pool)"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pool_of_its_own_has_its_count_and_work_inside_sees_it() {
        for n in [1, 2, 3] {
            let threads = Threads::new(Some(n)).unwrap();
            assert_eq!(threads.count(), n);
            assert_eq!(threads.install(rayon::current_num_threads), n);
            assert!(threads.install(|| rayon::current_thread_index().is_some()));
        }
        let caller = Threads::new(None).unwrap();
        assert!(!caller.is_own());
        assert_eq!(
            caller.install(rayon::current_num_threads),
            rayon::current_num_threads()
        );
    }

    #[test]
    fn a_count_of_zero_or_too_many_is_refused() {
        for n in [0, MAX_THREADS + 1] {
            let e = Threads::new(Some(n)).unwrap_err();
            assert!(matches!(e, ThreadsError::Count(m) if m == n), "{e}");
        }
    }
}
