//! Trajectory runs: run the scene as configured and summarize energy and momentum drift,
//! time per step and evaluation counts.

mod measure;
mod plan;
mod present;

pub use measure::COLUMNS;
pub use measure::Conservation;
pub use measure::OWN_COLUMNS;
pub(in crate::study) use measure::measure_with_state;
pub use measure::momentum_drift;

use crate::study::vocabulary::measured::Measured;
use crate::study::vocabulary::spec::RunSpec;
use softbench_core::parallel::Parallelism;

/// A trajectory study (and the runs of a sweep of one): each run as configured.
pub(in crate::study) struct Trajectory;

/// Run one trajectory.
pub fn measure(spec: &RunSpec, parallelism: Parallelism) -> Result<Measured, String> {
    measure_with_state(spec, parallelism, None).map(|(m, _, _)| m)
}
