//! Solver studies: fixed steps of a scene's trajectory — the incremental potentials its scheme
//! minimizes there — each solved by every run's Newton components (direction, globalization,
//! Hessian filter, linear solver) to working precision, with every iteration logged; the
//! iterations, wall time, factorizations, linear iterations and backtracks each run needs to
//! reach each tolerance of a ladder, under every convergence criterion.
//!
//! The states come from one trajectory per scene: the scene's scheme with default Newton
//! settings converged to `driver_tolerance` (required), so every run of a scene solves the same
//! problems, bit for bit; each row carries their fingerprint to show it. A run's own criterion
//! and tolerance do not decide anything: each solve goes on past the energy's round-off with
//! full steps (`roundoff_stop = false`) until a full step no longer lowers the gradient (the
//! `roundoff` stop: working precision) or `max_iterations`, and every criterion is read off the
//! log afterwards (the iterates do not depend on the criterion).

mod measure;
mod plan;
mod present;

pub use measure::COLUMNS;
pub use measure::Reach;
pub use measure::driver_settings;
pub use measure::measure;
pub use measure::reach;

use crate::study::vocabulary::config::StudyFile;
use softbench_core::integrate::newton::Criterion;

/// The kind's name in study files, the name of its table and the key of its resolved table.
const NAME: &str = "solver";

/// The tolerance ladder every criterion is read at.
pub const TOLERANCES: [f64; 5] = [1e-2, 1e-4, 1e-6, 1e-8, 1e-10];

/// The ladder's columns in `runs.csv`, per tolerance: iterations, median wall seconds with the
/// lowest and highest over the repeats, factorizations, linear iterations, backtracks (summed
/// over the solved steps).
const LADDER_COLUMNS: [[&str; 7]; 5] = [
    [
        "iterations_1e-2",
        "seconds_1e-2",
        "seconds_low_1e-2",
        "seconds_high_1e-2",
        "factorizations_1e-2",
        "linear_iterations_1e-2",
        "backtracks_1e-2",
    ],
    [
        "iterations_1e-4",
        "seconds_1e-4",
        "seconds_low_1e-4",
        "seconds_high_1e-4",
        "factorizations_1e-4",
        "linear_iterations_1e-4",
        "backtracks_1e-4",
    ],
    [
        "iterations_1e-6",
        "seconds_1e-6",
        "seconds_low_1e-6",
        "seconds_high_1e-6",
        "factorizations_1e-6",
        "linear_iterations_1e-6",
        "backtracks_1e-6",
    ],
    [
        "iterations_1e-8",
        "seconds_1e-8",
        "seconds_low_1e-8",
        "seconds_high_1e-8",
        "factorizations_1e-8",
        "linear_iterations_1e-8",
        "backtracks_1e-8",
    ],
    [
        "iterations_1e-10",
        "seconds_1e-10",
        "seconds_low_1e-10",
        "seconds_high_1e-10",
        "factorizations_1e-10",
        "linear_iterations_1e-10",
        "backtracks_1e-10",
    ],
];

/// The `[solver]` table: which steps, read under which criterion, capped where.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverStudySettings {
    /// The steps whose incremental potentials are solved (1 is the first step from the
    /// initial state), in increasing order.
    #[serde(default = "default_steps")]
    pub steps: Vec<usize>,
    /// The criterion `runs.csv`'s ladder is read under (`solves.csv` has every criterion).
    #[serde(default = "default_criterion")]
    pub criterion: Criterion,
    /// The cap on each solve's iterations (a tolerance not reached within it is reported so).
    #[serde(default = "default_max_iterations")]
    pub max_iterations: u32,
    /// How many times each run solves its steps (each time with a fresh Newton): the wall
    /// times' median and spread come from these.
    #[serde(default = "default_repeats")]
    pub repeats: usize,
    /// The `scaled-gradient` tolerance (required) of the trajectory that sets the steps.
    #[serde(default = "default_driver_tolerance")]
    pub driver_tolerance: f64,
    /// The cap on that trajectory's Newton iterations per step.
    #[serde(default = "default_driver_max_iterations")]
    pub driver_max_iterations: u32,
}

fn default_steps() -> Vec<usize> {
    vec![1]
}

fn default_criterion() -> Criterion {
    Criterion::ScaledGradient
}

fn default_max_iterations() -> u32 {
    100
}

fn default_repeats() -> usize {
    1
}

fn default_driver_tolerance() -> f64 {
    1e-10
}

fn default_driver_max_iterations() -> u32 {
    100
}

/// The study's `[solver]` table as resolved at load.
fn settings(file: &StudyFile) -> Option<SolverStudySettings> {
    file.settings(NAME)
}

/// A solver study.
pub(in crate::study) struct Solver;

/// `1, 5, 20`.
fn steps_text(steps: &[usize]) -> String {
    steps
        .iter()
        .map(usize::to_string)
        .collect::<Vec<_>>()
        .join(", ")
}
