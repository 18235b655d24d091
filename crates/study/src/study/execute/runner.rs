//! Running a study: skip runs already complete, compute what the runs share (eigenvalues,
//! reference solutions), run the rest (in parallel with `jobs`), and write every output
//! atomically as soon as it exists, so an interrupted study resumes where it stopped. The
//! same steps serve a whole study and one shard of it; what differs is the strategy's
//! (`strategy`, with `local` and `sharded`), and both end in one finishing step (`finish`).

use crate::study::execute::finish::{Left, finish};
use crate::study::execute::invocation::{RunOptions, StudyRun, matches};
use crate::study::execute::progress::Progress;
use crate::study::execute::record::record;
use crate::study::execute::rows::{earlier_rows, header, is_done};
use crate::study::execute::shared::{SharedWork, Workers};
use crate::study::execute::strategy::{Started, Strategy};
use crate::study::execute::workers::execute;
use crate::study::vocabulary::error::{RunError, io_error as io};
use crate::study::vocabulary::format::{epoch_seconds, now_utc};
use crate::study::vocabulary::machine::Machine;
use crate::study::vocabulary::shared_store::SharedStore;
use crate::study::vocabulary::spec::{RunSpec, Study};
use softbench_core::interrupt;
use softbench_core::parallel::Parallelism;
use softbench_core::threads::Threads;
use softbench_run::lock::{FolderLock, Wait};
use std::collections::{BTreeSet, HashMap};
use std::path::Path;

/// Run the study into `options.dir` — all of it, or with [`RunOptions::shard`] one part of
/// its grid (see [`crate::study::vocabulary::shard`]).
pub fn run(study: &Study, options: &RunOptions) -> Result<StudyRun, RunError> {
    let threads = Threads::new(options.threads)?;
    let dir = &options.dir;
    std::fs::create_dir_all(dir.join("series")).map_err(io(dir))?;
    let mut strategy = strategy_of(dir, options.shard, options.progress);
    let lock = lock(strategy.as_ref(), study, options.wait)?;
    // What loading warned about, said once before the runs (meta.json and report.md keep it).
    if options.progress {
        for w in &study.warnings {
            softbench_run::console::err(&format!("warning: {}: {w}", study.file.name));
        }
    }
    let started = Started {
        when: now_utc(),
        epoch: epoch_seconds(),
        clock: std::time::Instant::now(),
        machine: Machine::current(),
        jobs: options.jobs,
        only: options.only.as_deref(),
    };
    let header = header(study);
    let (assigned, estimated_cost) = strategy.assigned(study);
    strategy.remove_stale_partials(&assigned)?;
    let mut rows = earlier_rows(study, dir, &header)?;
    let selection = Selection::of(&assigned, dir, &rows, options);
    strategy.start(study, &assigned, estimated_cost, &started)?;
    let progress = selection.progress(
        study,
        strategy.as_ref(),
        (assigned.len(), estimated_cost),
        options,
    );
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
    let source = strategy.source(&store, options.force)?;
    let pending_runs: Vec<&RunSpec> = selection.pending.iter().map(|(_, r)| *r).collect();
    let shared = SharedWork::prepare(study, &pending_runs, source, &workers, &progress)?;
    progress.begin_runs();
    let table_path = strategy.own_dir().join("runs.csv");
    let signal_before = interrupt::requested();
    let mut filled: BTreeSet<&'static str> = BTreeSet::new();
    let stopped = execute(
        study,
        &selection.pending,
        &shared,
        &workers,
        &progress,
        |spec, m| {
            filled.extend(m.cells.iter().map(|(name, _)| *name));
            let row = record(study, spec, m, &header, dir)?;
            rows.insert(spec.id.clone(), row);
            let table = strategy.table(study, &header, &assigned, &rows);
            table.write(&table_path).map_err(io(&table_path))
        },
    );
    progress.done();
    let left = Left {
        table: strategy.table(study, &header, &assigned, &rows),
        stop: stopped.err(),
        signal_before,
        pending: selection.pending.len(),
        reused: selection.reused(),
        skipped: study.runs.len() - selection.selected.len(),
        filled,
        shared: &shared,
    };
    finish(study, strategy, lock, &started, &progress, left)
}

/// The strategy `shard` asks for in the results folder `dir`.
fn strategy_of(
    dir: &Path,
    shard: Option<crate::study::vocabulary::shard::Shard>,
    progress: bool,
) -> Box<dyn Strategy> {
    match shard {
        None => Box::new(crate::study::execute::local::Local::new(dir)),
        Some(shard) => Box::new(crate::study::execute::sharded::Sharded::new(
            dir, shard, progress,
        )),
    }
}

/// Lock the strategy's folder for this process; with `wait`, wait for another holder, saying
/// so.
fn lock(strategy: &dyn Strategy, study: &Study, wait: bool) -> Result<FolderLock, RunError> {
    let folder = strategy.own_dir();
    std::fs::create_dir_all(folder).map_err(io(folder))?;
    let wait = if wait { Wait::Yes } else { Wait::No };
    let shown = folder.to_owned();
    let on_wait = move |h: &softbench_run::lock::Waiting| {
        softbench_run::console::err(&format!(
            "waiting for {h} to finish with {}",
            shown.display()
        ));
    };
    Ok(FolderLock::acquire(
        folder,
        &strategy.purpose(study),
        wait,
        on_wait,
    )?)
}

/// Which of an invocation's runs `--only` selects and which of those are to do now.
struct Selection<'s> {
    /// The runs `--only` selects, in grid order (the progress's plan).
    selected: Vec<&'s RunSpec>,
    /// Whether each selected run is done already (and not `--force`d).
    complete: Vec<bool>,
    /// The runs to do now, each with its index in `selected`.
    pending: Vec<(usize, &'s RunSpec)>,
}

impl<'s> Selection<'s> {
    fn of(
        assigned: &[&'s RunSpec],
        dir: &Path,
        rows: &HashMap<String, Vec<String>>,
        options: &RunOptions,
    ) -> Self {
        let selected: Vec<&RunSpec> = assigned
            .iter()
            .copied()
            .filter(|r| options.only.as_deref().is_none_or(|p| matches(&r.id, p)))
            .collect();
        let complete: Vec<bool> = selected
            .iter()
            .map(|r| !options.force && is_done(dir, r, rows))
            .collect();
        let pending = selected
            .iter()
            .copied()
            .enumerate()
            .filter(|&(i, _)| !complete[i])
            .collect();
        Self {
            selected,
            complete,
            pending,
        }
    }

    /// Runs reused from earlier invocations.
    fn reused(&self) -> usize {
        self.selected.len() - self.pending.len()
    }

    /// The invocation's progress, with the reused runs skipped and a line on what this
    /// invocation does (`assigned` runs, and their share of the study's estimated cost when
    /// that is not all of it).
    fn progress(
        &self,
        study: &Study,
        strategy: &dyn Strategy,
        (assigned, estimated_cost): (usize, Option<f64>),
        options: &RunOptions,
    ) -> Progress {
        let progress = Progress::new(
            options.progress,
            crate::study::execute::eta::plan(study, &self.selected),
            options.jobs,
        );
        for i in (0..self.selected.len()).filter(|&i| self.complete[i]) {
            progress.skip(i);
        }
        let name = strategy.label(study);
        if let Some(cost) = estimated_cost {
            progress.line(&format!(
                "{name}: {assigned} of the study's {} runs ({:.0}% of its estimated cost)",
                study.runs.len(),
                100.0 * cost
                    / crate::study::vocabulary::shard::total_cost(study).max(f64::MIN_POSITIVE)
            ));
        }
        let reused = self.reused();
        if reused > 0 {
            progress.line(&format!(
                "{name}: {reused} of {} runs already complete with the same configuration \
                 (--force redoes them)",
                self.selected.len()
            ));
        }
        progress
    }
}
