//! The study file schema (TOML): which scenes, which grid of runs, what is measured.
//!
//! Values the runner must point back to (grid entries, scenes, overrides) keep their byte
//! span in the file, so an error can name the line.

use crate::integrate::Method;
use std::collections::BTreeMap;
use toml::Spanned;

/// The scene key of the integration method (a grid axis of its own).
pub(super) const METHOD_KEY: &str = "integrator.method";
/// The scene key of the linear solver (a grid axis of its own).
pub(super) const SOLVER_KEY: &str = "integrator.linear_solver";

/// What a study measures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum StudyKind {
    /// Energies, momenta, iterations and time per step over each run.
    Trajectory,
    /// Error against a reference solution next to wall time and evaluation counts.
    WorkPrecision,
    /// The largest stable time step per run, by bisection.
    Stability,
    /// One of the above over a parameter, with its metrics plotted against it.
    Sweep,
}

impl StudyKind {
    /// The name in study files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Trajectory => "trajectory",
            Self::WorkPrecision => "work-precision",
            Self::Stability => "stability",
            Self::Sweep => "sweep",
        }
    }
}

/// A study file as written.
#[derive(Clone, Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    /// The study's name: its results folder.
    pub name: String,
    /// What is measured.
    pub study: StudyKind,
    /// A sentence or two for the report.
    #[serde(default)]
    pub description: Option<String>,
    /// Scene files (relative to the study file) or inline scene tables.
    pub scenes: Vec<Spanned<toml::Value>>,
    /// Scene keys set for every run (dotted paths), e.g. `"run.steps" = 100`.
    #[serde(default)]
    pub set: BTreeMap<String, Spanned<toml::Value>>,
    /// Scene keys to sweep (dotted paths); every combination is one run.
    #[serde(default)]
    pub grid: BTreeMap<String, Spanned<toml::Value>>,
    /// Methods each with their own options (`[[methods]] method = "adaptive-rk4"
    /// "integrator.adaptive.tolerance" = [1e-4, 1e-6]`), instead of `integrator.method` in
    /// the grid.
    #[serde(default)]
    pub methods: Vec<Spanned<toml::Table>>,
    #[serde(default)]
    pub stability: Option<StabilitySettings>,
    #[serde(default, rename = "work-precision", alias = "work_precision")]
    pub work_precision: Option<WorkPrecisionSettings>,
    #[serde(default)]
    pub sweep: Option<SweepSettings>,
    /// What `--quick` changes.
    #[serde(default)]
    pub quick: QuickSettings,
}

/// `[stability]`: the search for the largest stable time step.
///
/// A trial at `dt` runs the scene over `horizon` and counts as stable only if it covers the
/// whole horizon, in at least `min_steps` and at most `max_steps` steps, with the energy
/// balance holding and every step taken. So the steps that can be judged lie in
/// `[max(dt_floor, horizon / max_steps), dt_ceiling]`, and the answer never depends on a cap
/// that stopped a trial early.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StabilitySettings {
    /// Presumed-stable lower end of the first bracket (s); tried only once the bracket closes
    /// in on it.
    pub dt_min: f64,
    /// The first step tried (s). If it is stable the bracket widens upward (x4 at a time) to
    /// `dt_ceiling`, so methods stable there are still ranked.
    pub dt_max: f64,
    /// Simulated time every trial must cover (s).
    pub horizon: f64,
    /// A trial is unstable when the energy balance's excess (energy gained beyond the work
    /// done on the body) exceeds this many times the energy budget (see
    /// `run::balance`). Default 1.
    #[serde(default = "default_energy_factor")]
    pub energy_factor: f64,
    /// Bisection stops when `hi/lo - 1` is below this. Default 0.01.
    #[serde(default = "default_relative_precision")]
    pub relative_precision: f64,
    /// If `dt_min` is unstable the bracket widens downward by 10x steps to this floor (or to
    /// `horizon / max_steps`, whichever is larger). Default `dt_min / 1000`.
    #[serde(default)]
    pub dt_floor: Option<f64>,
    /// The largest step tried (s). Default and upper bound: `horizon / min_steps`.
    #[serde(default)]
    pub dt_ceiling: Option<f64>,
    /// Steps per trial at most; steps below `horizon / max_steps` are not judged. Default
    /// 20,000.
    #[serde(default = "default_max_steps")]
    pub max_steps: usize,
    /// Steps per trial at least, so a trial of one huge step never counts as stable.
    /// Default 20.
    #[serde(default = "default_min_steps")]
    pub min_steps: usize,
    /// After a limit is found, this many smaller steps (dt/2, dt/4, ...) are tried; a failure
    /// there flags the result as non-monotone. Default 2.
    #[serde(default = "default_probes")]
    pub probes: usize,
    /// Newton must converge within its iteration cap, or the step fails as `solver-failed`
    /// (otherwise unconverged steps are accepted and counted). Default true.
    #[serde(default = "yes")]
    pub require_newton_convergence: bool,
    /// Sample times of the error against a converged reference at the largest stable step
    /// (`error_at_stable_dt`); 0 turns the reference off. Default 10.
    #[serde(default = "default_error_samples")]
    pub error_samples: usize,
    /// How that reference is computed (defaults as in work-precision studies, with a default
    /// step of `horizon / 4000`; in quick mode never finer than `horizon / 400`).
    #[serde(default)]
    pub reference: ReferenceSettings,
}

fn default_energy_factor() -> f64 {
    1.0
}
fn default_relative_precision() -> f64 {
    0.01
}
fn default_max_steps() -> usize {
    20_000
}
fn default_min_steps() -> usize {
    20
}
fn default_probes() -> usize {
    2
}
fn default_error_samples() -> usize {
    10
}
fn yes() -> bool {
    true
}

impl StabilitySettings {
    /// The floor of the downward widening as set (see [`StabilitySettings::lowest_dt`]).
    pub fn floor(&self) -> f64 {
        self.dt_floor.unwrap_or(self.dt_min / 1000.0)
    }

    /// The smallest step a trial can judge: the floor, or the step at which `max_steps` steps
    /// just cover the horizon.
    pub fn lowest_dt(&self) -> f64 {
        self.floor().max(self.horizon / self.max_steps as f64)
    }

    /// The largest step a trial can judge: `dt_ceiling`, at most `horizon / min_steps`.
    pub fn highest_dt(&self) -> f64 {
        let bound = self.horizon / self.min_steps.max(1) as f64;
        self.dt_ceiling.map_or(bound, |c| c.min(bound))
    }
}

/// `[work-precision]`: where errors are measured and against what.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorkPrecisionSettings {
    /// Simulated time of every run (s); must be a whole number of steps of every dt.
    pub horizon: f64,
    /// Newton must converge within its iteration cap, or the step fails as `solver-failed`.
    /// Default true.
    #[serde(default = "yes")]
    pub require_newton_convergence: bool,
    /// Errors are measured at `horizon k / samples`, k = 1..samples. Default 4.
    #[serde(default = "default_samples")]
    pub samples: usize,
    #[serde(default)]
    pub reference: ReferenceSettings,
}

fn default_samples() -> usize {
    4
}

/// How the reference solution is computed.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ReferenceSettings {
    /// The method. Default: RK4 when it is stable at the reference step (below 2.5/omega_max),
    /// else implicit midpoint (second order, stable at any step); with `same_dt`, backward
    /// Euler.
    pub method: Option<Method>,
    /// Work-precision only: the reference runs at each run's own dt, so a run's error is its
    /// distance from the converged step it approximates (the iteration error of VBD,
    /// projective dynamics, XPBD or a truncated Newton solve), not from the exact motion.
    /// Its own accuracy is then its difference from a second reference at a Newton
    /// tolerance 100× tighter. Default false.
    pub same_dt: bool,
    /// The reference step (s). Default: the smallest dt of the grid divided by `dt_factor`.
    pub dt: Option<f64>,
    /// Default 8.
    pub dt_factor: f64,
    /// Newton tolerance of an implicit reference. Default 1e-10.
    pub newton_tolerance: f64,
    /// Errors below this factor times the difference between the reference and a second one
    /// at half its step are not scored. Default 2.
    pub floor_factor: f64,
}

impl Default for ReferenceSettings {
    fn default() -> Self {
        Self {
            method: None,
            same_dt: false,
            dt: None,
            dt_factor: 8.0,
            newton_tolerance: 1e-10,
            floor_factor: 2.0,
        }
    }
}

/// `[sweep]`: a study of another kind over one grid key.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepSettings {
    /// What each run measures: trajectory, work-precision or stability.
    pub kind: StudyKind,
    /// The swept grid key (dotted path), the x axis of the sweep plots.
    pub parameter: String,
    /// Columns of runs.csv plotted against the parameter. Default per kind.
    #[serde(default)]
    pub metrics: Vec<String>,
}

/// `[quick]`: how `--quick` shortens the study (so any shipped study takes under a minute).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct QuickSettings {
    /// Scene keys set in quick mode (dotted paths), after `set` and the grid.
    #[serde(default)]
    pub set: BTreeMap<String, toml::Value>,
    /// Trajectory runs take at most this many steps. Default 20.
    #[serde(default)]
    pub steps: Option<usize>,
    /// Work-precision: the horizon. Stability studies refuse it: they keep their horizon, so a
    /// quick verdict at a step is the full study's verdict at that step.
    #[serde(default)]
    pub horizon: Option<f64>,
    /// Stability: steps per trial at most, so only larger steps are judged (default: the
    /// study's, at most 2000), and the bisection precision (default 0.05).
    #[serde(default)]
    pub max_steps: Option<usize>,
    #[serde(default)]
    pub relative_precision: Option<f64>,
    /// Work-precision: only the largest this many time steps of the ladder. Default 2.
    #[serde(default)]
    pub dts: Option<usize>,
}

/// The line (1-based) of byte offset `at` in `text`.
pub fn line_of(text: &str, at: usize) -> usize {
    text[..at.min(text.len())].matches('\n').count() + 1
}
