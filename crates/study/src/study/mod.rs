//! Studies: a TOML file naming scenes and a grid of runs becomes `runs.csv`, per-run series,
//! plots, `meta.json` and `report.md` under `results/<study>/`.
//!
//! The folders follow a study's phases, each importing only the ones above it in this list:
//! - `vocabulary`: what every kind and phase speaks — the study file's schema, the run
//!   specs, tables and columns, a run's measurement, reference solutions, metadata;
//! - `kind`: what the phases ask of a study kind, one trait per phase (`Plan`, `Measure`,
//!   `Present`);
//! - `kinds`: the registered kinds, one folder each (its settings, its measurement, its
//!   presentation), and the registry listing them;
//! - `plan`: [`load`] parses a study file, expands its grid and checks every run before
//!   anything is written;
//! - `execute`: [`run`] runs what is not already done (resuming; locally or as one shard),
//!   then finishes the folder; [`merge`] merges shards;
//! - `present`: the report, the plots and the pictures, drawn from the written files only
//!   ([`redraw`] draws them again).

mod execute;
mod kind;
mod kinds;
mod plan;
mod present;
mod vocabulary;

// The paths users name (`softbench::study::table::Table`, `softbench::study::load`, ...).
pub use execute::invocation::{MergeOutcome, RunOptions, StudyRun, matches};
pub use execute::merge::{MergeError, Merged, merge};
pub use execute::runner::run;
pub use kinds::{KindInfo, kinds, solver, stability, suite, trajectory, work_precision};
pub use plan::load::load;
pub use present::redraw::{RedrawError, redraw, redraw_pictures};
pub use present::report::compute_findings;
pub use present::{findings, pictures, plots, profiles};
pub use vocabulary::config::{SWEEP, StudyFile};
pub use vocabulary::error::{ResultsError, RunError, StudyError};
pub use vocabulary::identity::{fnv1a, value_text};
pub use vocabulary::machine::Machine;
pub use vocabulary::measured::Measured;
pub use vocabulary::meta::{Meta, StudyMeta};
pub use vocabulary::settings::check_name as check_study_name;
pub use vocabulary::shard::Shard;
pub use vocabulary::shard_record::ShardRecord;
pub use vocabulary::spec::{RunSpec, Study};
pub use vocabulary::{config, format, shard, spread, table};
