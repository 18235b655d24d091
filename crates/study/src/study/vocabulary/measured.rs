//! What one run of a study produced: an outcome, named metric cells for `runs.csv`, and the
//! sampled series; plus the pieces every kind shares (building the run, summary columns).

use crate::study::vocabulary::meter::{Counting, StepMeter};
use crate::study::vocabulary::spec::RunSpec;
use softbench_core::integrate::State;
use softbench_core::parallel::Parallelism;
use softbench_run::pipeline::{self, BodySurface, Recording};
use softbench_run::run::{Observer, Outcome, RunSummary, Sample};
use softbench_run::scene::{self, RunConfig, Scene};

/// The names of the tables a run may write next to its series ([`Measured::tables`]).
pub const SERIES_TABLES: [&str; 4] = ["trials", "iterations", "solves", "steps"];

/// The result of one run.
#[derive(Clone, Debug, Default)]
pub struct Measured {
    /// The outcome word ([`OutcomeKind`](softbench_run::run::OutcomeKind)): how the run ended, or, for
    /// a kind that runs trials (stability), how its first failing trial ended (`completed`
    /// when none failed).
    pub outcome: String,
    /// The message behind an outcome other than `completed`.
    pub message: String,
    /// Metric columns (name, cell).
    pub cells: Vec<(&'static str, String)>,
    /// The per-step series for `series/<run-id>.csv`.
    pub series: Vec<Sample>,
    /// Tables of their own, each written as `series/<run-id>-<name>.csv` (a stability run's
    /// `trials`, a solver run's `iterations` and `solves`); the names are [`SERIES_TABLES`].
    pub tables: Vec<(&'static str, crate::study::vocabulary::table::Table)>,
    /// The body's surface at a few times (`series/<run-id>.snapshots`), for pictures.
    pub snapshots: Option<softbench_run::render::Snapshots>,
}

impl Measured {
    /// Set a metric cell.
    pub fn set(&mut self, name: &'static str, value: String) {
        match self.cells.iter_mut().find(|(n, _)| *n == name) {
            Some(c) => c.1 = value,
            None => self.cells.push((name, value)),
        }
    }

    /// A cell by name.
    pub fn get(&self, name: &str) -> Option<&str> {
        self.cells
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| v.as_str())
    }
}

/// The outcome word and message of a run's outcome.
pub fn outcome_of(outcome: &Outcome) -> (String, String) {
    let message = if outcome.is_completed() {
        String::new()
    } else {
        format!(
            "{} at step {} (t = {}): {}",
            outcome.cause,
            outcome.step.unwrap_or(0),
            crate::study::vocabulary::format::short(outcome.t.unwrap_or(0.0)),
            outcome.message
        )
    };
    (outcome.status.name().to_owned(), message)
}

/// Starts a new peak-memory window: on Linux, writing 5 to `/proc/self/clear_refs` resets
/// the process's resident high-water mark (VmHWM). Elsewhere, or if it fails, the peak stays
/// the process's since its start.
pub fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// The process's peak resident memory (MiB) since the last [`reset_peak_rss`]: VmHWM from
/// `/proc/self/status`, else `getrusage`'s since the start. With `--jobs` above 1, runs share
/// the window, so this bounds a run's peak from above.
pub fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok();
    let hwm = status.as_deref().and_then(|s| {
        s.lines()
            .find_map(|l| l.strip_prefix("VmHWM:"))
            .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
    });
    if let Some(kib) = hwm {
        return Some(kib / 1024.0);
    }
    // SAFETY: getrusage writes one plain struct we own.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let ok = unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } == 0;
    // Linux reports ru_maxrss in KiB.
    ok.then(|| usage.ru_maxrss as f64 / 1024.0)
}

/// The scene of a run, built with the given parallelism.
pub fn build(spec: &RunSpec, parallelism: Parallelism) -> Result<Scene, scene::SceneError> {
    scene::build(&spec.loaded, &spec.data, parallelism)
}

/// Run `scene` from rest with `run`, passing every row to `inner`; with a `surface`, also
/// record its snapshots (see [`softbench_run::render`]); with a `meter`, count its steps there (for
/// the study's ETA). Returns the final state too (how far a run that ended early got). Each
/// call is one run with its own integrator ([`Scene::take_integrator`]).
pub fn run_observed(
    scene: &mut Scene,
    run: &RunConfig,
    surface: Option<softbench_run::render::Surface>,
    inner: &mut dyn Observer,
    meter: Option<&StepMeter>,
) -> (RunSummary, State, Option<softbench_run::render::Snapshots>) {
    let recording = Recording {
        pictures: surface,
        ..Recording::default()
    };
    let mut counting;
    let inner: &mut dyn Observer = match meter {
        Some(meter) => {
            counting = Counting::new(inner, meter);
            &mut counting
        }
        None => inner,
    };
    let observed = pipeline::run_observed(scene, run, recording, inner)
        .expect("keeping rows and snapshots in memory cannot fail");
    (observed.summary, observed.state, observed.snapshots)
}

/// The surface a study run's pictures show, as `simulate --render` draws it
/// ([`BodySurface`]): the scene's `[display]` mesh skinned onto the tets, else the boundary
/// of the body's tets; `None` when there are no tets to draw.
pub fn picture_surface(
    scene: &Scene,
    spec: &RunSpec,
) -> Result<Option<softbench_run::render::Surface>, String> {
    let body =
        BodySurface::new(&spec.loaded, &spec.data, scene, true).map_err(|e| e.to_string())?;
    Ok(body.picture_surface(scene))
}

/// The highest mode of a scene at rest: `omega_max` and the explicit limit `2 / omega_max`.
pub fn highest_mode_at_rest(
    scene: &mut Scene,
) -> Result<softbench_core::model::HighestMode, String> {
    let q = scene.initial.q.clone();
    softbench_core::model::highest_mode(
        &mut scene.model,
        &q,
        &softbench_core::model::SpectrumSettings::default(),
    )
    .map_err(|e| e.to_string())
}
