//! The `softbench` command line. Each subcommand is one variant of [`Command`] and one
//! function. Exit codes: 0 on success; 1 when a simulation failed (blew up) or on any other
//! error (such as an unwritable output, or an output folder in use by another softbench);
//! 2 for bad input (a scene, mesh or option that is missing or malformed), in which case
//! nothing is written; 130 or 143 after SIGINT or SIGTERM (what was done is written first).
//!
//! Nothing here uses `println!`/`eprintln!`: they panic on a closed pipe. Output goes through
//! [`softbench_run::console`], and a broken pipe ends the command quietly.
//!
//! It is a library module so that a program which registers its own methods, solvers or
//! materials gets the whole command line with them: its `main` registers, then calls
//! [`main`]. The `softbench` binary is exactly that with nothing registered.
//!
//! ```no_run
//! fn main() -> std::process::ExitCode {
//!     // softbench::integrate::register_method(my_method_entry()).unwrap();
//!     softbench::cli::main()
//! }
//! ```

use std::io::Write;
use std::path::{Path, PathBuf};

mod args;
use args::*;

use clap::Parser;
use serde::Serialize;
use softbench_core::contact::{ContactResponse, ObstacleKind};
use softbench_core::fem::FilterSpace;
use softbench_core::integrate::HessianFilter;
use softbench_core::integrate::acceleration::Acceleration;
use softbench_core::integrate::methods::METHODS;
use softbench_core::integrate::newton;
use softbench_core::integrate::vbd::VbdSweep;
use softbench_core::interrupt::{self, Signal};
use softbench_core::material::MaterialKind;
use softbench_core::mesh::{AnyMesh, MESH_FORMATS, MeshFormat, MeshReport, read_mesh};
use softbench_core::parallel::Parallelism;
use softbench_core::registry::{Listing, NamedEnum};
use softbench_core::solve::LINEAR_SOLVERS;
use softbench_run::console;
use softbench_run::data::DataPaths;
use softbench_run::export::ExportFormat;
use softbench_run::lock::{FolderLock, LockError, Wait, Waiting};
use softbench_run::pipeline::{
    RUN_SNAPSHOTS, SimulateError, SimulateOptions, Simulation, draw_pictures,
};
use softbench_run::render::{Coloring, Snapshots};
use softbench_run::run::OutcomeKind;
use softbench_run::scene;
use softbench_study::study;

use crate::error::{Context, Error, Failure};

/// Run the command line of this process's arguments (`std::env::args_os`) with every method,
/// solver and material registered so far, and return the exit code. Parse errors and `--help`
/// are clap's: printed, then the process exits (2 for a usage error).
pub fn main() -> std::process::ExitCode {
    run(std::env::args_os())
}

/// [`main`] with the given arguments (the first is the program's name).
pub fn run<I, T>(args: I) -> std::process::ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    std::process::ExitCode::from(status(args))
}

/// [`run`]'s exit status as a number, for a host that exits itself (the Python package's
/// `python -m softbench`).
pub fn status<I, T>(args: I) -> u8
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    dispatch(args).0
}

/// The command that runs this command line when it is not the process's own binary (the
/// Python package's `python3 -m softbench`): what `softbench slurm` writes into job scripts.
static HOST_COMMAND: std::sync::OnceLock<Vec<PathBuf>> = std::sync::OnceLock::new();

/// Say which command runs this command line (see [`status`]); the first call counts.
pub fn set_host_command(words: Vec<PathBuf>) {
    let _ = HOST_COMMAND.set(words);
}

/// An exit status: the process's `ExitCode` without its opacity, so [`status`] can return it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct ExitCode(u8);

impl ExitCode {
    const SUCCESS: Self = Self(0);
    const FAILURE: Self = Self(1);
    fn from(code: u8) -> Self {
        Self(code)
    }
}

fn dispatch<I, T>(args: I) -> ExitCode
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = Cli::parse_from(args);
    if let Err(e) = interrupt::install() {
        console::err(&format!("warning: cannot handle SIGINT/SIGTERM: {e}"));
    }
    // A file size limit (`ulimit -f`) would kill the process with SIGXFSZ and no word; ignored,
    // the write fails with EFBIG instead, the atomic file is never committed and the error
    // below says which file and why.
    // SAFETY: setting a signal's disposition to SIG_IGN at start-up, before any thread.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    let result = match cli.command {
        Command::MeshInfo(args) => mesh_info(&args),
        Command::Simulate(args) => simulate(&args),
        Command::Run(args) => run_study(&args),
        Command::Merge(args) => merge(&args),
        Command::Slurm(args) => slurm(&args),
        Command::Plot(args) => plot(&args),
        Command::Profiles(args) => profiles(&args),
        Command::Ledger(args) => ledger(&args),
        Command::Render(args) => render_folder(&args),
        Command::List => list(),
    };
    match result {
        Ok(code) => code,
        // The reader of our output went away (`softbench list | head -1`): what was done is
        // written; end quietly.
        Err(err) if err.chain().any(console::is_broken_pipe) => ExitCode::SUCCESS,
        Err(err) => {
            console::err(&format!("error: {err}"));
            // EFBIG, kept as a number or (where a writer's error became text) in the message.
            let efbig = format!("(os error {})", libc::EFBIG);
            if err.chain().any(|e| {
                e.downcast_ref::<std::io::Error>()
                    .is_some_and(|io| io.raw_os_error() == Some(libc::EFBIG))
                    || e.to_string().contains(&efbig)
            }) {
                console::err(
                    "the file size limit (`ulimit -f`) was reached: raise it or write less \
                     (fewer rows or frames); the file cut short was not kept",
                );
            }
            // Stopped by a signal, or failed while stopping (waiting for a lock, a reference
            // solution cut short): report the signal's exit code.
            if let Some(signal) = err
                .chain()
                .find_map(|e| e.downcast_ref::<Stopped>())
                .map(|s| s.0)
                .or_else(interrupt::requested)
            {
                ExitCode::from(signal.exit_code())
            } else if err.class().is_bad_input() {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// Stopped by a signal before anything was written (exit code 130 or 143).
#[derive(Debug, thiserror::Error)]
#[error("stopped by {} before anything was written", .0.name())]
struct Stopped(Signal);

// The signal decides the exit code; the class is never asked.
softbench_core::classify_all!(Failure: Stopped);

/// Stop here if a signal has arrived (before anything is written).
fn stop_if_requested() -> Result<(), Stopped> {
    interrupt::requested().map_or(Ok(()), |s| Err(Stopped(s)))
}

/// Lock an output folder for this process; with `wait`, wait for another holder, saying so.
fn lock_folder(folder: &Path, purpose: &str, wait: bool) -> Result<FolderLock, LockError> {
    let wait = if wait { Wait::Yes } else { Wait::No };
    FolderLock::acquire(folder, purpose, wait, |holder: &Waiting| {
        console::err(&format!(
            "waiting for {holder} to finish with {}",
            folder.display()
        ));
    })
}

/// A bad command-line value (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
struct BadInput(String);

softbench_core::classify_all!(BadInput: BadInput);

/// An output folder named on the command line must be a folder or not exist yet: a path
/// whose first existing part is a file is bad input (exit 2), found before anything runs.
fn check_out_folder(option: &str, folder: &Path) -> Result<(), BadInput> {
    let Some(existing) = folder
        .ancestors()
        .find(|p| !p.as_os_str().is_empty() && p.exists())
    else {
        return Ok(());
    };
    if existing.is_dir() {
        return Ok(());
    }
    let what = if existing == folder {
        "is a file".to_owned()
    } else {
        format!("has a file in its path ({})", existing.display())
    };
    Err(BadInput(format!(
        "{option} {}: {what}, not a folder; name a folder (it is created if missing)",
        folder.display()
    )))
}

/// The JSON form of `mesh-info`: the report plus where it came from.
#[derive(Serialize)]
struct MeshInfo<'a> {
    file: &'a Path,
    format: MeshFormat,
    #[serde(flatten)]
    report: &'a MeshReport,
}

fn mesh_info(args: &MeshInfoArgs) -> Result<ExitCode, Error> {
    let path = DataPaths::from_env()
        .resolve_from_cwd(&args.file)
        .context("cannot find the mesh")?;
    let (format, mesh) = read_mesh(&path).context("cannot read the mesh")?;
    let report = match &mesh {
        AnyMesh::Tet(m) => MeshReport::for_tet_mesh(m),
        AnyMesh::Surface(m) => MeshReport::for_surface(m),
    };
    let mut out = std::io::stdout().lock();
    if args.json {
        let info = MeshInfo {
            file: &path,
            format,
            report: &report,
        };
        serde_json::to_writer_pretty(&mut out, &info).failure("cannot write the report")?;
        writeln!(out)?;
    } else {
        writeln!(out, "file                {}", path.display())?;
        writeln!(out, "format              {}", format.title())?;
        write!(out, "{report}")?;
    }
    out.flush().context("cannot write the report")?;
    Ok(ExitCode::SUCCESS)
}

fn simulate(args: &SimulateArgs) -> Result<ExitCode, Error> {
    let export = args
        .export
        .as_deref()
        .map(ExportFormat::from_name)
        .transpose()
        .map_err(|e| BadInput(format!("--export: {e}")))?;
    let every = args.every.unwrap_or(1);
    if every == 0 {
        return Err(BadInput("--every must be at least 1".into()).into());
    }
    if args.threads == Some(0) {
        return Err(BadInput("--threads must be at least 1".into()).into());
    }
    // Everything that can be wrong with the input is found before anything is written.
    let loaded = scene::load(&args.scene, &args.set)?;
    let options = SimulateOptions {
        export,
        every,
        pictures: args.render,
        progress: true,
        threads: args.threads,
    };
    let simulation =
        Simulation::prepare(loaded, &DataPaths::from_env(), Parallelism::Rayon, options).map_err(
            |e| match e {
                SimulateError::NoSurface => Error::from(BadInput(format!("--render: {e}"))),
                e => e.into(),
            },
        )?;
    if export == Some(ExportFormat::Obj)
        && let Some(display) = simulation.display()
    {
        let skin = &display.skinning;
        if !skin.outside().is_empty() {
            console::err(&format!(
                "note: {} of {} display vertices of {} lie outside the tet mesh (largest \
                 distance {:.3e}); they follow the closest point of their nearest tet",
                skin.outside().len(),
                skin.num_display_vertices(),
                display.path.display(),
                skin.max_outside_distance()
            ));
        }
    }

    stop_if_requested()?;
    check_out_folder("--out", &args.out)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let _lock = lock_folder(&args.out, "simulate", args.wait)?;
    let done = simulation.run(&args.out)?;

    let summary = &done.summary;
    let outcome = &summary.outcome;
    let rows = done.rows;
    match outcome.status {
        OutcomeKind::Completed => {
            let frames_note = if done.frames > 0 {
                format!(" ({} frames in {})", done.frames, done.frames_dir.display())
            } else {
                String::new()
            };
            let unconverged = if summary.newton_unconverged_steps > 0 {
                format!(
                    "; Newton stopped unconverged at its iteration cap in {} of {} steps",
                    summary.newton_unconverged_steps, summary.steps_completed
                )
            } else {
                String::new()
            };
            let springs_note = if done.spring_counts.is_empty() {
                String::new()
            } else {
                let counts: Vec<String> = done
                    .spring_counts
                    .iter()
                    .map(|(k, n)| format!("{k} {n}"))
                    .collect();
                format!("; springs: {}", counts.join(", "))
            };
            let internal_note = summary.internal_dt.map_or_else(String::new, |d| {
                format!(
                    "; internal steps {} (dt min {:e}, median {:e}, max {:e} s)",
                    summary.totals.substeps, d.min, d.median, d.max
                )
            });
            console::out(&format!(
                "{}: completed {} steps of {} with dt = {:e} s in {:.3} s{unconverged}{internal_note}; {}; wrote {}{frames_note}{springs_note}",
                done.name,
                summary.steps_completed,
                summary.method,
                summary.dt,
                summary.totals.times.total,
                done.dofs,
                args.out.display()
            ));
            Ok(ExitCode::SUCCESS)
        }
        OutcomeKind::Interrupted => {
            let step = outcome.step.unwrap_or(0);
            console::err(&format!(
                "{}: {} of {}; the {rows} rows so far are in {}, the state after step {step} in \
                 {} and summary.json says `interrupted`. simulate keeps no checkpoint: run the \
                 same command again to start over",
                done.name,
                outcome.message,
                summary.steps_requested,
                done.trajectory.display(),
                done.final_positions.display()
            ));
            let code = match interrupt::requested() {
                Some(s) => s.exit_code(),
                None => Signal::Interrupt.exit_code(),
            };
            Ok(ExitCode::from(code))
        }
        _ => {
            console::err(&format!(
                "error: {} with {} ended {} at step {} (t = {:e} s): {}: {}; {}; the {rows} \
                 rows written before it are in {}",
                done.name,
                summary.method,
                outcome.status,
                outcome.step.unwrap_or(0),
                outcome.t.unwrap_or(0.0),
                outcome.cause,
                outcome.message,
                done.dofs,
                done.trajectory.display()
            ));
            Ok(ExitCode::FAILURE)
        }
    }
}

fn list() -> Result<ExitCode, Error> {
    let mut out = std::io::stdout().lock();
    let families: [(&str, Vec<Listing>); 16] = [
        ("integrators (integrator.method)", METHODS.listing()),
        (
            "linear solvers (integrator.linear_solver)",
            LINEAR_SOLVERS.listing(),
        ),
        (
            "hessian filters (integrator.newton.filter)",
            HessianFilter::listing(),
        ),
        (
            "hessian filter spaces (integrator.newton.filter_space)",
            FilterSpace::listing(),
        ),
        (
            "Newton directions (integrator.newton.direction)",
            newton::Direction::listing(),
        ),
        (
            "globalizations (integrator.newton.globalization)",
            newton::Globalization::listing(),
        ),
        (
            "convergence criteria (integrator.newton.criterion)",
            newton::Criterion::listing(),
        ),
        (
            "L-BFGS initial Hessians (integrator.newton.lbfgs_initial)",
            newton::LbfgsInitial::listing(),
        ),
        (
            "step-size controllers (integrator.adaptive.controller)",
            softbench_core::integrate::Controller::listing(),
        ),
        (
            "local-solver accelerations (integrator.vbd/projective_dynamics.acceleration)",
            Acceleration::listing(),
        ),
        ("vbd sweeps (integrator.vbd.sweep)", VbdSweep::listing()),
        ("materials (material.model)", MaterialKind::listing()),
        (
            "contact responses (contact.response)",
            ContactResponse::listing(),
        ),
        (
            "obstacle kinds ([[obstacles]] kind)",
            ObstacleKind::listing(),
        ),
        (
            "export formats (simulate --export)",
            ExportFormat::listing(),
        ),
        (
            "mesh formats (mesh.file, mesh-info)",
            MESH_FORMATS.listing(),
        ),
    ];
    for (title, entries) in families {
        writeln!(out, "{title}:")?;
        for e in entries {
            writeln!(out, "  {:26} {}", e.name, e.description)?;
            let facts = e.facts_text();
            if !facts.is_empty() {
                writeln!(out, "  {:26} [{facts}]", "")?;
            }
        }
    }
    writeln!(out, "study kinds (study = ...):")?;
    for kind in study::kinds() {
        writeln!(out, "  {:26} {}", kind.name, kind.description)?;
    }
    writeln!(
        out,
        "  {:26} one of the kinds above ([sweep] kind) over one grid key, its metrics plotted \
         against it",
        "sweep"
    )?;
    for (title, folder) in [
        ("scenes (experiments/scenes)", "experiments/scenes"),
        ("studies (experiments)", "experiments"),
    ] {
        let files = toml_files(Path::new(folder));
        if files.is_empty() {
            continue;
        }
        writeln!(out, "{title}:")?;
        for (path, line) in files {
            let stem = path.file_stem().unwrap_or_default().to_string_lossy();
            writeln!(out, "  {stem:26} {line}")?;
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// The TOML files of `folder` (relative to the current folder, else to the softbench source
/// tree) with the first comment or description line of each.
fn toml_files(folder: &Path) -> Vec<(PathBuf, String)> {
    let base = if folder.is_dir() {
        folder.to_owned()
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join(folder)
    };
    let Ok(entries) = std::fs::read_dir(&base) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap_or_default();
            let line = text
                .lines()
                .find_map(|l| {
                    l.strip_prefix("description = ")
                        .map(|d| d.trim_matches('"').to_owned())
                        .or_else(|| l.strip_prefix('#').map(|c| c.trim().to_owned()))
                })
                .unwrap_or_default();
            let name = p.strip_prefix(&base).map_or(p.clone(), Path::to_path_buf);
            (folder.join(name), line)
        })
        .collect()
}

fn run_study(args: &RunArgs) -> Result<ExitCode, Error> {
    if args.jobs == 0 {
        return Err(BadInput("--jobs must be at least 1".into()).into());
    }
    if args.threads == Some(0) {
        return Err(BadInput("--threads must be at least 1".into()).into());
    }
    if let Some(set) = args.set.first() {
        return Err(BadInput(format!(
            "run has no --set (given `--set {set}`): a study's scenes are changed in the study \
             file (its `[grid]` axes, any scene key by dotted path; see docs/studies.md); `--set` \
             belongs to `simulate`, which runs one scene"
        ))
        .into());
    }
    check_out_folder("--out", &args.out)?;
    // Everything that can be wrong with the study is found before anything is written.
    let study = study::load(&args.study, args.quick, &DataPaths::from_env())?;
    let _always_rendered = args.render;
    let options = study::RunOptions {
        dir: args.out.join(&study.file.name),
        only: args.only.clone(),
        jobs: args.jobs,
        force: args.force,
        progress: true,
        wait: args.wait,
        shard: args.shard,
        threads: args.threads,
    };
    if let Some(p) = &options.only
        && !study.runs.iter().any(|r| study::matches(&r.id, p))
    {
        let ids: Vec<&str> = study.runs.iter().map(|r| r.id.as_str()).collect();
        return Err(BadInput(format!(
            "--only {p}: no run id matches (runs: {})",
            ids.join(", ")
        ))
        .into());
    }
    stop_if_requested()?;
    let done = study::run(&study, &options)
        .with_context(|| format!("study {} stopped", study.file.name))?;
    if let Some(signal) = done.interrupted {
        console::err(&format!(
            "{}: stopped by {}: {} runs are done and kept in {} (plots and report.md are not \
             drawn); run the same command again to resume: finished runs are reused",
            study.file.name,
            signal.name(),
            done.ran + done.reused,
            done.dir.join("runs.csv").display()
        ));
        return Ok(ExitCode::from(signal.exit_code()));
    }
    let name = match args.shard {
        Some(shard) => format!("{} shard {shard}", study.file.name),
        None => study.file.name.clone(),
    };
    console::out(&format!(
        "{name}: {} runs ({} run now, {} reused{}); {} not ok; wrote {}",
        done.ran + done.reused,
        done.ran,
        done.reused,
        if done.skipped > 0 && args.shard.is_none() {
            format!(", {} left out by --only", done.skipped)
        } else {
            String::new()
        },
        done.not_ok.len(),
        done.dir.display()
    ));
    if args.shard.is_some() {
        let _ = match &done.merged {
            Some(study::MergeOutcome::Merged(m)) => console::out(&format!(
                "{}: every run of the study is done: merged {} runs into {} (runs.csv, plots, \
                 report.md, meta.json)",
                study.file.name,
                m.runs,
                m.dir.display()
            )),
            Some(study::MergeOutcome::Busy(holder)) => console::out(&format!(
                "{}: every run of the study is done; {holder} holds the study folder (merging), \
                 so this shard leaves the merge to it (or run `softbench merge {}`)",
                study.file.name,
                done.dir.display()
            )),
            Some(study::MergeOutcome::Unended(shards)) => console::out(&format!(
                "{}: every run of the study is done, but shard {} has not recorded its end \
                 (still ending: it merges when it does; or killed: run `softbench merge {}`)",
                study.file.name,
                shards.join(", "),
                done.dir.display()
            )),
            None => console::out(&format!(
                "{}: other shards' runs are not all done yet; the last shard to finish merges \
                 (or run `softbench merge {}`)",
                study.file.name,
                done.dir.display()
            )),
        };
    }
    Ok(ExitCode::SUCCESS)
}

fn merge(args: &MergeArgs) -> Result<ExitCode, Error> {
    let merged = study::merge(&args.dir, args.wait, true, &DataPaths::from_env())
        .with_context(|| format!("cannot merge {}", args.dir.display()))?;
    let hosts: std::collections::BTreeSet<&str> =
        merged.shards.iter().map(|r| r.host.as_str()).collect();
    console::out(&format!(
        "merged {} of {} runs from {} shard(s) on {} host(s) ({}); {} not ok; wrote {}",
        merged.runs,
        merged.total,
        merged.shards.len(),
        hosts.len(),
        hosts.into_iter().collect::<Vec<_>>().join(", "),
        merged.not_ok.len(),
        merged.dir.display()
    ));
    if merged.missing.is_empty() {
        return Ok(ExitCode::SUCCESS);
    }
    const SHOWN: usize = 20;
    let mut list: Vec<&str> = merged
        .missing
        .iter()
        .take(SHOWN)
        .map(String::as_str)
        .collect();
    if merged.missing.len() > SHOWN {
        list.push("...");
    }
    console::err(&format!(
        "error: {} of {} runs are missing (no shard has finished them with the current \
         configuration): {}; run their shards again (a shard resumes), then merge again. \
         report.md and meta.json list them",
        merged.missing.len(),
        merged.total,
        list.join(", ")
    ));
    Ok(ExitCode::FAILURE)
}

fn slurm(args: &SlurmArgs) -> Result<ExitCode, Error> {
    if args.cpus_per_task == 0 {
        return Err(BadInput("--cpus-per-task must be at least 1".into()).into());
    }
    check_out_folder("--out", &args.out)?;
    if let Some(t) = &args.time {
        softbench_study::slurm::check_time(t)?;
    }
    if let Some(p) = &args.partition {
        softbench_study::slurm::check_partition(p)?;
    }
    // Everything that can be wrong with the study is found before anything is written.
    let data = DataPaths::from_env();
    let study = study::load(&args.study, args.quick, &data)?;
    let runs = study.runs.len();
    let shards = match args.shards {
        Some(0) => return Err(BadInput("--shards must be at least 1".into()).into()),
        Some(n) if n > runs => {
            return Err(BadInput(format!(
                "--shards {n}: the study has only {runs} runs (with{} --quick); a shard \
                 without runs would only wait in the queue",
                if args.quick { "" } else { "out" }
            ))
            .into());
        }
        Some(n) => n,
        None => runs.min(4),
    };
    let absolute = |p: &Path| {
        std::path::absolute(p).with_context(|| format!("cannot resolve {}", p.display()))
    };
    let job = softbench_study::slurm::SlurmJob {
        study_file: absolute(&args.study)?,
        name: study.file.name.clone(),
        out: absolute(&args.out)?,
        exe: match HOST_COMMAND.get() {
            Some(words) => words.clone(),
            None => vec![std::env::current_exe().context("cannot find the softbench binary")?],
        },
        shards,
        partition: args.partition.clone(),
        time: args.time.clone(),
        cpus_per_task: args.cpus_per_task,
        quick: args.quick,
        data: data.data_dir.as_deref().map(absolute).transpose()?,
    };
    // Paths that an #SBATCH line cannot hold are bad input, found before writing.
    job.array_script()?;
    stop_if_requested()?;
    let dir = job
        .write()
        .with_context(|| format!("cannot write the scripts to {}", job.script_dir().display()))?;
    console::out(&format!(
        "{}: {runs} runs in {shards} shards; wrote {} (shards.sbatch: the job array, \
         merge.sbatch: the merge, submit.sh: submits both)",
        study.file.name,
        dir.display()
    ));
    if args.submit {
        let (array, merge) = job.submit()?;
        console::out(&format!(
            "submitted: shards job {array} ({shards} tasks), merge job {merge} (after every \
             task succeeded); results in {}",
            job.study_dir().display()
        ));
    } else {
        console::out(&format!("submit with: {}", dir.join("submit.sh").display()));
    }
    Ok(ExitCode::SUCCESS)
}

fn render_folder(args: &RenderArgs) -> Result<ExitCode, Error> {
    let coloring = match args.color.as_str() {
        "plain" => Coloring::Plain,
        "energy" => Coloring::EnergyDensity,
        _ => Coloring::VolumeRatio,
    };
    let single = args.dir.join(RUN_SNAPSHOTS);
    if single.is_file() {
        let s = Snapshots::read(&single)?;
        draw_pictures(&args.dir, &s, coloring)?;
        for f in ["filmstrip.png", "animation.gif"] {
            console::out(&args.dir.join(f).display().to_string());
        }
        return Ok(ExitCode::SUCCESS);
    }
    if !args.dir.join("runs.csv").is_file() {
        return Err(BadInput(format!(
            "{}: neither a `simulate --render` folder ({RUN_SNAPSHOTS}) nor a study folder (runs.csv)",
            args.dir.display()
        ))
        .into());
    }
    let _lock = lock_folder(&args.dir, "render", false)?;
    let pictures = study::redraw_pictures(&args.dir, coloring)
        .with_context(|| format!("cannot draw the pictures of {}", args.dir.display()))?;
    if pictures.is_empty() {
        console::err(&format!(
            "{}: no run has snapshots (series/<run-id>.snapshots); rerun the study to record them",
            args.dir.display()
        ));
        return Ok(ExitCode::FAILURE);
    }
    for p in &pictures {
        for ext in ["png", "gif"] {
            console::out(
                &args
                    .dir
                    .join(format!("{}.{ext}", p.stem))
                    .display()
                    .to_string(),
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn plot(args: &PlotArgs) -> Result<ExitCode, Error> {
    // Redrawing replaces and removes plot files: not while a study writes the folder.
    let _lock = if args.dir.is_dir() {
        Some(lock_folder(&args.dir, "plot", false)?)
    } else {
        None
    };
    let plots = study::redraw(&args.dir)
        .with_context(|| format!("cannot redraw the plots of {}", args.dir.display()))?;
    for p in &plots {
        console::out(
            &args
                .dir
                .join(format!("{}.png", p.stem))
                .display()
                .to_string(),
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn profiles(args: &ProfilesArgs) -> Result<ExitCode, Error> {
    use study::profiles;
    let targets = if args.targets.is_empty() {
        profiles::DEFAULT_TARGETS.to_vec()
    } else {
        args.targets.clone()
    };
    profiles::check_targets(&targets)?;
    if let Some(out) = &args.out {
        check_out_folder("--out", out)?;
    }
    let table = profiles::read_runs(&args.dir)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| args.dir.join("profiles"));
    let written = profiles::write(&table, &targets, profiles::floor_factor(&args.dir), &out)
        .with_context(|| format!("cannot write the profiles into {}", out.display()))?;
    console::out(&format!(
        "{} problems ({} targets), {} methods; wrote {}",
        written.problems,
        targets.len(),
        written.solvers,
        out.join("profiles.md").display()
    ));
    Ok(ExitCode::SUCCESS)
}

fn ledger(args: &LedgerArgs) -> Result<ExitCode, Error> {
    use softbench_study::ledger;
    let claims = ledger::read_claims(&args.claims)?;
    let judged = ledger::judge(&claims, &args.results);
    let page = ledger::page::render(&judged, &args.results.display().to_string());
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| args.results.join("suite").join("ledger.md"));
    let counts: Vec<String> = [
        ledger::verdict::Class::Validated,
        ledger::verdict::Class::Qualified,
        ledger::verdict::Class::Refuted,
        ledger::verdict::Class::Unmeasured,
    ]
    .iter()
    .map(|c| {
        let n = judged.iter().filter(|j| j.verdict.class == *c).count();
        format!("{n} {}", c.name())
    })
    .collect();
    // Each verdict with the problems that decided it.
    for j in &judged {
        let on = j
            .implementation
            .as_ref()
            .map_or(String::new(), |i| format!(" (on {})", i.label(j.timed())));
        console::out(&format!(
            "{}{on}: {}{}",
            j.claim.id,
            j.verdict.class.name(),
            if j.verdict.cases.total() == 0 {
                format!(" ({})", j.verdict.condition)
            } else {
                format!(", {}", j.verdict.tally())
            }
        ));
    }
    if args.check {
        let on_disk = std::fs::read_to_string(&out).unwrap_or_default();
        if on_disk != page {
            console::err(&format!(
                "{} is not the ledger the claims and results give ({}): run `softbench ledger` \
                 to write it",
                out.display(),
                counts.join(", ")
            ));
            return Ok(ExitCode::FAILURE);
        }
        console::out(&format!(
            "{} is up to date ({})",
            out.display(),
            counts.join(", ")
        ));
        return Ok(ExitCode::SUCCESS);
    }
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    softbench_run::io::write_atomic(&out, |w| w.write_all(page.as_bytes()))
        .with_context(|| format!("cannot write {}", out.display()))?;
    console::out(&format!(
        "{} claims: {}; wrote {}",
        judged.len(),
        counts.join(", "),
        out.display()
    ));
    Ok(ExitCode::SUCCESS)
}
