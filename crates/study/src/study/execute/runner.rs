//! Running a study: skip runs already complete, compute what the runs share (eigenvalues,
//! reference solutions), run the rest (in parallel with `jobs`), and write every output
//! atomically as soon as it exists, so an interrupted study resumes where it stopped.

use crate::study::execute::progress::Progress;
use crate::study::execute::rows::{earlier_rows, header, is_done, ordered, shard_folder};
use crate::study::execute::shared::{SharedWork, Source, Workers};
use crate::study::kind::{Measure, RunInputs, not_ok};
use crate::study::present::report;
use crate::study::vocabulary::error::{RunError, io_error as io};
use crate::study::vocabulary::format::{epoch_seconds, now_utc};
use crate::study::vocabulary::identity::value_text;
use crate::study::vocabulary::machine::Machine;
use crate::study::vocabulary::measured::Measured;
use crate::study::vocabulary::meta::Meta;
use crate::study::vocabulary::shard::Shard;
use crate::study::vocabulary::shard_record::ShardRecord;
use crate::study::vocabulary::shared_store::SharedStore;
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_core::interrupt;
use softbench_core::parallel::Parallelism;
use softbench_core::threads::Threads;
use softbench_run::io::write_atomic;
use softbench_run::lock::{FolderLock, Wait};
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};

/// How to run a study.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// The study's results folder (e.g. `results/<study>`).
    pub dir: PathBuf,
    /// Only runs whose id matches this pattern (`*` matches anything; otherwise a substring).
    pub only: Option<String>,
    /// Runs in parallel.
    pub jobs: usize,
    /// Redo runs even when a finished run with the same resolved config exists.
    pub force: bool,
    /// Show a progress bar (on a terminal) or a line per run (otherwise), after the warnings
    /// loading the study found ([`Study::warnings`]).
    pub progress: bool,
    /// When another process holds the folder's lock: wait for it (else stop with an error
    /// naming it).
    pub wait: bool,
    /// Run only this part of the grid (`--shard K/N`): its runs' series go to `series/`, its
    /// table and record to `shards/K-of-N/`, and the shard that finds every run of the study
    /// done merges them (see [`crate::study::execute::merge`]).
    pub shard: Option<Shard>,
    /// The threads of the study's pool, which every run and shared computation (highest
    /// modes, references) runs in; `None`: the caller's pool (rayon's global one). With
    /// `jobs` above 1 each run is sequential, and the count does not matter. The results are
    /// the same bits for any count.
    pub threads: Option<usize>,
}

/// What a study invocation did.
#[derive(Clone, Debug)]
pub struct StudyRun {
    pub dir: PathBuf,
    /// Runs executed now.
    pub ran: usize,
    /// Runs reused from a previous invocation.
    pub reused: usize,
    /// Runs left out by `--only`.
    pub skipped: usize,
    /// Runs whose status is not ok.
    pub not_ok: Vec<(String, String)>,
    /// Set when SIGINT/SIGTERM stopped the study: the finished runs are in `runs.csv`, plots
    /// and report are not drawn, and running the same command again resumes.
    pub interrupted: Option<softbench_core::interrupt::Signal>,
    /// For a shard that found every run of the study done: the merge it did, or who else
    /// held the study folder.
    pub merged: Option<MergeOutcome>,
    /// The kind's measured columns that none of the runs done now filled (a defect of the
    /// kind, which declares a column it never writes; a warning line says so). Empty when no
    /// run was done now.
    pub unfilled_columns: Vec<&'static str>,
}

/// What a shard that finished last did about the merge.
#[derive(Clone, Debug)]
pub enum MergeOutcome {
    Merged(crate::study::execute::merge::Merged),
    /// Another process (e.g. another shard merging) holds the study folder.
    Busy(String),
    /// Every run is done but these shards (`K/N`) have not recorded their end yet: each is
    /// still writing (it merges when it ends) or was killed (`softbench merge` then).
    Unended(Vec<String>),
}

/// Whether a run id matches `--only`.
pub fn matches(id: &str, pattern: &str) -> bool {
    if !pattern.contains('*') {
        return id.contains(pattern);
    }
    let parts: Vec<&str> = pattern.split('*').collect();
    let (first, last) = (parts[0], parts[parts.len() - 1]);
    if !id.starts_with(first) || id.len() < first.len() + last.len() || !id.ends_with(last) {
        return false;
    }
    let mut rest = &id[first.len()..id.len() - last.len()];
    for part in &parts[1..parts.len() - 1] {
        match rest.find(part) {
            Some(i) => rest = &rest[i + part.len()..],
            None => return false,
        }
    }
    true
}

/// Run the study into `options.dir` — all of it, or with [`RunOptions::shard`] one part of
/// its grid (see [`crate::study::vocabulary::shard`]).
pub fn run(study: &Study, options: &RunOptions) -> Result<StudyRun, RunError> {
    let threads = Threads::new(options.threads)?;
    let dir = &options.dir;
    std::fs::create_dir_all(dir.join("series")).map_err(io(dir))?;
    let wait = if options.wait { Wait::Yes } else { Wait::No };
    let on_wait = |folder: &Path| {
        let folder = folder.to_owned();
        move |h: &softbench_run::lock::Waiting| {
            softbench_run::console::err(&format!(
                "waiting for {h} to finish with {}",
                folder.display()
            ));
        }
    };
    // A local study owns the study folder; a shard owns its own folder under `shards/` and
    // only adds its runs' series to `series/` (the other shards write theirs meanwhile).
    let (lock_dir, purpose) = match options.shard {
        None => (dir.clone(), format!("run {}", study.file.name)),
        Some(shard) => (
            shard_folder(dir, shard),
            format!("run {} --shard {shard}", study.file.name),
        ),
    };
    std::fs::create_dir_all(&lock_dir).map_err(io(&lock_dir))?;
    let _lock = FolderLock::acquire(&lock_dir, &purpose, wait, on_wait(&lock_dir))?;
    // What loading warned about, said once before the runs (meta.json and report.md keep it).
    if options.progress {
        for w in &study.warnings {
            softbench_run::console::err(&format!("warning: {}: {w}", study.file.name));
        }
    }
    let started = now_utc();
    let started_epoch = epoch_seconds();
    let clock = std::time::Instant::now();
    let header = header(study);
    let measured = crate::study::kinds::measure(study.kind);
    let presented = crate::study::kinds::present(study.kind);

    // The runs this invocation is for.
    let (assigned, estimated_cost) = match options.shard {
        None => (study.runs.iter().collect::<Vec<_>>(), None),
        Some(shard) => {
            let (runs, cost) = crate::study::vocabulary::shard::runs_of(study, shard);
            (runs, Some(cost))
        }
    };
    // A run killed mid-write (SIGKILL, power loss) leaves its temporary files; under the lock
    // no live writer owns them (a shard removes only those of its own runs in `series/`).
    match options.shard {
        None => {
            for folder in [dir.clone(), dir.join("series")] {
                softbench_run::io::remove_stale_partials(&folder).map_err(io(&folder))?;
            }
        }
        Some(_) => {
            softbench_run::io::remove_stale_partials(&lock_dir).map_err(io(&lock_dir))?;
            let own: std::collections::HashSet<String> = assigned
                .iter()
                .flat_map(|r| {
                    let tables = crate::study::vocabulary::measured::SERIES_TABLES
                        .map(|t| format!("{}-{t}.csv", r.id));
                    std::iter::once(format!("{}.csv", r.id)).chain(tables)
                })
                .collect();
            let series = dir.join("series");
            softbench_run::io::remove_stale_partials_of(&series, |target| own.contains(target))
                .map_err(io(&series))?;
        }
    }

    let mut rows = earlier_rows(study, dir, &header)?;
    let selected: Vec<&RunSpec> = assigned
        .iter()
        .copied()
        .filter(|r| options.only.as_deref().is_none_or(|p| matches(&r.id, p)))
        .collect();
    let complete: Vec<bool> = selected
        .iter()
        .map(|r| !options.force && is_done(dir, r, &rows))
        .collect();
    // The runs to do now, each with its index in `selected` (the progress's plan).
    let pending: Vec<(usize, &RunSpec)> = selected
        .iter()
        .copied()
        .enumerate()
        .filter(|&(i, _)| !complete[i])
        .collect();
    let reused = selected.len() - pending.len();
    let machine = Machine::current();
    let mut shard_record = options.shard.map(|shard| {
        ShardRecord::start(
            study,
            shard,
            &assigned,
            estimated_cost.unwrap_or(0.0),
            options.jobs,
            &machine,
            &started,
            started_epoch,
        )
    });
    match &shard_record {
        None => Meta::of(
            study,
            options.jobs,
            options.only.as_deref(),
            &machine,
            &started,
            None,
        )
        .write(dir)
        .map_err(io(&dir.join("meta.json")))?,
        Some(record) => record.write(&lock_dir).map_err(io(&lock_dir))?,
    }

    let progress = Progress::new(
        options.progress,
        crate::study::execute::eta::plan(study, &selected),
        options.jobs,
    );
    for i in (0..selected.len()).filter(|&i| complete[i]) {
        progress.skip(i);
    }
    let pending_runs: Vec<&RunSpec> = pending.iter().map(|(_, r)| *r).collect();
    let name = match options.shard {
        None => study.file.name.clone(),
        Some(shard) => format!("{} shard {shard}", study.file.name),
    };
    if let Some(cost) = estimated_cost {
        progress.line(&format!(
            "{name}: {} of the study's {} runs ({:.0}% of its estimated cost)",
            assigned.len(),
            study.runs.len(),
            100.0 * cost
                / crate::study::vocabulary::shard::total_cost(study).max(f64::MIN_POSITIVE)
        ));
    }
    if reused > 0 {
        progress.line(&format!(
            "{name}: {reused} of {} runs already complete with the same configuration (--force redoes them)",
            selected.len()
        ));
    }
    let workers = Workers {
        parallelism: if options.jobs > 1 {
            Parallelism::Sequential
        } else {
            Parallelism::Rayon
        },
        threads: &threads,
        jobs: options.jobs,
    };
    let store = SharedStore::new(dir);
    let source = match options.shard {
        None => {
            // Redoing every run redoes the work they share too.
            if options.force {
                let shared = dir.join("shared");
                if shared.is_dir() {
                    std::fs::remove_dir_all(&shared).map_err(io(&shared))?;
                }
            }
            Source::Local(&store)
        }
        Some(_) => Source::Stored(&store),
    };
    let shared = SharedWork::prepare(study, &pending_runs, source, &workers, &progress)?;
    progress.begin_runs();
    let table_path = lock_dir.join("runs.csv");
    // The rows this invocation's table holds: the whole study's, or the shard's.
    let table_of = |rows: &HashMap<String, Vec<String>>| match options.shard {
        None => ordered(study, &header, rows),
        Some(_) => {
            let mut table = Table::new(header.clone());
            table.rows = assigned
                .iter()
                .filter(|r| is_done(dir, r, rows))
                .filter_map(|r| rows.get(&r.id).cloned())
                .collect();
            table
        }
    };
    let mut interrupted = interrupt::requested();
    let mut filled: BTreeSet<&'static str> = BTreeSet::new();
    let failure = execute(study, &pending, &shared, &workers, &progress, |spec, m| {
        filled.extend(m.cells.iter().map(|(name, _)| *name));
        let row = record(study, spec, m, &header, dir)?;
        rows.insert(spec.id.clone(), row);
        table_of(&rows).write(&table_path).map_err(io(&table_path))
    });
    progress.done();
    if let Err(Stop::Failed(e)) = failure {
        if let Some(record) = shard_record.as_mut() {
            record.end("failed", clock.elapsed(), pending_runs.len(), reused);
            let _ = record.write(&lock_dir);
        }
        return Err(e);
    }
    if let Err(Stop::Interrupted(signal)) = failure {
        interrupted.get_or_insert(signal);
    }
    let table = table_of(&rows);
    table.write(&table_path).map_err(io(&table_path))?;
    let unfilled_columns = unfilled(measured, &filled);
    if !unfilled_columns.is_empty() {
        progress.line(&format!(
            "warning: the {} study kind declares columns none of its runs filled: {} (a \
             defect of the kind; the columns are empty)",
            study.kind,
            unfilled_columns.join(", ")
        ));
    }
    let skipped = study.runs.len() - selected.len();
    let done_now = table.rows.len().saturating_sub(reused);
    if let Some(signal) = interrupted.or_else(interrupt::requested) {
        // meta.json stays as written at the start (no end time): the study is not finished.
        if let Some(record) = shard_record.as_mut() {
            record.end("interrupted", clock.elapsed(), done_now, reused);
            record.write(&lock_dir).map_err(io(&lock_dir))?;
        }
        return Ok(StudyRun {
            dir: dir.clone(),
            ran: done_now,
            reused,
            skipped,
            not_ok: not_ok(presented, &table),
            interrupted: Some(signal),
            merged: None,
            unfilled_columns: Vec::new(),
        });
    }
    if let Some(record) = shard_record.as_mut() {
        record.end("finished", clock.elapsed(), pending_runs.len(), reused);
        record.write(&lock_dir).map_err(io(&lock_dir))?;
        drop(_lock);
        // The last shard to finish merges (any shard that finds every run done does; a merge
        // is idempotent).
        // Each shard records its end before it looks, so the last to end sees every record
        // ended: a merge never lists a shard as `running` that only had its record to write.
        let complete = crate::study::execute::merge::is_complete(study, dir)?;
        let unended = match options.shard {
            Some(shard) if complete => ShardRecord::unended(dir, shard.count, study.quick)
                .map_err(io(&dir.join("shards")))?,
            _ => Vec::new(),
        };
        let merged = if !complete {
            None
        } else if !unended.is_empty() {
            Some(MergeOutcome::Unended(unended))
        } else {
            match crate::study::execute::merge::merge_study(study, dir, Wait::No, options.progress)
            {
                Ok(m) => Some(MergeOutcome::Merged(m)),
                Err(RunError::Lock(softbench_run::lock::LockError::Held { holder, .. })) => {
                    Some(MergeOutcome::Busy(holder.to_string()))
                }
                Err(e) => return Err(e),
            }
        };
        return Ok(StudyRun {
            dir: dir.clone(),
            ran: pending.len(),
            reused,
            skipped,
            not_ok: not_ok(presented, &table),
            interrupted: None,
            merged,
            unfilled_columns,
        });
    }
    let meta = Meta::of(
        study,
        options.jobs,
        options.only.as_deref(),
        &machine,
        &started,
        Some(clock.elapsed()),
    );
    let plots = crate::study::present::plots::draw_all(dir, &meta.study, &table)
        .map_err(|e| RunError::Run(format!("cannot draw the plots: {e}")))?;
    report::write(
        dir,
        study,
        &meta,
        &table,
        &plots,
        reused,
        report::References {
            solved: &shared.references,
            failed: &shared.failed_references,
        },
    )
    .map_err(io(&dir.join("report.md")))?;
    meta.write(dir).map_err(io(&dir.join("meta.json")))?;
    Ok(StudyRun {
        dir: dir.clone(),
        ran: pending.len(),
        reused,
        skipped,
        not_ok: not_ok(presented, &table),
        interrupted: None,
        merged: None,
        unfilled_columns,
    })
}

/// The kind's measured columns that no run of `filled` (the names of the cells the runs done
/// now wrote) filled; none when no run was done. The outcome is the runner's own.
fn unfilled(kind: &dyn Measure, filled: &BTreeSet<&'static str>) -> Vec<&'static str> {
    if filled.is_empty() {
        return Vec::new();
    }
    kind.columns()
        .iter()
        .copied()
        .filter(|c| *c != "outcome" && !filled.contains(c))
        .collect()
}

/// Why [`execute`] stopped early.
enum Stop {
    Interrupted(softbench_core::interrupt::Signal),
    Failed(RunError),
}

/// Measure `pending` (each with its index in the progress's plan), `jobs` at a time,
/// handing each result to `keep` as it arrives (in this thread). Stops handing out runs at
/// the first failure or stop request; the runs already running finish, and after a stop
/// request their results are dropped (they were cut short; a resume redoes them).
fn execute(
    study: &Study,
    pending: &[(usize, &RunSpec)],
    shared: &SharedWork,
    workers: &Workers,
    progress: &Progress,
    mut keep: impl FnMut(&RunSpec, &Measured) -> Result<(), RunError>,
) -> Result<(), Stop> {
    let Workers {
        parallelism,
        threads,
        jobs,
    } = *workers;
    let (sender, receiver) = std::sync::mpsc::channel::<(usize, Result<Measured, String>)>();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut stop: Option<Stop> = None;
    std::thread::scope(|scope| {
        for _ in 0..jobs.max(1).min(pending.len().max(1)) {
            let sender = sender.clone();
            let next = &next;
            scope.spawn(move || {
                loop {
                    if interrupt::requested().is_some() {
                        break;
                    }
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                    let Some(&(run, spec)) = pending.get(i) else {
                        break;
                    };
                    progress.start_run(run, &spec.id);
                    let inputs = RunInputs {
                        meter: Some(progress.meter(run)),
                        ..shared.of(spec)
                    };
                    let result = threads.install(|| {
                        crate::study::kinds::measure(study.kind).measure(
                            study,
                            spec,
                            &inputs,
                            parallelism,
                        )
                    });
                    progress.finish_run(run, &spec.id);
                    if sender.send((i, result)).is_err() {
                        break;
                    }
                }
            });
        }
        drop(sender);
        for (i, result) in receiver {
            if let Some(signal) = interrupt::requested() {
                if stop.is_none() {
                    stop = Some(Stop::Interrupted(signal));
                }
                next.store(usize::MAX / 2, std::sync::atomic::Ordering::SeqCst);
                continue;
            }
            if matches!(stop, Some(Stop::Interrupted(_))) {
                continue;
            }
            let spec = pending[i].1;
            let kept = match result {
                Ok(m) => keep(spec, &m).map(|()| {
                    progress.line(&progress.run_line(
                        &spec.id,
                        &summary_line(crate::study::kinds::measure(study.kind), &m),
                    ));
                    progress.inc();
                }),
                Err(message) => Err(RunError::Run(format!("run {}: {message}", spec.id))),
            };
            if let Err(e) = kept {
                stop.get_or_insert(Stop::Failed(e));
                // Stop handing out runs; the ones running finish.
                next.store(usize::MAX / 2, std::sync::atomic::Ordering::SeqCst);
            }
        }
    });
    stop.map_or(Ok(()), Err)
}

/// One line per finished run.
fn summary_line(kind: &dyn Measure, m: &Measured) -> String {
    let extra = kind.progress(m);
    format!("{}{}", m.outcome, extra.unwrap_or_default())
}

/// Write a finished run's series files and return its `runs.csv` row.
fn record(
    study: &Study,
    spec: &RunSpec,
    m: &Measured,
    header: &[String],
    dir: &Path,
) -> Result<Vec<String>, RunError> {
    let series = dir.join("series").join(format!("{}.csv", spec.id));
    write_atomic(&series, |w| {
        let mut csv = csv::Writer::from_writer(w);
        if m.series.is_empty() {
            csv.write_record(["step"])?;
        }
        for row in &m.series {
            csv.serialize(row)?;
        }
        csv.flush()
    })
    .map_err(|error| RunError::Io {
        path: series.clone(),
        error,
    })?;
    if let Some(snapshots) = &m.snapshots {
        let path = crate::study::present::pictures::snapshot_path(dir, &spec.id);
        snapshots
            .write(&path)
            .map_err(|e| RunError::Run(e.to_string()))?;
    }
    for (name, table) in &m.tables {
        debug_assert!(crate::study::vocabulary::measured::SERIES_TABLES.contains(name));
        let path = dir.join("series").join(format!("{}-{name}.csv", spec.id));
        table
            .write(&path)
            .map_err(|error| RunError::Io { path, error })?;
    }
    let params: HashMap<String, String> = study
        .parameter_columns()
        .into_iter()
        .map(|(i, name)| {
            (
                name,
                spec.parameters[i]
                    .as_ref()
                    .map_or(String::new(), value_text),
            )
        })
        .collect();
    let fixed = |column: &str| match column {
        "run_id" => Some(spec.id.clone()),
        "scene" => Some(spec.scene.clone()),
        "method" => Some(spec.method.name().to_owned()),
        "linear_solver" => Some(
            spec.linear_solver
                .map_or("-".to_owned(), |s| s.name().to_owned()),
        ),
        "outcome" => Some(m.outcome.clone()),
        "message" => Some(m.message.clone()),
        "config_hash" => Some(spec.hash.clone()),
        other => params.get(other).cloned(),
    };
    crate::study::vocabulary::columns::row(header, &fixed, &m.cells).map_err(|e| {
        RunError::Run(format!(
            "run {}: {e} (a defect of the {} study kind)",
            spec.id, study.kind
        ))
    })
}
