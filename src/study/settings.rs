//! Checking a study's kind and its settings tables before anything runs.

use super::config::{StudyFile, StudyKind};
use super::context::Context;
use super::error::StudyError;

/// Longest study name: it is a folder name, and run ids and file names are built from it.
pub const MAX_NAME: usize = 100;

/// A study name is the name of its results folder under `--out`: letters, digits, '-', '_'
/// and '.', not starting with '.' (so never `.` or `..`, which would write into `--out` itself
/// or its parent), at most [`MAX_NAME`] characters.
pub fn check_name(name: &str) -> Result<(), String> {
    let shown = crate::quote::clip_message(name);
    if name.is_empty()
        || name
            .chars()
            .any(|c| !(c.is_ascii_alphanumeric() || "-_.".contains(c)))
    {
        return Err(format!(
            "`{shown}` must be a non-empty folder name of letters, digits, '-', '_' or '.'"
        ));
    }
    if name.starts_with('.') {
        return Err(format!(
            "`{shown}` must not start with '.': the study's folder must be a new folder inside \
             --out (`.` would be --out itself, `..` its parent)"
        ));
    }
    if name.len() > MAX_NAME {
        return Err(format!(
            "is {} characters long; at most {MAX_NAME} (it names a folder)",
            name.len()
        ));
    }
    Ok(())
}

/// The measured kind, after checking the kind's settings are present and sane.
pub(super) fn check_settings(file: &StudyFile, ctx: &Context) -> Result<StudyKind, StudyError> {
    check_name(&file.name).map_err(|m| ctx.invalid(0, "name", m))?;
    // The sweep's own table (its kind, parameter and metrics) is about the sweep, not a kind,
    // so it is checked here; the measured kind then checks its own table.
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
            let columns = super::kinds::spec(sweep.kind).columns;
            if let Some(unknown) = sweep
                .metrics
                .iter()
                .find(|m| !columns.contains(&m.as_str()))
            {
                return Err(StudyError::Invalid {
                    path: ctx.path.to_owned(),
                    line: ctx.line_of_key("metrics"),
                    key: "sweep.metrics".into(),
                    message: crate::names::unknown_name_message(
                        &format!("{} metric", sweep.kind.name()),
                        unknown,
                        columns,
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
    (super::kinds::spec(kind).check)(file, ctx, &bad)?;
    check_quick(file, &bad)?;
    Ok(kind)
}

/// The `[<table>.reference]` settings' ranges.
pub(super) fn check_reference(
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
    if r.same_dt && table != "work-precision" {
        return Err(bad(
            &format!("{table}.reference.same_dt"),
            "only a work-precision study compares runs with a reference at their own dt".into(),
        ));
    }
    if r.same_dt && r.dt.is_some() {
        return Err(bad(
            &format!("{table}.reference.dt"),
            "with same_dt = true the reference runs at each run's own dt; remove `dt`".into(),
        ));
    }
    if !(r.newton_tolerance.is_finite() && r.newton_tolerance > 0.0) {
        return Err(bad(
            &format!("{table}.reference.newton_tolerance"),
            format!("must be > 0 (got {})", r.newton_tolerance),
        ));
    }
    Ok(())
}

/// Finest bisection precision of a stability study: well above f64 resolution, so the
/// bracket always closes.
pub const MIN_RELATIVE_PRECISION: f64 = 1e-9;

/// `[quick]`, checked whether or not `--quick` is given, so a study file is valid or not.
fn check_quick(
    file: &StudyFile,
    bad: &dyn Fn(&str, String) -> StudyError,
) -> Result<(), StudyError> {
    let q = &file.quick;
    for (key, value) in [
        ("quick.steps", q.steps),
        ("quick.max_steps", q.max_steps),
        ("quick.dts", q.dts),
    ] {
        if value == Some(0) {
            return Err(bad(key, "must be at least 1".into()));
        }
    }
    if let Some(h) = q.horizon
        && !(h.is_finite() && h > 0.0)
    {
        return Err(bad("quick.horizon", format!("must be > 0 s (got {h})")));
    }
    if let Some(p) = q.relative_precision
        && !(MIN_RELATIVE_PRECISION..1.0).contains(&p)
    {
        return Err(bad(
            "quick.relative_precision",
            format!("must be in [{MIN_RELATIVE_PRECISION:e}, 1) (got {p})"),
        ));
    }
    Ok(())
}
