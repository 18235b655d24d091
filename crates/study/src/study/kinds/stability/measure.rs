//! The stability study kind, measuring: its columns, the work its runs share and one run's
//! measurement.

use super::{
    ERROR_COLUMNS, ERROR_TOLERANCES, EXPONENT_TOLERANCE, GROWING_BELOW, MAX_BISECTIONS, ROBUSTNESS,
    Stability, StabilitySettings, settings,
};
use crate::study::kind::{Measure, RunInputs, number};
use crate::study::vocabulary::columns;
use crate::study::vocabulary::columns::{CAPS, SUMMARY};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::format::{cell, short};
use crate::study::vocabulary::measured::{
    Measured, build, outcome_of, picture_surface, run_observed,
};
use crate::study::vocabulary::reference::{Reference, ScoringSettings};
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_core::integrate::State;
use softbench_core::model::Model;
use softbench_core::parallel::Parallelism;
use softbench_run::run::growth::MIN_FIT_R2;
use softbench_run::run::{Observer, Outcome, OutcomeKind, RunSummary, Sample};
use softbench_run::scene::RunConfig;
use std::sync::LazyLock;

/// A stability study's own columns of `runs.csv` (after the identity and parameters; the run's
/// summary and the integrator's caps follow, [`COLUMNS`]).
pub const OWN_COLUMNS: &[&str] = &[
    "stability",
    "outcome",
    "max_stable_dt",
    "first_unstable_dt",
    "largest_stable_dt",
    "stable_fraction",
    "stable_intervals",
    "scan_map",
    "scan_per_decade",
    "invented_energy_limit",
    "omega_max",
    "dt_theory",
    "stable_over_theory",
    "cost_per_simulated_second",
    "cost_per_simulated_second_q1",
    "cost_per_simulated_second_q3",
    "evaluations_per_simulated_second",
    "error_at_stable_dt",
    "error_scored",
    "reference_difference",
    "non_monotone_dt",
    "growth_exponent",
    "limit_robust",
    "dt_error_1pct",
    "dt_error_1pct_bound",
    "error_at_dt_error_1pct",
    "energy_excess_at_dt_error_1pct",
    "dt_error_1pct_met_again",
    "dt_error_10pct",
    "dt_error_10pct_bound",
    "error_at_dt_error_10pct",
    "energy_excess_at_dt_error_10pct",
    "dt_error_10pct_met_again",
    "error_dt_precision",
    "phases",
    "error_phase1",
    "reference_difference_phase1",
    "error_phase2",
    "reference_difference_phase2",
    "error_phase3",
    "reference_difference_phase3",
    "error_phase4",
    "reference_difference_phase4",
    "centroid_error",
    "bounding_box_error",
    "lowest_dt",
    "highest_dt",
    "horizon",
    "min_steps",
    "max_steps",
    "trials",
    "trials_wall_seconds",
];

/// Every measured column of a stability study's `runs.csv`: its own, the run's summary (of
/// the trial it reports) and the integrator's caps.
pub static COLUMNS: LazyLock<Vec<&'static str>> =
    LazyLock::new(|| columns::declare(OWN_COLUMNS, true, true));

impl Measure for Stability {
    fn columns(&self) -> &'static [&'static str] {
        &COLUMNS
    }

    fn progress(&self, m: &Measured) -> Option<String> {
        Some(format!(
            ", {}{}",
            m.get("stability").unwrap_or_default(),
            number(m, "max_stable_dt")
                .map(|dt| format!(" at dt {dt} s"))
                .unwrap_or_default()
        ))
    }

    /// The search starts from the explicit limit, and the reference picks its method from it.
    fn needs_omega(&self, _: &StudyFile) -> bool {
        true
    }

    fn reference_settings(&self, file: &StudyFile, _: &RunSpec) -> Option<ScoringSettings> {
        reference_settings(file)
    }

    fn reference_dt(&self, study: &Study, w: &ScoringSettings, spec: &RunSpec) -> f64 {
        reference_dt(study, w, spec)
    }

    /// It still judges stability without its reference: the errors at the largest stable
    /// steps are left empty, and the report says why.
    fn reference_optional(&self) -> bool {
        true
    }

    fn measure(
        &self,
        study: &Study,
        spec: &RunSpec,
        inputs: &RunInputs,
        parallelism: Parallelism,
    ) -> Result<Measured, String> {
        let settings = settings(&study.file).ok_or("no [stability] table")?;
        measure(spec, &settings, inputs, parallelism)
    }
}

/// Its reference solutions: its error samples over its horizon, if it has any.
fn reference_settings(file: &StudyFile) -> Option<ScoringSettings> {
    let s = settings(file)?;
    (s.error_samples > 0).then(|| ScoringSettings {
        phases: s.phases.clone(),
        horizon: s.horizon,
        samples: s.error_samples,
        require_newton_convergence: true,
        reference: s.reference.clone(),
        repeats: 1,
    })
}

/// The reference step: as set, or `horizon / 4000` (in quick mode never finer than
/// `horizon / 400`); rounded down to divide the sample interval.
fn reference_dt(study: &Study, w: &ScoringSettings, _: &RunSpec) -> f64 {
    let target = w.reference.dt.unwrap_or(w.horizon / 4000.0);
    // Quick mode: a reference no finer than horizon / 400 (it is a smoke test).
    let target = if study.quick {
        target.max(w.horizon / 400.0)
    } else {
        target
    };
    let interval = w.horizon / w.samples as f64;
    interval / (interval / target).ceil().max(1.0)
}

/// The largest stable step within an error tolerance.
#[derive(Clone, Copy, Debug)]
struct Within {
    dt: f64,
    bound: &'static str,
    error: f64,
    excess: f64,
    /// The largest tried step above `dt` that meets the tolerance again.
    met_again: Option<f64>,
}

/// The smallest ratio of consecutive steps in a growth trend (closer steps, a bisection's
/// two ends say, make a local exponent noise).
const SPACING: f64 = 1.04;

/// The smallest ratio between the first and last of a trend's three steps.
const SPAN: f64 = 1.1;

/// How the energy's growth rate changes with dt over the three smallest trials that grew
/// exponentially (at least [`SPACING`] apart, spanning [`SPAN`]), when every trial blew up
/// or grew: `rate ∝ dt^exponent`. Explicit Euler's top mode grows at `omega² dt`
/// (exponent 1) and explicit midpoint's at `omega⁴ dt³ / 4` (exponent 3) below the explicit
/// limit; a method whose limit lies below the range grows ever more slowly as dt approaches
/// it (the local exponent steepens), and above `2/omega_max` every explicit method may blow
/// up, so no claim about every dt is made from trials there.
#[derive(Clone, Copy, Debug)]
struct GrowthTrend {
    /// Least-squares slope of `ln rate` against `ln dt`.
    exponent: f64,
    /// The slopes between the first and second, and second and third smallest trials.
    local: (f64, f64),
    smallest_dt: f64,
    /// The largest of the three steps over `2/omega_max`, when omega_max is known.
    over_theory: Option<f64>,
}

impl GrowthTrend {
    /// The trend of the three smallest trials whose growth the horizon resolves (see
    /// [`RESOLVED_GROWTH`]), if each has a positive growth rate.
    fn of<'a>(
        trials: impl Iterator<Item = &'a Trial>,
        omega: Option<f64>,
        horizon: f64,
    ) -> Option<Self> {
        let resolved = RESOLVED_GROWTH / (0.5 * horizon);
        let mut points: Vec<(f64, f64)> = trials
            .map(|t| Some((t.dt, t.summary.energy_growth?.rate)))
            .collect::<Option<Vec<_>>>()?
            .into_iter()
            .filter(|&(_, rate)| rate >= resolved)
            .collect();
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        // The smallest step, the next at least SPACING above it, and the next at least
        // SPACING above that and SPAN above the first.
        let mut spaced: Vec<(f64, f64)> = Vec::with_capacity(3);
        for p in points {
            let far_enough = match spaced.as_slice() {
                [] => true,
                [first] => p.0 >= SPACING * first.0,
                [first, second] => p.0 >= (SPACING * second.0).max(SPAN * first.0),
                _ => false,
            };
            if far_enough {
                spaced.push(p);
            }
        }
        let points = spaced;
        if points.len() < 3 || points.iter().any(|p| p.1 <= 0.0 || p.1.is_nan()) {
            return None;
        }
        let logs: Vec<(f64, f64)> = points.iter().map(|(d, r)| (d.ln(), r.ln())).collect();
        let slope = |a: (f64, f64), b: (f64, f64)| (b.1 - a.1) / (b.0 - a.0);
        let mean = |f: fn(&(f64, f64)) -> f64| logs.iter().map(f).sum::<f64>() / 3.0;
        let (mx, my) = (mean(|p| p.0), mean(|p| p.1));
        let sxx: f64 = logs.iter().map(|p| (p.0 - mx).powi(2)).sum();
        let sxy: f64 = logs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        Some(Self {
            exponent: sxy / sxx,
            local: (slope(logs[0], logs[1]), slope(logs[1], logs[2])),
            smallest_dt: points[0].0,
            over_theory: omega.map(|w| points[2].0 * w / 2.0),
        })
    }

    /// Whether the trials show a blow-up at every dt: a rate that shrinks as a positive
    /// power of dt, no steeper at the smaller steps than at the larger (a rate that steepens
    /// towards small steps is heading for a limit where it vanishes; one that keeps its power,
    /// or flattens as higher-order terms fade, extrapolates to every smaller step), at steps
    /// below the explicit limit.
    fn every_dt(&self) -> bool {
        let (abs, rel) = EXPONENT_TOLERANCE;
        self.exponent > 0.0
            && self.local.0 > 0.0
            && self.local.1 > 0.0
            && self.local.0 - self.local.1 <= abs.max(rel * self.exponent)
            && self.over_theory.is_none_or(|b| b <= 1.0)
    }
}

/// The e-folds over the last half of the horizon (`rate × horizon / 2`) from which a trial's
/// fitted growth rate enters a trend: twice the sustained-growth threshold (ln 1e3), so the
/// rate is at least twice the slowest growth the horizon can call a blow-up. A rate near that
/// limit is biased by how the excess started (explicit midpoint's top mode, growing at
/// `ω⁴dt³/8`, read a local exponent of 4.0 just above detection and 2.8 once resolved), and
/// where the excess grows by a factor of ~2 its fit is the slope of a drift, not a rate (the
/// same method read 4.3/s at every small step, an exponent of 0.04). A trial that blew up
/// early has a large rate and counts. A longer horizon resolves smaller steps.
const RESOLVED_GROWTH: f64 = 2.0 * 6.907_755_278_982_137;

/// Rows kept per trial in the series (the balance itself is checked at every step).
const ROWS_PER_TRIAL: usize = 200;

/// One trial at one dt.
struct Trial {
    dt: f64,
    /// Simulated time covered (s).
    covered: f64,
    summary: RunSummary,
    rows: Vec<Sample>,
    /// Positions at the reference's sample times (dense output), as far as the trial got.
    positions: Vec<Vec<f64>>,
    /// The surface at the recorder's times over the trial's steps (its last valid state if it
    /// failed), for the study's pictures; `None` for a body without tets.
    snapshots: Option<softbench_run::render::Snapshots>,
    /// Run to check an end of the stable set (a hair from it), not part of the map.
    check: bool,
}

impl Trial {
    fn stable(&self) -> bool {
        self.summary.outcome.is_completed()
    }
}

/// Keeps the sampled rows and the positions at given times, interpolated between steps by
/// the cubic Hermite polynomial of the two states around each time (positions and
/// velocities), so a trial at any dt can be compared with a reference at fixed times.
pub(in crate::study) struct DenseOutput {
    times: Vec<f64>,
    previous: State,
    rows: Vec<Sample>,
    positions: Vec<Vec<f64>>,
}

impl DenseOutput {
    pub(in crate::study) fn new(times: Vec<f64>) -> Self {
        Self {
            times,
            previous: State::default(),
            rows: Vec::new(),
            positions: Vec::new(),
        }
    }

    fn hermite(a: &State, b: &State, t: f64) -> Vec<f64> {
        let h = b.t - a.t;
        if h <= 0.0 {
            return b.q.clone();
        }
        let s = ((t - a.t) / h).clamp(0.0, 1.0);
        let (s2, s3) = (s * s, s * s * s);
        let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
        let h10 = s3 - 2.0 * s2 + s;
        let h01 = -2.0 * s3 + 3.0 * s2;
        let h11 = s3 - s2;
        (0..a.q.len())
            .map(|i| h00 * a.q[i] + h10 * h * a.v[i] + h01 * b.q[i] + h11 * h * b.v[i])
            .collect()
    }
}

impl Observer for DenseOutput {
    fn sample(&mut self, sample: &Sample) -> std::io::Result<()> {
        self.rows.push(sample.clone());
        Ok(())
    }

    fn after_step(&mut self, step: usize, _: &Model, state: &State) -> std::io::Result<()> {
        if step > 0 {
            while let Some(&t) = self.times.get(self.positions.len()) {
                // A sample time within round-off of this step's time counts as reached.
                let h = (state.t - self.previous.t).abs();
                if t > state.t + 1e-9 * h {
                    break;
                }
                self.positions.push(Self::hermite(&self.previous, state, t));
            }
        }
        if !self.times.is_empty() {
            self.previous.clone_from(state);
        }
        Ok(())
    }
}

/// Find the largest stable dt of one run, and its cost and error there.
pub(in crate::study) fn measure(
    spec: &RunSpec,
    settings: &StabilitySettings,
    shared: &RunInputs,
    parallelism: Parallelism,
) -> Result<Measured, String> {
    let mut scene = build(spec, parallelism).map_err(|e| e.to_string())?;
    let sample_times = shared
        .reference
        .map_or_else(Vec::new, |r| r.times().to_vec());
    let surface = picture_surface(&scene, spec)?;
    let search = Search {
        run: |dt: f64| {
            run_trial(
                &mut scene,
                surface.clone(),
                &sample_times,
                settings,
                shared,
                dt,
            )
        },
        trials: Vec::new(),
        precision: settings.relative_precision,
    };
    let found = Found::search(search, settings, shared);
    Ok(found.measured(spec, settings, shared))
}

/// One trial of the search: the scene run at `dt` over the horizon (at most
/// `stability.max_steps` steps), its state at the reference's sample times kept.
fn run_trial(
    scene: &mut softbench_run::scene::Scene,
    surface: Option<softbench_run::render::Surface>,
    sample_times: &[f64],
    settings: &StabilitySettings,
    shared: &RunInputs,
    dt: f64,
) -> Trial {
    let needed = (settings.horizon / dt * (1.0 - 1e-12)).ceil().max(1.0);
    let steps = (needed as usize).min(settings.max_steps);
    let run = RunConfig {
        dt,
        steps,
        sample_every: steps.div_ceil(ROWS_PER_TRIAL).max(1),
        energy_limit: settings.energy_factor,
        // A stability trial is judged whole: a cost budget would decide it.
        budget: None,
    };
    let mut output = DenseOutput::new(sample_times.to_vec());
    // Every trial records its pictures (a copy of the surface per step), so the reported
    // trial's need no second run.
    let (mut summary, state, snapshots) =
        run_observed(scene, &run, surface, &mut output, shared.meter);
    if summary.outcome.is_completed()
        && let Some(kept) = invented_energy(&summary, &output.rows, state.t)
        && kept > settings.invented_energy_limit
    {
        summary.outcome = Outcome::ended(
            OutcomeKind::Unstable,
            summary.steps_completed,
            state.t,
            INVENTED,
            format!(
                "the energy gained beyond the work done stayed above {} x the energy the body \
                 holds or exchanges over the last quarter of the horizon (at least {} x; \
                 stability.invented_energy_limit = {}): energy invented and kept",
                short(settings.invented_energy_limit),
                short(kept),
                short(settings.invented_energy_limit)
            ),
        );
    }
    if summary.outcome.is_completed() && (needed as usize) > steps {
        summary.outcome = Outcome::ended(
            OutcomeKind::HorizonNotReached,
            steps,
            state.t,
            "step cap",
            format!(
                "stability.max_steps = {} steps of {dt:e} s cover {:e} s of the {:e} s horizon",
                settings.max_steps, state.t, settings.horizon
            ),
        );
    }
    Trial {
        dt,
        covered: state.t,
        summary,
        rows: output.rows,
        positions: output.positions,
        snapshots,
        check: false,
    }
}

/// The outcome cause of a trial that completed but kept invented energy.
const INVENTED: &str = "energy invented";

/// A completed trial whose energy excess stayed above `limit` times the energy scale over the
/// whole last quarter of the horizon invented that energy and kept it: unstable, even if the
/// excess stopped growing (a bounded spurious oscillation). Returns the smallest excess over
/// that quarter, relative to the scale.
fn invented_energy(summary: &RunSummary, rows: &[Sample], covered: f64) -> Option<f64> {
    let scale = summary.energy_scale.total().max(f64::MIN_POSITIVE);
    rows.iter()
        .filter(|r| r.t >= 0.75 * covered)
        .map(|r| r.energy_excess / scale)
        .min_by(f64::total_cmp)
}

/// Whether every trial blew up.
fn every_unstable(trials: &[Trial]) -> bool {
    trials
        .iter()
        .all(|t| t.summary.outcome.status == OutcomeKind::Unstable)
}

/// The stable set over the judged range: maximal runs of stable trials among the tried steps
/// (robustness checks apart), as intervals of their end steps, ascending.
#[derive(Clone, Debug, Default, PartialEq)]
struct StableSet {
    intervals: Vec<(f64, f64)>,
    lowest: f64,
    highest: f64,
}

impl StableSet {
    /// The stable set of the trials of the map (robustness checks apart).
    fn of(trials: &[Trial], lowest: f64, highest: f64) -> Self {
        let points = trials
            .iter()
            .filter(|t| !t.check)
            .map(|t| (t.dt, t.stable()));
        Self::from_points(points, lowest, highest)
    }

    /// The stable set of `(dt, stable)` points, in any order.
    fn from_points(points: impl Iterator<Item = (f64, bool)>, lowest: f64, highest: f64) -> Self {
        let mut points: Vec<(f64, bool)> = points.collect();
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        let mut intervals: Vec<(f64, f64)> = Vec::new();
        let mut open = false;
        for (dt, stable) in points {
            match (stable, open) {
                (true, true) => intervals.last_mut().expect("open interval").1 = dt,
                (true, false) => intervals.push((dt, dt)),
                (false, _) => {}
            }
            open = stable;
        }
        Self {
            intervals,
            lowest,
            highest,
        }
    }

    fn starts_at_lowest(&self) -> bool {
        self.intervals.first().is_some_and(|i| i.0 <= self.lowest)
    }

    fn reaches_ceiling(&self) -> bool {
        self.intervals.last().is_some_and(|i| i.1 >= self.highest)
    }

    /// The largest step below which every tried step is stable.
    fn max_stable(&self) -> Option<f64> {
        self.starts_at_lowest().then(|| self.intervals[0].1)
    }

    /// The largest stable step tried.
    fn largest(&self) -> Option<f64> {
        self.intervals.last().map(|i| i.1)
    }

    /// The stable share of the judged range, in log dt.
    fn fraction(&self) -> f64 {
        let range = (self.highest / self.lowest).ln();
        if range <= 0.0 {
            return if self.intervals.is_empty() { 0.0 } else { 1.0 };
        }
        self.intervals.iter().map(|i| (i.1 / i.0).ln()).sum::<f64>() / range
    }

    /// What the map shows, when anything is stable.
    fn class(&self) -> Option<&'static str> {
        match (
            self.intervals.len(),
            self.starts_at_lowest(),
            self.reaches_ceiling(),
        ) {
            (0, ..) => None,
            (1, true, true) => Some("stable-to-ceiling"),
            (1, true, false) => Some("limit-found"),
            (1, false, true) => Some("stable-only-above"),
            _ => Some("stable-in-bands"),
        }
    }

    /// `[lo, hi]` per interval, for the `stable_intervals` column.
    fn text(&self) -> String {
        self.intervals
            .iter()
            .map(|(lo, hi)| format!("[{}, {}]", short(*lo), short(*hi)))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// What the search found: the stable set, what checks it, and every trial run.
struct Found {
    set: StableSet,
    /// The largest step below which every tried step is stable, and the smallest unstable
    /// step above it (`None`: stable to the ceiling); `None` when the lowest step is unstable.
    bracket: Option<(f64, Option<f64>)>,
    /// The largest unstable step tried below the largest stable one (the map is not one
    /// interval from the lowest step).
    non_monotone: Option<f64>,
    /// The trials a hair from the intervals' ends that disagree with them.
    not_robust: Vec<f64>,
    /// How the growth rate follows dt, where nothing (or only a slowly growing step) was
    /// stable.
    trend: Option<GrowthTrend>,
    /// The largest step that completed though its energy still grew, and by how much, when
    /// the growth above it follows one power of dt (the limit is then the horizon's).
    growing_below: Option<(f64, f64)>,
    /// The largest step below which every tried step is within each error tolerance.
    within: Vec<Option<Within>>,
    /// The scanned steps, ascending.
    scan: Vec<f64>,
    trials: Vec<Trial>,
}

impl Found {
    /// Scan the range, bisect every change, check the ends, then the error steps.
    fn search<F: FnMut(f64) -> Trial>(
        mut search: Search<F>,
        settings: &StabilitySettings,
        shared: &RunInputs,
    ) -> Self {
        let (lowest, highest) = (settings.lowest_dt(), settings.highest_dt());
        let scan = settings.scan();
        for &dt in &scan {
            search.stable(dt);
        }
        for pair in scan.windows(2) {
            if search.stable(pair[0]) != search.stable(pair[1]) {
                search.bisect(pair[0], pair[1]);
            }
        }
        let mut set = StableSet::of(&search.trials, lowest, highest);
        let not_robust = robustness(&mut search, &set, settings);
        let mut trend = None;
        if set.intervals.is_empty() && every_unstable(&search.trials) {
            trend = GrowthTrend::of(
                search.trials.iter().filter(|t| !t.check),
                shared.omega,
                settings.horizon,
            );
        }
        let bracket = set
            .max_stable()
            .map(|lo| (lo, first_above(&search.trials, lo)));
        let growing_below = growing_below(&mut search, &set, bracket, settings, shared);
        if let Some(((lo, _), t)) = growing_below {
            // Then the steps up to `lo` are not stable: they only did not show it within the
            // horizon.
            trend = Some(t);
            set.intervals.retain(|i| i.0 > lo);
        }
        let bracket = if growing_below.is_some() {
            None
        } else {
            bracket
        };
        let within = match shared.reference {
            Some(reference) if !set.intervals.is_empty() => ERROR_TOLERANCES
                .iter()
                .map(|&tolerance| {
                    search.largest_within(tolerance, settings.error_dt_precision, reference)
                })
                .collect(),
            _ => Vec::new(),
        };
        let largest = set.largest();
        let non_monotone = largest.and_then(|top| {
            search
                .trials
                .iter()
                .filter(|t| !t.check && !t.stable() && t.dt < top)
                .map(|t| t.dt)
                .max_by(f64::total_cmp)
        });
        Self {
            set,
            bracket,
            non_monotone,
            not_robust,
            trend,
            growing_below: growing_below.map(|(g, _)| g),
            within,
            scan,
            trials: search.trials,
        }
    }

    /// The run's verdict.
    fn verdict(&self) -> &'static str {
        match self.set.class() {
            Some(class) => class,
            None if (every_unstable(&self.trials) || self.growing_below.is_some())
                && self.trend.is_some_and(|t| t.every_dt()) =>
            {
                "unstable-at-every-dt"
            }
            None => "no-stable-dt-in-range",
        }
    }

    /// The trial at the largest stable step, and the unstable trial the row reports: the
    /// first above the largest stable step (a limit), or the largest below the stable set
    /// (unstable at small steps), or with nothing stable the smallest step tried, which
    /// decides "nothing was stable".
    fn reported(&self) -> (Option<&Trial>, Option<&Trial>) {
        let tried = || self.trials.iter().filter(|t| !t.check);
        let best = self
            .set
            .largest()
            .and_then(|dt| tried().find(|t| t.dt == dt && t.stable()));
        let first_unstable = match (self.bracket, self.set.intervals.first()) {
            (Some((_, Some(hi))), _) => tried().find(|t| t.dt == hi),
            (Some((_, None)), _) => None,
            (None, Some(&(lo, _))) => tried()
                .filter(|t| !t.stable() && t.dt < lo)
                .max_by(|a, b| a.dt.total_cmp(&b.dt)),
            (None, None) => tried()
                .filter(|t| !t.stable())
                .min_by(|a, b| a.dt.total_cmp(&b.dt)),
        };
        (best, first_unstable)
    }

    /// The run's row, series, trials table and pictures.
    fn measured(
        self,
        spec: &RunSpec,
        settings: &StabilitySettings,
        shared: &RunInputs,
    ) -> Measured {
        let verdict = self.verdict();
        let (best, first_unstable) = self.reported();
        let mut m = Measured::default();
        match first_unstable {
            Some(t) => {
                let (outcome, message) = outcome_of(&t.summary.outcome);
                m.outcome = outcome;
                m.message = format!("at dt = {}: {message}", short(t.dt));
            }
            None => m.outcome = OutcomeKind::Completed.name().to_owned(),
        }
        if let Some(best) = best {
            set_best_cells(&mut m, best, shared);
            m.series = best.rows.clone();
        } else if let Some(t) = first_unstable {
            m.series = t.rows.clone();
        }
        // The pictures of the reported trial: the largest stable step, or, with nothing
        // stable, the smallest failing one, which shows how the method breaks.
        let pictured = best.or(first_unstable).map(|t| t.dt);
        m.cells.extend(CAPS.cells(spec));
        self.set_search_cells(&mut m, verdict, first_unstable, settings);
        self.explain(&mut m, verdict, settings);
        set_settings_cells(&mut m, settings, shared, self.bracket);
        m.set("trials", self.trials.len().to_string());
        let total: f64 = self
            .trials
            .iter()
            .map(|t| t.summary.totals.times.total)
            .sum();
        m.set("trials_wall_seconds", cell(Some(total)));
        m.tables = vec![("trials", trial_table(&self.trials, shared.reference))];
        m.snapshots = pictured.and_then(|dt| {
            let mut trials = self.trials;
            let t = trials.iter_mut().find(|t| t.dt == dt && !t.check)?;
            t.snapshots.take()
        });
        m
    }

    /// The scan as one character per scanned step, ascending: `#` stable, `^` completed
    /// but growing on the trend that blows up at every step (slower than the horizon shows),
    /// `~` energy invented and kept, `x` blew up, `!` any other failure.
    fn scan_map(&self) -> String {
        let growing_to = self.growing_below.map_or(0.0, |(lo, _)| lo);
        self.scan
            .iter()
            .map(|&dt| {
                let t = self.trials.iter().find(|t| t.dt == dt && !t.check);
                match t {
                    Some(t) if t.stable() && t.dt <= growing_to => '^',
                    Some(t) if t.stable() => '#',
                    Some(t) if t.summary.outcome.cause == INVENTED => '~',
                    Some(t) if t.summary.outcome.status == OutcomeKind::Unstable => 'x',
                    _ => '!',
                }
            })
            .collect()
    }

    /// The verdict, the stable set, its checks and the steps within each error tolerance.
    fn set_search_cells(
        &self,
        m: &mut Measured,
        verdict: &str,
        first_unstable: Option<&Trial>,
        settings: &StabilitySettings,
    ) {
        let bracket = self.bracket;
        m.set("stability", verdict.to_owned());
        m.set("max_stable_dt", cell(bracket.map(|(lo, _)| lo)));
        m.set("first_unstable_dt", cell(bracket.and_then(|(_, hi)| hi)));
        m.set("largest_stable_dt", cell(self.set.largest()));
        m.set("stable_fraction", cell(Some(self.set.fraction())));
        m.set("stable_intervals", self.set.text());
        m.set("scan_map", self.scan_map());
        m.set("scan_per_decade", cell(Some(settings.scan_per_decade)));
        m.set(
            "invented_energy_limit",
            cell(Some(settings.invented_energy_limit)),
        );
        m.set("non_monotone_dt", cell(self.non_monotone));
        m.set(
            "energy_growth_rate",
            cell(first_unstable.and_then(|t| t.summary.energy_growth.map(|g| g.rate))),
        );
        m.set("growth_exponent", cell(self.trend.map(|t| t.exponent)));
        for (k, name) in ERROR_COLUMNS.iter().enumerate() {
            let found = self.within.get(k).copied().flatten();
            m.set(name[0], cell(found.map(|w: Within| w.dt)));
            m.set(name[1], found.map_or(String::new(), |w| w.bound.into()));
            m.set(name[2], cell(found.map(|w| w.error)));
            m.set(name[3], cell(found.map(|w| w.excess)));
            m.set(name[4], cell(found.and_then(|w| w.met_again)));
        }
        m.set(
            "error_dt_precision",
            cell(Some(settings.error_dt_precision)),
        );
        m.set(
            "limit_robust",
            match self.set.intervals.is_empty() {
                true => String::new(),
                false if !settings.robustness_trials => "not-checked".into(),
                false if self.not_robust.is_empty() => "yes".into(),
                false => "no".into(),
            },
        );
    }

    /// The run's message: why nothing was stable, or what is wrong with the stable set.
    fn explain(&self, m: &mut Measured, verdict: &str, settings: &StabilitySettings) {
        let range = format!(
            "[{}, {}] s",
            short(settings.lowest_dt()),
            short(settings.highest_dt())
        );
        if self.set.intervals.is_empty() {
            let why = self.why_unstable(verdict);
            m.message = format!("{verdict} in {range}: {why}; {}", m.message);
        } else if verdict == "stable-only-above" || verdict == "stable-in-bands" {
            m.message = format!(
                "{verdict}: stable in {} of {range}; {}",
                self.set.text(),
                m.message
            );
        } else if !self.not_robust.is_empty() {
            m.message = format!(
                "the stable set is not robust: trials at {} (within {ROBUSTNESS:e} of its ends) \
                 disagree with them",
                self.not_robust
                    .iter()
                    .map(|d| format!("{d:e}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }

    /// Why no step was found stable, from the growth trend.
    fn why_unstable(&self, verdict: &str) -> String {
        match (verdict, self.trend) {
            ("unstable-at-every-dt", Some(t)) => format!(
                "{}, and the energy's growth rate shrinks like dt^{:.2} as dt shrinks (fitted \
                 from {} s{})",
                match self.growing_below {
                    Some((lo, factor)) => format!(
                        "trials up to {} s completed, but their energy still grew (x{} over \
                         the last half of the largest), only too slowly to be sustained \
                         growth within the horizon",
                        short(lo),
                        short(factor)
                    ),
                    None => "every trial blew up".to_owned(),
                },
                t.exponent,
                short(t.smallest_dt),
                t.over_theory
                    .map(|b| format!(", up to {b:.2} x 2/omega_max"))
                    .unwrap_or_default()
            ),
            (_, Some(t)) => format!(
                "no trial was stable, but that is not shown to hold at every dt: the growth rate \
                 of the three smallest trials does not follow one power of dt (local exponents \
                 {:.2} and {:.2}){}, so a limit may lie below the range",
                t.local.0,
                t.local.1,
                t.over_theory
                    .filter(|b| *b > 1.0)
                    .map(|b| format!(
                        " or they all lie above the explicit limit ({b:.2} x 2/omega_max)"
                    ))
                    .unwrap_or_default()
            ),
            _ => "no trial was stable".into(),
        }
    }
}

/// Of `(dt, meets)` points ascending, the largest `dt` at or below which every point meets,
/// and the next point above it (which misses); `(None, _)` when the smallest misses.
fn holds_below(points: &[(f64, bool)]) -> (Option<f64>, Option<f64>) {
    let mut lo = None;
    for &(dt, meets) in points {
        if !meets {
            return (lo, Some(dt));
        }
        lo = Some(dt);
    }
    (lo, None)
}

/// The smallest unstable step tried above `dt` (robustness checks apart).
fn first_above(trials: &[Trial], dt: f64) -> Option<f64> {
    trials
        .iter()
        .filter(|t| !t.check && !t.stable() && t.dt > dt)
        .map(|t| t.dt)
        .min_by(f64::total_cmp)
}

/// The largest unstable step tried below `dt` (robustness checks apart).
fn last_below(trials: &[Trial], dt: f64) -> Option<f64> {
    trials
        .iter()
        .filter(|t| !t.check && !t.stable() && t.dt < dt)
        .map(|t| t.dt)
        .max_by(f64::total_cmp)
}

/// The stable set is robust when trials a hair from each end of each bracket inside the range
/// agree with it: just inside the interval's end (stable) and just beyond the unstable step
/// that brackets it (unstable). (The change itself lies somewhere in the bracket, so a trial a
/// hair outside the stable end proves nothing.) The trials that disagree.
fn robustness<F: FnMut(f64) -> Trial>(
    search: &mut Search<F>,
    set: &StableSet,
    settings: &StabilitySettings,
) -> Vec<f64> {
    let mut not_robust = Vec::new();
    if !settings.robustness_trials {
        return not_robust;
    }
    let range = set.lowest..=set.highest;
    for &(lo, hi) in &set.intervals {
        for (end, outward) in [(lo, -1.0), (hi, 1.0)] {
            if end <= set.lowest || end >= set.highest {
                continue;
            }
            let beyond = if outward > 0.0 {
                first_above(&search.trials, end)
            } else {
                last_below(&search.trials, end)
            };
            let mut checks = vec![(end * (1.0 - outward * ROBUSTNESS), true)];
            if let Some(b) = beyond {
                checks.push((b * (1.0 + outward * ROBUSTNESS), false));
            }
            for (dt, stable) in checks {
                if range.contains(&dt) && search.check(dt) != stable {
                    not_robust.push(dt);
                }
            }
        }
    }
    not_robust
}

/// A stable interval from the lowest step whose every trial gained energy exponentially
/// (a positive fitted rate with R^2 >= [`MIN_FIT_R2`]), its largest by more than
/// [`GROWING_BELOW`] x over its last half, is where growth became detectable within the
/// horizon, not where it starts: if the growth rates from the smallest step up (the interval's
/// and the unstable trials' above it) follow one positive power of dt below 2/omega_max
/// (explicit midpoint's dt^3, BDF3's on an undamped body), the method blows up at every dt
/// and the interval is the horizon's, not the method's. Returns the interval's top step and
/// its growth factor, with the trend.
fn growing_below<F: FnMut(f64) -> Trial>(
    search: &mut Search<F>,
    set: &StableSet,
    bracket: Option<(f64, Option<f64>)>,
    settings: &StabilitySettings,
    shared: &RunInputs,
) -> Option<((f64, f64), GrowthTrend)> {
    let (lo, Some(hi)) = bracket? else {
        return None;
    };
    let growing = |t: &Trial| {
        t.summary
            .energy_growth
            .is_some_and(|g| g.rate > 0.0 && g.r2 >= MIN_FIT_R2)
    };
    let interval = |t: &&Trial| !t.check && t.stable() && t.dt <= lo;
    if !search.trials.iter().filter(interval).all(growing) {
        return None;
    }
    let top = search
        .trials
        .iter()
        .find(|t| t.dt == lo && !t.check)
        .and_then(|t| t.summary.energy_growth)
        .filter(|g| g.rate > 0.0 && g.factor >= GROWING_BELOW)?;
    // Enough unstable trials above for a trend when the interval is one or two steps.
    for k in [1.5, 2.25] {
        if hi * k <= settings.highest_dt() && set.intervals.len() == 1 {
            search.stable(hi * k);
        }
    }
    let trend = search.trials.iter().filter(|t| {
        !t.check
            && (interval(t) || (t.dt >= hi && t.summary.outcome.status == OutcomeKind::Unstable))
    });
    let t = GrowthTrend::of(trend, shared.omega, settings.horizon)?;
    t.every_dt().then_some(((lo, top.factor), t))
}

/// The cost and error of the largest stable trial: its summary, its steady cost per simulated
/// second (the median step, its quartiles as the spread, the first step's setup apart) and
/// its error against the reference.
fn set_best_cells(m: &mut Measured, best: &Trial, shared: &RunInputs) {
    m.cells = SUMMARY.cells(&best.summary);
    let simulated = best.covered.max(f64::MIN_POSITIVE);
    let s = &best.summary;
    let totals = &s.totals;
    let per_second = s.steps_completed as f64 / simulated;
    m.set(
        "cost_per_simulated_second",
        cell(Some(s.step_seconds_median * per_second)),
    );
    m.set(
        "cost_per_simulated_second_q1",
        cell(Some(s.step_seconds_q1 * per_second)),
    );
    m.set(
        "cost_per_simulated_second_q3",
        cell(Some(s.step_seconds_q3 * per_second)),
    );
    let evaluations = totals.evaluations.gradient + totals.evaluations.hessian;
    m.set(
        "evaluations_per_simulated_second",
        cell(Some(evaluations as f64 / simulated)),
    );
    if let Some(reference) = shared.reference {
        m.set("reference_difference", cell(Some(reference.difference)));
        crate::study::vocabulary::reference::set_phase_cells(m, reference, &best.positions);
        if let Some(error) = reference.relative_l2_error(&best.positions) {
            let scored = error > reference.floor();
            m.set("error_at_stable_dt", cell(Some(error)));
            m.set("error_scored", if scored { "yes" } else { "no" }.into());
        }
    }
}

/// The search's settings and the explicit limit it is judged against.
fn set_settings_cells(
    m: &mut Measured,
    settings: &StabilitySettings,
    shared: &RunInputs,
    bracket: Option<(f64, Option<f64>)>,
) {
    m.set("lowest_dt", cell(Some(settings.lowest_dt())));
    m.set("highest_dt", cell(Some(settings.highest_dt())));
    m.set("horizon", cell(Some(settings.horizon)));
    m.set("min_steps", settings.min_steps.to_string());
    m.set("max_steps", settings.max_steps.to_string());
    m.set("energy_limit", cell(Some(settings.energy_factor)));
    let omega = shared.omega;
    m.set("omega_max", cell(omega));
    let theory = omega.map(|w| 2.0 / w);
    m.set("dt_theory", cell(theory));
    m.set(
        "stable_over_theory",
        cell(bracket.zip(theory).map(|((lo, _), th)| lo / th)),
    );
}

/// The search over dt: runs trials (each dt once) and keeps them.
struct Search<F: FnMut(f64) -> Trial> {
    run: F,
    trials: Vec<Trial>,
    precision: f64,
}

impl<F: FnMut(f64) -> Trial> Search<F> {
    /// Whether the trial at `dt` is stable (run now, or recalled).
    fn stable(&mut self, dt: f64) -> bool {
        self.tried(dt, false)
    }

    /// Whether the trial at `dt` is stable, run as a robustness check (not part of the map).
    fn check(&mut self, dt: f64) -> bool {
        self.tried(dt, true)
    }

    fn tried(&mut self, dt: f64, check: bool) -> bool {
        if let Some(t) = self.trials.iter().find(|t| t.dt == dt) {
            return t.stable();
        }
        let mut trial = (self.run)(dt);
        trial.check = check;
        let stable = trial.stable();
        self.trials.push(trial);
        stable
    }

    /// Bisect in log dt between two steps whose trials differ (either may be the stable
    /// one) until they are `precision` apart.
    fn bisect(&mut self, mut lo: f64, mut hi: f64) {
        let low_stable = self.stable(lo);
        for _ in 0..MAX_BISECTIONS {
            if hi / lo - 1.0 <= self.precision {
                break;
            }
            let mid = (lo * hi).sqrt();
            if self.stable(mid) == low_stable {
                lo = mid;
            } else {
                hi = mid;
            }
        }
    }

    /// The error of the trial at `dt` against `reference` (run now, or recalled); `None` when
    /// it is not stable or did not reach every sample time.
    fn error(&mut self, dt: f64, reference: &Reference) -> Option<f64> {
        if !self.stable(dt) {
            return None;
        }
        let trial = self.trials.iter().find(|t| t.dt == dt)?;
        reference.relative_l2_error(&trial.positions)
    }

    /// The largest step below which every tried step (robustness checks apart, and stable
    /// trials the step cap stopped short of the horizon, which have no error) is stable
    /// with an error of at most `tolerance`: the largest such tried step, then bisected in log
    /// dt (to `precision`) towards the next tried step above it, which misses. A tried step
    /// above the answer that meets the tolerance again is reported, not claimed. `None` when
    /// the smallest step misses it, or the tolerance is below the reference's own accuracy
    /// (errors there are not scored).
    fn largest_within(
        &mut self,
        tolerance: f64,
        precision: f64,
        reference: &Reference,
    ) -> Option<Within> {
        if tolerance <= reference.floor() {
            return None;
        }
        let meets = |s: &mut Self, dt: f64| s.error(dt, reference).is_some_and(|e| e <= tolerance);
        let tried = |s: &Self| {
            let mut dts: Vec<f64> = s.trials.iter().filter(|t| !t.check).map(|t| t.dt).collect();
            dts.sort_by(f64::total_cmp);
            dts
        };
        // A stable trial that the step cap stopped before the last sample time has no error:
        // it is not a tested step either way.
        let points: Vec<(f64, bool)> = tried(self)
            .into_iter()
            .filter_map(|dt| match self.error(dt, reference) {
                Some(e) => Some((dt, e <= tolerance)),
                None if self.stable(dt) => None,
                None => Some((dt, false)),
            })
            .collect();
        let (lo, hi) = holds_below(&points);
        let mut lo = lo?;
        if let Some(mut hi) = hi {
            for _ in 0..MAX_BISECTIONS {
                if hi / lo - 1.0 <= precision {
                    break;
                }
                let mid = (lo * hi).sqrt();
                if meets(self, mid) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
        }
        let met_again = tried(self)
            .into_iter()
            .filter(|&dt| dt > lo)
            .filter(|&dt| meets(self, dt))
            .max_by(f64::total_cmp);
        let trial = self.trials.iter().find(|t| t.dt == lo)?;
        let scale = trial.summary.energy_scale.total();
        let excess = trial
            .rows
            .last()
            .map_or(0.0, |r| r.energy_excess / scale.max(f64::MIN_POSITIVE));
        let limit = StableSet::of(&self.trials, f64::MIN_POSITIVE, f64::MAX)
            .intervals
            .first()
            .map(|i| i.1);
        Some(Within {
            dt: lo,
            bound: if Some(lo) == limit { "limit" } else { "error" },
            error: self.error(lo, reference)?,
            excess,
            met_again,
        })
    }
}

/// `series/<id>-trials.csv`: every trial with its outcome.
fn trial_table(trials: &[Trial], reference: Option<&Reference>) -> Table {
    let header = [
        "dt",
        "steps",
        "covered",
        "stable",
        "outcome",
        "energy_excess_peak",
        "energy_growth_rate",
        "energy_growth_factor",
        "energy_growth_r2",
        "error",
        "newton_unconverged_steps",
        "wall_seconds",
        "message",
    ];
    Table {
        header: header.map(str::to_owned).to_vec(),
        rows: trials
            .iter()
            .map(|t| {
                let (outcome, message) = outcome_of(&t.summary.outcome);
                vec![
                    cell(Some(t.dt)),
                    t.summary.steps_completed.to_string(),
                    cell(Some(t.covered)),
                    t.stable().to_string(),
                    outcome,
                    cell(Some(t.summary.energy_excess_peak)),
                    cell(t.summary.energy_growth.map(|g| g.rate)),
                    cell(t.summary.energy_growth.map(|g| g.factor)),
                    cell(t.summary.energy_growth.map(|g| g.r2)),
                    cell(
                        reference
                            .filter(|_| t.stable())
                            .and_then(|r| r.relative_l2_error(&t.positions)),
                    ),
                    t.summary.newton_unconverged_steps.to_string(),
                    cell(Some(t.summary.totals.times.total)),
                    message,
                ]
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::{StableSet, holds_below};
    use crate::study::kinds::stability::StabilitySettings;

    fn set(points: &[(f64, bool)]) -> StableSet {
        StableSet::from_points(points.iter().copied(), 1e-4, 1e-1)
    }

    #[test]
    fn the_map_says_what_the_stable_set_is() {
        let (s, u) = (true, false);
        let ceiling = set(&[(1e-4, s), (1e-3, s), (1e-2, s), (1e-1, s)]);
        assert_eq!(ceiling.class(), Some("stable-to-ceiling"));
        assert_eq!(ceiling.max_stable(), Some(1e-1));
        assert!((ceiling.fraction() - 1.0).abs() < 1e-12);
        let limit = set(&[(1e-4, s), (1e-3, s), (2e-3, u), (1e-1, u)]);
        assert_eq!(limit.class(), Some("limit-found"));
        assert_eq!(limit.max_stable(), Some(1e-3));
        // Unstable at small steps, stable above: no step below which every step is stable.
        let above = set(&[(1e-1, s), (1e-4, u), (1e-3, u), (1e-2, s)]);
        assert_eq!(above.class(), Some("stable-only-above"));
        assert_eq!(above.max_stable(), None);
        assert_eq!(above.largest(), Some(1e-1));
        assert!((above.fraction() - 1.0 / 3.0).abs() < 1e-12);
        let bands = set(&[(1e-4, s), (1e-3, u), (1e-2, s), (1e-1, u)]);
        assert_eq!(bands.class(), Some("stable-in-bands"));
        assert_eq!(bands.max_stable(), Some(1e-4));
        assert_eq!(bands.intervals, vec![(1e-4, 1e-4), (1e-2, 1e-2)]);
        assert_eq!(bands.text(), "[1e-4, 1e-4] [0.01, 0.01]");
        let inside = set(&[(1e-4, u), (1e-3, s), (1e-1, u)]);
        assert_eq!(inside.class(), Some("stable-in-bands"));
        assert_eq!(set(&[(1e-4, u), (1e-1, u)]).class(), None);
    }

    #[test]
    fn an_error_step_holds_below_it_and_a_non_monotone_curve_is_not_claimed_above_the_jump() {
        // Errors 0.01, 0.05, 0.085, then a jump to 0.46 and back to 0.08 at a larger step:
        // within 10 % holds up to the third step only.
        let errors = [
            (1e-3, 0.01),
            (2e-3, 0.05),
            (5e-3, 0.085),
            (5.5e-3, 0.46),
            (8e-3, 0.08),
        ];
        let points: Vec<(f64, bool)> = errors.iter().map(|&(dt, e)| (dt, e <= 0.1)).collect();
        assert_eq!(holds_below(&points), (Some(5e-3), Some(5.5e-3)));
        // The smallest misses: no step.
        assert_eq!(
            holds_below(&[(1e-3, false), (2e-3, true)]),
            (None, Some(1e-3))
        );
        assert_eq!(
            holds_below(&[(1e-3, true), (2e-3, true)]),
            (Some(2e-3), None)
        );
    }

    #[test]
    fn the_scan_covers_the_judged_range_and_the_first_step() {
        let settings: StabilitySettings = toml::from_str(
            "dt_min = 1e-4\ndt_max = 0.0123\nhorizon = 1.0\nmax_steps = 10000\nmin_steps = 10\n\
             scan_per_decade = 4",
        )
        .unwrap();
        let scan = settings.scan();
        assert_eq!(scan.first(), Some(&1e-4));
        assert_eq!(scan.last(), Some(&0.1));
        assert!(scan.contains(&0.0123));
        // Three decades at four per decade, both ends, and dt_max.
        assert_eq!(scan.len(), 14);
        assert!(
            scan.windows(2)
                .all(|w| w[1] > w[0] && w[1] / w[0] <= 10f64.powf(0.25) + 1e-9)
        );
    }
}
