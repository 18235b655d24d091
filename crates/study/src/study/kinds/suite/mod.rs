//! The benchmark suite: every registered method on a problem set, under one protocol.
//!
//! A suite's scenes are *problems* (scene files with a `[problem]` table, usually a folder of
//! them): each fixes its physics, its step `run.dt`, its horizon `run.dt × run.steps`, its
//! budget `run.budget`, the accuracy a run must reach and how its reference is made (a method
//! at its step, checked against an independent second solution whose difference is the
//! reference's error bar). The suite runs every method once per problem and convergence
//! cut-off level, with one settings block per method for the whole suite (`[[methods]]`; a
//! registered method without one runs with its defaults), and judges each run: *solved* when
//! it reached the horizon within its budget with an error within the problem's tolerance,
//! else failed with a kind. Methods that cannot run a problem (a local solver without a form
//! for its material) and problems whose data is missing are left out with the reason, and
//! listed. The aggregates over the runs — data and performance profiles per stratum, tier and
//! level, pairwise views and findings — are `suite_aggregates` (written by `suite_tables`, read by `suite_report`).

mod measure;
mod plan;
mod present;

pub use measure::COLUMNS;
pub use measure::SUITE_COLUMNS;

use crate::study::vocabulary::config::StudyFile;
use std::collections::BTreeMap;

pub mod aggregates;

pub mod report;

pub mod tables;

/// The kind's name in study files, and the key of its resolved table.
const NAME: &str = "suite";

/// The `[suite]` table.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(in crate::study) struct SuiteSettings {
    /// Names of the convergence cut-off levels, loosest first (at least two). A method
    /// block's one multi-valued key is its cut-off, with one value per level.
    pub levels: Vec<String>,
    /// `"all"`: every registered method (those without a `[[methods]]` block run with their
    /// defaults, at every level); `"listed"`: only the `[[methods]]`. Default `"all"`.
    #[serde(default = "all")]
    pub methods: String,
    /// Methods left out of the suite, with the reason (the omissions list shows it).
    #[serde(default)]
    pub omit: BTreeMap<String, String>,
    /// Folders of private problems (relative to the study file): the hidden tier, whose
    /// aggregates are reported apart from the public problems'.
    #[serde(default)]
    pub hidden: Vec<String>,
    /// Newton must converge within its iteration cap, or the step fails. Default true.
    #[serde(default = "yes")]
    pub require_newton_convergence: bool,
    /// Times each run is run: wall time is the median. Default 1.
    #[serde(default = "one")]
    pub repeats: usize,
}

fn yes() -> bool {
    true
}

fn one() -> usize {
    1
}

fn settings(file: &StudyFile) -> Option<SuiteSettings> {
    file.settings(NAME)
}

/// The suite.
pub(in crate::study) struct Suite;

fn all() -> String {
    "all".into()
}
