//! Checking a study's kind and its settings tables before anything runs.

use super::config::{StudyFile, StudyKind};
use super::error::StudyError;
use super::load::Context;

/// The measured kind, after checking the kind's settings are present and sane.
pub(super) fn check_settings(file: &StudyFile, ctx: &Context) -> Result<StudyKind, StudyError> {
    if file.name.trim().is_empty()
        || file
            .name
            .chars()
            .any(|c| !(c.is_ascii_alphanumeric() || "-_.".contains(c)))
    {
        return Err(ctx.invalid(
            0,
            "name",
            format!(
                "`{}` must be a non-empty folder name of letters, digits, '-', '_' or '.'",
                file.name
            ),
        ));
    }
    let kind = match (&file.study, &file.sweep) {
        (StudyKind::Sweep, Some(sweep)) => {
            if sweep.kind == StudyKind::Sweep {
                return Err(ctx.invalid(
                    0,
                    "sweep.kind",
                    "must be trajectory, work-precision or stability",
                ));
            }
            if !file.grid.contains_key(&sweep.parameter)
                && !file
                    .methods
                    .iter()
                    .any(|m| m.get_ref().contains_key(&sweep.parameter))
            {
                return Err(StudyError::Invalid {
                    path: ctx.path.to_owned(),
                    line: ctx.line_of_key("parameter"),
                    key: "sweep.parameter".into(),
                    message: format!(
                        "`{}` is not a key of [grid]; the swept parameter must be one",
                        sweep.parameter
                    ),
                });
            }
            sweep.kind
        }
        (StudyKind::Sweep, None) => {
            return Err(ctx.invalid(
                0,
                "sweep",
                "a sweep study needs a [sweep] table with `kind` and `parameter`",
            ));
        }
        (kind, _) => *kind,
    };
    let line = |key: &str| ctx.line_of_key(key);
    let bad = |key: &str, message: String| StudyError::Invalid {
        path: ctx.path.to_owned(),
        line: line(key.rsplit('.').next().unwrap_or(key)),
        key: key.to_owned(),
        message,
    };
    match kind {
        StudyKind::Stability => {
            let Some(s) = &file.stability else {
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
            if !(s.relative_precision > 0.0 && s.relative_precision < 1.0) {
                return Err(bad(
                    "stability.relative_precision",
                    format!("must be in (0, 1) (got {})", s.relative_precision),
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
            check_reference(&s.reference, "stability", &bad)?;
        }
        StudyKind::WorkPrecision => {
            let Some(w) = &file.work_precision else {
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
            check_reference(&w.reference, "work-precision", &bad)?;
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
        }
        StudyKind::Trajectory | StudyKind::Sweep => {}
    }
    Ok(kind)
}

/// The `[<table>.reference]` settings' ranges.
fn check_reference(
    r: &super::config::ReferenceSettings,
    table: &str,
    bad: &dyn Fn(&str, String) -> StudyError,
) -> Result<(), StudyError> {
    if !(r.dt_factor.is_finite() && r.dt_factor >= 1.0) {
        return Err(bad(
            &format!("{table}.reference.dt_factor"),
            format!("must be >= 1 (got {})", r.dt_factor),
        ));
    }
    if r.dt.is_some_and(|dt| !(dt.is_finite() && dt > 0.0)) {
        return Err(bad(
            &format!("{table}.reference.dt"),
            "must be > 0 s".into(),
        ));
    }
    Ok(())
}
