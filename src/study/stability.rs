//! Stability runs: the largest time step at which a method survives a fixed horizon, by
//! bisection, next to the explicit limit 2/omega_max of the scene at rest.
//!
//! A trial is stable when every step succeeds and the internal energy stays within
//! `energy_factor` times its initial value plus the work done on the body (see
//! [`crate::experiment::run`]): a non-finite state, an inverted element (for materials that
//! cannot invert), energy growth or a Newton failure make it unstable. Bisection assumes
//! stability is monotone in dt over the bracket, which it is for the linear stability of
//! these methods but need not be for Newton failures.

use super::config::StabilitySettings;
use super::format::{cell, short};
use super::load::RunSpec;
use super::measured::{Measured, build, run_rows, status_of, summary_cells};
use super::table::Table;
use crate::experiment::{Outcome, RunSummary, Sample};
use crate::model::{HighestMode, SpectrumSettings, highest_mode};
use crate::parallel::Parallelism;
use crate::scene::{RunConfig, Scene};

/// Columns of a stability study's `runs.csv` after the run's identity.
pub const COLUMNS: &[&str] = &[
    "status",
    "max_stable_dt",
    "omega_max",
    "dt_theory",
    "stable_over_theory",
    "first_unstable_dt",
    "unstable_cause",
    "trials",
    "horizon",
    "newton_iterations_per_step",
    "step_seconds_median",
    "step_seconds_p95",
    "steps",
    "wall_seconds",
    "trials_wall_seconds",
    "force_evaluations",
    "hessian_evaluations",
    "factorizations",
    "linear_iterations",
    "assemble_seconds",
    "factor_seconds",
    "solve_seconds",
    "qp_seconds",
];

/// Rows kept per trial in the series (the energy check runs at these rows).
const ROWS_PER_TRIAL: usize = 200;

/// One trial at one dt.
struct Trial {
    dt: f64,
    horizon: f64,
    summary: RunSummary,
    rows: Vec<Sample>,
}

impl Trial {
    fn stable(&self) -> bool {
        self.summary.outcome == Outcome::Completed
    }
}

/// The highest mode of the scene at rest: `omega_max` and the explicit limit `2 / omega_max`.
pub fn explicit_limit(scene: &mut Scene) -> Result<HighestMode, String> {
    let q = scene.initial.q.clone();
    highest_mode(&mut scene.model, &q, &SpectrumSettings::default()).map_err(|e| e.to_string())
}

/// Find the largest stable dt of one run. `omega` is the scene's highest mode (cached by the
/// caller per scene).
pub fn measure(
    spec: &RunSpec,
    settings: &StabilitySettings,
    omega: Option<f64>,
    parallelism: Parallelism,
) -> Result<Measured, String> {
    let mut scene = build(spec, parallelism).map_err(|e| e.to_string())?;
    let mut trials: Vec<Trial> = Vec::new();
    let try_dt = |scene: &mut Scene, dt: f64, trials: &mut Vec<Trial>| -> bool {
        let steps = ((settings.horizon / dt).ceil() as usize).clamp(1, settings.max_steps);
        let run = RunConfig {
            dt,
            steps,
            sample_every: steps.div_ceil(ROWS_PER_TRIAL).max(1),
            energy_limit: settings.energy_factor,
        };
        let (summary, rows) = run_rows(scene, &run);
        let trial = Trial {
            dt,
            horizon: steps as f64 * dt,
            summary,
            rows,
        };
        let stable = trial.stable();
        trials.push(trial);
        stable
    };

    // Bisect in log dt with `lo` presumed stable: a trial at dt_min is the most expensive one
    // (an implicit method over the whole horizon at the smallest step), so `lo` is tried only
    // once the bracket has closed in on it (within 4x) without a stable trial above it. If it
    // fails, the bracket widens downward by 10x steps to the floor.
    let (mut lo, mut hi) = (settings.dt_min, settings.dt_max);
    let floor = settings.floor();
    let none_in_range = || {
        format!(
            "no stable dt in [{}, {}]",
            short(floor),
            short(settings.dt_max)
        )
    };
    let (status, bracket): (String, Option<(f64, Option<f64>)>) =
        if try_dt(&mut scene, hi, &mut trials) {
            (format!("stable at dt_max={}", short(hi)), Some((hi, None)))
        } else {
            let mut verified = false;
            loop {
                let closed = hi / lo - 1.0 <= settings.relative_precision;
                if !verified && (closed || hi / lo <= 4.0) {
                    if try_dt(&mut scene, lo, &mut trials) {
                        verified = true;
                    } else if lo <= floor * (1.0 + 1e-12) {
                        break (none_in_range(), None);
                    } else {
                        hi = lo;
                        lo = (lo / 10.0).max(floor);
                    }
                    continue;
                }
                if closed {
                    break ("ok".to_owned(), Some((lo, Some(hi))));
                }
                let mid = (lo * hi).sqrt();
                if try_dt(&mut scene, mid, &mut trials) {
                    lo = mid;
                    verified = true;
                } else {
                    hi = mid;
                }
            }
        };

    let best = bracket.and_then(|(dt, _)| trials.iter().find(|t| t.dt == dt && t.stable()));
    let first_unstable = bracket
        .and_then(|(_, hi)| hi)
        .and_then(|hi| trials.iter().find(|t| t.dt == hi))
        .or_else(|| trials.iter().rev().find(|t| !t.stable()));
    let mut m = Measured {
        status,
        ..Measured::default()
    };
    if let Some(best) = best {
        m.cells = summary_cells(&best.summary);
        m.set("horizon", cell(Some(best.horizon)));
        m.series = best.rows.clone();
    }
    m.set("max_stable_dt", cell(bracket.map(|(lo, _)| lo)));
    m.set("first_unstable_dt", cell(bracket.and_then(|(_, hi)| hi)));
    if let Some(t) = first_unstable {
        let (s, message) = status_of(&t.summary.outcome);
        m.set("unstable_cause", s);
        if bracket.is_none() {
            m.message = message;
        }
    }
    m.set("omega_max", cell(omega));
    let theory = omega.map(|w| 2.0 / w);
    m.set("dt_theory", cell(theory));
    m.set(
        "stable_over_theory",
        cell(bracket.zip(theory).map(|((lo, _), th)| lo / th)),
    );
    m.set("trials", trials.len().to_string());
    let total: f64 = trials.iter().map(|t| t.summary.totals.times.total).sum();
    m.set("trials_wall_seconds", cell(Some(total)));
    let header = ["dt", "steps", "horizon", "stable", "status", "message"];
    m.trials = Some(Table {
        header: header.map(str::to_owned).to_vec(),
        rows: trials
            .iter()
            .map(|t| {
                let (status, message) = status_of(&t.summary.outcome);
                vec![
                    cell(Some(t.dt)),
                    t.summary.steps_requested.to_string(),
                    cell(Some(t.horizon)),
                    t.stable().to_string(),
                    status,
                    message,
                ]
            })
            .collect(),
    });
    Ok(m)
}
