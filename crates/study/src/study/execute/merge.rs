//! Merging a study run as shards: `softbench merge <study folder>` (and the last shard to
//! finish, automatically) assembles `runs.csv` from the shards' tables, draws the plots,
//! writes `report.md` and `meta.json` (which lists the shards, their machines and times)
//! and says which runs are missing. It reads the shards' outputs and rewrites only the
//! study-level files, so merging again gives the same files.

use crate::study::execute::progress::Progress;
use crate::study::execute::rows::{earlier_rows, header, is_done};
use crate::study::execute::shared::{SharedWork, Source, Workers};
use crate::study::kind::not_ok;
use crate::study::vocabulary::error::RunError;
use crate::study::vocabulary::format::utc;
use crate::study::vocabulary::machine::Machine;
use crate::study::vocabulary::meta::Meta;
use crate::study::vocabulary::shard_record::ShardRecord;
use crate::study::vocabulary::shared_store::SharedStore;
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_core::threads::Threads;
use softbench_run::lock::{FolderLock, Wait};
use std::path::{Path, PathBuf};

/// What a merge wrote.
#[derive(Clone, Debug)]
pub struct Merged {
    pub dir: PathBuf,
    /// Runs in the merged `runs.csv`, of the study's `total`.
    pub runs: usize,
    pub total: usize,
    /// Runs no shard has finished (with the current configuration), in grid order.
    pub missing: Vec<String>,
    /// Shard records found (`shards/K-of-N/shard.json`).
    pub shards: Vec<ShardRecord>,
    /// Runs whose status is not ok.
    pub not_ok: Vec<(String, String)>,
}

/// Why a folder could not be merged.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    #[error(
        "{0}: not a study folder: it has neither shards/*/shard.json (written by `softbench \
         run --shard K/N`) nor meta.json (written by `softbench run`)"
    )]
    NotAStudy(PathBuf),
    #[error("{path}: {message}")]
    Unreadable { path: PathBuf, message: String },
    /// The study file the shards ran cannot be loaded any more.
    #[error(transparent)]
    Study(#[from] crate::study::vocabulary::error::StudyError),
    #[error(transparent)]
    Run(#[from] RunError),
}

impl softbench_core::error_class::Classify for MergeError {
    /// A folder that is not a study's, or a study file that no longer loads, is the input's;
    /// a shard record that cannot be read, and a failed write, are not.
    fn class(&self) -> softbench_core::error_class::ErrorClass {
        match self {
            Self::NotAStudy(_) => softbench_core::error_class::ErrorClass::BadInput,
            Self::Unreadable { .. } => softbench_core::error_class::ErrorClass::Failure,
            Self::Study(e) => softbench_core::error_class::Classify::class(e),
            Self::Run(e) => softbench_core::error_class::Classify::class(e),
        }
    }
}

/// Merge the study folder `dir`: load the study its shards ran (the study file is recorded,
/// absolute, in each `shard.json`; for a folder of a local run, in `meta.json`), its scenes'
/// data files found through `data`, and merge.
pub fn merge(
    dir: &Path,
    wait: bool,
    progress: bool,
    data: &softbench_run::data::DataPaths,
) -> Result<Merged, MergeError> {
    let records = ShardRecord::read_all(dir).map_err(|e| MergeError::Unreadable {
        path: dir.join("shards"),
        message: e.to_string(),
    })?;
    let (path, quick) = match records.iter().max_by_key(|r| r.started_epoch) {
        Some(r) => (r.study_file.clone(), r.quick),
        None => {
            let meta_path = dir.join("meta.json");
            let text = std::fs::read_to_string(&meta_path)
                .map_err(|_| MergeError::NotAStudy(dir.to_owned()))?;
            let meta: Meta = serde_json::from_str(&text).map_err(|e| MergeError::Unreadable {
                path: meta_path,
                message: e.to_string(),
            })?;
            (meta.study.file, meta.study.quick)
        }
    };
    let study = crate::study::plan::load::load(&path, quick, data)?;
    let wait = if wait { Wait::Yes } else { Wait::No };
    Ok(merge_study(&study, dir, wait, progress)?)
}

/// Whether every run of `study` is done in `dir` (a row of its current configuration in
/// `runs.csv` or a shard's table, and its series file).
pub(in crate::study) fn is_complete(study: &Study, dir: &Path) -> Result<bool, RunError> {
    let rows = earlier_rows(study, dir, &header(study))?;
    Ok(study.runs.iter().all(|r| is_done(dir, r, &rows)))
}

/// Merge `study`'s results in `dir` (see the module documentation).
pub(in crate::study) fn merge_study(
    study: &Study,
    dir: &Path,
    wait: Wait,
    progress: bool,
) -> Result<Merged, RunError> {
    let io = |path: &Path| {
        let path = path.to_owned();
        move |error| RunError::Io { path, error }
    };
    let _lock = FolderLock::acquire(dir, &format!("merge {}", study.file.name), wait, |h| {
        softbench_run::console::err(&format!("waiting for {h} to finish with {}", dir.display()));
    })?;
    softbench_run::io::remove_stale_partials(dir).map_err(io(dir))?;
    let header = header(study);
    let rows = earlier_rows(study, dir, &header)?;
    let (done, missing): (Vec<&RunSpec>, Vec<&RunSpec>) =
        study.runs.iter().partition(|r| is_done(dir, r, &rows));
    let mut table = Table::new(header);
    table.rows = done
        .iter()
        .filter_map(|r| rows.get(&r.id).cloned())
        .collect();
    let runs_path = dir.join("runs.csv");
    table.write(&runs_path).map_err(io(&runs_path))?;

    // The folder is the study's (named after it); its shards in the same mode count. (Not
    // compared by study file path: nodes may mount the same file under different paths.)
    let records: Vec<ShardRecord> = ShardRecord::read_all(dir)
        .map_err(io(&dir.join("shards")))?
        .into_iter()
        .filter(|r| r.quick == study.quick)
        .collect();
    // The references the shards stored, for the report.
    let store = SharedStore::new(dir);
    let all: Vec<&RunSpec> = study.runs.iter().collect();
    let shared = SharedWork::prepare(
        study,
        &all,
        Source::ReadOnly(&store),
        &Workers::reading(&Threads::default()),
        &Progress::without_runs(false),
    )?;
    // The runs' load is each shard's, in its record; the merge's own moment says nothing
    // about the timings (and merging again must give the same files).
    let machine = Machine {
        load_average: None,
        ..Machine::current()
    };
    let mut meta = Meta::of(
        study,
        records.iter().map(|r| r.jobs).max().unwrap_or(1),
        None,
        &machine,
        &crate::study::vocabulary::format::now_utc(),
        None,
    );
    // The study ran from its first shard's start to its last shard's end.
    if let Some(first) = records.iter().map(|r| r.started_epoch).min() {
        meta.started = utc(first);
        if let Some(last) = records.iter().filter_map(|r| r.finished_epoch).max() {
            meta.finished = Some(utc(last));
            meta.wall_seconds = Some(last.saturating_sub(first) as f64);
        }
    }
    meta.missing = missing.iter().map(|r| r.id.clone()).collect();
    meta.shards = records.clone();
    let plots = if table.rows.is_empty() {
        Vec::new()
    } else {
        crate::study::present::plots::draw_all(dir, &meta.study, &table)
            .map_err(|e| RunError::Run(format!("cannot draw the plots: {e}")))?
    };
    let reused = records.iter().map(|r| r.reused).sum();
    crate::study::present::report::write(
        dir,
        study,
        &meta,
        &table,
        &plots,
        reused,
        crate::study::present::report::References {
            solved: &shared.references,
            failed: &shared.failed_references,
        },
    )
    .map_err(io(&dir.join("report.md")))?;
    meta.write(dir).map_err(io(&dir.join("meta.json")))?;
    if progress {
        softbench_run::console::err(&format!(
            "{}: merged {} of {} runs from {} shard record(s) into {}",
            study.file.name,
            table.rows.len(),
            study.runs.len(),
            records.len(),
            dir.display()
        ));
    }
    Ok(Merged {
        dir: dir.to_owned(),
        runs: table.rows.len(),
        total: study.runs.len(),
        missing: meta.missing.clone(),
        shards: records,
        not_ok: not_ok(crate::study::kinds::present(study.kind), &table),
    })
}
