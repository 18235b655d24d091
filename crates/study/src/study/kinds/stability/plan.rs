//! The stability study kind, planning a study: its settings table and `[quick]` keys, its
//! checks and how each run is adapted.

use super::{NAME, Stability, StabilitySettings, settings};
use crate::study::kind::{OwnKey, Plan, parse_quick};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::grid::Axis;
use softbench_run::scene::SceneConfig;

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
    /// The scan's steps per decade (default: the study's, at most 3).
    scan_per_decade: Option<f64>,
    /// Refused: a stability study keeps its horizon (see `check_quick`).
    horizon: Option<f64>,
    /// Refused: a stability study keeps its judged range (see `check_quick`).
    max_steps: Option<usize>,
}

/// Quick mode's default bisection precision and error-tolerance precision.
const QUICK_PRECISION: f64 = 0.1;

const QUICK_ERROR_DT_PRECISION: f64 = 0.5;

/// Quick mode's default scan density (steps per decade) at most.
const QUICK_SCAN_PER_DECADE: f64 = 3.0;

impl Plan for Stability {
    fn name(&self) -> &'static str {
        NAME
    }

    fn description(&self) -> &'static str {
        "each run's stable time steps over a horizon, scanned over the whole judged range and \
         every change bisected, and its cost and error at its largest stable step"
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
            "scan_per_decade",
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
        if let Some(n) = file.quick.get::<f64>("scan_per_decade")
            && !(n.is_finite() && (1.0..=100.0).contains(&n))
        {
            return Err(bad(
                "quick.scan_per_decade",
                format!("must be in [1, 100] steps per decade (got {n})"),
            ));
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

    /// The scan's trials, each covering the horizon (dominated by the smallest steps), and
    /// a few bisections near the first one tried.
    fn estimated_steps(&self, file: &StudyFile, _: &SceneConfig) -> f64 {
        settings(file).map_or(1.0, |s| {
            let scanned: f64 = s.scan().iter().map(|dt| s.horizon / dt).sum();
            scanned + 8.0 * (s.horizon / s.dt_max).clamp(s.min_steps as f64, s.max_steps as f64)
        })
    }
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
    if s.probes.is_some() {
        return Err(bad(
            "stability.probes",
            "is no longer a setting: the search scans the whole judged range and bisects every \
             change (`scan_per_decade`, default 6), so no step below a limit goes untried"
                .into(),
        ));
    }
    if !(s.scan_per_decade.is_finite() && (1.0..=100.0).contains(&s.scan_per_decade)) {
        return Err(bad(
            "stability.scan_per_decade",
            format!(
                "must be in [1, 100] steps per decade (got {})",
                s.scan_per_decade
            ),
        ));
    }
    if !(s.invented_energy_limit.is_finite() && s.invented_energy_limit > 0.0) {
        return Err(bad(
            "stability.invented_energy_limit",
            format!(
                "must be > 0 times the energy scale (got {})",
                s.invented_energy_limit
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
                          set relative_precision, error_dt_precision and scan_per_decade \
                          (coarser searches)"
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
        s.scan_per_decade = q
            .get("scan_per_decade")
            .unwrap_or(s.scan_per_decade.min(QUICK_SCAN_PER_DECADE));
        s.robustness_trials = false;
        file.set_settings(NAME, &s);
    }
    Ok(())
}

/// Finest bisection precision: well above f64 resolution, so the bracket always closes.
pub const MIN_RELATIVE_PRECISION: f64 = 1e-9;
