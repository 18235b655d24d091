//! What each Newton iteration did ([`IterationRecord`]), when each convergence criterion is
//! met by a record ([`Criterion::met`]), and re-scoring a logged solve under another
//! criterion ([`rescore`]): the iterates do not depend on the criterion, so the first record
//! that meets it is where a fresh run with that criterion stops.

use super::settings::Criterion;

/// Why a Newton solve stopped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stop {
    /// Not the last iteration of its solve.
    #[default]
    Running,
    /// The criterion was met at this iterate.
    Criterion,
    /// The predicted decrease fell below the energy's round-off: the full step was taken and
    /// the solve ended (converged to working precision, whatever the criterion).
    Roundoff,
    /// `max_iterations` reached without meeting the criterion.
    Cap,
}

impl Stop {
    /// The name in `iterations.csv`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Running => "",
            Self::Criterion => "criterion",
            Self::Roundoff => "roundoff",
            Self::Cap => "cap",
        }
    }
}

/// One Newton iterate `x_k` of one solve: where it is, how it was reached, what its direction
/// cost, and the scales every criterion is relative to (so a log can be re-scored).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct IterationRecord {
    /// The solve within the run (0, 1, ...; a step of a multi-stage or retried scheme has
    /// several).
    pub solve: u64,
    /// `k`: 0 is the initial guess.
    pub iteration: u32,
    /// `‖g(x_k)‖`.
    pub gradient_norm: f64,
    /// `-g·dx` of the direction taken from `x_k` (NaN when none was computed: the last
    /// record of a solve that stopped on another test).
    pub decrement: f64,
    /// `E(x_k)`.
    pub energy: f64,
    /// `E(x_(k-1)) - E(x_k)` (NaN at k = 0).
    pub energy_decrease: f64,
    /// `‖x_k - x_(k-1)‖_inf` (NaN at k = 0).
    pub step_norm: f64,
    /// The step length `alpha` that reached `x_k` (1 for a trust-region step; NaN at k = 0).
    pub step_length: f64,
    /// Line-search backtracks (rejected trust-region steps) that reaching `x_k` took.
    pub backtracks: u32,
    /// Linear-solver iterations of the direction from `x_k` (CG iterations; 1 per direct
    /// solve; the L-BFGS initial Hessian's solves).
    pub linear_iterations: u64,
    /// Factorizations made for the direction from `x_k`.
    pub factorizations: u32,
    /// Element Hessians a filter changed in this iteration's assembly.
    pub projected_elements: u64,
    /// Wall time from the start of the solve to the end of this iteration (s).
    pub seconds: f64,
    /// The scale of `scaled-gradient`.
    pub scaled_gradient_scale: f64,
    /// `‖g(x_0)‖`, the scale of `relative-gradient`.
    pub initial_gradient: f64,
    /// `beta ‖M a_g‖`, the scale of `gravity-gradient` (0 without gravity).
    pub gravity_scale: f64,
    /// The sum of the magnitudes of `E`'s terms at `x_k`, the scale of `energy`.
    pub energy_scale: f64,
    /// Why the solve stopped here ([`Stop::Running`] if it went on).
    pub stop: Stop,
}

impl Criterion {
    /// Whether `record` meets this criterion at `tolerance`: `value <= tolerance * scale`
    /// ([`Self::measure`]). A test a record cannot answer (a decrement not computed, a step or
    /// decrease at k = 0) is not met.
    pub fn met(self, tolerance: f64, r: &IterationRecord) -> bool {
        let (value, scale) = self.measure(r);
        value <= tolerance * scale
    }

    /// The number this criterion compares with its tolerance at `r`, `value / scale`: the
    /// gradient norm over its scale, half the decrement, the step, or the decrease over the
    /// energy's scale (NaN where the record cannot answer).
    pub fn residual(self, r: &IterationRecord) -> f64 {
        let (value, scale) = self.measure(r);
        value / scale
    }

    /// What the criterion measures at `r` and the scale its tolerance is relative to (1 for
    /// an absolute test); the value is NaN where the record cannot answer (no direction, or
    /// k = 0 for `step` and `energy`).
    fn measure(self, r: &IterationRecord) -> (f64, f64) {
        let g = r.gradient_norm;
        let later = |v: f64| if r.iteration > 0 { v } else { f64::NAN };
        match self {
            Self::ScaledGradient => (g, r.scaled_gradient_scale),
            Self::Gradient => (g, 1.0),
            Self::RelativeGradient => (g, r.initial_gradient),
            Self::GravityGradient => (g, r.gravity_scale),
            Self::Decrement => (0.5 * r.decrement, 1.0),
            Self::Step => (later(r.step_norm), 1.0),
            Self::Energy => (later(r.energy_decrease.abs()), r.energy_scale),
        }
    }

    /// Whether the test needs the iteration's direction (it is made after the direction).
    pub fn needs_direction(self) -> bool {
        self == Self::Decrement
    }
}

/// Where a logged solve would have stopped under another criterion.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rescored {
    /// At this iteration `k` (the criterion met, or the solve's own round-off stop or cap,
    /// which do not depend on the criterion).
    At(u32, Stop),
    /// Later than the log shows: the logged solve stopped first on its own criterion.
    BeyondLog,
}

/// Re-score one solve's records (in order, as logged) under `criterion` at `tolerance`.
pub fn rescore(records: &[IterationRecord], criterion: Criterion, tolerance: f64) -> Rescored {
    for r in records {
        if criterion.met(tolerance, r) {
            return Rescored::At(r.iteration, Stop::Criterion);
        }
        match r.stop {
            Stop::Roundoff | Stop::Cap => return Rescored::At(r.iteration, r.stop),
            Stop::Running | Stop::Criterion => {}
        }
    }
    Rescored::BeyondLog
}

/// The header of `iterations.csv`.
pub const CSV_HEADER: &[&str] = &[
    "step",
    "solve",
    "iteration",
    "gradient_norm",
    "decrement",
    "energy",
    "energy_decrease",
    "step_norm",
    "step_length",
    "backtracks",
    "linear_iterations",
    "factorizations",
    "projected_elements",
    "seconds",
    "scaled_gradient_scale",
    "initial_gradient",
    "gravity_scale",
    "energy_scale",
    "stop",
];

impl IterationRecord {
    /// The record's `iterations.csv` cells after the step number (exact digits).
    pub fn csv_cells(&self, step: usize) -> Vec<String> {
        let f = |v: f64| {
            if v.is_nan() {
                String::new()
            } else {
                format!("{v:e}")
            }
        };
        vec![
            step.to_string(),
            self.solve.to_string(),
            self.iteration.to_string(),
            f(self.gradient_norm),
            f(self.decrement),
            f(self.energy),
            f(self.energy_decrease),
            f(self.step_norm),
            f(self.step_length),
            self.backtracks.to_string(),
            self.linear_iterations.to_string(),
            self.factorizations.to_string(),
            self.projected_elements.to_string(),
            f(self.seconds),
            f(self.scaled_gradient_scale),
            f(self.initial_gradient),
            f(self.gravity_scale),
            f(self.energy_scale),
            self.stop.name().to_owned(),
        ]
    }
}
