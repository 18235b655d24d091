//! What the rest of the study code asks of a study kind: each kind's module
//! (`trajectory.rs`, `work_precision.rs`, `stability.rs`) declares its
//! [`KindSpec`] (its `runs.csv` columns, the report's summary columns, a sweep's default
//! metrics, the progress line); `kinds.rs` picks one per [`super::StudyKind`].

use super::measured::Measured;

/// A study kind's columns and summaries.
pub(super) struct KindSpec {
    /// The measured columns of `runs.csv` (after the identity and parameter columns).
    pub columns: &'static [&'static str],
    /// The report's summary table columns (those present in runs.csv are shown).
    pub summary_columns: &'static [&'static str],
    /// The metrics a sweep plots when the study names none.
    pub sweep_metrics: &'static [&'static str],
    /// What the progress line adds after a finished run's outcome (", error 1e-3").
    pub progress: fn(&Measured) -> Option<String>,
}

/// A measured number, shortened for a progress line.
pub(super) fn number(m: &Measured, name: &str) -> Option<String> {
    m.get(name)
        .and_then(|s| s.parse::<f64>().ok())
        .map(super::format::short)
}
