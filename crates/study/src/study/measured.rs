//! What one run of a study produced: an outcome, named metric cells for `runs.csv`, and the
//! sampled series; plus the pieces every kind shares (building the run, summary columns).

use super::format::cell;
use super::meter::{Counting, StepMeter};
use super::spec::RunSpec;
use softbench_core::integrate::State;
use softbench_core::parallel::Parallelism;
use softbench_run::pipeline::{self, BodySurface, Recording};
use softbench_run::run::{Observer, Outcome, RunSummary, Sample};
use softbench_run::scene::{self, RunConfig, Scene};

/// The names of the tables a run may write next to its series ([`Measured::tables`]).
pub const SERIES_TABLES: [&str; 3] = ["trials", "iterations", "solves"];

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
    pub tables: Vec<(&'static str, super::table::Table)>,
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
            super::format::short(outcome.t.unwrap_or(0.0)),
            outcome.message
        )
    };
    (outcome.status.name().to_owned(), message)
}

/// The summary columns every run kind reports (work, time, drift).
pub fn summary_cells(s: &RunSummary) -> Vec<(&'static str, String)> {
    let t = &s.totals;
    let steps = s.steps_completed.max(1) as f64;
    let f = |x: f64| cell(Some(x));
    // Empty without an AMG hierarchy.
    let amg = |x: f64| cell((t.amg_builds > 0).then_some(x));
    vec![
        ("steps", s.steps_completed.to_string()),
        ("final_time", f(s.final_time)),
        ("energy_drift_max", f(s.energy_drift_max)),
        ("energy_drift_final", f(s.energy_drift_final)),
        ("step_seconds_median", f(s.step_seconds_median)),
        ("step_seconds_q1", f(s.step_seconds_q1)),
        ("step_seconds_q3", f(s.step_seconds_q3)),
        ("step_seconds_p95", f(s.step_seconds_p95)),
        ("first_step_seconds", f(s.first_step_seconds)),
        (
            "setup_seconds",
            f((s.first_step_seconds - s.step_seconds_median).max(0.0)),
        ),
        ("wall_seconds", f(t.times.total)),
        ("force_evaluations", t.evaluations.gradient.to_string()),
        ("energy_evaluations", t.evaluations.potential.to_string()),
        ("hessian_evaluations", t.evaluations.hessian.to_string()),
        ("factorizations", t.factorizations.to_string()),
        ("linear_solves", t.linear_solves.to_string()),
        ("linear_iterations", t.linear_iterations.to_string()),
        ("newton_iterations", t.newton_iterations.to_string()),
        (
            "newton_iterations_per_step",
            f(f64::from(t.newton_iterations) / steps),
        ),
        ("substeps", t.substeps.to_string()),
        ("rejected_substeps", t.rejected_substeps.to_string()),
        ("failed_substeps", t.failed_substeps.to_string()),
        ("local_iterations", t.local_iterations.to_string()),
        (
            "local_iterations_per_step",
            f(f64::from(t.local_iterations) / steps),
        ),
        ("assemble_seconds", f(t.times.assemble)),
        ("factor_seconds", f(t.times.factor)),
        ("solve_seconds", f(t.times.solve)),
        ("qp_seconds", f(t.times.qp)),
        ("force_seconds", f(t.times.forces)),
        ("mass_solves", t.mass_solves.to_string()),
        ("mass_solve_seconds", f(t.times.mass_solve)),
        ("internal_dt_min", cell(s.internal_dt.map(|d| d.min))),
        ("internal_dt_median", cell(s.internal_dt.map(|d| d.median))),
        ("internal_dt_max", cell(s.internal_dt.map(|d| d.max))),
        (
            "newton_unconverged_steps",
            s.newton_unconverged_steps.to_string(),
        ),
        ("inverted_elements_max", s.inverted_elements_max.to_string()),
        ("energy_excess_peak", f(s.energy_excess_peak)),
        ("energy_growth_rate", cell(s.energy_growth.map(|g| g.rate))),
        (
            "energy_growth_factor",
            cell(s.energy_growth.map(|g| g.factor)),
        ),
        ("energy_limit", f(s.energy_limit)),
        ("linear_solver_used", t.linear_solver.to_owned()),
        ("ordering", t.ordering.to_owned()),
        ("factor_nnz", t.factor_nnz.to_string()),
        ("symbolic_analyses", t.symbolic_analyses.to_string()),
        ("factor_flops", f(t.factor_flops)),
        ("factor_threads", t.factor_threads.to_string()),
        ("factor_scheduler", t.factor_scheduler.to_owned()),
        ("amg_operator_complexity", amg(t.amg_operator_complexity)),
        ("amg_grid_complexity", amg(t.amg_grid_complexity)),
        ("amg_builds", t.amg_builds.to_string()),
        ("amg_reuses", t.amg_reuses.to_string()),
        ("amg_lagged", t.amg_lagged.to_string()),
        (
            "linear_iterations_per_solve",
            f(t.linear_iterations as f64 / f64::from(t.linear_solves.max(1))),
        ),
    ]
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

/// The caps and tolerances of a run's integrator that can decide its result, reported next
/// to it: Newton's iteration cap, whether convergence was required, and how many iterations
/// share a factorization (modified Newton).
pub fn cap_cells(spec: &RunSpec) -> Vec<(&'static str, String)> {
    let mut cells = newton_cap_cells(spec);
    cells.extend(adaptive_cells(spec));
    cells
}

/// The tolerances and controller that set an adaptive method's steps (empty for fixed-step
/// methods): its error is what they ask for, so they are reported next to it.
fn adaptive_cells(spec: &RunSpec) -> Vec<(&'static str, String)> {
    let integrator = &spec.loaded.config.integrator;
    let a = &integrator.adaptive;
    let on = integrator.method.is_adaptive();
    let shown = |s: String| if on { s } else { String::new() };
    vec![
        ("adaptive_rtol", shown(a.tolerance.to_string())),
        ("adaptive_atol", shown(a.absolute_tolerance.to_string())),
        ("adaptive_controller", shown(a.controller.name().to_owned())),
        ("adaptive_max_substeps", shown(a.max_substeps.to_string())),
    ]
}

fn newton_cap_cells(spec: &RunSpec) -> Vec<(&'static str, String)> {
    let integrator = &spec.loaded.config.integrator;
    if !integrator.method.uses_newton() {
        return vec![
            ("newton_max_iterations", String::new()),
            ("newton_required", String::new()),
            ("newton_refactor_every", String::new()),
            ("newton_forcing_max", String::new()),
            ("amg_strength_threshold", String::new()),
            ("amg_rebuild_every", String::new()),
            ("amg_galerkin_every", String::new()),
            ("amg_smoother", String::new()),
        ];
    }
    let newton = &integrator.newton;
    // AMG's settings where AMG can run: CG with it, or `auto` (which may choose it).
    let amg = &integrator.solver.cg.amg;
    let uses_amg = integrator.linear_solver.name() == "auto"
        || (integrator.linear_solver.name() == "cg"
            && integrator.solver.cg.preconditioner == softbench_core::solve::Preconditioner::Amg);
    let amg_cell = |s: String| if uses_amg { s } else { String::new() };
    vec![
        ("newton_max_iterations", newton.max_iterations.to_string()),
        ("newton_required", newton.require_convergence.to_string()),
        ("newton_refactor_every", newton.refactor_every.to_string()),
        ("newton_forcing_max", newton.forcing_max.to_string()),
        (
            "amg_strength_threshold",
            amg_cell(amg.strength_threshold.to_string()),
        ),
        ("amg_rebuild_every", amg_cell(amg.rebuild_every.to_string())),
        (
            "amg_galerkin_every",
            amg_cell(amg.galerkin_every.to_string()),
        ),
        ("amg_smoother", amg_cell(amg.smoother.name().to_owned())),
    ]
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
