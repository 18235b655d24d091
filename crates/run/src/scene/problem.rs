//! `[problem]`: what makes a scene a problem of the benchmark suite (`study = "suite"`).
//!
//! A problem is a scene whose run settings are its protocol — every method runs it at
//! `run.dt` for `run.steps` steps, within `run.budget` — plus what the suite needs to judge a
//! run: the scenario and difficulty it stands for, the sample times and the accuracy a run
//! must reach, and how its reference is made: one method at its step, checked against an
//! independent second solution whose difference is the reference's error bar. `simulate`
//! runs a problem file as any scene (the table only describes it).

use softbench_core::integrate::Method;

/// The difficulty strata of the suite.
pub const DIFFICULTIES: [&str; 3] = ["easy", "typical", "adversarial"];

/// The `[problem]` table.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProblemConfig {
    /// One sentence: what the problem tests.
    pub description: String,
    /// What happens in it (`hanging`, `twist-release`, `drop`, ...): a stratum of the suite.
    pub scenario: String,
    /// One of [`DIFFICULTIES`]: a stratum of the suite.
    pub difficulty: String,
    /// Errors are measured at `k horizon / samples`, k = 1..samples, with horizon =
    /// `run.dt × run.steps`; `samples` must divide `run.steps`. Default 4.
    #[serde(default = "default_samples")]
    pub samples: usize,
    /// A run solves the problem when it reaches the horizon within `run.budget` with a
    /// relative position error (largest over the sample times, relative to the reference's
    /// largest displacement) at most this.
    pub tolerance: f64,
    /// How the reference is made.
    pub reference: ProblemReference,
    /// Set when the problem needs data that a machine may not have (the course meshes): the
    /// reason, which the suite reports when it leaves the problem out because its files are
    /// not found. Default: the problem is required.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub optional: Option<String>,
}

fn default_samples() -> usize {
    4
}

/// `[problem.reference]`: the reference solution and its independent check.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProblemReference {
    /// The reference method and its step (s), which must divide the sample interval.
    pub method: Method,
    pub dt: f64,
    /// The independent second solution: the reference's error bar is its difference from
    /// the reference.
    pub independent: IndependentSolution,
    /// Newton tolerance of an implicit reference or check. Default 1e-10.
    #[serde(default = "default_newton_tolerance")]
    pub newton_tolerance: f64,
}

fn default_newton_tolerance() -> f64 {
    1e-10
}

/// A second solution a reference is checked against: another method at its own step.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IndependentSolution {
    pub method: Method,
    /// Its step (s); must divide the sample interval.
    pub dt: f64,
}

/// A check of `[problem]` that failed: the key and the message.
pub(super) struct Invalid {
    pub key: String,
    pub message: String,
}

impl ProblemConfig {
    /// Check the table against the run it describes (`dt`, `steps`).
    pub(super) fn validate(&self, dt: f64, steps: usize) -> Result<(), Invalid> {
        let bad = |key: &str, message: String| Invalid {
            key: format!("problem.{key}"),
            message,
        };
        if self.description.trim().is_empty() {
            return Err(bad(
                "description",
                "say in one sentence what it tests".into(),
            ));
        }
        let kebab = |s: &str| {
            !s.is_empty()
                && s.chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '-')
        };
        if !kebab(&self.scenario) {
            return Err(bad(
                "scenario",
                format!(
                    "`{}` must be lowercase letters, digits and '-' (a stratum's name)",
                    softbench_core::quote::clip_message(&self.scenario)
                ),
            ));
        }
        if !DIFFICULTIES.contains(&self.difficulty.as_str()) {
            return Err(bad(
                "difficulty",
                softbench_core::names::unknown_name_message(
                    "difficulty",
                    &self.difficulty,
                    &DIFFICULTIES,
                ),
            ));
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(bad(
                "tolerance",
                format!("must be a positive relative error (got {})", self.tolerance),
            ));
        }
        if self.samples == 0 || !steps.is_multiple_of(self.samples) {
            return Err(bad(
                "samples",
                format!(
                    "must divide run.steps = {steps} (got {}): errors are measured at whole \
                     steps",
                    self.samples
                ),
            ));
        }
        let interval = dt * (steps / self.samples) as f64;
        let r = &self.reference;
        for (key, step) in [
            ("reference.dt", r.dt),
            ("reference.independent.dt", r.independent.dt),
        ] {
            let per = interval / step;
            if !(step.is_finite() && step > 0.0)
                || (per - per.round()).abs() > 1e-6 * per.max(1.0)
                || per < 0.5
            {
                return Err(bad(
                    key,
                    format!(
                        "{step:e} s must be a positive step that divides the sample interval \
                         {interval:e} s (run.dt × run.steps / samples)"
                    ),
                ));
            }
        }
        if !(r.newton_tolerance.is_finite() && r.newton_tolerance > 0.0) {
            return Err(bad(
                "reference.newton_tolerance",
                format!("must be > 0 (got {})", r.newton_tolerance),
            ));
        }
        if r.method.is_adaptive() || r.independent.method.is_adaptive() {
            return Err(bad(
                "reference.method",
                "a reference steps at its own dt: name a fixed-step method".into(),
            ));
        }
        if self
            .optional
            .as_deref()
            .is_some_and(|s| s.trim().is_empty())
        {
            return Err(bad(
                "optional",
                "give the reason the problem may be left out (what data it needs)".into(),
            ));
        }
        Ok(())
    }

    /// The simulated time of a run at `dt` for `steps` steps (s).
    pub fn horizon(dt: f64, steps: usize) -> f64 {
        dt * steps as f64
    }
}
