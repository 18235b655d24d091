//! The work-precision study kind, planning a study: its settings table and `[quick]` keys, its
//! checks and how each run is adapted.

use super::{NAME, WorkPrecision, settings};
use crate::study::kind::{OwnKey, Plan, parse_quick};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::grid::Axis;
use crate::study::vocabulary::identity::float;
use crate::study::vocabulary::reference::ScoringSettings;
use softbench_run::scene::SceneConfig;

/// The most repeats of a run a work-precision study may ask for.
const MAX_REPEATS: usize = 100;

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
