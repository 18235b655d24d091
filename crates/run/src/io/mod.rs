//! Writing results: every file is written to a temporary name and renamed into place, so an
//! interrupted run never leaves a half-written file under its final name.

mod atomic;

pub use atomic::{AtomicFile, remove_stale_partials, remove_stale_partials_of, write_atomic};
