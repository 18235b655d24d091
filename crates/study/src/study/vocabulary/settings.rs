//! Checks of a study's settings that every kind shares: its name (a folder name) and the
//! ranges of a `reference` table.

use crate::study::vocabulary::error::StudyError;

/// Longest study name: it is a folder name, and run ids and file names are built from it.
pub const MAX_NAME: usize = 100;

/// A study name is the name of its results folder under `--out`: letters, digits, '-', '_'
/// and '.', not starting with '.' (so never `.` or `..`, which would write into `--out` itself
/// or its parent), at most [`MAX_NAME`] characters.
pub fn check_name(name: &str) -> Result<(), String> {
    let shown = softbench_core::quote::clip_message(name);
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

/// The `[<table>.reference]` settings' ranges.
pub(in crate::study) fn check_reference(
    r: &crate::study::vocabulary::reference::ReferenceSettings,
    table: &str,
    allows_same_dt: bool,
    bad: &dyn Fn(&str, String) -> StudyError,
) -> Result<(), StudyError> {
    if !(r.dt_factor.is_finite() && r.dt_factor >= 1.0) {
        return Err(bad(
            &format!("{table}.reference.dt_factor"),
            format!("must be >= 1 (got {})", r.dt_factor),
        ));
    }
    let max_modes = crate::study::vocabulary::reference::MAX_MODES;
    if r.modes > max_modes {
        return Err(bad(
            &format!("{table}.reference.modes"),
            format!(
                "must be at most {max_modes} (got {}; 0 measures no modal error)",
                r.modes
            ),
        ));
    }
    if r.dt.is_some_and(|dt| !(dt.is_finite() && dt > 0.0)) {
        return Err(bad(
            &format!("{table}.reference.dt"),
            "must be > 0 s".into(),
        ));
    }
    if r.same_dt && !allows_same_dt {
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
    if let Some(i) = &r.independent {
        if !(i.dt.is_finite() && i.dt > 0.0) {
            return Err(bad(
                &format!("{table}.reference.independent.dt"),
                format!("must be > 0 s (got {})", i.dt),
            ));
        }
        if r.same_dt {
            return Err(bad(
                &format!("{table}.reference.independent"),
                "with same_dt = true the reference is checked against a tighter solve at the \
                 runs' own dt; remove `independent`"
                    .into(),
            ));
        }
    }
    if !(r.newton_tolerance.is_finite() && r.newton_tolerance > 0.0) {
        return Err(bad(
            &format!("{table}.reference.newton_tolerance"),
            format!("must be > 0 (got {})", r.newton_tolerance),
        ));
    }
    Ok(())
}

/// A sample count (`work-precision.samples`, `stability.error_samples`) within
/// [`softbench_core::limits::SAMPLES`], checked before anything loops over the sample times.
pub(in crate::study) fn check_samples(
    samples: usize,
    key: &str,
    bad: &dyn Fn(&str, String) -> StudyError,
) -> Result<(), StudyError> {
    softbench_core::limits::SAMPLES
        .check_usize(Some(samples))
        .map_err(|e| bad(key, e.to_string()))
}

/// Steps of a reference (or run) over `horizon` at `dt`, twice when `halved` (a reference is
/// also run at dt / 2), within [`softbench_core::limits::STEPS`].
pub(in crate::study) fn check_steps(
    horizon: f64,
    dt: f64,
    halved: bool,
) -> Result<(), softbench_core::limits::OverBudget> {
    let dt = if halved { dt / 2.0 } else { dt };
    softbench_core::limits::STEPS.check(softbench_core::limits::steps_of(horizon, dt))
}

/// `phases` (see [`crate::study::vocabulary::reference::ScoringSettings::phases`]): at most `MAX_PHASES`
/// windows `0 <= start < end <= horizon`, each holding a sample time `horizon k / samples`.
pub(in crate::study) fn check_phases(
    phases: &[[f64; 2]],
    horizon: f64,
    samples: usize,
    table: &str,
    bad: &dyn Fn(&str, String) -> StudyError,
) -> Result<(), StudyError> {
    use crate::study::vocabulary::reference::MAX_PHASES;
    let key = format!("{table}.phases");
    if phases.len() > MAX_PHASES {
        return Err(bad(
            &key,
            format!("at most {MAX_PHASES} phases (got {})", phases.len()),
        ));
    }
    for &[start, end] in phases {
        if !(start.is_finite() && end.is_finite() && 0.0 <= start && start < end && end <= horizon)
        {
            return Err(bad(
                &key,
                format!(
                    "each phase is [start, end] with 0 <= start < end <= horizon = {horizon} s \
                     (got [{start}, {end}])"
                ),
            ));
        }
        let holds = (1..=samples).any(|k| {
            let t = horizon * k as f64 / samples as f64;
            let eps = 1e-9 * end.abs().max(1.0);
            t > start + eps && t <= end + eps
        });
        if !holds {
            return Err(bad(
                &key,
                format!(
                    "the phase [{start}, {end}] s holds none of the {samples} sample times \
                     (every {} s): widen it or raise the sample count",
                    horizon / samples.max(1) as f64
                ),
            ));
        }
    }
    Ok(())
}
