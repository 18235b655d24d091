//! The solver study kind, planning a study: its settings table and `[quick]` keys, its checks
//! and how each run is adapted.

use super::{NAME, Solver, SolverStudySettings, settings, steps_text};
use crate::study::kind::{OwnKey, Plan, parse_quick};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::grid::Axis;
use softbench_run::scene::SceneConfig;

/// The `[solver]` table of a study file (its other keys are the study's).
#[derive(serde::Deserialize)]
struct FileTable {
    #[serde(default)]
    solver: Option<SolverStudySettings>,
}

/// The `[quick]` keys a solver study reads.
#[derive(Default, serde::Serialize, serde::Deserialize)]
struct Quick {
    /// Each solve's cap in quick mode (default: the study's, at most 30).
    max_iterations: Option<u32>,
}

/// Quick mode's cap on each solve.
const QUICK_MAX_ITERATIONS: u32 = 30;

impl Plan for Solver {
    fn name(&self) -> &'static str {
        NAME
    }

    fn description(&self) -> &'static str {
        "fixed steps of a trajectory, each solved by the run's Newton components to working \
         precision: iterations, time and work to reach each tolerance under each criterion"
    }

    fn example(&self) -> &'static str {
        "[[methods]]\nmethod = \"backward-euler\"\n\"integrator.newton.direction\" = \
         [\"newton\", \"lbfgs\"]\n\n[solver]\nsteps = [1, 3]\nmax_iterations = 60\n"
    }

    fn table_names(&self) -> &'static [&'static str] {
        &[NAME]
    }

    fn parse_table(&self, text: &str) -> Result<serde_json::Value, toml::de::Error> {
        let file: FileTable = toml::from_str(text)?;
        Ok(serde_json::to_value(&file.solver).unwrap_or_default())
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
        &["max_iterations"]
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
        if file.quick.get::<u32>("max_iterations") == Some(0) {
            return Err(bad("quick.max_iterations", "must be at least 1".into()));
        }
        Ok(())
    }

    fn quick_table(&self, file: &mut StudyFile, _: &Context) -> Result<(), StudyError> {
        if let Some(mut s) = settings(file) {
            let cap = file
                .quick
                .get::<u32>("max_iterations")
                .unwrap_or(QUICK_MAX_ITERATIONS.min(s.max_iterations));
            s.max_iterations = cap;
            file.set_settings(NAME, &s);
        }
        Ok(())
    }

    fn configure(
        &self,
        ctx: &Context,
        _: &StudyFile,
        config: &mut SceneConfig,
        axes: &[Axis],
        _: bool,
    ) -> Result<(), StudyError> {
        let method = config.integrator.method;
        let line = axes
            .iter()
            .find(|a| a.key == "integrator.method")
            .map_or_else(|| ctx.line_of_key("methods"), |a| a.line);
        if !method.uses_newton() {
            return Err(ctx.invalid(
                line,
                "integrator.method",
                format!(
                    "a solver study solves each step's incremental potential with Newton, and \
                     `{}` minimizes none (methods on the Newton loop: {})",
                    method.name(),
                    newton_methods().join(", ")
                ),
            ));
        }
        if !config.obstacles.is_empty() {
            return Err(ctx.invalid(
                ctx.line_of_key("scenes"),
                "obstacles",
                "a solver study takes scenes without obstacles: a contact response acts \
                 around or inside the minimization, so a frozen step is not the step the \
                 scene takes",
            ));
        }
        Ok(())
    }

    /// A run drives the scene's trajectory to the last listed step and solves frozen steps:
    /// only `run.dt` of the scene's `[run]` is used.
    fn own_keys(&self) -> &'static [OwnKey] {
        &[
            OwnKey {
                key: "run.steps",
                why: "each run drives the trajectory to the last of [solver] steps",
                replaced: false,
            },
            OwnKey {
                key: "run.sample_every",
                why: "a run solves frozen steps and samples no rows",
                replaced: false,
            },
            OwnKey {
                key: "run.energy_limit",
                why: "a run solves frozen steps and judges no blow-up",
                replaced: false,
            },
            OwnKey {
                key: "run.budget",
                why: "a run's solves are capped by [solver] max_iterations",
                replaced: false,
            },
        ]
    }

    fn estimated_steps(&self, file: &StudyFile, _: &SceneConfig) -> f64 {
        settings(file).map_or(1.0, |s| {
            let last = s.steps.iter().copied().max().unwrap_or(1) as f64;
            last + (s.steps.len() * s.repeats) as f64 * f64::from(s.max_iterations) / 5.0
        })
    }
}

/// The methods a solver study can run, for messages.
fn newton_methods() -> Vec<&'static str> {
    softbench_core::integrate::methods::METHODS
        .all()
        .into_iter()
        .filter(|m| m.newton)
        .map(|m| m.name)
        .collect()
}

/// The `[solver]` table is present and sane.
fn check(
    file: &StudyFile,
    ctx: &Context,
    bad: &dyn Fn(&str, String) -> StudyError,
) -> Result<(), StudyError> {
    let Some(s) = &settings(file) else {
        return Err(ctx.invalid(
            0,
            NAME,
            "a solver study needs a [solver] table (it may be empty: steps = [1] by default)",
        ));
    };
    if s.steps.is_empty() {
        return Err(bad("solver.steps", "must list at least one step".into()));
    }
    if s.steps.contains(&0) {
        return Err(bad(
            "solver.steps",
            "steps count from 1 (the first step from the initial state)".into(),
        ));
    }
    if !s.steps.windows(2).all(|w| w[0] < w[1]) {
        return Err(bad(
            "solver.steps",
            format!("must increase, each once (got [{}])", steps_text(&s.steps)),
        ));
    }
    let last = s.steps.last().copied().unwrap_or(1);
    softbench_core::limits::STEPS
        .check_usize(Some(last))
        .map_err(|e| bad("solver.steps", format!("step {last}: {e}")))?;
    for (key, n) in [
        ("solver.max_iterations", s.max_iterations),
        ("solver.driver_max_iterations", s.driver_max_iterations),
    ] {
        if n == 0 {
            return Err(bad(key, "must be at least 1".into()));
        }
        softbench_core::limits::ITERATIONS
            .check(Some(u64::from(n)))
            .map_err(|e| bad(key, e.to_string()))?;
    }
    if s.repeats == 0 || s.repeats > 100 {
        return Err(bad(
            "solver.repeats",
            format!("must be 1 to 100 (got {})", s.repeats),
        ));
    }
    if !(s.driver_tolerance.is_finite() && s.driver_tolerance > 0.0) {
        return Err(bad(
            "solver.driver_tolerance",
            format!("must be > 0 (got {})", s.driver_tolerance),
        ));
    }
    Ok(())
}
