//! Running a study: skip runs already complete, compute what the runs share (eigenvalues,
//! reference solutions), run the rest (in parallel with `jobs`), and write every output
//! atomically as soon as it exists, so an interrupted study resumes where it stopped.

use super::config::StudyKind;
use super::format::now_utc;
use super::identity::value_text;
use super::machine::Machine;
use super::measured::{Measured, is_clean};
use super::meta::Meta;
use super::progress::Progress;
use super::spec::{RunSpec, Study};
use super::table::Table;
use super::work_precision::Reference;
use super::{report, stability, work_precision};
use crate::integrate::Method;
use crate::interrupt;
use crate::io::write_atomic;
use crate::lock::{FolderLock, Wait};
use crate::parallel::Parallelism;
use std::collections::{BTreeMap, HashMap};
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
    /// Show a progress bar (on a terminal) or a line per run (otherwise).
    pub progress: bool,
    /// When another process holds the folder's lock: wait for it (else stop with an error
    /// naming it).
    pub wait: bool,
}

/// Why a study stopped before finishing.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("{path}: cannot write: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error(transparent)]
    Results(#[from] super::error::ResultsError),
    /// Another process is writing the study's folder.
    #[error(transparent)]
    Lock(#[from] crate::lock::LockError),
    /// A run could not even start (its scene failed to build), or a reference failed.
    #[error("{0}")]
    Run(String),
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
    pub interrupted: Option<crate::interrupt::Signal>,
}

/// The identity columns of every `runs.csv`.
const IDENTITY: [&str; 4] = ["run_id", "scene", "method", "linear_solver"];

/// The header of the study's `runs.csv`.
pub fn header(study: &Study) -> Vec<String> {
    let kind_columns = super::kinds::spec(study.kind).columns;
    IDENTITY
        .iter()
        .map(|s| (*s).to_owned())
        .chain(study.parameter_columns().into_iter().map(|(_, c)| c))
        .chain(kind_columns.iter().map(|s| (*s).to_owned()))
        .chain(["message".to_owned(), "config_hash".to_owned()])
        .collect()
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

/// Run the study into `options.dir`.
pub fn run(study: &Study, options: &RunOptions) -> Result<StudyRun, RunError> {
    let dir = &options.dir;
    let io = |path: &Path| {
        let path = path.to_owned();
        move |error| RunError::Io { path, error }
    };
    std::fs::create_dir_all(dir.join("series")).map_err(io(dir))?;
    let wait = if options.wait { Wait::Yes } else { Wait::No };
    let _lock = FolderLock::acquire(dir, &format!("run {}", study.file.name), wait, |h| {
        crate::console::err(&format!("waiting for {h} to finish with {}", dir.display()));
    })?;
    // A run killed mid-write (SIGKILL, power loss) leaves its temporary files; under the lock
    // no live writer owns them.
    for folder in [dir.clone(), dir.join("series")] {
        crate::io::remove_stale_partials(&folder).map_err(io(&folder))?;
    }
    let started = now_utc();
    let clock = std::time::Instant::now();
    let header = header(study);
    let runs_path = dir.join("runs.csv");
    let hash_col = header.len() - 1;

    // Rows of earlier invocations, by run id.
    let mut rows: HashMap<String, Vec<String>> = HashMap::new();
    if let Some(old) = Table::read(&runs_path)? {
        for row in old.rows {
            // Rows are reused only when the columns are the same.
            if old.header == header && row.len() == header.len() {
                rows.insert(row[0].clone(), row);
            }
        }
    }
    let selected: Vec<&RunSpec> = study
        .runs
        .iter()
        .filter(|r| options.only.as_deref().is_none_or(|p| matches(&r.id, p)))
        .collect();
    let done = |r: &RunSpec| {
        !options.force
            && rows.get(&r.id).is_some_and(|row| row[hash_col] == r.hash)
            && dir.join("series").join(format!("{}.csv", r.id)).exists()
    };
    let pending: Vec<&RunSpec> = selected.iter().copied().filter(|r| !done(r)).collect();
    let reused = selected.len() - pending.len();
    let machine = Machine::current();
    Meta::of(
        study,
        options.jobs,
        options.only.as_deref(),
        &machine,
        &started,
        None,
    )
    .write(dir)
    .map_err(io(&dir.join("meta.json")))?;

    let progress = Progress::new(options.progress, pending.len() as u64);
    if reused > 0 {
        progress.line(&format!(
            "{}: {reused} of {} runs already complete with the same configuration (--force redoes them)",
            study.file.name,
            selected.len()
        ));
    }
    let parallelism = if options.jobs > 1 {
        Parallelism::Sequential
    } else {
        Parallelism::Rayon
    };
    let shared = Shared::prepare(study, &pending, parallelism, options.jobs, &progress)?;
    let mut interrupted = interrupt::requested();

    // Run, each result written as soon as it arrives.
    let (sender, receiver) = std::sync::mpsc::channel::<(usize, Result<Measured, String>)>();
    let next = std::sync::atomic::AtomicUsize::new(0);
    let mut not_ok = Vec::new();
    let mut failure: Option<RunError> = None;
    std::thread::scope(|scope| {
        for _ in 0..options.jobs.max(1).min(pending.len().max(1)) {
            let sender = sender.clone();
            let (next, pending, shared, progress) = (&next, &pending, &shared, &progress);
            scope.spawn(move || {
                loop {
                    if interrupt::requested().is_some() {
                        break;
                    }
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                    let Some(spec) = pending.get(i) else { break };
                    progress.start(&spec.id);
                    let result = measure(study, spec, shared, parallelism);
                    progress.finish(&spec.id);
                    if sender.send((i, result)).is_err() {
                        break;
                    }
                }
            });
        }
        drop(sender);
        for (i, result) in receiver {
            // After a stop request, results are cut short (interrupted runs, stability trials
            // stopped at once): keep none of them; the runs are redone on resume.
            if let Some(signal) = interrupt::requested() {
                interrupted.get_or_insert(signal);
                next.store(usize::MAX / 2, std::sync::atomic::Ordering::SeqCst);
                continue;
            }
            let spec = pending[i];
            let outcome = match result {
                Ok(m) => record(study, spec, &m, &header, dir).map(|row| (row, m)),
                Err(message) => Err(RunError::Run(format!("run {}: {message}", spec.id))),
            };
            match outcome {
                Ok((row, m)) => {
                    progress.line(&format!(
                        "{} {}: {}",
                        progress.position(),
                        spec.id,
                        summary_line(study.kind, &m)
                    ));
                    progress.inc();
                    rows.insert(spec.id.clone(), row);
                    let table = ordered(study, &header, &rows);
                    if let Err(e) = table.write(&runs_path) {
                        failure.get_or_insert(RunError::Io {
                            path: runs_path.clone(),
                            error: e,
                        });
                        next.store(usize::MAX / 2, std::sync::atomic::Ordering::SeqCst);
                    }
                }
                Err(e) => {
                    failure.get_or_insert(e);
                    // Stop handing out runs; the ones running finish.
                    next.store(usize::MAX / 2, std::sync::atomic::Ordering::SeqCst);
                }
            }
        }
    });
    progress.done();
    if let Some(e) = failure {
        return Err(e);
    }
    let table = ordered(study, &header, &rows);
    table.write(&runs_path).map_err(io(&runs_path))?;
    if let Some(signal) = interrupted.or_else(interrupt::requested) {
        // meta.json stays as written at the start (no end time): the study is not finished.
        progress.done();
        return Ok(StudyRun {
            dir: dir.clone(),
            ran: table.rows.len().saturating_sub(reused),
            reused,
            skipped: study.runs.len() - selected.len(),
            not_ok,
            interrupted: Some(signal),
        });
    }
    for row in &table.rows {
        if !is_clean(&table, row) {
            let what = table
                .get(row, "stability")
                .or_else(|| table.get(row, "outcome"))
                .unwrap_or_default();
            not_ok.push((row[0].clone(), what.to_owned()));
        }
    }
    let meta = Meta::of(
        study,
        options.jobs,
        options.only.as_deref(),
        &machine,
        &started,
        Some(clock.elapsed()),
    );
    let plots = super::plots::draw_all(dir, &meta.study, &table)
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
        skipped: study.runs.len() - selected.len(),
        not_ok,
        interrupted: None,
    })
}

/// One line per finished run.
fn summary_line(kind: StudyKind, m: &Measured) -> String {
    let extra = (super::kinds::spec(kind).progress)(m);
    format!("{}{}", m.outcome, extra.unwrap_or_default())
}

/// What runs share, computed once before they start: the highest mode of each scene (for
/// stability studies and the default reference method) and the reference solutions.
struct Shared {
    omega: HashMap<u64, Option<f64>>,
    /// Reference solution by physics.
    references: BTreeMap<u64, (String, Reference)>,
    /// References that failed (stability studies go on without them): scene and message.
    failed_references: BTreeMap<u64, (String, String)>,
}

impl Shared {
    fn prepare(
        study: &Study,
        pending: &[&RunSpec],
        parallelism: Parallelism,
        jobs: usize,
        progress: &Progress,
    ) -> Result<Self, RunError> {
        let mut omega = HashMap::new();
        let kind = super::kinds::spec(study.kind);
        let needs_omega = (kind.needs_omega)(&study.file);
        // (A stability study's reference also picks its method from omega_max.)
        for spec in pending {
            if needs_omega && !omega.contains_key(&spec.physics) {
                let task = format!("highest mode of {}", spec.scene);
                progress.start(&task);
                let value = super::measured::build(spec, parallelism)
                    .map_err(|e| e.to_string())
                    .and_then(|mut scene| stability::explicit_limit(&mut scene))
                    .map(|m| m.omega)
                    .ok();
                progress.finish(&task);
                omega.insert(spec.physics, value);
            }
        }
        let mut references = BTreeMap::new();
        let mut failed_references = BTreeMap::new();
        let references_of = kind.references.as_ref();
        let settings = references_of.and_then(|r| (r.settings)(&study.file));
        if let (Some(w), Some(references_of)) = (settings.as_ref(), references_of) {
            // One reference per physics, `jobs` of them at a time (each is independent).
            let mut needed: Vec<&RunSpec> = Vec::new();
            for spec in pending {
                if !needed.iter().any(|s| s.physics == spec.physics) {
                    needed.push(spec);
                }
            }
            let compute = |spec: &RunSpec| {
                let dt = (references_of.dt)(study, w, spec);
                let method = w.reference.method.unwrap_or_else(|| {
                    // RK4 where it is stable at dt (its limit is 2.83 / omega_max), else the
                    // second-order implicit midpoint rule.
                    let name = match omega.get(&spec.physics).copied().flatten() {
                        Some(w) if dt < 2.5 / w => "rk4",
                        _ => "implicit-midpoint",
                    };
                    Method::from_name(name).expect("a built-in method")
                });
                let task = format!(
                    "reference for {}: {} at dt = {dt:e} s and dt/2",
                    spec.scene,
                    method.name()
                );
                progress.start(&task);
                let result = work_precision::reference(spec, w, method, dt, parallelism);
                progress.finish(&task);
                (method, result)
            };
            let mut results = Vec::new();
            for group in needed.chunks(jobs.max(1)) {
                let computed: Vec<_> = std::thread::scope(|scope| {
                    let handles: Vec<_> = group
                        .iter()
                        .map(|spec| scope.spawn(|| compute(spec)))
                        .collect();
                    handles
                        .into_iter()
                        .map(|h| h.join().expect("a reference computation panicked"))
                        .collect()
                });
                results.extend(group.iter().copied().zip(computed));
            }
            for (spec, (method, result)) in results {
                let reference = match result {
                    Ok(r) => r,
                    // A kind that goes on without its reference (stability) leaves the errors
                    // that need it empty, and the report says why.
                    Err(m) if references_of.optional => {
                        progress.line(&format!(
                            "reference for {} failed, so error_at_stable_dt is left empty: {m}",
                            spec.scene
                        ));
                        failed_references.insert(spec.physics, (spec.scene.clone(), m));
                        continue;
                    }
                    Err(m) => return Err(RunError::Run(format!("scene {}: {m}", spec.scene))),
                };
                progress.line(&format!(
                    "reference for {}: {} at dt = {:e} s, {:.3e} from the one at twice its step ({:.1} s)",
                    spec.scene,
                    method.name(),
                    reference.dt,
                    reference.difference,
                    reference.wall_seconds
                ));
                references.insert(spec.physics, (spec.scene.clone(), reference));
            }
        }
        Ok(Self {
            omega,
            references,
            failed_references,
        })
    }
}

fn measure(
    study: &Study,
    spec: &RunSpec,
    shared: &Shared,
    parallelism: Parallelism,
) -> Result<Measured, String> {
    let shared = super::kind::Shared {
        omega: shared.omega.get(&spec.physics).copied().flatten(),
        reference: shared.references.get(&spec.physics).map(|(_, r)| r),
    };
    (super::kinds::spec(study.kind).measure)(study, spec, &shared, parallelism)
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
        let path = super::pictures::snapshot_path(dir, &spec.id);
        snapshots
            .write(&path)
            .map_err(|e| RunError::Run(e.to_string()))?;
    }
    if let Some(trials) = &m.trials {
        let path = dir.join("series").join(format!("{}-trials.csv", spec.id));
        trials
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
    let row = header
        .iter()
        .map(|column| match column.as_str() {
            "run_id" => spec.id.clone(),
            "scene" => spec.scene.clone(),
            "method" => spec.method.name().to_owned(),
            "linear_solver" => spec
                .linear_solver
                .map_or("-".to_owned(), |s| s.name().to_owned()),
            "outcome" => m.outcome.clone(),
            "message" => m.message.clone(),
            "config_hash" => spec.hash.clone(),
            other => params
                .get(other)
                .cloned()
                .or_else(|| m.get(other).map(str::to_owned))
                .unwrap_or_default(),
        })
        .collect();
    Ok(row)
}

/// The rows present, in the study's run order.
fn ordered(study: &Study, header: &[String], rows: &HashMap<String, Vec<String>>) -> Table {
    let mut table = Table::new(header.to_vec());
    table.rows = study
        .runs
        .iter()
        .filter_map(|r| rows.get(&r.id).cloned())
        .collect();
    table
}
