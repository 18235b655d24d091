//! Stability runs: the set of time steps at which a method covers a fixed horizon, drawn as a
//! map over the whole judged range, what it costs per simulated second at its largest stable
//! step and how wrong it is, next to the explicit limit 2/omega_max of the scene at rest.
//!
//! A trial at `dt` is stable when it covers the whole horizon in at least `min_steps` and at
//! most `max_steps` steps with every step taken, no blow-up (see [`softbench_run::run::balance`]:
//! a blow-up is energy gained beyond the work done on the body that keeps growing, not a level
//! crossed) and no invented energy kept: an excess above `invented_energy_limit` times the
//! energy scale throughout the last quarter of the horizon is instability even when it stopped
//! growing (a bounded spurious oscillation). Steps outside `[lowest_dt, highest_dt]` are never
//! judged, so no cap decides a verdict.
//!
//! The search does not presume stability is monotone in dt. It scans the whole judged range,
//! `scan_per_decade` log-spaced steps per decade (and `dt_max`), then bisects *every* change
//! between stable and unstable between neighbouring trials to `relative_precision`; the stable
//! set is reported as intervals (`stable_intervals`, `scan_map`). Trials [`ROBUSTNESS`] away
//! from each end of each interval inside the range must agree with that end (`limit_robust`).
//!
//! The verdict (`stability`) says what the map shows: `stable-to-ceiling` (every step tried is
//! stable), `limit-found` (stable from the lowest step up to `max_stable_dt`, unstable above:
//! `first_unstable_dt`), `stable-only-above` (unstable at the small steps, stable from some step
//! up to the ceiling: BDF3-6 on lightly damped bodies), `stable-in-bands` (any other stable
//! set), `unstable-at-every-dt` (every trial blew up and the growth rate of the three smallest
//! shrinks as a positive power of dt, no steeper at the smaller steps, `growth_exponent`,
//! below 2/omega_max: see `GrowthTrend`; also when the trials of a stable interval from the
//! lowest step all still grew, only too slowly to show within the horizon, and the rates from
//! the smallest step up follow such a power) or
//! `no-stable-dt-in-range` (no trial was stable, which says nothing about steps below the
//! range). Rankings use `max_stable_dt`, the largest step below which every tried step is
//! stable, and `stable_fraction`, the stable share of the range in log dt. The `outcome` column
//! is how the reported unstable trial ended.

mod measure;
mod plan;
mod present;

pub use measure::COLUMNS;
pub use measure::OWN_COLUMNS;
pub use plan::MIN_RELATIVE_PRECISION;

use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::reference::ReferenceSettings;

/// A stability study: each run's largest stable time step, by bisection.
pub(in crate::study) struct Stability;

/// The kind's name in study files, the name of its table and the key of its resolved table.
const NAME: &str = "stability";

/// The study's `[stability]` table as resolved at load.
fn settings(file: &StudyFile) -> Option<StabilitySettings> {
    file.settings(NAME)
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
    /// The smallest step of interest (s): the judged range's floor defaults to `dt_min / 1000`.
    pub dt_min: f64,
    /// A step the scan always tries (s), the scene's own step say; the judged range reaches up
    /// to `dt_ceiling` above it, so methods stable there are still ranked.
    pub dt_max: f64,
    /// Simulated time every trial must cover (s).
    pub horizon: f64,
    /// The trials' `run.energy_limit`: a trial blows up when the energy it gained beyond the
    /// work done on the body passes this many times the energy the body holds or exchanges
    /// while growing (see `run::balance`; sustained exponential growth is a blow-up at any
    /// level). Default 1.
    #[serde(default = "default_energy_factor")]
    pub energy_factor: f64,
    /// Each change between stable and unstable is bisected until `hi/lo - 1` is below this.
    /// Default 0.01.
    #[serde(default = "default_relative_precision")]
    pub relative_precision: f64,
    /// The judged range's lower end (or `horizon / max_steps`, whichever is larger). Default
    /// `dt_min / 1000`.
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
    /// Log-spaced steps per decade of the judged range the scan tries before any bisection
    /// (both ends included). Default 6.
    #[serde(default = "default_scan_per_decade")]
    pub scan_per_decade: f64,
    /// Written by softbench before the stability maps (smaller steps probed below a limit
    /// found by bisection): read back only so results written then redraw and say how they
    /// were searched. A study file that sets it is refused.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub probes: Option<usize>,
    /// A trial that completed but kept an energy excess above this many times the energy
    /// scale over the whole last quarter of its horizon invented that energy: it is unstable
    /// (`energy-invented`). Default 0.05.
    #[serde(default = "default_invented_energy_limit")]
    pub invented_energy_limit: f64,
    /// Newton must converge within its iteration cap, or the step fails as `solver-failed`
    /// (otherwise unconverged steps are accepted and counted). Default true.
    #[serde(default = "yes")]
    pub require_newton_convergence: bool,
    /// Sample times of the error against a converged reference at the largest stable step
    /// (`error_at_stable_dt`); 0 turns the reference off. Default 10.
    #[serde(default = "default_error_samples")]
    pub error_samples: usize,
    /// Time windows `[start, end]` (s) in which the error at the largest stable step is also
    /// reported on its own (`error_phase1`...), against the reference's own difference there.
    /// Default none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub phases: Vec<[f64; 2]>,
    /// Relative precision of the search for the largest stable step within each error
    /// tolerance (`dt_error_1pct`, `dt_error_10pct`). Default 0.1.
    #[serde(default = "default_error_dt_precision")]
    pub error_dt_precision: f64,
    /// Whether trials [`ROBUSTNESS`] (relative) on each side of each end of a bracket check
    /// it (`limit_robust`); quick mode turns them off (`not-checked`). Default true.
    #[serde(default = "yes")]
    pub robustness_trials: bool,
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

fn default_scan_per_decade() -> f64 {
    6.0
}

fn default_invented_energy_limit() -> f64 {
    0.05
}

fn default_error_dt_precision() -> f64 {
    0.1
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

    /// The scan's steps, ascending: `scan_per_decade` log-spaced steps per decade over the
    /// judged range, both ends included, and `dt_max` when it lies inside.
    pub fn scan(&self) -> Vec<f64> {
        let (lowest, highest) = (self.lowest_dt(), self.highest_dt());
        if highest <= lowest {
            return vec![lowest];
        }
        let cells = ((highest / lowest).log10() * self.scan_per_decade)
            .ceil()
            .max(1.0) as usize;
        let mut steps: Vec<f64> = (0..=cells)
            .map(|i| match i {
                0 => lowest,
                i if i == cells => highest,
                i => lowest * (highest / lowest).powf(i as f64 / cells as f64),
            })
            .collect();
        if lowest < self.dt_max && self.dt_max < highest {
            steps.push(self.dt_max);
            steps.sort_by(f64::total_cmp);
            steps.dedup_by(|a, b| (*a / *b - 1.0).abs() < 1e-12);
        }
        steps
    }
}

/// The verdicts of the `stability` column.
pub const VERDICTS: [&str; 6] = [
    "limit-found",
    "stable-to-ceiling",
    "stable-only-above",
    "stable-in-bands",
    "unstable-at-every-dt",
    "no-stable-dt-in-range",
];

/// The error tolerances (relative L2 position error against the reference) at which the
/// largest stable step is reported: `dt_error_1pct` and `dt_error_10pct`.
pub const ERROR_TOLERANCES: [f64; 2] = [0.01, 0.1];

/// Per tolerance: the largest step below which every tried step meets it, what bounds it
/// (`limit` when it is the largest stable step, `error` when a larger step misses the
/// tolerance), the error there, the energy excess at the end of that trial over the energy the
/// body holds or exchanges (signed: negative = lost), and the largest tried step above it that
/// meets the tolerance again (a non-monotone error curve: that step is not claimed).
const ERROR_COLUMNS: [[&str; 5]; 2] = [
    [
        "dt_error_1pct",
        "dt_error_1pct_bound",
        "error_at_dt_error_1pct",
        "energy_excess_at_dt_error_1pct",
        "dt_error_1pct_met_again",
    ],
    [
        "dt_error_10pct",
        "dt_error_10pct_bound",
        "error_at_dt_error_10pct",
        "energy_excess_at_dt_error_10pct",
        "dt_error_10pct_met_again",
    ],
];

/// How much steeper the local exponent of the growth rate between the two smaller steps of a
/// trend may be than between the two larger (absolute, or this fraction of the fitted
/// exponent if larger) for the growth to extrapolate to every smaller step.
const EXPONENT_TOLERANCE: (f64, f64) = (0.5, 0.25);

/// Bisections at most (a precision near round-off cannot loop forever).
const MAX_BISECTIONS: usize = 64;

/// Relative distance from a bracket's ends of the trials that check it is robust.
pub const ROBUSTNESS: f64 = 1e-6;

/// How much the excess of the largest stable trial must have grown over its last half for
/// the bracket to be questioned as detection-limited (a stable method's excess stays
/// bounded; at a true limit it does not grow below it).
const GROWING_BELOW: f64 = 10.0;
