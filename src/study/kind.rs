//! What the rest of the study code asks of a study kind: each kind's module
//! (`trajectory.rs`, `work_precision.rs`, `stability.rs`) declares its
//! [`KindSpec`] (its `runs.csv` columns, the report's summary columns and paragraphs, a
//! sweep's default metrics, the progress line, what it hashes, how loading adapts its runs,
//! what its runs share and how one is measured); `kinds.rs` picks one per
//! [`super::StudyKind`].

use super::config::{StudyFile, WorkPrecisionSettings};
use super::context::Context;
use super::error::StudyError;
use super::grid::Axis;
use super::measured::Measured;
use super::plots::{Emit, SceneRows};
use super::spec::{RunSpec, Study};
use super::table::Table;
use crate::parallel::Parallelism;
use crate::plot::PlotError;
use crate::scene::SceneConfig;

/// A study kind's columns, summaries, settings and measurement.
pub(super) struct KindSpec {
    /// The measured columns of `runs.csv` (after the identity and parameter columns).
    pub columns: &'static [&'static str],
    /// The report's summary table columns (those present in runs.csv are shown).
    pub summary_columns: &'static [&'static str],
    /// The metrics a sweep plots when the study names none.
    pub sweep_metrics: &'static [&'static str],
    /// What the progress line adds after a finished run's outcome (", error 1e-3").
    pub progress: fn(&Measured) -> Option<String>,
    /// The kind's settings table as hashed into every run's hash (null when it has none).
    pub settings_json: fn(&StudyFile) -> serde_json::Value,
    /// What `--quick` does to the kind's runs, for the report's quick-mode notice.
    pub quick_notice: &'static str,
    /// The report's paragraphs on the kind's settings and every cap that can decide a result.
    pub report_settings: fn(&mut String, &StudyFile),
    /// What the report adds after the references, before the runs (a work-precision study's
    /// observed orders).
    pub report_findings: fn(&mut String, &Table),
    /// Checks of the kind's settings table (`bad` makes the error for a key).
    pub check: Check,
    /// Checks of the kind's `[quick]` settings, whether or not `--quick` is given.
    pub check_quick: fn(&StudyFile, &Context) -> Result<(), StudyError>,
    /// In quick mode, what the kind drops from each method's axes.
    pub quick_axes: fn(&StudyFile, &mut [Vec<Axis>]),
    /// Adapt one run's resolved scene to the kind (`quick` applies `[quick]`).
    pub configure: Configure,
    /// Roughly how many steps one run takes (its trials together, for a stability search): the
    /// cost estimate that balances `--shard` (only ratios between runs matter).
    pub estimated_steps: fn(&StudyFile, &SceneConfig) -> f64,
    /// Whether the runs need the highest mode of each scene before they start.
    pub needs_omega: fn(&StudyFile) -> bool,
    /// How the kind's reference solutions are computed, if it has any.
    pub references: Option<References>,
    /// Measure one run with what the runs share.
    pub measure: fn(&Study, &RunSpec, &Shared, Parallelism) -> Result<Measured, String>,
    /// The kind's own charts of one scene (before the time histories and phases).
    pub scene_charts: fn(&SceneRows, &mut Emit) -> Result<(), PlotError>,
    /// The caption of the energy chart over time, if the kind draws time histories.
    pub energy_caption: Option<&'static str>,
    /// Whether time histories get one chart per time step (when the scene has several).
    pub by_time_step: bool,
    /// Whether the phase chart shows only each line's run at its smallest dt.
    pub phases_at_smallest_dt: bool,
    /// Which runs the pictures of the bodies show.
    pub picture_rows: super::pictures::PictureRows,
    /// The columns whose first number labels a phase bar with its dt.
    pub phase_dt_columns: &'static [&'static str],
}

/// Checks a settings table: the study, its text (for lines), and `bad`, which makes the error
/// for a key.
pub(super) type Check =
    fn(&StudyFile, &Context, &dyn Fn(&str, String) -> StudyError) -> Result<(), StudyError>;

/// Adapts a run's resolved scene: the study, its scene config, the grid axes (for error
/// lines) and whether `[quick]` applies.
pub(super) type Configure =
    fn(&Context, &StudyFile, &mut SceneConfig, &[Axis], bool) -> Result<(), StudyError>;

/// A kind's reference solutions.
pub(super) struct References {
    /// Their settings, if the study computes any.
    pub settings: fn(&StudyFile) -> Option<WorkPrecisionSettings>,
    /// The reference step for the physics of a run.
    pub dt: fn(&Study, &WorkPrecisionSettings, &RunSpec) -> f64,
    /// Whether the runs go on without a reference that failed (else the study stops).
    pub optional: bool,
}

/// What a run gets from what the runs share: its scene's highest mode and its reference
/// (the stability kind's, which is public).
pub(super) use super::stability::Shared;

/// A measured number, shortened for a progress line.
pub(super) fn number(m: &Measured, name: &str) -> Option<String> {
    m.get(name)
        .and_then(|s| s.parse::<f64>().ok())
        .map(super::format::short)
}

/// For kinds without a settings table, a `[quick]` table or findings: nothing to hash, check
/// or write.
pub(super) fn no_settings(_: &StudyFile) -> serde_json::Value {
    serde_json::Value::Null
}
pub(super) fn no_report(_: &mut String, _: &StudyFile) {}
pub(super) fn no_findings(_: &mut String, _: &Table) {}
pub(super) fn no_quick_check(_: &StudyFile, _: &Context) -> Result<(), StudyError> {
    Ok(())
}
pub(super) fn keep_axes(_: &StudyFile, _: &mut [Vec<Axis>]) {}
pub(super) fn run_steps(_: &StudyFile, config: &SceneConfig) -> f64 {
    config.run.steps as f64
}
pub(super) fn no_omega(_: &StudyFile) -> bool {
    false
}
pub(super) fn no_charts(_: &SceneRows, _: &mut Emit) -> Result<(), PlotError> {
    Ok(())
}
