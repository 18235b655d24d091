//! What one run of a study produced: a status, named metric cells for `runs.csv`, and the
//! sampled series; plus the pieces every kind shares (building the run, summary columns).

use super::format::cell;
use super::load::RunSpec;
use crate::data::DataPaths;
use crate::experiment::{self, Outcome, RunSummary, Sample};
use crate::integrate::State;
use crate::parallel::Parallelism;
use crate::scene::{self, RunConfig, Scene};

/// The result of one run.
#[derive(Clone, Debug, Default)]
pub struct Measured {
    /// `ok`, `unstable at t=… (cause)` or `failed: cause` (or a kind's own, e.g. for a
    /// stability bracket).
    pub status: String,
    /// The message behind a non-ok status.
    pub message: String,
    /// Metric columns (name, cell).
    pub cells: Vec<(&'static str, String)>,
    /// The per-step series for `series/<run-id>.csv`.
    pub series: Vec<Sample>,
    /// The table of `series/<run-id>-trials.csv` (stability trials).
    pub trials: Option<super::table::Table>,
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

/// Whether a status cell means the run ended as it should: `ok`, or stable over the whole
/// stability bracket.
pub fn is_clean(status: &str) -> bool {
    status == "ok" || status.starts_with("stable at")
}

/// Causes that mean the method lost stability (rather than a solver giving up).
const UNSTABLE_CAUSES: [&str; 3] = ["non-finite state", "inverted element", "energy growth"];

/// The status cell and message of a run's outcome.
pub fn status_of(outcome: &Outcome) -> (String, String) {
    match outcome {
        Outcome::Completed => ("ok".into(), String::new()),
        Outcome::Failed {
            t, cause, message, ..
        } => {
            let status = if UNSTABLE_CAUSES.contains(&cause.as_str()) {
                format!("unstable at t={} ({cause})", super::format::short(*t))
            } else {
                format!("failed: {cause}")
            };
            (status, message.clone())
        }
        Outcome::Interrupted { step, signal } => {
            ("interrupted".into(), format!("{signal} after step {step}"))
        }
    }
}

/// The summary columns every run kind reports (work, time, drift).
pub fn summary_cells(s: &RunSummary) -> Vec<(&'static str, String)> {
    let t = &s.totals;
    let steps = s.steps_completed.max(1) as f64;
    let f = |x: f64| cell(Some(x));
    vec![
        ("steps", s.steps_completed.to_string()),
        ("final_time", f(s.final_time)),
        ("energy_drift_max", f(s.energy_drift_max)),
        ("energy_drift_final", f(s.energy_drift_final)),
        ("step_seconds_median", f(s.step_seconds_median)),
        ("step_seconds_p95", f(s.step_seconds_p95)),
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
        ("assemble_seconds", f(t.times.assemble)),
        ("factor_seconds", f(t.times.factor)),
        ("solve_seconds", f(t.times.solve)),
        ("qp_seconds", f(t.times.qp)),
    ]
}

/// The scene of a run, built with the given parallelism.
pub fn build(spec: &RunSpec, parallelism: Parallelism) -> Result<Scene, scene::SceneError> {
    scene::build(&spec.loaded, &DataPaths::from_env(), parallelism)
}

/// Run `scene` from rest with `run`, keeping every sampled row.
pub fn run_rows(scene: &mut Scene, run: &RunConfig) -> (RunSummary, Vec<Sample>) {
    let mut integrator = scene.integrator();
    let mut state: State = scene.initial.clone();
    let mut rows = Vec::new();
    let mut keep = |s: &Sample| {
        rows.push(s.clone());
        Ok(())
    };
    let summary = experiment::run(
        &mut scene.model,
        integrator.as_mut(),
        &mut state,
        run,
        &mut keep,
    )
    .expect("keeping rows in memory cannot fail");
    (summary, rows)
}
