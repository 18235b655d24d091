//! The stability study kind, measuring: its columns, the work its runs share and one run's
//! measurement.

use super::{
    ERROR_COLUMNS, ERROR_TOLERANCES, EXPONENT_TOLERANCE, GROWING_BELOW, MAX_BISECTIONS, ROBUSTNESS,
    Stability, StabilitySettings, WIDEN_UP, settings,
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
    "dt_error_10pct",
    "dt_error_10pct_bound",
    "error_at_dt_error_10pct",
    "energy_excess_at_dt_error_10pct",
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
}

/// The smallest ratio of consecutive steps in a growth trend.
const SPACING: f64 = 1.5;

/// How the energy's growth rate changes with dt over the three smallest trials (at least
/// [`SPACING`] apart), when every
/// trial blew up: `rate ∝ dt^exponent`. Explicit Euler's top mode grows at `omega² dt`
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
    /// The trend of the three smallest trials, if each has a positive growth rate.
    fn of<'a>(trials: impl Iterator<Item = &'a Trial>, omega: Option<f64>) -> Option<Self> {
        let mut points: Vec<(f64, f64)> = trials
            .map(|t| Some((t.dt, t.summary.energy_growth?.rate)))
            .collect::<Option<_>>()?;
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        // The smallest trial and the next ones at least 1.5x apart (the search runs 2x and 4x
        // the smallest step): close steps make a local exponent noise.
        let mut spaced: Vec<(f64, f64)> = Vec::with_capacity(3);
        for p in points {
            if spaced.len() < 3 && spaced.last().is_none_or(|l| p.0 >= SPACING * l.0) {
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

    /// Whether the trials show a blow-up at every dt: a rate that shrinks as one positive
    /// power of dt, at steps below the explicit limit.
    fn every_dt(&self) -> bool {
        let (abs, rel) = EXPONENT_TOLERANCE;
        self.exponent > 0.0
            && (self.local.0 - self.local.1).abs() <= abs.max(rel * self.exponent)
            && self.over_theory.is_none_or(|b| b <= 1.0)
    }
}

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
    }
}

/// Whether every trial blew up.
fn every_unstable(trials: &[Trial]) -> bool {
    trials
        .iter()
        .all(|t| t.summary.outcome.status == OutcomeKind::Unstable)
}

/// What the search found: the bracket of the largest stable step, what checks it, and every
/// trial run.
struct Found {
    /// The largest stable step and the smallest unstable one above it (`None`: stable to the
    /// ceiling); `None` when no step is stable.
    bracket: Option<(f64, Option<f64>)>,
    /// The first probe below the limit that failed.
    non_monotone: Option<f64>,
    /// The trials a hair from the bracket's ends that disagree with them.
    not_robust: Vec<f64>,
    /// How the growth rate follows dt, where nothing (or only a slowly growing step) was
    /// stable.
    trend: Option<GrowthTrend>,
    /// The largest step that completed though its energy still grew, and by how much, when
    /// the growth above it follows one power of dt (the bracket is then the horizon's).
    growing_below: Option<(f64, f64)>,
    /// The largest stable step within each error tolerance.
    within: Vec<Option<Within>>,
    trials: Vec<Trial>,
}

impl Found {
    /// Run the search and its checks.
    fn search<F: FnMut(f64) -> Trial>(
        mut search: Search<F>,
        settings: &StabilitySettings,
        shared: &RunInputs,
    ) -> Self {
        let lowest = settings.lowest_dt();
        let highest = settings.highest_dt();
        let bracket = search.find(settings);
        let non_monotone = probe_below(&mut search, bracket, settings);
        let not_robust = robustness(&mut search, bracket, settings);
        // Nothing stable and every trial a blow-up: does the growth shrink as dt does?
        let mut trend = None;
        if bracket.is_none() && every_unstable(&search.trials) {
            for k in [2.0, 4.0] {
                if lowest * k <= highest {
                    search.stable(lowest * k);
                }
            }
            trend = GrowthTrend::of(search.trials.iter(), shared.omega);
        }
        let growing_below = growing_below(&mut search, bracket, settings, shared);
        if let Some((_, t)) = growing_below {
            trend = Some(t);
        }
        // Then no step is stable: the trials below only did not show it within the horizon.
        let bracket = if growing_below.is_some() {
            None
        } else {
            bracket
        };
        // The largest stable step within each error tolerance: what ranks methods that are
        // stable up to the ceiling (and the rest at their limit's accuracy).
        let mut within = Vec::new();
        if let (Some((limit, _)), Some(reference)) = (bracket, shared.reference) {
            for &tolerance in &ERROR_TOLERANCES {
                within.push(search.largest_within(
                    limit,
                    lowest,
                    tolerance,
                    settings.error_dt_precision,
                    reference,
                ));
            }
        }
        Self {
            bracket,
            non_monotone,
            not_robust,
            trend,
            growing_below: growing_below.map(|(g, _)| g),
            within,
            trials: search.trials,
        }
    }

    /// The run's verdict.
    fn verdict(&self) -> &'static str {
        match self.bracket {
            Some((_, None)) => "stable-to-ceiling",
            Some((_, Some(_))) => "limit-found",
            None if (every_unstable(&self.trials) || self.growing_below.is_some())
                && self.trend.is_some_and(|t| t.every_dt()) =>
            {
                "unstable-at-every-dt"
            }
            None => "no-stable-dt-in-range",
        }
    }

    /// The trial at the largest stable step, and the first unstable trial (above the limit,
    /// or with nothing stable the smallest step tried, which decides "nothing was stable").
    fn reported(&self) -> (Option<&Trial>, Option<&Trial>) {
        let trials = &self.trials;
        let best = self
            .bracket
            .and_then(|(dt, _)| trials.iter().find(|t| t.dt == dt && t.stable()));
        let first_unstable = match self.bracket {
            Some((_, Some(hi))) => trials.iter().find(|t| t.dt == hi),
            Some((_, None)) => None,
            None => trials
                .iter()
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
            let t = trials.iter_mut().find(|t| t.dt == dt)?;
            t.snapshots.take()
        });
        m
    }

    /// The verdict, the bracket, its checks and the steps within each error tolerance.
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
        }
        m.set(
            "error_dt_precision",
            cell(Some(settings.error_dt_precision)),
        );
        m.set(
            "limit_robust",
            match bracket {
                None => String::new(),
                Some(_) if !settings.robustness_trials => "not-checked".into(),
                Some(_) if self.not_robust.is_empty() => "yes".into(),
                Some(_) => "no".into(),
            },
        );
    }

    /// The run's message: why nothing was stable, or what is wrong with the bracket.
    fn explain(&self, m: &mut Measured, verdict: &str, settings: &StabilitySettings) {
        if verdict != "limit-found" && verdict != "stable-to-ceiling" {
            let why = self.why_unstable(verdict);
            m.message = format!(
                "{verdict} in [{}, {}] s: {why}; {}",
                short(settings.lowest_dt()),
                short(settings.highest_dt()),
                m.message
            );
        } else if !self.not_robust.is_empty() {
            m.message = format!(
                "the bracket is not robust: trials at {} (within {ROBUSTNESS:e} of its ends) \
                 disagree with them",
                self.not_robust
                    .iter()
                    .map(|d| format!("{d:e}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        } else if let Some(dt) = self.non_monotone {
            m.message = format!(
                "not monotone: the smaller step {} failed ({})",
                short(dt),
                self.trials
                    .iter()
                    .find(|t| t.dt == dt)
                    .map(|t| outcome_of(&t.summary.outcome).1)
                    .unwrap_or_default()
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

/// Probe smaller steps below a limit: the first that fails makes the limit non-monotone.
fn probe_below<F: FnMut(f64) -> Trial>(
    search: &mut Search<F>,
    bracket: Option<(f64, Option<f64>)>,
    settings: &StabilitySettings,
) -> Option<f64> {
    let mut non_monotone = None;
    if let Some((limit, Some(_))) = bracket {
        let mut dt = limit;
        for _ in 0..settings.probes {
            dt /= 2.0;
            if dt < settings.lowest_dt() {
                break;
            }
            if !search.stable(dt) && non_monotone.is_none() {
                non_monotone = Some(dt);
            }
        }
    }
    non_monotone
}

/// A bracket is robust when trials a hair away from its ends agree with them: the trials
/// that do not.
fn robustness<F: FnMut(f64) -> Trial>(
    search: &mut Search<F>,
    bracket: Option<(f64, Option<f64>)>,
    settings: &StabilitySettings,
) -> Vec<f64> {
    let mut not_robust = Vec::new();
    let range = settings.lowest_dt()..=settings.highest_dt();
    if let Some((lo, hi)) = bracket.filter(|_| settings.robustness_trials) {
        let ends = [(lo, true)].into_iter().chain(hi.map(|h| (h, false)));
        for (end, stable) in ends {
            for dt in [end * (1.0 - ROBUSTNESS), end * (1.0 + ROBUSTNESS)] {
                if range.contains(&dt) && search.stable(dt) != stable {
                    not_robust.push(dt);
                }
            }
        }
    }
    not_robust
}

/// A bracket below which the excess still grows, only too slowly to be sustained growth
/// within the horizon, is where growth became detectable, not where it starts: if the growth
/// above it follows one power of dt below 2/omega_max (explicit midpoint's dt^3), the method
/// blows up at every dt and the bracket is the horizon's, not the method's. Returns the
/// largest completed step and its growth factor, with the trend above it.
fn growing_below<F: FnMut(f64) -> Trial>(
    search: &mut Search<F>,
    bracket: Option<(f64, Option<f64>)>,
    settings: &StabilitySettings,
    shared: &RunInputs,
) -> Option<((f64, f64), GrowthTrend)> {
    let (lo, Some(hi)) = bracket? else {
        return None;
    };
    let below = search
        .trials
        .iter()
        .find(|t| t.dt == lo)
        .and_then(|t| t.summary.energy_growth)
        .filter(|g| g.rate > 0.0 && g.factor >= GROWING_BELOW)?;
    for k in [SPACING, SPACING * SPACING] {
        if hi * k <= settings.highest_dt() {
            search.stable(hi * k);
        }
    }
    let above = search
        .trials
        .iter()
        .filter(|t| t.dt >= hi && t.summary.outcome.status == OutcomeKind::Unstable);
    let t = GrowthTrend::of(above, shared.omega)?;
    t.every_dt().then_some(((lo, below.factor), t))
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
        if let Some(t) = self.trials.iter().find(|t| t.dt == dt) {
            return t.stable();
        }
        let trial = (self.run)(dt);
        let stable = trial.stable();
        self.trials.push(trial);
        stable
    }

    fn closed(&self, lo: f64, hi: f64) -> bool {
        hi / lo - 1.0 <= self.precision
    }

    /// The bracket `(largest stable dt, smallest unstable dt above it)`, `(ceiling, None)`
    /// when the ceiling is stable, or `None` when no step in range is.
    fn find(&mut self, settings: &StabilitySettings) -> Option<(f64, Option<f64>)> {
        let (lowest, highest) = (settings.lowest_dt(), settings.highest_dt());
        let start = settings.dt_max.clamp(lowest, highest);
        if self.stable(start) {
            // Widen upward until a failure or the ceiling.
            let mut lo = start;
            while lo < highest {
                let next = (lo * WIDEN_UP).min(highest);
                if !self.stable(next) {
                    return Some(self.bisect(lo, next));
                }
                lo = next;
            }
            return Some((lo, None));
        }
        // `lo` is presumed stable: a trial at the lowest step is the most expensive one (an
        // implicit method over the whole horizon at its smallest step), so it is tried only
        // once the bracket has closed in on it (within 4x) without a stable trial above it.
        // If it fails, the bracket widens downward by 10x steps to `lowest`.
        let mut hi = start;
        let mut lo = settings.dt_min.clamp(lowest, hi);
        if lo >= hi {
            lo = (hi / 10.0).max(lowest);
        }
        for _ in 0..MAX_BISECTIONS {
            if lo >= hi {
                return None;
            }
            if self.closed(lo, hi) || hi / lo <= 4.0 {
                if self.stable(lo) {
                    return Some(self.bisect(lo, hi));
                }
                if lo <= lowest * (1.0 + 1e-12) {
                    return None;
                }
                hi = lo;
                lo = (lo / 10.0).max(lowest);
                continue;
            }
            let mid = (lo * hi).sqrt();
            if self.stable(mid) {
                return Some(self.bisect(mid, hi));
            }
            hi = mid;
        }
        None
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

    /// The largest stable step at most `limit` (the largest stable one) whose error is at most
    /// `tolerance`: `limit` itself if it is, else by bisection in log dt (to `precision`)
    /// between a step within the tolerance (found by quartering down to `lowest`) and one
    /// beyond it. `None` when no step down to `lowest` is within it, or the tolerance is
    /// below the reference's own accuracy (errors there are not scored).
    fn largest_within(
        &mut self,
        limit: f64,
        lowest: f64,
        tolerance: f64,
        precision: f64,
        reference: &Reference,
    ) -> Option<Within> {
        if tolerance <= reference.floor() {
            return None;
        }
        let within = |s: &mut Self, dt: f64| s.error(dt, reference).is_some_and(|e| e <= tolerance);
        let (mut lo, mut hi) = (limit, None);
        while !within(self, lo) {
            hi = Some(lo);
            lo /= 4.0;
            if lo < lowest {
                return None;
            }
        }
        if let Some(mut hi) = hi {
            for _ in 0..MAX_BISECTIONS {
                if hi / lo - 1.0 <= precision {
                    break;
                }
                let mid = (lo * hi).sqrt();
                if within(self, mid) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
        }
        let trial = self.trials.iter().find(|t| t.dt == lo)?;
        let scale = trial.summary.energy_scale.total();
        let excess = trial
            .rows
            .last()
            .map_or(0.0, |r| r.energy_excess / scale.max(f64::MIN_POSITIVE));
        Some(Within {
            dt: lo,
            bound: if lo == limit { "limit" } else { "error" },
            error: self.error(lo, reference)?,
            excess,
        })
    }

    /// Bisect in log dt between a stable `lo` and an unstable `hi`.
    fn bisect(&mut self, mut lo: f64, mut hi: f64) -> (f64, Option<f64>) {
        for _ in 0..MAX_BISECTIONS {
            if self.closed(lo, hi) {
                break;
            }
            let mid = (lo * hi).sqrt();
            if self.stable(mid) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        (lo, Some(hi))
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
