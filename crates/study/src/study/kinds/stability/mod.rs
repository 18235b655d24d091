//! Stability runs: the largest time step at which a method covers a fixed horizon, what it
//! costs per simulated second there and how wrong it is, next to the explicit limit
//! 2/omega_max of the scene at rest.
//!
//! A trial at `dt` is stable when it covers the whole horizon in at least `min_steps` and at
//! most `max_steps` steps with every step taken and no blow-up (see [`softbench_run::run::balance`]: a
//! blow-up is energy gained beyond the work done on the body that keeps growing, not a level
//! crossed). Steps outside `[lowest_dt, highest_dt]` are never judged, so no cap decides a
//! verdict. The search: try `dt_max`; if it is stable, widen upward (x4) to the ceiling;
//! otherwise bisect in log dt between a presumed-stable `dt_min` (tried once the bracket
//! closes in on it, widened downward by 10x to `lowest_dt` if it fails) and the failure.
//! Bisection presumes stability is monotone in dt; after it, a few smaller steps are probed
//! and a failure there is reported (`non_monotone_dt`), and trials [`ROBUSTNESS`] away from
//! each end of the bracket must agree with that end (`limit_robust`).
//!
//! The verdict (`stability`): `limit-found` (a bracket: `max_stable_dt`, `first_unstable_dt`),
//! `stable-to-ceiling`, `unstable-at-every-dt` (every trial blew up and the growth rate of the
//! three smallest shrinks as one positive power of dt, `growth_exponent`, below 2/omega_max:
//! see [`GrowthTrend`]; also when the trials below a bracket still grew, only too slowly to
//! show within the horizon, and the growth above it follows such a power) or
//! `no-stable-dt-in-range` (no trial was stable, which says nothing about steps below the
//! range). The `outcome` column is how the first unstable trial ended.

use crate::study::kind::{
    Measure, OwnKey, Plan, Present, RunInputs, SweepLine, Verdict, number, parse_quick,
};
use crate::study::present::charts::{Emit, SceneRows, label};
use crate::study::present::findings::{self, Better, Ranking};
use crate::study::vocabulary::columns::{self, CAPS, SUMMARY};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::format::{cell, short};
use crate::study::vocabulary::grid::Axis;
use crate::study::vocabulary::measured::{
    Measured, build, outcome_of, picture_surface, run_observed,
};
use crate::study::vocabulary::reference::{Reference, ReferenceSettings, ScoringSettings};
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_core::integrate::State;
use softbench_core::model::Model;
use softbench_core::parallel::Parallelism;
use softbench_run::plot::{Bar, BarChart, Chart, LineChart, PlotError, ReferenceLine, Series};
use softbench_run::run::balance::GROWN;
use softbench_run::run::{Observer, Outcome, OutcomeKind, RunSummary, Sample};
use softbench_run::scene::{RunConfig, SceneConfig};
use std::fmt::Write;
use std::path::Path;
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

/// A stability study: each run's largest stable time step, by bisection.
pub(in crate::study) struct Stability;

/// The kind's name in study files, the name of its table and the key of its resolved table.
const NAME: &str = "stability";

/// The `[stability]` table of a study file (its other keys are the study's).
#[derive(serde::Deserialize)]
struct FileTable {
    #[serde(default)]
    stability: Option<StabilitySettings>,
}

/// The `[quick]` keys a stability study reads. Quick mode keeps the horizon, the judged range
/// of steps and the criterion, so every quick trial is the full study's trial at that step
/// and a quick verdict is of the full study's class; it is quicker by searching coarser and
/// skipping the robustness trials.
#[derive(Default, serde::Serialize, serde::Deserialize)]
struct Quick {
    /// The bisection precision (default: the study's, at least 0.1).
    relative_precision: Option<f64>,
    /// The precision of the error-tolerance search (default: the study's, at least 0.5).
    error_dt_precision: Option<f64>,
    /// Refused: a stability study keeps its horizon (see `check_quick`).
    horizon: Option<f64>,
    /// Refused: a stability study keeps its judged range (see `check_quick`).
    max_steps: Option<usize>,
}

/// Quick mode's default bisection precision and error-tolerance precision.
const QUICK_PRECISION: f64 = 0.1;
const QUICK_ERROR_DT_PRECISION: f64 = 0.5;

/// The study's `[stability]` table as resolved at load.
fn settings(file: &StudyFile) -> Option<StabilitySettings> {
    file.settings(NAME)
}

impl Plan for Stability {
    fn name(&self) -> &'static str {
        NAME
    }

    fn description(&self) -> &'static str {
        "each run's largest stable time step over a horizon, by bisection, and its cost and \
         error there"
    }

    fn example(&self) -> &'static str {
        "[grid]\n\"integrator.method\" = [\"symplectic-euler\", \"backward-euler\"]\n\n\
         [stability]\ndt_min = 1e-4\ndt_max = 0.005\nhorizon = 0.1\nerror_samples = 4\n"
    }

    fn table_names(&self) -> &'static [&'static str] {
        &[NAME]
    }

    fn parse_table(&self, text: &str) -> Result<serde_json::Value, toml::de::Error> {
        let file: FileTable = toml::from_str(text)?;
        Ok(serde_json::to_value(&file.stability).unwrap_or_default())
    }

    fn check(
        &self,
        file: &StudyFile,
        ctx: &Context,
        bad: &dyn Fn(&str, String) -> StudyError,
    ) -> Result<(), StudyError> {
        check(file, ctx, bad)
    }

    fn quick_keys(&self) -> &'static [&'static str] {
        &[
            "relative_precision",
            "error_dt_precision",
            "horizon",
            "max_steps",
        ]
    }

    fn parse_quick(
        &self,
        text: &str,
    ) -> Result<serde_json::Map<String, serde_json::Value>, toml::de::Error> {
        parse_quick::<Quick>(text)
    }

    fn check_quick_values(
        &self,
        file: &StudyFile,
        bad: &dyn Fn(&str, String) -> StudyError,
    ) -> Result<(), StudyError> {
        for key in ["relative_precision", "error_dt_precision"] {
            if let Some(p) = file.quick.get::<f64>(key)
                && !(MIN_RELATIVE_PRECISION..1.0).contains(&p)
            {
                return Err(bad(
                    &format!("quick.{key}"),
                    format!("must be in [{MIN_RELATIVE_PRECISION:e}, 1) (got {p})"),
                ));
            }
        }
        Ok(())
    }

    fn check_quick(&self, file: &StudyFile, ctx: &Context) -> Result<(), StudyError> {
        check_quick(file, ctx)
    }

    fn quick_table(&self, file: &mut StudyFile, ctx: &Context) -> Result<(), StudyError> {
        quick_table(file, ctx)
    }

    fn configure(
        &self,
        ctx: &Context,
        file: &StudyFile,
        config: &mut SceneConfig,
        _: &[Axis],
        _: bool,
    ) -> Result<(), StudyError> {
        // A trial is judged over its whole horizon: a cost budget would end it early and so
        // decide the verdict, so a scene that sets one is refused rather than ignored.
        if config.run.budget.is_some() {
            return Err(ctx.invalid(
                0,
                "scenes",
                format!(
                    "scene `{}` sets run.budget: a stability trial must cover its horizon, so a \
                     budget cannot stop it; remove it (the trials' step bounds are [stability] \
                     min_steps and max_steps)",
                    config.name.as_deref().unwrap_or("?")
                ),
            ));
        }
        // It judges methods, so by default an unconverged Newton solve fails the step instead
        // of being accepted.
        if settings(file).is_some_and(|s| s.require_newton_convergence) {
            config.integrator.newton.require_convergence = true;
        }
        Ok(())
    }

    fn own_keys(&self) -> &'static [OwnKey] {
        &[
            OwnKey {
                key: "run.dt",
                why: "the search chooses each trial's step, starting at [stability] dt_max",
                replaced: true,
            },
            OwnKey {
                key: "run.steps",
                why: "every trial covers [stability] horizon, in horizon / dt steps",
                replaced: true,
            },
            OwnKey {
                key: "run.sample_every",
                why: "a trial keeps about 200 rows whatever its steps",
                replaced: true,
            },
            OwnKey {
                key: "run.energy_limit",
                why: "a trial's blow-up level is [stability] energy_factor",
                replaced: true,
            },
        ]
    }

    fn horizon(&self, file: &StudyFile) -> Option<(f64, &'static str)> {
        settings(file).map(|s| (s.horizon, "horizon / dt steps of each dt the search tries"))
    }

    /// About a dozen trials (widening, bisection, probes), each covering the horizon at a
    /// step near the first one tried.
    fn estimated_steps(&self, file: &StudyFile, _: &SceneConfig) -> f64 {
        settings(file).map_or(1.0, |s| {
            12.0 * (s.horizon / s.dt_max).clamp(s.min_steps as f64, s.max_steps as f64)
        })
    }
}

impl Measure for Stability {
    fn columns(&self) -> &'static [&'static str] {
        &COLUMNS
    }

    fn own_columns(&self) -> &'static [&'static str] {
        OWN_COLUMNS
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

impl Present for Stability {
    fn summary_columns(&self) -> &'static [&'static str] {
        &[
            "stability",
            "max_stable_dt",
            "outcome",
            "first_unstable_dt",
            "stable_over_theory",
            "cost_per_simulated_second",
            "evaluations_per_simulated_second",
            "error_at_stable_dt",
            "non_monotone_dt",
            "energy_growth_rate",
            "growth_exponent",
            "limit_robust",
            "dt_error_1pct",
            "dt_error_10pct",
            "newton_unconverged_steps",
            "trials",
        ]
    }

    fn sweep_metrics(&self) -> &'static [&'static str] {
        &["max_stable_dt", "newton_iterations_per_step"]
    }

    fn quick_notice(&self) -> &'static str {
        "the same horizon, judged range and criterion (a verdict at a step is the full \
         study's, and a run's verdict of the same class), but coarser searches and no \
         robustness trials"
    }

    /// The `stability` column: clean when it answers the question (a limit, or stable up to
    /// the ceiling).
    fn verdict<'a>(&self, runs: &'a Table, row: &'a [String]) -> Verdict<'a> {
        let word = runs.get(row, "stability").unwrap_or_default();
        Verdict {
            word,
            clean: ANSWERED.contains(&word),
        }
    }

    /// A limit below which a smaller step failed, or whose bracket is not robust, is listed,
    /// though it was found.
    fn flagged(&self, runs: &Table, row: &[String]) -> bool {
        runs.get(row, "non_monotone_dt")
            .is_some_and(|v| !v.is_empty())
            || runs.get(row, "limit_robust") == Some("no")
    }

    /// A row's outcome is how its first unstable trial ended; its series is the trial it
    /// reports.
    fn outcome_ends_series(&self) -> bool {
        false
    }

    fn report_settings(&self, out: &mut String, file: &StudyFile) {
        report_settings(out, file);
    }

    fn scene_charts(&self, s: &SceneRows, _: &Path, emit: &mut Emit) -> Result<(), PlotError> {
        scene_charts(s, emit)
    }

    /// The largest stable dt, and the cost per simulated second there.
    fn rankings(&self, s: &SceneRows, _: Option<&str>) -> Vec<Ranking> {
        let runs = s.runs;
        let has = |c: &str| runs.column(c).is_some();
        let mut out = Vec::new();
        if has("max_stable_dt") {
            out.extend(findings::ranking(
                s,
                "largest stable dt (s)".into(),
                Better::Larger,
                &|r| {
                    runs.number(r, "max_stable_dt").ok_or_else(|| {
                        runs.get(r, "stability")
                            .unwrap_or("no limit found")
                            .to_owned()
                    })
                },
            ));
        }
        for (k, tolerance) in ERROR_TOLERANCES.iter().enumerate() {
            let column = ERROR_COLUMNS[k][0];
            if has(column) {
                out.extend(findings::ranking(
                    s,
                    format!(
                        "largest stable dt with a position error of at most {}% against the \
                         reference (s)",
                        tolerance * 100.0
                    ),
                    Better::Larger,
                    &|r| {
                        runs.number(r, column)
                            .ok_or_else(|| "no stable step within it".to_owned())
                    },
                ));
            }
        }
        if has("cost_per_simulated_second") {
            out.extend(findings::ranking_with_spread(
                s,
                "cost per simulated second at the largest stable dt (wall s / simulated s: \
                 median step, quartiles as spread; first step apart)"
                    .into(),
                Better::Smaller,
                &|r| {
                    runs.number(r, "cost_per_simulated_second")
                        .ok_or_else(|| "not measured".into())
                },
                &|r| {
                    Some((
                        runs.number(r, "cost_per_simulated_second_q1")?,
                        runs.number(r, "cost_per_simulated_second_q3")?,
                    ))
                },
            ));
        } else if has("wall_seconds") && has("final_time") {
            out.extend(findings::cost_per_simulated_second(s));
        }
        out
    }

    fn unscored(&self, runs: &Table, row: &[String]) -> bool {
        runs.get(row, "error_scored") == Some("no")
    }

    /// A row's outcome is its first unstable trial's, which is expected; only a trial cut by a
    /// step cap is worth a warning.
    fn stopped_early(&self, runs: &Table, row: &[String]) -> bool {
        runs.get(row, "outcome") == Some(OutcomeKind::HorizonNotReached.name())
    }

    fn energy_caption(&self) -> Option<&'static str> {
        Some(
            "Energy balance over time of each method's trial at its largest stable dt (or its \
             failing trial): |E(t) - E(0) - work done| over the energy the body holds or \
             exchanges, the scale the blow-up check judges it against (log scale); the legend \
             says whether energy was gained or lost.",
        )
    }

    /// The largest stable dt against the parameter comes with the explicit limit.
    fn sweep_line(&self, metric: &str) -> SweepLine {
        if metric != "max_stable_dt" {
            return SweepLine::default();
        }
        SweepLine {
            note: " A line at the top is stable at the largest step judged (the ceiling, \
                   horizon / min_steps).",
            reference: Some(("dt_theory", "2/omega_max (explicit limit)")),
        }
    }

    fn unit_notes(&self, _: &Table, shown: &dyn Fn(&str) -> bool) -> Vec<String> {
        shown("error_at_stable_dt")
            .then(|| "errors relative to the reference's displacement".to_owned())
            .into_iter()
            .collect()
    }

    fn dt_columns(&self) -> &'static [&'static str] {
        &["max_stable_dt", "dt"]
    }
}

/// Cost against error at the largest stable steps, and the largest stable step per method.
fn scene_charts(s: &SceneRows, emit: &mut Emit) -> Result<(), PlotError> {
    if let Some(chart) = cost_error_chart(s.scene, s.runs, s.params, s.rows) {
        emit(
            format!("cost-error-{}", s.slug),
            "Wall seconds per simulated second against the relative L2 position error, both at \
             each method's largest stable dt (log-log): lower left is better. Methods with no \
             stable dt in range are absent.",
            Chart::Line(chart),
        )?;
    }
    emit(
        format!("stable-dt-{}", s.slug),
        "Largest stable time step per method (log scale); the line is the explicit limit \
         2/omega_max of the scene at rest. Bars marked >= ceiling were stable at the largest \
         step judged (horizon / min_steps).",
        Chart::Bar(stable_dt_chart(s.scene, s.runs, s.params, s.rows)),
    )
}

/// The `[stability]` table is present and sane.
fn check(
    file: &StudyFile,
    ctx: &Context,
    bad: &dyn Fn(&str, String) -> StudyError,
) -> Result<(), StudyError> {
    let Some(s) = &settings(file) else {
        return Err(ctx.invalid(
            0,
            "stability",
            "a stability study needs a [stability] table with dt_min, dt_max and horizon",
        ));
    };
    let positive = |x: f64| x.is_finite() && x > 0.0;
    if !positive(s.dt_min) {
        return Err(bad(
            "stability.dt_min",
            format!("must be > 0 s (got {})", s.dt_min),
        ));
    }
    if !(positive(s.dt_max) && s.dt_max > s.dt_min) {
        return Err(bad(
            "stability.dt_max",
            format!("must be > dt_min = {} s (got {})", s.dt_min, s.dt_max),
        ));
    }
    if !positive(s.horizon) {
        return Err(bad(
            "stability.horizon",
            format!("must be > 0 s (got {})", s.horizon),
        ));
    }
    if !(s.energy_factor.is_finite() && s.energy_factor > 0.0) {
        return Err(bad(
            "stability.energy_factor",
            format!("must be > 0 (got {})", s.energy_factor),
        ));
    }
    if !(MIN_RELATIVE_PRECISION..1.0).contains(&s.relative_precision) {
        return Err(bad(
            "stability.relative_precision",
            format!(
                "must be in [{MIN_RELATIVE_PRECISION:e}, 1) (got {}): the bisection \
                 cannot resolve dt more finely than that",
                s.relative_precision
            ),
        ));
    }
    if !(MIN_RELATIVE_PRECISION..1.0).contains(&s.error_dt_precision) {
        return Err(bad(
            "stability.error_dt_precision",
            format!(
                "must be in [{MIN_RELATIVE_PRECISION:e}, 1) (got {})",
                s.error_dt_precision
            ),
        ));
    }
    if !(positive(s.floor()) && s.floor() <= s.dt_min) {
        return Err(bad(
            "stability.dt_floor",
            format!("must be in (0, dt_min] (got {})", s.floor()),
        ));
    }
    if s.max_steps == 0 {
        return Err(bad("stability.max_steps", "must be at least 1".into()));
    }
    softbench_core::limits::STEPS
        .check_usize(Some(s.max_steps))
        .map_err(|e| bad("stability.max_steps", e.to_string()))?;
    crate::study::vocabulary::settings::check_samples(
        s.error_samples,
        "stability.error_samples",
        &bad,
    )?;
    if s.min_steps == 0 || s.min_steps > s.max_steps {
        return Err(bad(
            "stability.min_steps",
            format!(
                "must be in [1, max_steps = {}] (got {})",
                s.max_steps, s.min_steps
            ),
        ));
    }
    if s.dt_ceiling.is_some_and(|c| !positive(c)) {
        return Err(bad("stability.dt_ceiling", "must be > 0 s".into()));
    }
    if s.lowest_dt() > s.highest_dt() {
        return Err(bad(
            "stability.max_steps",
            format!(
                "no step can be judged: horizon / max_steps = {:e} s is above the \
                 ceiling {:e} s (horizon / min_steps or dt_ceiling); raise max_steps",
                s.horizon / s.max_steps as f64,
                s.highest_dt()
            ),
        ));
    }
    crate::study::vocabulary::settings::check_reference(&s.reference, NAME, false, &bad)?;
    crate::study::vocabulary::settings::check_phases(
        &s.phases,
        s.horizon,
        s.error_samples,
        NAME,
        &bad,
    )?;
    Ok(())
}

/// A stability study keeps its horizon and its judged range in quick mode: the range decides
/// a verdict's class (a limit below it is `no-stable-dt-in-range`), so a quick study that
/// judged fewer steps would answer a different question.
fn check_quick(file: &StudyFile, ctx: &Context) -> Result<(), StudyError> {
    for key in ["horizon", "max_steps"] {
        let set = match key {
            "horizon" => file.quick.get::<f64>(key).is_some(),
            _ => file.quick.get::<usize>(key).is_some(),
        };
        if set {
            return Err(StudyError::Invalid {
                path: ctx.path.to_owned(),
                line: ctx.line_of_key(key),
                key: format!("quick.{key}"),
                message: "a stability study keeps its horizon and its judged range of steps in \
                          quick mode, so every quick trial is the full study's trial at that \
                          step and every quick verdict of the full study's class; [quick] may \
                          set relative_precision and error_dt_precision (coarser searches)"
                    .into(),
            });
        }
    }
    Ok(())
}

/// `[quick]` applied to the `[stability]` table: coarser searches, no robustness trials.
fn quick_table(file: &mut StudyFile, _: &Context) -> Result<(), StudyError> {
    if let Some(mut s) = settings(file) {
        let q = &file.quick;
        s.relative_precision = q
            .get("relative_precision")
            .unwrap_or(s.relative_precision.max(QUICK_PRECISION));
        s.error_dt_precision = q
            .get("error_dt_precision")
            .unwrap_or(s.error_dt_precision.max(QUICK_ERROR_DT_PRECISION));
        s.robustness_trials = false;
        file.set_settings(NAME, &s);
    }
    Ok(())
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

/// The report's paragraph on the search's settings, and every cap and threshold that can
/// decide a result.
fn report_settings(out: &mut String, file: &StudyFile) {
    if let Some(st) = &settings(file) {
        let _ = writeln!(
            out,
            "Stability search: first trial at {} s, bisection down to a presumed-stable {} s or \
             widening up (x4) to the ceiling, to {}% precision, then {} smaller probe(s){}. A trial is \
             stable when it covers the {} s horizon in {} to {} steps with every step taken and \
             no blow-up: its energy gain beyond the work done on the body never passed {} x the \
             energy the body holds or exchanges while growing ({GROWN:e} x its first half's) \
             and did not grow exponentially over the last half (x{} with R^2 >= {}); so only steps in [{}, {}] s are judged. With no stable trial, \
             `unstable-at-every-dt` needs the three smallest trials' growth rates to follow \
             one positive power of dt below 2/omega_max; a bracket whose largest stable trial's \
             excess grew more than {GROWING_BELOW} x, and above which the growth rates follow \
             such a power, is the horizon's and reported as `unstable-at-every-dt` too. With a \
             reference, the largest stable \
             step within each error tolerance ({}) is searched to {}% precision. Newton \
             convergence {}.\n",
            short(st.dt_max),
            short(st.dt_min),
            st.relative_precision * 100.0,
            st.probes,
            if st.robustness_trials {
                format!(
                    " and a trial {ROBUSTNESS:e} (relative) on each side of each end of the \
                     bracket"
                )
            } else {
                " (no robustness trials: `limit_robust` is `not-checked`)".to_owned()
            },
            short(st.horizon),
            st.min_steps,
            st.max_steps,
            st.energy_factor,
            softbench_run::run::growth::SUSTAINED_GROWTH,
            softbench_run::run::growth::MIN_FIT_R2,
            short(st.lowest_dt()),
            short(st.highest_dt()),
            ERROR_TOLERANCES
                .iter()
                .map(|t| format!("{}%", t * 100.0))
                .collect::<Vec<_>>()
                .join(", "),
            st.error_dt_precision * 100.0,
            if st.require_newton_convergence {
                "is required (an unconverged step fails as solver-failed)"
            } else {
                "is **not** required: unconverged steps are accepted and counted \
                 (`newton_unconverged_steps`)"
            }
        );
    }
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
    /// The trials' `run.energy_limit`: a trial blows up when the energy it gained beyond the
    /// work done on the body passes this many times the energy the body holds or exchanges
    /// while growing (see `run::balance`; sustained exponential growth is a blow-up at any
    /// level). Default 1.
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
fn default_probes() -> usize {
    2
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
}

/// The verdicts of the `stability` column.
pub const VERDICTS: [&str; 4] = [
    "limit-found",
    "stable-to-ceiling",
    "unstable-at-every-dt",
    "no-stable-dt-in-range",
];

/// Finest bisection precision: well above f64 resolution, so the bracket always closes.
pub const MIN_RELATIVE_PRECISION: f64 = 1e-9;

/// The verdicts that answer the question (a limit, or stable up to the ceiling).
const ANSWERED: [&str; 2] = ["limit-found", "stable-to-ceiling"];

/// The error tolerances (relative L2 position error against the reference) at which the
/// largest stable step is reported: `dt_error_1pct` and `dt_error_10pct`.
pub const ERROR_TOLERANCES: [f64; 2] = [0.01, 0.1];

/// Per tolerance: the step, what bounds it (`limit` when the largest stable step is within
/// the tolerance, `error` when the error is), the error there, and the energy excess at the
/// end of that trial over the energy the body holds or exchanges (signed: negative = lost).
const ERROR_COLUMNS: [[&str; 4]; 2] = [
    [
        "dt_error_1pct",
        "dt_error_1pct_bound",
        "error_at_dt_error_1pct",
        "energy_excess_at_dt_error_1pct",
    ],
    [
        "dt_error_10pct",
        "dt_error_10pct_bound",
        "error_at_dt_error_10pct",
        "energy_excess_at_dt_error_10pct",
    ],
];

/// The largest stable step within an error tolerance.
#[derive(Clone, Copy, Debug)]
struct Within {
    dt: f64,
    bound: &'static str,
    error: f64,
    excess: f64,
}

/// Relative distance from a bracket's ends of the trials that check it is robust.
pub const ROBUSTNESS: f64 = 1e-6;

/// How much the excess of the largest stable trial must have grown over its last half for
/// the bracket to be questioned as detection-limited (a stable method's excess stays
/// bounded; at a true limit it does not grow below it).
const GROWING_BELOW: f64 = 10.0;

/// The smallest ratio of consecutive steps in a growth trend.
const SPACING: f64 = 1.5;

/// How far the two local exponents of the growth rate may differ (absolute, or this fraction
/// of the fitted exponent if larger) for the growth to follow one power of dt.
const EXPONENT_TOLERANCE: (f64, f64) = (0.5, 0.25);

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

/// Upward widening factor when `dt_max` is stable.
const WIDEN_UP: f64 = 4.0;

/// Bisections at most (a precision near round-off cannot loop forever).
const MAX_BISECTIONS: usize = 64;

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
    let lowest = settings.lowest_dt();
    let highest = settings.highest_dt();
    let sample_times = shared
        .reference
        .map_or_else(Vec::new, |r| r.times().to_vec());
    let surface = picture_surface(&scene, spec)?;
    let run_trial = |dt: f64| -> Trial {
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
        let mut output = DenseOutput::new(sample_times.clone());
        // Every trial records its pictures (a copy of the surface per step), so the reported
        // trial's need no second run.
        let (mut summary, state, snapshots) =
            run_observed(&mut scene, &run, surface.clone(), &mut output, shared.meter);
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
    };
    let mut search = Search {
        run: run_trial,
        trials: Vec::new(),
        precision: settings.relative_precision,
    };
    let bracket = search.find(settings);
    // Probe smaller steps below a limit.
    let mut non_monotone = None;
    if let Some((limit, Some(_))) = bracket {
        let mut dt = limit;
        for _ in 0..settings.probes {
            dt /= 2.0;
            if dt < lowest {
                break;
            }
            if !search.stable(dt) && non_monotone.is_none() {
                non_monotone = Some(dt);
            }
        }
    }
    // A bracket is robust when trials a hair away from its ends agree with them.
    let mut not_robust = Vec::new();
    if let Some((lo, hi)) = bracket.filter(|_| settings.robustness_trials) {
        let ends = [(lo, true)].into_iter().chain(hi.map(|h| (h, false)));
        for (end, stable) in ends {
            for dt in [end * (1.0 - ROBUSTNESS), end * (1.0 + ROBUSTNESS)] {
                if (lowest..=highest).contains(&dt) && search.stable(dt) != stable {
                    not_robust.push(dt);
                }
            }
        }
    }
    // Nothing stable and every trial a blow-up: does the growth shrink as dt does?
    let every_unstable = |trials: &[Trial]| {
        trials
            .iter()
            .all(|t| t.summary.outcome.status == OutcomeKind::Unstable)
    };
    let mut trend = None;
    if bracket.is_none() && every_unstable(&search.trials) {
        for k in [2.0, 4.0] {
            if lowest * k <= highest {
                search.stable(lowest * k);
            }
        }
        trend = GrowthTrend::of(search.trials.iter(), shared.omega);
    }
    // A bracket below which the excess still grows, only too slowly to be sustained growth
    // within the horizon, is where growth became detectable, not where it starts: if the
    // growth above it follows one power of dt below 2/omega_max (explicit midpoint's dt^3),
    // the method blows up at every dt and the bracket is the horizon's, not the method's.
    let mut growing_below = None;
    if let Some((lo, Some(hi))) = bracket {
        let below = search
            .trials
            .iter()
            .find(|t| t.dt == lo)
            .and_then(|t| t.summary.energy_growth)
            .filter(|g| g.rate > 0.0 && g.factor >= GROWING_BELOW);
        if let Some(below) = below {
            for k in [SPACING, SPACING * SPACING] {
                if hi * k <= highest {
                    search.stable(hi * k);
                }
            }
            let above = search
                .trials
                .iter()
                .filter(|t| t.dt >= hi && t.summary.outcome.status == OutcomeKind::Unstable);
            let t = GrowthTrend::of(above, shared.omega);
            if t.is_some_and(|t| t.every_dt()) {
                trend = t;
                growing_below = Some((lo, below.factor));
            }
        }
    }
    // Then no step is stable: the trials below only did not show it within the horizon.
    let bracket = if growing_below.is_some() {
        None
    } else {
        bracket
    };
    // The largest stable step within each error tolerance: what ranks methods that are stable
    // up to the ceiling (and the rest at their limit's accuracy).
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
    let trials = search.trials;

    let verdict = match bracket {
        Some((_, None)) => "stable-to-ceiling",
        Some((_, Some(_))) => "limit-found",
        None if (every_unstable(&trials) || growing_below.is_some())
            && trend.is_some_and(|t| t.every_dt()) =>
        {
            "unstable-at-every-dt"
        }
        None => "no-stable-dt-in-range",
    };
    let best = bracket.and_then(|(dt, _)| trials.iter().find(|t| t.dt == dt && t.stable()));
    let first_unstable = match bracket {
        Some((_, Some(hi))) => trials.iter().find(|t| t.dt == hi),
        Some((_, None)) => None,
        // The smallest step tried decides "nothing was stable".
        None => trials
            .iter()
            .filter(|t| !t.stable())
            .min_by(|a, b| a.dt.total_cmp(&b.dt)),
    };

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
        m.cells = SUMMARY.cells(&best.summary);
        let simulated = best.covered.max(f64::MIN_POSITIVE);
        let totals = &best.summary.totals;
        // The steady cost: the median step (its quartiles as the spread), the first step's
        // setup apart (setup_seconds).
        let s = &best.summary;
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
            crate::study::vocabulary::reference::set_phase_cells(
                &mut m,
                reference,
                &best.positions,
            );
            if let Some(error) = reference.relative_l2_error(&best.positions) {
                let scored = error > reference.floor();
                m.set("error_at_stable_dt", cell(Some(error)));
                m.set("error_scored", if scored { "yes" } else { "no" }.into());
            }
        }
        m.series = best.rows.clone();
    } else if let Some(t) = first_unstable {
        m.series = t.rows.clone();
    }
    // The pictures of the reported trial: the largest stable step, or, with nothing stable,
    // the smallest failing one, which shows how the method breaks.
    let pictured = best.or(first_unstable).map(|t| t.dt);
    m.cells.extend(CAPS.cells(spec));
    m.set("stability", verdict.to_owned());
    m.set("max_stable_dt", cell(bracket.map(|(lo, _)| lo)));
    m.set("first_unstable_dt", cell(bracket.and_then(|(_, hi)| hi)));
    m.set("non_monotone_dt", cell(non_monotone));
    m.set(
        "energy_growth_rate",
        cell(first_unstable.and_then(|t| t.summary.energy_growth.map(|g| g.rate))),
    );
    m.set("growth_exponent", cell(trend.map(|t| t.exponent)));
    for (k, name) in ERROR_COLUMNS.iter().enumerate() {
        let found = within.get(k).copied().flatten();
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
            Some(_) if not_robust.is_empty() => "yes".into(),
            Some(_) => "no".into(),
        },
    );
    if verdict != "limit-found" && verdict != "stable-to-ceiling" {
        let why = match (verdict, trend) {
            ("unstable-at-every-dt", Some(t)) => format!(
                "{}, and the energy's growth rate shrinks like dt^{:.2} as dt shrinks (fitted \
                 from {} s{})",
                match growing_below {
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
        };
        m.message = format!(
            "{verdict} in [{}, {}] s: {why}; {}",
            short(lowest),
            short(highest),
            m.message
        );
    } else if !not_robust.is_empty() {
        m.message = format!(
            "the bracket is not robust: trials at {} (within {ROBUSTNESS:e} of its ends) \
             disagree with them",
            not_robust
                .iter()
                .map(|d| format!("{d:e}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    } else if let Some(dt) = non_monotone {
        m.message = format!(
            "not monotone: the smaller step {} failed ({})",
            short(dt),
            trials
                .iter()
                .find(|t| t.dt == dt)
                .map(|t| outcome_of(&t.summary.outcome).1)
                .unwrap_or_default()
        );
    }
    m.set("lowest_dt", cell(Some(lowest)));
    m.set("highest_dt", cell(Some(highest)));
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
    m.set("trials", trials.len().to_string());
    let total: f64 = trials.iter().map(|t| t.summary.totals.times.total).sum();
    m.set("trials_wall_seconds", cell(Some(total)));
    m.tables = vec![("trials", trial_table(&trials, shared.reference))];
    m.snapshots = pictured.and_then(|dt| {
        let mut trials = trials;
        let t = trials.iter_mut().find(|t| t.dt == dt)?;
        t.snapshots.take()
    });
    Ok(m)
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

/// The largest stable step per method, with 2/omega_max as a line (or a tick per bar when
/// the physics differ).
fn stable_dt_chart(
    scene: &str,
    runs: &Table,
    params: &[String],
    rows: &[&Vec<String>],
) -> BarChart {
    // Each physics (a swept stiffness, say) has its own 2/omega_max: every bar carries its
    // own as a tick, and one reference line is drawn only when they all agree.
    let theories: Vec<f64> = rows
        .iter()
        .filter_map(|r| runs.number(r, "dt_theory"))
        .collect();
    let theory = theories
        .first()
        .copied()
        .filter(|t| theories.iter().all(|u| (u / t - 1.0).abs() < 1e-9));
    let per_bar = theory.is_none() && !theories.is_empty();
    BarChart {
        title: format!("Largest stable time step: {scene}"),
        y_label: "largest stable dt (s)".into(),
        y_log: true,
        bars: rows
            .iter()
            .map(|r| {
                let value = runs.number(r, "max_stable_dt");
                let verdict = runs.get(r, "stability").unwrap_or_default();
                let mut label = label(runs, params, r, &[]);
                if verdict == "stable-to-ceiling" {
                    // The bar is the ceiling of the search, not a limit that was found.
                    label.push_str(" (>= ceiling)");
                }
                if runs
                    .get(r, "non_monotone_dt")
                    .is_some_and(|v| !v.is_empty())
                {
                    label.push_str(" (non-monotone)");
                }
                let note = match verdict {
                    "unstable-at-every-dt" => Some(match runs.number(r, "energy_growth_rate") {
                        Some(rate) => format!(
                            "unstable at every dt (energy e-folds at {}/s)",
                            crate::study::vocabulary::format::short(rate)
                        ),
                        None => "unstable at every dt".into(),
                    }),
                    _ if value.is_none() => Some(format!(
                        "no stable dt in range ({})",
                        runs.get(r, "outcome").unwrap_or("?")
                    )),
                    _ => None,
                };
                Bar {
                    label,
                    value,
                    marker: if per_bar {
                        runs.number(r, "dt_theory")
                    } else {
                        None
                    },
                    note,
                }
            })
            .collect(),
        marker_label: per_bar.then(|| "2/omega_max of the bar's physics".to_owned()),
        reference: theory.map(|t| ReferenceLine {
            label: format!(
                "2/omega_max = {} s",
                crate::study::vocabulary::format::short(t)
            ),
            value: t,
        }),
    }
}

/// Cost per simulated second against the error at the largest stable step: one point per
/// method, the headline of a stability study.
fn cost_error_chart(
    scene: &str,
    runs: &Table,
    params: &[String],
    rows: &[&Vec<String>],
) -> Option<LineChart> {
    let series: Vec<Series> = rows
        .iter()
        .filter_map(|r| {
            let error = runs.number(r, "error_at_stable_dt")?;
            let cost = runs.number(r, "cost_per_simulated_second")?;
            let mut label = label(runs, params, r, &[]);
            if let Some(dt) = runs.number(r, "max_stable_dt") {
                label.push_str(&format!(
                    " dt={}",
                    crate::study::vocabulary::format::short(dt)
                ));
            }
            if runs.get(r, "error_scored") == Some("no") {
                label.push_str(" (error within reference accuracy)");
            }
            Some(Series {
                label,
                points: vec![(error, cost)],
                ended: false,
            })
        })
        .collect();
    (!series.is_empty()).then(|| LineChart {
        title: format!("Cost against error at the largest stable step: {scene}"),
        x_label: "relative L2 position error at the largest stable dt".into(),
        y_label: "wall seconds per simulated second".into(),
        x_log: true,
        y_log: true,
        series,
    })
}
