//! Work-precision runs: the error of a run against a reference solution at fixed sample
//! times, next to its wall time and hardware-independent cost.
//!
//! The position error at a sample time is `|x - x_ref|` over the free DOFs, relative to the
//! reference's largest displacement `max_k |x_ref(t_k) - X|` from the rest positions X (so the
//! error is relative to how far the body moves, not to where it happens to sit), and a run's
//! error is the largest over the sample times. The energy error is
//! `|E - E_ref|` over the largest kinetic + stored energy of the reference. The reference is
//! computed twice, at its step and at half of it; their difference is the reference's own
//! accuracy, and errors below `floor_factor` times it are not scored.

mod measure;
mod plan;
mod present;

pub use measure::COLUMNS;
pub use measure::OWN_COLUMNS;
pub(in crate::study) use measure::measure_with;
pub use present::DRIFT_RANKED_WITHIN;

use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::measured::Measured;
use crate::study::vocabulary::reference::{Reference, ScoringSettings};
use crate::study::vocabulary::spec::RunSpec;
use softbench_core::parallel::Parallelism;

/// A work-precision study: each run's error against a reference solution.
pub(in crate::study) struct WorkPrecision;

/// The kind's name in study files, and the key of its resolved table.
const NAME: &str = "work-precision";

/// The study's `[work-precision]` table as resolved at load.
fn settings(file: &StudyFile) -> Option<ScoringSettings> {
    file.settings(NAME)
}

/// Run one work-precision run and score it against `reference`.
pub fn measure(
    spec: &RunSpec,
    settings: &ScoringSettings,
    reference: &Reference,
    parallelism: Parallelism,
) -> Result<Measured, String> {
    measure_with(spec, settings, reference, parallelism, true, None)
}
