//! Work-precision runs: the error of a run against a reference solution at fixed sample
//! times, next to its wall time and hardware-independent cost.
//!
//! The position error at a sample time is `|x - x_ref|` over the free DOFs, relative to the
//! reference's largest displacement `max_k |x_ref(t_k) - X|` from the rest positions X (so the
//! error is relative to how far the body moves, not to where it happens to sit), and a run's
//! error is the largest over the sample times. The energy error is
//! `|E - E_ref|` over the largest kinetic + stored energy of the reference. The reference is
//! computed twice, at its step and at half of it; their difference is the reference's own
//! accuracy, and errors below `floor_factor` times it are not scored.

use crate::study::kind::{Measure, OwnKey, Plan, Present, RunInputs, number, parse_quick};
use crate::study::present::charts::{ACCURACY_KNOBS, Emit, SceneRows, accuracy_rank, label};
use crate::study::present::findings::{self, Better, ORDER_EXCESS, Ranking};
use crate::study::present::pictures::PictureRows;
use crate::study::vocabulary::columns::{self, CAPS, SUMMARY};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::format::{cell, short};
use crate::study::vocabulary::grid::Axis;
use crate::study::vocabulary::identity::float;
use crate::study::vocabulary::measured::{Measured, build, outcome_of, picture_surface};
use crate::study::vocabulary::meter::StepMeter;
use crate::study::vocabulary::reference::{
    Reference, ScoringSettings, errors, sampled_run, stride,
};
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_core::integrate::Method;
use softbench_core::parallel::Parallelism;
use softbench_run::plot::{Chart, LineChart, PlotError, Series};
use softbench_run::scene::SceneConfig;
use std::collections::BTreeMap;
use std::fmt::Write;
use std::path::Path;
use std::sync::LazyLock;

/// A work-precision study's own columns of `runs.csv` (after the identity and parameters; the run's
/// summary and the integrator's caps follow, [`COLUMNS`]).
pub const OWN_COLUMNS: &[&str] = &[
    "dt",
    "outcome",
    "error",
    "error_final",
    "error_l2",
    "energy_error",
    "wall_seconds_min",
    "wall_seconds_max",
    "repeats",
    "repeatable",
    "scored",
    "error_unscored",
    "reference_method",
    "reference_dt",
    "reference_difference",
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
    "tets",
];

/// Every measured column of a work-precision study's `runs.csv`: its own, the run's summary
/// and the integrator's caps.
pub static COLUMNS: LazyLock<Vec<&'static str>> =
    LazyLock::new(|| columns::declare(OWN_COLUMNS, true, true));

/// A work-precision study: each run's error against a reference solution.
pub(in crate::study) struct WorkPrecision;

/// The most repeats of a run a work-precision study may ask for.
const MAX_REPEATS: usize = 100;

/// The kind's name in study files, and the key of its resolved table.
const NAME: &str = "work-precision";

/// The `[work-precision]` table of a study file (its other keys are the study's).
#[derive(serde::Deserialize)]
struct FileTable {
    #[serde(default, rename = "work-precision", alias = "work_precision")]
    table: Option<ScoringSettings>,
}

/// The `[quick]` keys a work-precision study reads.
#[derive(Default, serde::Serialize, serde::Deserialize)]
struct Quick {
    /// The horizon in quick mode.
    horizon: Option<f64>,
    /// Only the largest this many time steps of each ladder. Default 2.
    dts: Option<usize>,
}

/// The study's `[work-precision]` table as resolved at load.
fn settings(file: &StudyFile) -> Option<ScoringSettings> {
    file.settings(NAME)
}

impl Plan for WorkPrecision {
    fn name(&self) -> &'static str {
        NAME
    }

    fn description(&self) -> &'static str {
        "each run's error against a converged reference solution, next to its time and cost"
    }

    fn example(&self) -> &'static str {
        "[grid]\n\"integrator.method\" = [\"rk4\", \"backward-euler\"]\n\
         \"run.dt\" = [0.002, 0.001]\n\n\
         [work-precision]\nhorizon = 0.04\nsamples = 2\n"
    }

    fn table_names(&self) -> &'static [&'static str] {
        &["work-precision", "work_precision"]
    }

    fn parse_table(&self, text: &str) -> Result<serde_json::Value, toml::de::Error> {
        let file: FileTable = toml::from_str(text)?;
        Ok(serde_json::to_value(&file.table).unwrap_or_default())
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
        &["horizon", "dts"]
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
        if file.quick.get::<usize>("dts") == Some(0) {
            return Err(bad("quick.dts", "must be at least 1".into()));
        }
        if let Some(h) = file.quick.get::<f64>("horizon")
            && !(h.is_finite() && h > 0.0)
        {
            return Err(bad("quick.horizon", format!("must be > 0 s (got {h})")));
        }
        Ok(())
    }

    /// `[quick]` shortens the `[work-precision]` table's horizon.
    fn quick_table(&self, file: &mut StudyFile, _: &Context) -> Result<(), StudyError> {
        if let Some(mut w) = settings(file) {
            w.horizon = file.quick.get::<f64>("horizon").unwrap_or(w.horizon);
            file.set_settings(NAME, &w);
        }
        Ok(())
    }

    fn quick_axes(&self, file: &StudyFile, method_axes: &mut [Vec<Axis>]) {
        quick_axes(file, method_axes);
    }

    fn configure(
        &self,
        ctx: &Context,
        file: &StudyFile,
        config: &mut SceneConfig,
        axes: &[Axis],
        quick: bool,
    ) -> Result<(), StudyError> {
        configure(ctx, file, config, axes, quick)
    }

    fn own_keys(&self) -> &'static [OwnKey] {
        &[
            OwnKey {
                key: "run.steps",
                why: "every run covers [work-precision] horizon, in horizon / dt steps of its \
                      run.dt from the dt ladder",
                replaced: true,
            },
            OwnKey {
                key: "run.sample_every",
                why: "rows are kept at every sample time and in between as densely as 500 rows \
                      allow",
                replaced: true,
            },
        ]
    }

    fn horizon(&self, file: &StudyFile) -> Option<(f64, &'static str)> {
        settings(file).map(|w| {
            (
                w.horizon,
                "horizon / dt steps of each run.dt of the dt ladder",
            )
        })
    }

    /// Every repeat runs the whole trajectory again.
    fn estimated_steps(&self, file: &StudyFile, config: &SceneConfig) -> f64 {
        config.run.steps as f64 * settings(file).map_or(1, |w| w.repeats) as f64
    }
}

impl Measure for WorkPrecision {
    fn columns(&self) -> &'static [&'static str] {
        &COLUMNS
    }

    fn own_columns(&self) -> &'static [&'static str] {
        OWN_COLUMNS
    }

    fn progress(&self, m: &Measured) -> Option<String> {
        number(m, "error").map(|e| format!(", error {e}"))
    }

    fn needs_omega(&self, file: &StudyFile) -> bool {
        settings(file).is_some_and(|w| w.reference.method.is_none() && !w.reference.same_dt)
    }

    fn reference_settings(&self, file: &StudyFile, _: &RunSpec) -> Option<ScoringSettings> {
        settings(file)
    }

    fn reference_dt(&self, study: &Study, w: &ScoringSettings, spec: &RunSpec) -> f64 {
        reference_dt(study, w, spec)
    }

    fn measure(
        &self,
        study: &Study,
        spec: &RunSpec,
        inputs: &RunInputs,
        parallelism: Parallelism,
    ) -> Result<Measured, String> {
        let settings = settings(&study.file).ok_or("no [work-precision] table")?;
        let reference = inputs.reference.ok_or("no reference solution")?;
        measure_with(spec, &settings, reference, parallelism, true, inputs.meter)
    }
}

impl Present for WorkPrecision {
    fn summary_columns(&self) -> &'static [&'static str] {
        &[
            "dt",
            "outcome",
            "error",
            "energy_error",
            "wall_seconds",
            "force_evaluations",
            "hessian_evaluations",
            "factorizations",
            "linear_iterations",
            "newton_unconverged_steps",
        ]
    }

    fn sweep_metrics(&self) -> &'static [&'static str] {
        &["error", "wall_seconds"]
    }

    fn quick_notice(&self) -> &'static str {
        "the horizon and the dt ladders are shortened"
    }

    /// An error within the reference's own accuracy is listed, though the run completed.
    fn flagged(&self, runs: &Table, row: &[String]) -> bool {
        self.unscored(runs, row) && findings::completed(runs, row)
    }

    fn report_settings(&self, out: &mut String, file: &StudyFile) {
        report_settings(out, file);
    }

    fn report_findings(
        &self,
        out: &mut String,
        runs: &Table,
        _: &crate::study::vocabulary::meta::StudyMeta,
    ) {
        orders(out, runs);
    }

    fn scene_charts(&self, s: &SceneRows, _: &Path, emit: &mut Emit) -> Result<(), PlotError> {
        scene_charts(s, emit)
    }

    /// Cost, energy drift among the runs close to the reference, and error at equal cost.
    fn rankings(&self, s: &SceneRows, damped: Option<&str>) -> Vec<Ranking> {
        let has = |c: &str| s.runs.column(c).is_some();
        let mut out = Vec::new();
        if has("wall_seconds") && has("final_time") {
            out.extend(findings::cost_per_simulated_second(s));
        }
        if has("energy_drift_max") {
            out.extend(drift_near_the_reference(s, damped));
        }
        if has("error") && has("wall_seconds") {
            out.extend(error_at_equal_cost(s.runs, s.params, s.scene, s.rows));
        }
        out
    }

    /// Observed orders more than [`ORDER_EXCESS`] above the method's formal order.
    fn table_warnings(&self, runs: &Table) -> Vec<String> {
        let mut out = Vec::new();
        for (scene, line, order) in observed_orders(runs) {
            let method = line.split(' ').next().unwrap_or_default();
            if let Ok(m) = method.parse::<Method>() {
                let theory = f64::from(m.order());
                if order > theory + ORDER_EXCESS {
                    out.push(format!(
                        "{scene}, {line}: observed order {order:.2} is more than {ORDER_EXCESS} \
                         above its formal order {theory}: its errors are not in the asymptotic \
                         range (or are at the reference's noise), so this order is not a \
                         measurement of the method."
                    ));
                }
            }
        }
        out
    }

    fn unit_notes(&self, _: &Table, shown: &dyn Fn(&str) -> bool) -> Vec<String> {
        shown("error")
            .then(|| "errors relative to the reference's displacement".to_owned())
            .into_iter()
            .collect()
    }

    fn unscored(&self, runs: &Table, row: &[String]) -> bool {
        runs.get(row, "scored") == Some("no")
    }

    /// (It draws no time histories, the default: its runs differ only in accuracy.)
    fn phases_at_smallest_dt(&self) -> bool {
        true
    }

    fn picture_rows(&self) -> PictureRows {
        PictureRows::LeastAccuratePerLine
    }
}

/// Error against wall time, time per step, cost and dt (and local-solver iterations where
/// there are any), one line per method.
fn scene_charts(s: &SceneRows, emit: &mut Emit) -> Result<(), PlotError> {
    let iterative = s.rows.iter().any(|r| {
        s.runs
            .number(r, "local_iterations_per_step")
            .is_some_and(|n| n > 0.0)
    });
    // One step for every run: error against dt would be a vertical line of points.
    let mut dts = s.rows.iter().filter_map(|r| s.runs.number(r, "dt"));
    let first = dts.next();
    let one_dt = dts.all(|dt| Some(dt) == first);
    for (x, x_label, what) in [
        ("wall_seconds", "wall time (s)", "time"),
        (
            "step_seconds_median",
            "median wall time per step (s)",
            "step-time",
        ),
        ("cost", "force + Hessian evaluations", "cost"),
        ("dt", "time step dt (s)", "dt"),
        (
            "local_iterations_per_step",
            "local-solver iterations per step",
            "iterations",
        ),
    ] {
        if what == "iterations" && !iterative {
            continue;
        }
        if what == "dt" && one_dt {
            continue;
        }
        emit(
            format!("work-precision-{what}-{}", s.slug),
            &format!(
                "Position error against the reference versus {x_label} (log-log), one line per \
                 method; unscored and failed runs are left out."
            ),
            Chart::Line(work_precision_chart(
                s.scene, s.runs, s.params, s.rows, x, x_label,
            )),
        )?;
    }
    Ok(())
}

/// The `[work-precision]` table is present and sane, and the study sweeps dt.
fn check(
    file: &StudyFile,
    ctx: &Context,
    bad: &dyn Fn(&str, String) -> StudyError,
) -> Result<(), StudyError> {
    let Some(w) = &settings(file) else {
        return Err(ctx.invalid(
            0,
            "work-precision",
            "a work-precision study needs a [work-precision] table with `horizon`",
        ));
    };
    if !(w.horizon.is_finite() && w.horizon > 0.0) {
        return Err(bad(
            "work-precision.horizon",
            format!("must be > 0 s (got {})", w.horizon),
        ));
    }
    if w.samples == 0 {
        return Err(bad("work-precision.samples", "must be at least 1".into()));
    }
    if !(1..=MAX_REPEATS).contains(&w.repeats) {
        return Err(bad(
            "work-precision.repeats",
            format!("must be from 1 to {MAX_REPEATS} (got {})", w.repeats),
        ));
    }
    crate::study::vocabulary::settings::check_samples(w.samples, "work-precision.samples", &bad)?;
    crate::study::vocabulary::settings::check_reference(&w.reference, NAME, true, &bad)?;
    crate::study::vocabulary::settings::check_phases(&w.phases, w.horizon, w.samples, NAME, &bad)?;
    if !file.grid.contains_key("run.dt")
        && !file
            .methods
            .iter()
            .any(|m| m.get_ref().contains_key("run.dt"))
    {
        return Err(ctx.invalid(
            0,
            "grid",
            "a work-precision study sweeps the time step: add \"run.dt\" = [..] to [grid]",
        ));
    }
    Ok(())
}

/// Quick mode keeps the largest steps of each ladder (the global one and each method's own).
fn quick_axes(file: &StudyFile, method_axes: &mut [Vec<Axis>]) {
    let keep = file.quick.get::<usize>("dts").unwrap_or(2).max(1);
    for axis in method_axes
        .iter_mut()
        .flatten()
        .filter(|a| a.key == "run.dt")
    {
        axis.values.sort_by(|a, b| float(b).total_cmp(&float(a)));
        axis.values.truncate(keep);
    }
}

/// A run covers the horizon in whole sample intervals, with rows at every sample time.
fn configure(
    ctx: &Context,
    file: &StudyFile,
    config: &mut SceneConfig,
    axes: &[Axis],
    _quick: bool,
) -> Result<(), StudyError> {
    // It judges methods, so by default an unconverged Newton solve fails the step instead of
    // being accepted.
    if settings(file).is_some_and(|w| w.require_newton_convergence) {
        config.integrator.newton.require_convergence = true;
    }
    check_step_fits(ctx, file, config, axes)?;
    let w = settings(file).expect("checked");
    // The steps are counted in f64 and checked against the budget before any integer is made
    // of them (a cast saturates, a product wraps, and a loop up to the stride never ends).
    let per_sample = (w.horizon / w.samples as f64 / config.run.dt).round();
    let steps = per_sample * w.samples as f64;
    softbench_core::limits::STEPS
        .check((steps.is_finite() && steps < u64::MAX as f64).then_some(steps as u64))
        .map_err(|e| {
            let line = axes
                .iter()
                .find(|a| a.key == "run.dt")
                .map_or(1, |a| a.line);
            StudyError::Invalid {
                path: ctx.path.to_owned(),
                line,
                key: "grid.\"run.dt\"".into(),
                message: format!(
                    "dt = {:e} s over the horizon {} s: {e}",
                    config.run.dt, w.horizon
                ),
            }
        })?;
    let stride = per_sample as usize;
    config.run.steps = stride * w.samples;
    // Rows at every sample time, and in between as densely as 500 rows allow: the smallest
    // divisor d of the stride with steps / d <= 500 (none below steps / 501 + 1 can be).
    let first = config.run.steps / 501 + 1;
    config.run.sample_every = (first.min(stride)..=stride)
        .find(|d| stride.is_multiple_of(*d) && config.run.steps / d <= 500)
        .unwrap_or(stride);
    Ok(())
}

/// The reference step for the physics of `spec`: as set, or the smallest dt of the grid over
/// `dt_factor`.
fn reference_dt(study: &Study, w: &ScoringSettings, spec: &RunSpec) -> f64 {
    if w.reference.same_dt {
        return spec.loaded.config.run.dt;
    }
    w.reference.dt.unwrap_or_else(|| {
        let smallest = study
            .runs
            .iter()
            .filter(|r| r.physics == spec.physics)
            .map(|r| r.loaded.config.run.dt)
            .fold(f64::INFINITY, f64::min);
        smallest / w.reference.dt_factor
    })
}

/// A work-precision run's horizon and sample times must be whole numbers of its steps.
fn check_step_fits(
    ctx: &Context,
    file: &StudyFile,
    config: &SceneConfig,
    axes: &[Axis],
) -> Result<(), StudyError> {
    let w = settings(file).expect("checked");
    let dt = config.run.dt;
    let interval = w.horizon / w.samples as f64;
    let per_sample = interval / dt;
    if (per_sample - per_sample.round()).abs() > 1e-6 * per_sample.max(1.0) || per_sample < 0.5 {
        let line = axes
            .iter()
            .find(|a| a.key == "run.dt")
            .map_or(1, |a| a.line);
        return Err(StudyError::Invalid {
            path: ctx.path.to_owned(),
            line,
            key: "grid.\"run.dt\"".into(),
            message: format!(
                "dt = {dt} s does not divide the sample interval horizon / samples = {interval} s; \
                 errors are measured at whole steps, so choose dt values that divide it"
            ),
        });
    }
    Ok(())
}

/// Run one work-precision run and score it against `reference`.
pub fn measure(
    spec: &RunSpec,
    settings: &ScoringSettings,
    reference: &Reference,
    parallelism: Parallelism,
) -> Result<Measured, String> {
    measure_with(spec, settings, reference, parallelism, true, None)
}

/// [`measure`], recording the snapshots the pictures are drawn from only with `pictures` and
/// counting the steps of every repeat on `meter`; the `tets` cell says how many elastic tets
/// the body has.
pub(in crate::study) fn measure_with(
    spec: &RunSpec,
    settings: &ScoringSettings,
    reference: &Reference,
    parallelism: Parallelism,
    pictures: bool,
    meter: Option<&StepMeter>,
) -> Result<Measured, String> {
    let mut scene = build(spec, parallelism).map_err(|e| e.to_string())?;
    let run = scene.config.run;
    let tets = scene.model.elastic_elements().map_or(0, |e| e.tets.len());
    let surface = if pictures {
        picture_surface(&scene, spec)?
    } else {
        None
    };
    let (summary, rows, snapshots, pictures) =
        sampled_run(&mut scene, &run, stride(settings, run.dt), surface, meter);
    let (outcome, message) = outcome_of(&summary.outcome);
    let mut m = Measured {
        outcome,
        message,
        cells: SUMMARY.cells(&summary),
        series: rows,
        snapshots: pictures,
        ..Measured::default()
    };
    m.cells.extend(CAPS.cells(spec));
    m.set("tets", tets.to_string());
    repeat(
        spec,
        settings,
        parallelism,
        &summary,
        &snapshots,
        &mut m,
        meter,
    )?;
    m.set("dt", cell(Some(run.dt)));
    m.set("reference_method", reference.method.name().to_owned());
    m.set("reference_dt", cell(Some(reference.dt)));
    m.set("reference_difference", cell(Some(reference.difference)));
    let floor = settings.reference.floor_factor * reference.difference;
    match errors(&snapshots, &reference.snapshots, &reference.rest) {
        Some((error, energy)) if summary.outcome.is_completed() => {
            let scored = error > floor;
            m.set("scored", if scored { "yes" } else { "no" }.into());
            m.set("error", cell(scored.then_some(error)));
            m.set(
                "error_final",
                cell(
                    crate::study::vocabulary::reference::final_error(
                        &snapshots,
                        &reference.snapshots,
                        &reference.rest,
                    )
                    .filter(|_| scored),
                ),
            );
            m.set(
                "error_l2",
                cell(reference.relative_l2_error(&snapshots.q).filter(|_| scored)),
            );
            m.set("error_unscored", cell((!scored).then_some(error)));
            m.set("energy_error", cell(Some(energy)));
            crate::study::vocabulary::reference::set_phase_cells(&mut m, reference, &snapshots.q);
            if !scored {
                m.message = format!(
                    "error {error:.3e} is below {} x the reference's own difference {:.3e}: \
                     not scored",
                    settings.reference.floor_factor, reference.difference
                );
            }
        }
        _ => m.set("scored", "no".into()),
    }
    Ok(m)
}

/// Run `spec` `settings.repeats - 1` more times: `wall_seconds` becomes the median over all
/// runs, with `wall_seconds_min` and `_max`, and `repeatable` says whether every repeat
/// ended in the same state at every sample time, bit for bit.
fn repeat(
    spec: &RunSpec,
    settings: &ScoringSettings,
    parallelism: Parallelism,
    first: &softbench_run::run::RunSummary,
    snapshots: &crate::study::vocabulary::reference::Snapshots,
    m: &mut Measured,
    meter: Option<&StepMeter>,
) -> Result<(), String> {
    let mut seconds = vec![first.totals.times.total];
    let mut repeatable = true;
    for _ in 1..settings.repeats {
        let mut scene = build(spec, parallelism).map_err(|e| e.to_string())?;
        let run = scene.config.run;
        let (summary, _, again, _) =
            sampled_run(&mut scene, &run, stride(settings, run.dt), None, meter);
        seconds.push(summary.totals.times.total);
        repeatable &= again.q == snapshots.q && summary.outcome == first.outcome;
    }
    seconds.sort_by(f64::total_cmp);
    let n = seconds.len();
    let median = if n % 2 == 1 {
        seconds[n / 2]
    } else {
        0.5 * (seconds[n / 2 - 1] + seconds[n / 2])
    };
    m.set("repeats", n.to_string());
    m.set("wall_seconds", cell(Some(median)));
    m.set("wall_seconds_min", cell(Some(seconds[0])));
    m.set("wall_seconds_max", cell(Some(seconds[n - 1])));
    m.set("repeatable", if repeatable { "yes" } else { "no" }.into());
    Ok(())
}

/// The report's paragraph on the work-precision settings.
fn report_settings(out: &mut String, file: &StudyFile) {
    if let Some(w) = &settings(file) {
        let _ = writeln!(
            out,
            "Work-precision: horizon {} s, errors at {} sample times (the largest is reported, \
             and the final one as `error_final`); wall time the median of {} run(s). \
             Newton convergence {}.\n",
            short(w.horizon),
            w.samples,
            w.repeats,
            if w.require_newton_convergence {
                "is required"
            } else {
                "is **not** required: unconverged steps are accepted and counted"
            }
        );
    }
}

/// Observed order of each line of a work-precision study: the slope of log(error) against
/// log(dt) between its two smallest scored time steps.
fn orders(out: &mut String, runs: &Table) {
    let mut text = String::new();
    for (scene, method, order) in observed_orders(runs) {
        let _ = writeln!(text, "| {scene} | {method} | {order:.2} |");
    }
    if !text.is_empty() {
        let _ = writeln!(
            out,
            "Observed order (slope of log error against log dt between the two smallest scored \
             steps; adaptive methods, whose dt is only an output interval, are left out):\n\n| scene | method | order |\n|---|---|---|\n{text}"
        );
    }
}

/// Error against `x` (a column, or `cost`: force + Hessian evaluations), one line per
/// method from its cheapest setting to its most accurate.
fn work_precision_chart(
    scene: &str,
    runs: &Table,
    params: &[String],
    rows: &[&Vec<String>],
    x: &str,
    x_label: &str,
) -> LineChart {
    // Points carry their accuracy rank, so a line runs from the cheapest setting to the most
    // accurate one whatever the noise in its x (wall times on a busy machine).
    let mut lines: BTreeMap<String, Vec<(f64, f64, f64)>> = BTreeMap::new();
    for r in rows {
        let Some(error) = runs.number(r, "error") else {
            continue;
        };
        let xv = if x == "cost" {
            runs.number(r, "force_evaluations")
                .zip(runs.number(r, "hessian_evaluations"))
                .map(|(f, h)| f + h)
        } else {
            runs.number(r, x)
        };
        if let Some(xv) = xv {
            lines
                .entry(label(runs, params, r, &ACCURACY_KNOBS))
                .or_default()
                .push((accuracy_rank(runs, r), xv, error));
        }
    }
    LineChart {
        title: format!("Work-precision, error against {x_label}: {scene}"),
        x_label: x_label.into(),
        y_label: "relative position error".into(),
        x_log: true,
        y_log: true,
        series: lines
            .into_iter()
            .map(|(label, mut points)| {
                points.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
                let points = points.into_iter().map(|(_, x, e)| (x, e)).collect();
                Series {
                    label,
                    points,
                    ended: false,
                }
            })
            .collect(),
    }
}

/// The observed order of each (scene, method, solver) line of a work-precision study: the
/// slope of log error against log dt between the two smallest steps with a scored error.
/// Adaptive methods (dt is only their output interval) are left out.
pub(in crate::study) fn observed_orders(runs: &Table) -> Vec<(String, String, f64)> {
    let mut lines: BTreeMap<(String, String), Vec<(f64, f64)>> = BTreeMap::new();
    for r in &runs.rows {
        let method = runs.get(r, "method").unwrap_or_default();
        if Method::from_name(method).is_ok_and(|m| m.is_adaptive()) {
            continue;
        }
        if let (Some(dt), Some(e)) = (runs.number(r, "dt"), runs.number(r, "error")) {
            let solver = runs.get(r, "linear_solver").unwrap_or_default();
            let name = if solver.is_empty() || solver == "-" {
                method.to_owned()
            } else {
                format!("{method} {solver}")
            };
            let scene = runs.get(r, "scene").unwrap_or_default().to_owned();
            lines.entry((scene, name)).or_default().push((dt, e));
        }
    }
    let mut out = Vec::new();
    for ((scene, method), mut points) in lines {
        if points.len() < 2 {
            continue;
        }
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        // Points at one dt differ by another knob (iterations, a tolerance): no order in dt.
        if points.windows(2).any(|w| w[0].0 == w[1].0) {
            continue;
        }
        let ((d1, e1), (d2, e2)) = (points[0], points[1]);
        out.push((scene, method, (e2 / e1).ln() / (d2 / d1).ln()));
    }
    out
}

/// Error at equal cost in one scene: every method line's (its label without the accuracy
/// knobs: [`ACCURACY_KNOBS`]) log error interpolated in log cost at one cost, the geometric
/// middle of the cost interval that the most lines' measured ranges share; a line whose range
/// misses it is left out with its range. `None` when no two lines share a cost.
fn error_at_equal_cost(
    runs: &Table,
    params: &[String],
    scene: &str,
    rows: &[&Vec<String>],
) -> Option<Ranking> {
    let mut lines: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    let mut left_out = Vec::new();
    for r in rows {
        let name = label(runs, params, r, &ACCURACY_KNOBS);
        match (runs.number(r, "wall_seconds"), runs.number(r, "error")) {
            (Some(c), Some(e)) if c > 0.0 && e > 0.0 && findings::completed(runs, r) => {
                lines.entry(name).or_default().push((c, e))
            }
            _ => {
                lines.entry(name).or_default();
            }
        }
    }
    let mut ranges = Vec::new();
    for (name, pts) in &mut lines {
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        if pts.len() < 2 {
            left_out.push((name.clone(), "fewer than two scored runs".to_owned()));
        } else {
            ranges.push((pts[0].0, pts[pts.len() - 1].0));
        }
    }
    // The interval between consecutive range ends that the most ranges cover (the cheapest
    // of equals), and its geometric middle.
    let mut ends: Vec<f64> = ranges.iter().flat_map(|r| [r.0, r.1]).collect();
    ends.sort_by(f64::total_cmp);
    let covering = |lo: f64, hi: f64| ranges.iter().filter(|r| r.0 <= lo && hi <= r.1).count();
    let (lo, hi) = ends
        .windows(2)
        .map(|w| (w[0], w[1]))
        .chain(ends.iter().map(|&e| (e, e)))
        // Most lines, then an interval rather than a single cost, then the cheapest.
        .max_by_key(|&(lo, hi)| (covering(lo, hi), hi > lo, std::cmp::Reverse(lo.to_bits())))?;
    if covering(lo, hi) < 2 {
        return None;
    }
    let cost = (lo * hi).sqrt();
    let mut ranked = Vec::new();
    for (name, pts) in &lines {
        if pts.len() < 2 {
            continue;
        }
        let Some(i) = pts
            .windows(2)
            .position(|w| w[0].0 <= cost && cost <= w[1].0)
        else {
            left_out.push((
                name.clone(),
                format!(
                    "its runs cost {} to {} s, not {} s",
                    short(pts[0].0),
                    short(pts[pts.len() - 1].0),
                    short(cost)
                ),
            ));
            continue;
        };
        let ((c0, e0), (c1, e1)) = (pts[i], pts[i + 1]);
        let s = if c1 > c0 {
            (cost / c0).ln() / (c1 / c0).ln()
        } else {
            0.0
        };
        ranked.push((name.clone(), (e0.ln() + s * (e1.ln() - e0.ln())).exp()));
    }
    ranked.sort_by(|a, b| a.1.total_cmp(&b.1));
    Some(Ranking {
        scene: scene.to_owned(),
        metric: format!(
            "error at equal cost (interpolated in log-log at {} s of wall time, inside the \
             measured range of every line ranked)",
            short(cost)
        ),
        better: Better::Smaller,
        spreads: vec![None; ranked.len()],
        ranked,
        left_out,
    })
}

/// How far (relative position and energy error) a run may be from the reference for its
/// energy drift to be ranked: a method that conserves energy while converging to another
/// answer (XPBD at 14 % from the converged step) is not "best" by drift.
pub const DRIFT_RANKED_WITHIN: f64 = 0.01;

/// Energy drift among the runs whose scored errors against the reference, position and
/// energy, are both within [`DRIFT_RANKED_WITHIN`]; the others are left out with their error.
fn drift_near_the_reference(s: &SceneRows, damped: Option<&str>) -> Option<Ranking> {
    let runs = s.runs;
    let among = format!(
        ", among runs within {} of the reference (position and energy)",
        short(DRIFT_RANKED_WITHIN)
    );
    findings::energy_drift_of(s, damped, &among, &|r| {
        if runs.get(r, "scored") == Some("no") {
            return Ok(());
        }
        let error = |c: &str| runs.number(r, c);
        match (error("error"), error("energy_error")) {
            (Some(e), _) if e > DRIFT_RANKED_WITHIN => {
                Err(format!("error {} from the reference", short(e)))
            }
            (_, Some(e)) if e > DRIFT_RANKED_WITHIN => {
                Err(format!("energy error {} from the reference", short(e)))
            }
            (None, _) => Err("error not measured".into()),
            _ => Ok(()),
        }
    })
}
