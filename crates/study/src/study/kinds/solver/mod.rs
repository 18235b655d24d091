//! Solver studies: fixed steps of a scene's trajectory — the incremental potentials its scheme
//! minimizes there — each solved by every run's Newton components (direction, globalization,
//! Hessian filter, linear solver) to working precision, with every iteration logged; the
//! iterations, wall time, factorizations, linear iterations and backtracks each run needs to
//! reach each tolerance of a ladder, under every convergence criterion.
//!
//! The states come from one trajectory per scene: the scene's scheme with default Newton
//! settings converged to `driver_tolerance` (required), so every run of a scene solves the same
//! problems, bit for bit; each row carries their fingerprint to show it. A run's own criterion
//! and tolerance do not decide anything: each solve goes on past the energy's round-off with
//! full steps (`roundoff_stop = false`) until a full step no longer lowers the gradient (the
//! `roundoff` stop: working precision) or `max_iterations`, and every criterion is read off the
//! log afterwards (the iterates do not depend on the criterion).

use crate::study::kind::{Measure, OwnKey, Plan, Present, RunInputs, parse_quick};
use crate::study::present::charts::{Emit, SceneRows, label};
use crate::study::present::findings::{self, Better, Ranking};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::format::cell;
use crate::study::vocabulary::grid::Axis;
use crate::study::vocabulary::measured::{Measured, build, peak_rss_mib, reset_peak_rss};
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_core::integrate::newton::log::CSV_HEADER;
use softbench_core::integrate::newton::{Criterion, IterationRecord, Newton, Stop};
use softbench_core::integrate::{
    FrozenStep, IntegratorSettings, NewtonSettings, StepError, StepReport, solve_frozen,
};
use softbench_core::parallel::Parallelism;
use softbench_core::solve::{LinearSolverKind, SolverSettings as LinearSolverSettings};
use softbench_run::plot::{Chart, LineChart, PlotError, Series};
use softbench_run::run::OutcomeKind;
use softbench_run::scene::SceneConfig;
use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

/// The kind's name in study files, the name of its table and the key of its resolved table.
const NAME: &str = "solver";

/// The tolerance ladder every criterion is read at.
pub const TOLERANCES: [f64; 5] = [1e-2, 1e-4, 1e-6, 1e-8, 1e-10];

/// The ladder's columns in `runs.csv`, per tolerance: iterations, median wall seconds with the
/// lowest and highest over the repeats, factorizations, linear iterations, backtracks (summed
/// over the solved steps).
const LADDER_COLUMNS: [[&str; 7]; 5] = [
    [
        "iterations_1e-2",
        "seconds_1e-2",
        "seconds_low_1e-2",
        "seconds_high_1e-2",
        "factorizations_1e-2",
        "linear_iterations_1e-2",
        "backtracks_1e-2",
    ],
    [
        "iterations_1e-4",
        "seconds_1e-4",
        "seconds_low_1e-4",
        "seconds_high_1e-4",
        "factorizations_1e-4",
        "linear_iterations_1e-4",
        "backtracks_1e-4",
    ],
    [
        "iterations_1e-6",
        "seconds_1e-6",
        "seconds_low_1e-6",
        "seconds_high_1e-6",
        "factorizations_1e-6",
        "linear_iterations_1e-6",
        "backtracks_1e-6",
    ],
    [
        "iterations_1e-8",
        "seconds_1e-8",
        "seconds_low_1e-8",
        "seconds_high_1e-8",
        "factorizations_1e-8",
        "linear_iterations_1e-8",
        "backtracks_1e-8",
    ],
    [
        "iterations_1e-10",
        "seconds_1e-10",
        "seconds_low_1e-10",
        "seconds_high_1e-10",
        "factorizations_1e-10",
        "linear_iterations_1e-10",
        "backtracks_1e-10",
    ],
];

/// `runs.csv`'s columns before the ladder's.
const HEAD_COLUMNS: [&str; 5] = [
    "dt",
    "outcome",
    "criterion",
    "solved_steps",
    "problems_fingerprint",
];

/// `runs.csv`'s columns after the ladder's.
const TAIL_COLUMNS: [&str; 15] = [
    "final_residual",
    "iterations_total",
    "seconds_total",
    "stops",
    "projected_elements",
    "capped_subproblems",
    "repeats",
    "iterates_repeatable",
    "solve_max_iterations",
    "driver_tolerance",
    "driver_seconds",
    "tets",
    "free_dofs",
    "fixed_dofs",
    "peak_rss_mib",
];

/// [`HEAD_COLUMNS`], the ladder's columns in order, then [`TAIL_COLUMNS`].
const ALL_COLUMNS: [&str; 5 + 35 + 15] = {
    let mut out = [""; 5 + 35 + 15];
    let mut i = 0;
    while i < HEAD_COLUMNS.len() {
        out[i] = HEAD_COLUMNS[i];
        i += 1;
    }
    let mut level = 0;
    while level < LADDER_COLUMNS.len() {
        let mut k = 0;
        while k < LADDER_COLUMNS[level].len() {
            out[i] = LADDER_COLUMNS[level][k];
            i += 1;
            k += 1;
        }
        level += 1;
    }
    let mut k = 0;
    while k < TAIL_COLUMNS.len() {
        out[i] = TAIL_COLUMNS[k];
        i += 1;
        k += 1;
    }
    out
};

/// Columns of a solver study's `runs.csv` after the run's identity.
pub const COLUMNS: &[&str] = &ALL_COLUMNS;

/// The `[solver]` table: which steps, read under which criterion, capped where.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SolverStudySettings {
    /// The steps whose incremental potentials are solved (1 is the first step from the
    /// initial state), in increasing order.
    #[serde(default = "default_steps")]
    pub steps: Vec<usize>,
    /// The criterion `runs.csv`'s ladder is read under (`solves.csv` has every criterion).
    #[serde(default = "default_criterion")]
    pub criterion: Criterion,
    /// The cap on each solve's iterations (a tolerance not reached within it is reported so).
    #[serde(default = "default_max_iterations")]
    pub max_iterations: u32,
    /// How many times each run solves its steps (each time with a fresh Newton): the wall
    /// times' median and spread come from these.
    #[serde(default = "default_repeats")]
    pub repeats: usize,
    /// The `scaled-gradient` tolerance (required) of the trajectory that sets the steps.
    #[serde(default = "default_driver_tolerance")]
    pub driver_tolerance: f64,
    /// The cap on that trajectory's Newton iterations per step.
    #[serde(default = "default_driver_max_iterations")]
    pub driver_max_iterations: u32,
}

fn default_steps() -> Vec<usize> {
    vec![1]
}
fn default_criterion() -> Criterion {
    Criterion::ScaledGradient
}
fn default_max_iterations() -> u32 {
    100
}
fn default_repeats() -> usize {
    1
}
fn default_driver_tolerance() -> f64 {
    1e-10
}
fn default_driver_max_iterations() -> u32 {
    100
}

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

/// The study's `[solver]` table as resolved at load.
fn settings(file: &StudyFile) -> Option<SolverStudySettings> {
    file.settings(NAME)
}

/// A solver study.
pub(in crate::study) struct Solver;

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

impl Measure for Solver {
    fn columns(&self) -> &'static [&'static str] {
        COLUMNS
    }

    fn progress(&self, m: &Measured) -> Option<String> {
        let reached = m.get("iterations_1e-8").filter(|s| !s.is_empty());
        Some(match reached {
            Some(n) => format!(", {n} iterations to 1e-8"),
            None => format!(
                ", 1e-8 not reached ({})",
                m.get("stops").unwrap_or_default()
            ),
        })
    }

    fn measure(
        &self,
        study: &Study,
        spec: &RunSpec,
        _: &RunInputs,
        parallelism: Parallelism,
    ) -> Result<Measured, String> {
        let settings = settings(&study.file).ok_or("no [solver] table")?;
        measure(spec, &settings, parallelism)
    }
}

impl Present for Solver {
    fn summary_columns(&self) -> &'static [&'static str] {
        &[
            "outcome",
            "criterion",
            "iterations_1e-4",
            "seconds_1e-4",
            "iterations_1e-8",
            "seconds_1e-8",
            "factorizations_1e-8",
            "final_residual",
            "stops",
        ]
    }

    fn sweep_metrics(&self) -> &'static [&'static str] {
        &["iterations_1e-8", "seconds_1e-8"]
    }

    fn quick_notice(&self) -> &'static str {
        "each solve is capped at fewer iterations (tight tolerances may not be reached)"
    }

    fn report_settings(&self, out: &mut String, file: &StudyFile) {
        if let Some(s) = settings(file) {
            let _ = writeln!(
                out,
                "Solver study: the incremental potentials of steps {} of each scene's \
                 trajectory (its scheme with default Newton settings, converged to a \
                 scaled-gradient tolerance of {:e}, at most {} iterations a step, required), \
                 each solved {} time(s) by every run's components to working precision (past \
                 the energy's round-off with full steps, until one no longer lowers the \
                 gradient) or **{} iterations** (a tolerance not reached within them is \
                 empty). `runs.csv`'s ladder is read under `{}`, summed over the steps; \
                 `series/<run>-solves.csv` has every criterion. Wall seconds run from the \
                 start of a solve to the acceptance of the iterate that meets the tolerance \
                 (the median over the repeats, with the lowest and highest); the first solve \
                 of each repeat includes the linear solver's analysis.\n",
                steps_text(&s.steps),
                s.driver_tolerance,
                s.driver_max_iterations,
                s.repeats,
                s.max_iterations,
                s.criterion,
            );
        }
    }

    fn scene_charts(&self, s: &SceneRows, dir: &Path, emit: &mut Emit) -> Result<(), PlotError> {
        scene_charts(s, dir, emit)
    }

    /// Its rows are solves of frozen steps, not steps of a trajectory.
    fn draws_phases(&self) -> bool {
        false
    }

    /// Time and iterations to each tolerance of the ladder.
    fn rankings(&self, s: &SceneRows, _: Option<&str>) -> Vec<Ranking> {
        rankings(s)
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

/// `1, 5, 20`.
fn steps_text(steps: &[usize]) -> String {
    steps
        .iter()
        .map(usize::to_string)
        .collect::<Vec<_>>()
        .join(", ")
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

/// One solve of one frozen step: its log and how it ended.
struct Solve {
    step: usize,
    records: Vec<IterationRecord>,
    /// The error that ended it, if one did.
    error: Option<String>,
    report: StepReport,
}

impl Solve {
    /// How it ended: `roundoff`, `cap`, `criterion` or `failed`.
    fn stop(&self) -> &'static str {
        if self.error.is_some() {
            return "failed";
        }
        self.records.last().map_or("failed", |r| match r.stop {
            Stop::Running => "failed",
            stop => stop.name(),
        })
    }
}

/// What reaching a tolerance cost one solve.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Reach {
    /// The first iterate that meets it.
    pub iteration: u32,
    /// Wall time from the start of the solve until that iterate was accepted (0 for the
    /// guess).
    pub seconds: f64,
    pub factorizations: u64,
    pub linear_iterations: u64,
    pub backtracks: u64,
    pub projected_elements: u64,
}

/// Where the logged solve `records` first meets `criterion` at `tolerance`, with the work that
/// took: the directions computed from the earlier iterates (and, for a criterion that needs the
/// direction, from this one) and the backtracks that reached it. `None` if it never does.
pub fn reach(records: &[IterationRecord], criterion: Criterion, tolerance: f64) -> Option<Reach> {
    let mut work = Reach::default();
    for (i, r) in records.iter().enumerate() {
        work.backtracks += u64::from(r.backtracks);
        let own_direction = criterion.needs_direction();
        if own_direction {
            work.factorizations += u64::from(r.factorizations);
            work.linear_iterations += r.linear_iterations;
            work.projected_elements += r.projected_elements;
        }
        if criterion.met(tolerance, r) {
            work.iteration = r.iteration;
            work.seconds = if own_direction {
                r.seconds
            } else if i == 0 {
                0.0
            } else {
                records[i - 1].seconds
            };
            return Some(work);
        }
        if !own_direction {
            work.factorizations += u64::from(r.factorizations);
            work.linear_iterations += r.linear_iterations;
            work.projected_elements += r.projected_elements;
        }
    }
    None
}

/// Measure one run: drive the trajectory to the last step, freezing the listed ones, then solve
/// them `repeats` times with the run's Newton components.
pub fn measure(
    spec: &RunSpec,
    s: &SolverStudySettings,
    parallelism: Parallelism,
) -> Result<Measured, String> {
    reset_peak_rss();
    let criterion = s.criterion;
    let mut scene = build(spec, parallelism).map_err(|e| e.to_string())?;
    let dt = scene.config.run.dt;
    let settings = scene
        .config
        .integrator
        .with_parallelism(scene.model.parallelism());
    let mut m = Measured::default();
    m.set("dt", cell(Some(dt)));
    m.set("criterion", criterion.name().to_owned());
    m.set("solved_steps", steps_text(&s.steps));
    m.set("solve_max_iterations", s.max_iterations.to_string());
    m.set("driver_tolerance", cell(Some(s.driver_tolerance)));
    m.set("repeats", s.repeats.to_string());
    m.set("tets", scene.model.tets().len().to_string());
    let dofs = scene.model.dofs().counts();
    m.set("free_dofs", dofs.free_dofs.to_string());
    m.set("fixed_dofs", dofs.fixed_dofs.to_string());
    let failed = |mut m: Measured, kind: OutcomeKind, message: String| {
        m.outcome = kind.name().to_owned();
        m.message = message;
        Ok(m)
    };

    let mut driver = driver_settings(&settings, s).build();
    let mut state = scene.initial.clone();
    let last = s.steps.last().copied().unwrap_or(1);
    let mut frozen: Vec<(usize, FrozenStep)> = Vec::new();
    let start = Instant::now();
    for k in 1..=last {
        if s.steps.contains(&k) {
            match driver.freeze_step(&mut scene.model, &state, dt) {
                Some(Ok(f)) => frozen.push((k, f)),
                Some(Err(e)) => {
                    return failed(m, outcome_kind(&e), format!("freezing step {k}: {e}"));
                }
                None => {
                    return failed(
                        m,
                        OutcomeKind::SolverFailed,
                        format!(
                            "`{}` does not minimize one incremental potential at step {k} (an \
                             extrapolated BDF start-up step is three solves)",
                            settings.method.name()
                        ),
                    );
                }
            }
        }
        if k < last
            && let Err(e) = driver.step(&mut scene.model, &mut state, dt)
        {
            return failed(
                m,
                outcome_kind(&e),
                format!("the trajectory that sets the steps failed at step {k}: {e}"),
            );
        }
    }
    m.set("driver_seconds", cell(Some(start.elapsed().as_secs_f64())));
    m.set("problems_fingerprint", fingerprint(&frozen));

    // Each repeat: a fresh Newton with the run's components, solving the steps in order.
    let mut solve_settings = settings.newton;
    solve_settings.criterion = Criterion::Gradient;
    solve_settings.tolerance = 0.0;
    solve_settings.max_iterations = s.max_iterations;
    solve_settings.require_convergence = false;
    solve_settings.retry_halvings = 0;
    solve_settings.log_iterations = true;
    solve_settings.roundoff_stop = false;
    let mut repeats: Vec<Vec<Solve>> = Vec::with_capacity(s.repeats);
    for _ in 0..s.repeats {
        let solver = settings.linear_solver.build(&settings.solver);
        let mut newton = Newton::new(solver, solve_settings);
        let mut solves = Vec::with_capacity(frozen.len());
        for (k, f) in &frozen {
            let mut x = Vec::new();
            let mut report = StepReport::default();
            let result = solve_frozen(&mut newton, &mut scene.model, f, &mut x, &mut report);
            if let Err(StepError::Interrupted(signal)) = &result {
                return failed(
                    m,
                    OutcomeKind::Interrupted,
                    format!("stopped by {} while solving step {k}", signal.name()),
                );
            }
            let mut records = Vec::new();
            newton.drain_log(&mut records);
            solves.push(Solve {
                step: *k,
                records,
                error: result.err().map(|e| e.to_string()),
                report,
            });
        }
        repeats.push(solves);
    }
    let first = &repeats[0];
    summarize(&mut m, &repeats, criterion);
    m.tables = vec![
        ("iterations", iterations_table(first, criterion)),
        ("solves", solves_table(first)),
    ];
    m.set("peak_rss_mib", cell(peak_rss_mib()));
    let failures: Vec<String> = first
        .iter()
        .filter_map(|x| x.error.as_ref().map(|e| format!("step {}: {e}", x.step)))
        .collect();
    if failures.is_empty() {
        m.outcome = OutcomeKind::Completed.name().to_owned();
        Ok(m)
    } else {
        failed(m, OutcomeKind::SolverFailed, failures.join("; "))
    }
}

/// The trajectory that sets the steps: the run's scheme with default Newton settings (converged
/// to `driver_tolerance`, required) and the default Cholesky, so every run of a scene and scheme
/// freezes the same states whatever its own components and linear solver.
pub fn driver_settings(run: &IntegratorSettings, s: &SolverStudySettings) -> IntegratorSettings {
    let mut driver = *run;
    driver.newton = NewtonSettings {
        tolerance: s.driver_tolerance,
        max_iterations: s.driver_max_iterations,
        require_convergence: true,
        ..NewtonSettings::default()
    };
    driver.linear_solver = LinearSolverKind::cholesky();
    let parallelism = run.solver.direct.parallelism;
    driver.solver = LinearSolverSettings::default();
    driver.with_parallelism(parallelism)
}

/// The outcome a step error means.
fn outcome_kind(e: &StepError) -> OutcomeKind {
    match e {
        StepError::InvertedElement { .. } => OutcomeKind::LeftMaterialDomain,
        StepError::NonFinite { .. } => OutcomeKind::Unstable,
        StepError::Interrupted(_) => OutcomeKind::Interrupted,
        _ => OutcomeKind::SolverFailed,
    }
}

/// A hash of the frozen problems' numbers, bit for bit: equal in every run of a scene.
fn fingerprint(frozen: &[(usize, FrozenStep)]) -> String {
    let mut bytes = Vec::new();
    for (k, f) in frozen {
        let p = &f.problem;
        bytes.extend((*k as u64).to_le_bytes());
        for v in [
            &p.x_hat,
            &p.damping_anchor,
            &p.damping_at,
            &p.linear,
            &p.guess,
            &f.start,
        ] {
            bytes.extend(v.iter().flat_map(|x| x.to_bits().to_le_bytes()));
        }
        for x in [p.beta, p.force_time, p.damping_weight, p.force_scale] {
            bytes.extend(x.to_bits().to_le_bytes());
        }
        bytes.push(u8::from(p.quasi_static));
    }
    format!("{:016x}", crate::study::vocabulary::identity::fnv1a(&bytes))
}

/// The ladder's cells (summed over the steps; seconds as the median over the repeats with
/// their range) and the totals.
fn summarize(m: &mut Measured, repeats: &[Vec<Solve>], criterion: Criterion) {
    let first = &repeats[0];
    for (level, tolerance) in TOLERANCES.iter().enumerate() {
        let [
            iterations,
            seconds,
            low,
            high,
            factorizations,
            linear,
            backtracks,
        ] = LADDER_COLUMNS[level];
        let per_repeat: Vec<Option<Vec<Reach>>> = repeats
            .iter()
            .map(|solves| {
                solves
                    .iter()
                    .map(|x| {
                        x.error
                            .is_none()
                            .then(|| reach(&x.records, criterion, *tolerance))
                            .flatten()
                    })
                    .collect()
            })
            .collect();
        let Some(Some(reached)) = per_repeat.first() else {
            for column in LADDER_COLUMNS[level] {
                m.set(column, String::new());
            }
            continue;
        };
        let sum = |f: &dyn Fn(&Reach) -> u64| reached.iter().map(f).sum::<u64>().to_string();
        m.set(iterations, sum(&|r| u64::from(r.iteration)));
        m.set(factorizations, sum(&|r| r.factorizations));
        m.set(linear, sum(&|r| r.linear_iterations));
        m.set(backtracks, sum(&|r| r.backtracks));
        let mut times: Vec<f64> = per_repeat
            .iter()
            .flatten()
            .map(|r| r.iter().map(|x| x.seconds).sum())
            .collect();
        times.sort_by(f64::total_cmp);
        m.set(seconds, cell(Some(median(&times))));
        m.set(low, cell(times.first().copied()));
        m.set(high, cell(times.last().copied()));
    }
    let last_residuals: Vec<f64> = first
        .iter()
        .filter_map(|x| x.records.last().map(|r| criterion.residual(r)))
        .collect();
    m.set(
        "final_residual",
        cell(last_residuals.iter().copied().reduce(f64::max)),
    );
    m.set(
        "iterations_total",
        first
            .iter()
            .map(|x| x.records.last().map_or(0, |r| u64::from(r.iteration)))
            .sum::<u64>()
            .to_string(),
    );
    let mut totals: Vec<f64> = repeats
        .iter()
        .map(|solves| {
            solves
                .iter()
                .map(|x| x.records.last().map_or(0.0, |r| r.seconds))
                .sum()
        })
        .collect();
    totals.sort_by(f64::total_cmp);
    m.set("seconds_total", cell(Some(median(&totals))));
    m.set("stops", stops_text(first));
    m.set(
        "projected_elements",
        first
            .iter()
            .map(|x| x.report.projected_elements)
            .sum::<u64>()
            .to_string(),
    );
    m.set(
        "capped_subproblems",
        first
            .iter()
            .map(|x| u64::from(x.report.capped_subproblems))
            .sum::<u64>()
            .to_string(),
    );
    // The iterates must not depend on the repeat (a fresh Newton each time).
    let trace = |solves: &Vec<Solve>| -> Vec<(u32, u64)> {
        solves
            .iter()
            .flat_map(|x| x.records.iter())
            .map(|r| (r.iteration, r.gradient_norm.to_bits()))
            .collect()
    };
    let same = repeats.iter().all(|r| trace(r) == trace(first));
    m.set("iterates_repeatable", same.to_string());
}

/// The median of sorted `v` (NaN when empty).
fn median(v: &[f64]) -> f64 {
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// How the solves ended, counted: `roundoff 2, cap 1`.
fn stops_text(solves: &[Solve]) -> String {
    let mut counts: Vec<(&str, usize)> = Vec::new();
    for x in solves {
        let stop = x.stop();
        match counts.iter_mut().find(|(s, _)| *s == stop) {
            Some(c) => c.1 += 1,
            None => counts.push((stop, 1)),
        }
    }
    counts
        .iter()
        .map(|(s, n)| format!("{s} {n}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Every logged iteration of the first repeat, with the step it solved and the residual of
/// the study's criterion.
fn iterations_table(solves: &[Solve], criterion: Criterion) -> Table {
    let mut header: Vec<String> = CSV_HEADER.iter().map(|s| (*s).to_owned()).collect();
    header.push("residual".into());
    let mut table = Table::new(header);
    for x in solves {
        for r in &x.records {
            let mut row = r.csv_cells(x.step);
            row.push(cell(Some(criterion.residual(r))));
            table.rows.push(row);
        }
    }
    table
}

/// The columns of `series/<run>-solves.csv`.
const SOLVES_HEADER: [&str; 11] = [
    "step",
    "criterion",
    "tolerance",
    "iteration",
    "seconds",
    "factorizations",
    "linear_iterations",
    "backtracks",
    "projected_elements",
    "stop",
    "error",
];

/// Every step under every criterion at every tolerance of the ladder (the first repeat): where
/// it was reached and what that took; empty cells where it was not.
fn solves_table(solves: &[Solve]) -> Table {
    let mut table = Table::new(SOLVES_HEADER.iter().map(|s| (*s).to_owned()).collect());
    for x in solves {
        for criterion in Criterion::ALL {
            for tolerance in TOLERANCES {
                let reached = reach(&x.records, *criterion, tolerance);
                let n = |f: &dyn Fn(&Reach) -> String| reached.as_ref().map_or(String::new(), f);
                table.rows.push(vec![
                    x.step.to_string(),
                    criterion.name().to_owned(),
                    format!("{tolerance:e}"),
                    n(&|r| r.iteration.to_string()),
                    n(&|r| format!("{:e}", r.seconds)),
                    n(&|r| r.factorizations.to_string()),
                    n(&|r| r.linear_iterations.to_string()),
                    n(&|r| r.backtracks.to_string()),
                    n(&|r| r.projected_elements.to_string()),
                    x.stop().to_owned(),
                    x.error.clone().unwrap_or_default(),
                ]);
            }
        }
    }
    table
}

/// Residual against iterations and against wall time, one chart of each per solved step.
fn scene_charts(s: &SceneRows, dir: &Path, emit: &mut Emit) -> Result<(), PlotError> {
    let runs = s.runs;
    // Each row's log, read back (a run that failed before solving has none).
    let mut logs = Vec::new();
    for r in s.rows {
        let id = runs.get(r, "run_id").unwrap_or_default();
        let path = dir.join("series").join(format!("{id}-iterations.csv"));
        if let Ok(Some(table)) = Table::read(&path) {
            logs.push((label(runs, s.params, r, &[]), table));
        }
    }
    let Some(criterion) = s.rows.first().and_then(|r| runs.get(r, "criterion")) else {
        return Ok(());
    };
    let mut steps: Vec<usize> = Vec::new();
    for (_, t) in &logs {
        for row in &t.rows {
            if let Some(k) = t.get(row, "step").and_then(|v| v.parse().ok())
                && !steps.contains(&k)
            {
                steps.push(k);
            }
        }
    }
    steps.sort_unstable();
    for step in steps {
        for (x_column, x_label, stem) in [
            ("iteration", "Newton iteration", "residual-iterations"),
            (
                "seconds",
                "wall time from the start of the solve [s]",
                "residual-time",
            ),
        ] {
            let series = logs
                .iter()
                .map(|(name, t)| Series {
                    label: name.clone(),
                    points: t
                        .rows
                        .iter()
                        .filter(|row| t.get(row, "step") == Some(&step.to_string()))
                        .filter_map(|row| {
                            Some((t.number(row, x_column)?, t.number(row, "residual")?))
                        })
                        .collect(),
                    ended: t
                        .rows
                        .iter()
                        .rev()
                        .find(|row| t.get(row, "step") == Some(&step.to_string()))
                        .is_some_and(|row| t.get(row, "stop") != Some("roundoff")),
                })
                .collect();
            let chart = LineChart {
                title: format!("{}: step {step}, {criterion} residual", s.scene),
                x_label: x_label.into(),
                y_label: format!("{criterion} residual"),
                x_log: false,
                y_log: true,
                series,
            };
            emit(
                format!("{stem}-{}-step{step}", s.slug),
                &format!(
                    "The {criterion} residual of each iterate of step {step}'s solve against \
                     the {}, one line per run (log scale); a line ends at working precision \
                     (a full step that no longer lowered the gradient), with a large marker \
                     where it ended otherwise (the iteration cap or a failure).",
                    if x_column == "iteration" {
                        "iteration"
                    } else {
                        "wall time from the start of the solve (the iterate's acceptance)"
                    }
                ),
                Chart::Line(chart),
            )?;
        }
    }
    Ok(())
}

/// The ladder's tolerances the findings rank at: a loose one (what graphics runs use) and a
/// tight one; `runs.csv` has them all.
const RANKED: [usize; 2] = [1, 3];

/// At [`RANKED`] tolerances: wall time (with its range over the repeats) and iterations.
fn rankings(s: &SceneRows) -> Vec<Ranking> {
    let runs = s.runs;
    let mut out = Vec::new();
    let criterion = s
        .rows
        .first()
        .and_then(|r| runs.get(r, "criterion"))
        .unwrap_or("the criterion")
        .to_owned();
    let why = |r: &[String]| -> String {
        let outcome = runs.get(r, "outcome").unwrap_or_default();
        if outcome != OutcomeKind::Completed.name() {
            return outcome.to_owned();
        }
        format!(
            "not reached (stops: {}; cap {} iterations)",
            runs.get(r, "stops").unwrap_or_default(),
            runs.get(r, "solve_max_iterations").unwrap_or_default()
        )
    };
    for level in RANKED {
        let tolerance = TOLERANCES[level];
        let [iterations, seconds, low, high, ..] = LADDER_COLUMNS[level];
        out.extend(findings::ranking_with_spread(
            s,
            format!("wall seconds to reach {criterion} <= {tolerance:e}, over the solved steps"),
            Better::Smaller,
            &|r| runs.number(r, seconds).ok_or_else(|| why(r)),
            &|r| Some((runs.number(r, low)?, runs.number(r, high)?)),
        ));
        out.extend(findings::ranking(
            s,
            format!(
                "Newton iterations to reach {criterion} <= {tolerance:e}, over the solved steps"
            ),
            Better::Smaller,
            &|r| runs.number(r, iterations).ok_or_else(|| why(r)),
        ));
    }
    out
}
