//! Studies: a TOML file naming scenes and a grid of runs becomes `runs.csv`, per-run series,
//! plots, `meta.json` and `report.md` under `results/<study>/`.
//!
//! [`load`] parses and expands the grid and checks every run before anything is written;
//! [`run`] executes the runs not already complete (resuming an interrupted study), each run
//! measured by its study kind's own module ([`trajectory`], [`work_precision`],
//! [`stability`]; [`kinds()`] lists the registered ones); [`redraw`] draws the plots again from
//! the CSVs. The files form a one-way stack (vocabulary, the kind trait, the kinds, the
//! orchestrators): DESIGN.md's layout describes it.

mod charts;
mod columns;
pub mod config;
mod contact;
mod context;
mod error;
mod eta;
pub mod findings;
pub mod format;
mod grid;
mod identity;
mod kind;
mod kinds;
mod load;
mod machine;
mod measured;
mod merge;
mod meta;
mod meter;
mod own_keys;
pub mod pictures;
pub mod plots;
pub mod profiles;
mod progress;
mod reference;
mod report;
mod rows;
mod runner;
mod settings;
pub mod shard;
mod shard_record;
mod shared;
mod shared_store;
pub mod solver;
mod spec;
pub mod stability;
pub mod suite;
mod suite_aggregates;
mod suite_report;
mod suite_tables;
pub mod table;
pub mod trajectory;
pub mod work_precision;

pub use config::{SWEEP, StudyFile};
pub use error::RunError;
pub use error::{ResultsError, StudyError};
pub use identity::{fnv1a, value_text};
pub use load::load;
pub use machine::Machine;
pub use measured::Measured;
pub use merge::{MergeError, Merged, merge};
pub use meta::{Meta, StudyMeta};
pub use report::compute_findings;
pub use runner::{MergeOutcome, RunOptions, StudyRun, matches, run};
pub use settings::check_name as check_study_name;
pub use shard::Shard;
pub use shard_record::ShardRecord;
pub use spec::{RunSpec, Study};

/// A registered study kind, as `softbench list` and the docs show it.
#[derive(Clone, Copy, Debug)]
pub struct KindInfo {
    /// The name in study files (`study = "..."`).
    pub name: &'static str,
    /// One line: what a run of this kind measures.
    pub description: &'static str,
    /// Its `runs.csv` columns after the identity and parameter columns.
    pub columns: &'static [&'static str],
    /// The tables a minimal study of this kind adds (its settings table and grid).
    pub example: &'static str,
    /// What its scenes add to a plain scene file (empty for kinds that run any scene).
    pub scene_example: &'static str,
}

/// Every registered study kind, in registry order. (A `sweep` study runs one of these over a
/// parameter.)
pub fn kinds() -> Vec<KindInfo> {
    kinds::KINDS
        .iter()
        .map(|k| KindInfo {
            name: k.name(),
            description: k.description(),
            columns: k.columns(),
            example: k.example(),
            scene_example: k.scene_example(),
        })
        .collect()
}

/// Redraw the plots of a results folder from its `runs.csv`, series files and `meta.json`.
pub fn redraw(dir: &std::path::Path) -> Result<Vec<plots::Plot>, RedrawError> {
    let (meta, runs) = read_results(dir)?;
    check_runs_table(&runs, &meta.study, &dir.join("runs.csv"))?;
    let plots = plots::draw_all(dir, &meta.study, &runs)?;
    let report_error = |error| ResultsError::Io {
        path: dir.join("report.md"),
        error,
    };
    report::refresh_findings(dir, &meta, &runs).map_err(report_error)?;
    report::refresh_closing_sections(dir, &meta, &runs, &plots).map_err(report_error)?;
    Ok(plots)
}

/// [`pictures::draw`] for a study's results folder, reading its `runs.csv` and `meta.json` (for
/// the swept parameters that label the runs).
pub fn redraw_pictures(
    dir: &std::path::Path,
    coloring: softbench_run::render::Coloring,
) -> Result<Vec<charts::Plot>, RedrawError> {
    let (meta, runs) = read_results(dir)?;
    let which = kinds::of(&meta.study.kind).picture_rows();
    pictures::draw(dir, &runs, &meta.study.parameters, which, coloring)
        .map_err(|e| RedrawError::Plot(softbench_run::plot::PlotError::Draw(e.to_string())))
}

/// A results folder's `meta.json` (whose kind must be registered in this build) and
/// `runs.csv`.
fn read_results(dir: &std::path::Path) -> Result<(Meta, table::Table), ResultsError> {
    let meta_path = dir.join("meta.json");
    let text = std::fs::read_to_string(&meta_path).map_err(|error| ResultsError::Io {
        path: meta_path.clone(),
        error,
    })?;
    let meta: Meta = serde_json::from_str(&text).map_err(|e| ResultsError::Malformed {
        path: meta_path.clone(),
        message: e.to_string(),
    })?;
    if kinds::named(&meta.study.kind).is_none() {
        let names: Vec<&str> = kinds::KINDS.iter().map(|k| k.name()).collect();
        return Err(ResultsError::Malformed {
            path: meta_path,
            message: softbench_core::names::unknown_name_message(
                "study kind",
                &meta.study.kind,
                &names,
            ),
        });
    }
    let runs_path = dir.join("runs.csv");
    let runs = table::Table::read(&runs_path)?.ok_or_else(|| ResultsError::Io {
        path: runs_path.clone(),
        error: std::io::Error::from(std::io::ErrorKind::NotFound),
    })?;
    Ok((meta, runs))
}

/// Before any plot is replaced or removed: `runs.csv` must have the columns its study kind
/// writes and at least one row (a cut or emptied file would otherwise leave no plots).
fn check_runs_table(
    runs: &table::Table,
    study: &StudyMeta,
    path: &std::path::Path,
) -> Result<(), ResultsError> {
    let malformed = |message: String| ResultsError::Malformed {
        path: path.to_owned(),
        message,
    };
    // The groups of columns grow as runs report more: an earlier softbench's table lacks some,
    // and its plots are drawn without them.
    let own = kinds::of(&study.kind).own_columns();
    if let Some(missing) = columns::IDENTITY
        .iter()
        .chain(&columns::TRAILER)
        .chain(own)
        .find(|c| runs.column(c).is_none())
    {
        return Err(malformed(format!(
            "line 1: the header has no `{missing}` column (a {} study's runs.csv has it); the \
             file is cut short or not softbench's: no plot was changed",
            study.kind
        )));
    }
    if runs.rows.is_empty() {
        return Err(malformed(
            "no runs below the header: nothing to draw, no plot was changed".into(),
        ));
    }
    Ok(())
}

/// Why plots could not be redrawn.
#[derive(Debug, thiserror::Error)]
pub enum RedrawError {
    #[error(transparent)]
    Results(#[from] ResultsError),
    #[error("cannot draw: {0}")]
    Plot(#[from] softbench_run::plot::PlotError),
}

impl softbench_core::error_class::Classify for RedrawError {
    /// A results folder that cannot be read back is the input of `softbench plot`; drawing
    /// is the system's.
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        match self {
            Self::Results(e) => softbench_core::error_class::Classify::class(e),
            Self::Plot(e) => softbench_core::error_class::Classify::class(e),
        }
    }
}
