//! The benchmark suite: every registered method on a problem set, under one protocol.
//!
//! A suite's scenes are *problems* (scene files with a `[problem]` table, usually a folder of
//! them): each fixes its physics, its step `run.dt`, its horizon `run.dt × run.steps`, its
//! budget `run.budget`, the accuracy a run must reach and how its reference is made (a method
//! at its step, checked against an independent second solution whose difference is the
//! reference's error bar). The suite runs every method once per problem and convergence
//! cut-off level, with one settings block per method for the whole suite (`[[methods]]`; a
//! registered method without one runs with its defaults), and judges each run: *solved* when
//! it reached the horizon within its budget with an error within the problem's tolerance,
//! else failed with a kind. Methods that cannot run a problem (a local solver without a form
//! for its material) and problems whose data is missing are left out with the reason, and
//! listed. The aggregates over the runs — data and performance profiles per stratum, tier and
//! level, pairwise views and findings — are `suite_aggregates` (written by `suite_tables`, read by `suite_report`).

pub mod aggregates;
pub mod report;
pub mod tables;

use crate::study::kind::{Measure, OwnKey, Plan, Present, RunInputs, Verdict, number, parse_quick};
use crate::study::present::charts::{Emit, SceneRows};
use crate::study::vocabulary::config::{METHOD_KEY, StudyFile};
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::format::{cell, short};
use crate::study::vocabulary::measured::Measured;
use crate::study::vocabulary::meta::StudyMeta;
use crate::study::vocabulary::reference::{ReferenceSettings, ScoringSettings};
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_core::integrate::Method;
use softbench_core::parallel::Parallelism;
use softbench_run::plot::PlotError;
use softbench_run::scene::{ProblemConfig, SceneConfig};
use std::collections::BTreeMap;
use std::fmt::Write;
use std::path::Path;
use std::sync::LazyLock;

/// The kind's name in study files, and the key of its resolved table.
const NAME: &str = "suite";

/// A suite's columns of its problems and verdicts (after the identity and parameters; a
/// work-precision run's own columns, the run's summary and the integrator's caps follow,
/// [`COLUMNS`]).
pub const SUITE_COLUMNS: &[&str] = &[
    "tier",
    "mesh",
    "scenario",
    "difficulty",
    "material",
    "nu",
    "tets",
    "size",
    "level",
    "cutoff",
    "solved",
    "failure",
    "tolerance",
    "error",
    "error_unscored",
    "error_final",
    "energy_error",
    "outcome",
    "dt",
    "horizon",
    "evaluations",
    "wall_seconds_min",
    "wall_seconds_max",
    "repeats",
    "repeatable",
    "budget_wall_seconds",
    "budget_evaluations",
    "budget_factorizations",
    "budget_linear_iterations",
    "scored",
    "reference_method",
    "reference_dt",
    "reference_independent",
    "reference_difference",
];

/// A suite's own columns: its problems' and verdicts', then a work-precision run's (each run
/// is measured as one).
static OWN_COLUMNS: LazyLock<Vec<&'static str>> = LazyLock::new(|| {
    let mut own = SUITE_COLUMNS.to_vec();
    for c in crate::study::kinds::work_precision::OWN_COLUMNS {
        if !own.contains(c) {
            own.push(c);
        }
    }
    own
});

/// Every measured column of a suite's `runs.csv`: its own, the run's summary and the
/// integrator's caps.
pub static COLUMNS: LazyLock<Vec<&'static str>> =
    LazyLock::new(|| crate::study::vocabulary::columns::declare(&OWN_COLUMNS, true, true));

/// The settings keys a suite may set (in `[set]` and `[[methods]]`): a problem fixes its
/// physics and its run, so only the integrator's settings are the suite's.
const SETTABLE: &str = "integrator.";

/// Size strata by elastic tets (bodies without tets: by free DOFs, at about 0.6 DOF per tet).
const SIZES: [(&str, f64); 3] = [("small", 5e3), ("medium", 5e4), ("large", f64::INFINITY)];

/// The `[suite]` table.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub(in crate::study) struct SuiteSettings {
    /// Names of the convergence cut-off levels, loosest first (at least two). A method
    /// block's one multi-valued key is its cut-off, with one value per level.
    pub levels: Vec<String>,
    /// `"all"`: every registered method (those without a `[[methods]]` block run with their
    /// defaults, at every level); `"listed"`: only the `[[methods]]`. Default `"all"`.
    #[serde(default = "all")]
    pub methods: String,
    /// Methods left out of the suite, with the reason (the omissions list shows it).
    #[serde(default)]
    pub omit: BTreeMap<String, String>,
    /// Folders of private problems (relative to the study file): the hidden tier, whose
    /// aggregates are reported apart from the public problems'.
    #[serde(default)]
    pub hidden: Vec<String>,
    /// Newton must converge within its iteration cap, or the step fails. Default true.
    #[serde(default = "yes")]
    pub require_newton_convergence: bool,
    /// Times each run is run: wall time is the median. Default 1.
    #[serde(default = "one")]
    pub repeats: usize,
}

fn all() -> String {
    "all".into()
}

fn yes() -> bool {
    true
}

fn one() -> usize {
    1
}

/// The `[suite]` table of a study file (its other keys are the study's).
#[derive(serde::Deserialize)]
struct FileTable {
    #[serde(default)]
    suite: Option<SuiteSettings>,
}

/// The `[quick]` keys a suite reads.
#[derive(Default, serde::Serialize, serde::Deserialize)]
struct Quick {
    /// The problems (scene names) quick mode runs.
    problems: Option<Vec<String>>,
}

fn settings(file: &StudyFile) -> Option<SuiteSettings> {
    file.settings(NAME)
}

/// The suite.
pub(in crate::study) struct Suite;

impl Plan for Suite {
    fn name(&self) -> &'static str {
        NAME
    }

    fn description(&self) -> &'static str {
        "a benchmark: every method on a problem set (scenes with a [problem] table) under one \
         protocol; solved or failed with a kind, profiles per stratum"
    }

    fn example(&self) -> &'static str {
        "[suite]\nlevels = [\"loose\", \"tight\"]\nmethods = \"listed\"\n\n\
         [[methods]]\nmethod = \"backward-euler\"\n\
         \"integrator.newton.tolerance\" = [1e-4, 1e-8]\n\n\
         [[methods]]\nmethod = \"bdf2\"\n\
         \"integrator.newton.tolerance\" = [1e-4, 1e-8]\n"
    }

    fn scene_example(&self) -> &'static str {
        "[problem]\ndescription = \"a beam sagging under gravity\"\nscenario = \"hanging\"\n\
         difficulty = \"easy\"\nsamples = 2\ntolerance = 0.5\n\
         reference = { method = \"rk4\", dt = 2e-5, independent = { method = \"radau-iia\", \
         dt = 0.001 } }\n"
    }

    fn table_names(&self) -> &'static [&'static str] {
        &[NAME]
    }

    fn parse_table(&self, text: &str) -> Result<serde_json::Value, toml::de::Error> {
        let file: FileTable = toml::from_str(text)?;
        Ok(serde_json::to_value(&file.suite).unwrap_or_default())
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
        &["problems"]
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
        if file
            .quick
            .get::<Vec<String>>("problems")
            .is_some_and(|p| p.is_empty())
        {
            return Err(bad("quick.problems", "name at least one problem".into()));
        }
        Ok(())
    }

    fn extra_scenes(&self, file: &StudyFile) -> Vec<String> {
        settings(file).map(|s| s.hidden).unwrap_or_default()
    }

    fn keeps_scene(&self, file: &StudyFile, scene: &str, quick: bool) -> bool {
        !quick
            || file
                .quick
                .get::<Vec<String>>("problems")
                .is_none_or(|p| p.iter().any(|p| p == scene))
    }

    fn extra_methods(&self, file: &StudyFile) -> Vec<Method> {
        let Some(s) = settings(file) else {
            return Vec::new();
        };
        if s.methods != "all" {
            return Vec::new();
        }
        let listed = listed_methods(file);
        Method::all()
            .into_iter()
            .filter(|m| !listed.contains(&m.name().to_owned()) && !s.omit.contains_key(m.name()))
            .collect()
    }

    fn leaves_out_what_cannot_run(&self) -> bool {
        true
    }

    fn declared_omissions(
        &self,
        file: &StudyFile,
    ) -> Vec<crate::study::vocabulary::spec::Omission> {
        settings(file)
            .map(|s| {
                s.omit
                    .into_iter()
                    .map(
                        |(method, reason)| crate::study::vocabulary::spec::Omission {
                            scene: String::new(),
                            method: Some(method),
                            reason,
                        },
                    )
                    .collect()
            })
            .unwrap_or_default()
    }

    fn levels(&self, file: &StudyFile) -> Vec<String> {
        settings(file).map(|s| s.levels).unwrap_or_default()
    }

    fn configure(
        &self,
        ctx: &Context,
        file: &StudyFile,
        config: &mut SceneConfig,
        _axes: &[crate::study::vocabulary::grid::Axis],
        _quick: bool,
    ) -> Result<(), StudyError> {
        let Some(problem) = &config.problem else {
            return Err(ctx.invalid(
                0,
                "scenes",
                format!(
                    "scene `{}` has no [problem] table: a suite's scenes are problems (see \
                     docs/suite.md)",
                    config.name.as_deref().unwrap_or("?")
                ),
            ));
        };
        let s = settings(file).expect("checked");
        config.integrator.newton.require_convergence = s.require_newton_convergence;
        // Rows at the sample times only: the errors are measured there, and a suite has many
        // runs.
        config.run.sample_every = config.run.steps / problem.samples;
        Ok(())
    }

    fn own_keys(&self) -> &'static [OwnKey] {
        &[OwnKey {
            key: "run.sample_every",
            why: "a suite keeps rows at each problem's sample times ([problem] samples)",
            replaced: true,
        }]
    }

    /// Every repeat runs the whole trajectory again.
    fn estimated_steps(&self, file: &StudyFile, config: &SceneConfig) -> f64 {
        config.run.steps as f64 * settings(file).map_or(1, |s| s.repeats) as f64
    }
}

impl Measure for Suite {
    fn columns(&self) -> &'static [&'static str] {
        &COLUMNS
    }

    fn own_columns(&self) -> &'static [&'static str] {
        &OWN_COLUMNS
    }

    fn progress(&self, m: &Measured) -> Option<String> {
        let verdict = match m.get("failure") {
            Some("") | None => "solved".to_owned(),
            Some(kind) => kind.to_owned(),
        };
        Some(match number(m, "error") {
            Some(e) => format!(", {verdict}, error {e}"),
            None => format!(", {verdict}"),
        })
    }

    fn reference_settings(&self, file: &StudyFile, spec: &RunSpec) -> Option<ScoringSettings> {
        let problem = spec.loaded.config.problem.as_ref()?;
        scoring(file, problem, &spec.loaded.config)
    }

    fn reference_dt(&self, _: &Study, w: &ScoringSettings, _: &RunSpec) -> f64 {
        w.reference
            .dt
            .expect("a problem's reference states its step")
    }

    fn measure(
        &self,
        study: &Study,
        spec: &RunSpec,
        inputs: &RunInputs,
        parallelism: Parallelism,
    ) -> Result<Measured, String> {
        let config = &spec.loaded.config;
        let problem = config
            .problem
            .as_ref()
            .ok_or("the scene has no [problem]")?;
        let w = scoring(&study.file, problem, config).ok_or("no [suite] table")?;
        let reference = inputs.reference.ok_or("no reference solution")?;
        let mut m = crate::study::kinds::work_precision::measure_with(
            spec,
            &w,
            reference,
            parallelism,
            false,
            inputs.meter,
        )?;
        judge(study, spec, problem, &mut m);
        Ok(m)
    }
}

impl Present for Suite {
    fn summary_columns(&self) -> &'static [&'static str] {
        &[
            "level",
            "solved",
            "failure",
            "error",
            "tolerance",
            "wall_seconds",
            "evaluations",
        ]
    }

    fn sweep_metrics(&self) -> &'static [&'static str] {
        &["error", "evaluations"]
    }

    fn quick_notice(&self) -> &'static str {
        "only the problems `[quick] problems` names run"
    }

    /// Every run answers: solved, or failed with its kind.
    fn verdict<'a>(&self, runs: &'a Table, row: &'a [String]) -> Verdict<'a> {
        let failure = runs.get(row, "failure").unwrap_or_default();
        Verdict {
            word: if failure.is_empty() {
                "solved"
            } else {
                failure
            },
            clean: true,
        }
    }

    fn stopped_early(&self, _: &Table, _: &[String]) -> bool {
        false
    }

    fn failures_note(&self, runs: &Table) -> Option<String> {
        let mut by_kind: BTreeMap<&str, usize> = BTreeMap::new();
        for row in &runs.rows {
            let failure = runs.get(row, "failure").unwrap_or_default();
            if !failure.is_empty() {
                *by_kind.entry(failure).or_default() += 1;
            }
        }
        let failed: usize = by_kind.values().sum();
        let kinds: Vec<String> = by_kind.iter().map(|(k, n)| format!("{k} {n}")).collect();
        Some(format!(
            "{failed} of the {} runs did not solve their problem{}. In a suite a failure is a \
             result: they are counted per method and kind under *Suite aggregates*, and every \
             row's `failure` and `message` are in `runs.csv`.",
            runs.rows.len(),
            if kinds.is_empty() {
                String::new()
            } else {
                format!(" ({})", kinds.join(", "))
            }
        ))
    }

    fn report_settings(&self, out: &mut String, file: &StudyFile) {
        if let Some(s) = settings(file) {
            let _ = writeln!(
                out,
                "Suite: cut-off levels {} (loosest first); methods: {}; Newton convergence {}; \
                 wall time the median of {} run(s). A run **solves** its problem when it reaches \
                 the horizon within the problem's budget with a relative position error within \
                 its tolerance (both are columns of every row).\n",
                s.levels
                    .iter()
                    .map(|l| format!("`{l}`"))
                    .collect::<Vec<_>>()
                    .join(", "),
                if s.methods == "all" {
                    "every registered method, those without a block at their defaults"
                } else {
                    "the listed blocks"
                },
                if s.require_newton_convergence {
                    "required (an unconverged step fails)"
                } else {
                    "not required (unconverged steps are accepted and counted)"
                },
                s.repeats
            );
        }
    }

    fn report_findings(&self, out: &mut String, runs: &Table, study: &StudyMeta) {
        crate::study::kinds::suite::report::report(out, runs, study);
    }

    fn report_runs_table(&self) -> bool {
        false
    }

    fn study_charts(
        &self,
        dir: &Path,
        study: &StudyMeta,
        runs: &Table,
        emit: &mut Emit,
    ) -> Result<(), PlotError> {
        crate::study::kinds::suite::tables::charts(dir, study, runs, emit)
    }

    fn scene_charts(&self, _: &SceneRows, _: &Path, _: &mut Emit) -> Result<(), PlotError> {
        Ok(())
    }

    fn draws_phases(&self) -> bool {
        false
    }
}

/// The methods named by the study's `[[methods]]` blocks.
fn listed_methods(file: &StudyFile) -> Vec<String> {
    file.methods
        .iter()
        .filter_map(|m| m.get_ref().get("method")?.as_str().map(str::to_owned))
        .collect()
}

/// How the problem's runs are scored, under the suite's settings.
fn scoring(
    file: &StudyFile,
    problem: &ProblemConfig,
    config: &SceneConfig,
) -> Option<ScoringSettings> {
    let s = settings(file)?;
    let r = &problem.reference;
    Some(ScoringSettings {
        horizon: ProblemConfig::horizon(config.run.dt, config.run.steps),
        require_newton_convergence: s.require_newton_convergence,
        samples: problem.samples,
        phases: Vec::new(),
        reference: ReferenceSettings {
            method: Some(r.method),
            dt: Some(r.dt),
            newton_tolerance: r.newton_tolerance,
            independent: Some(r.independent),
            default_integrator: true,
            ..ReferenceSettings::default()
        },
        repeats: s.repeats,
    })
}

/// A run's cut-off: the key its method's block sweeps, the level (index into `levels`) and
/// the value; `None` for a method without a cut-off (it stands at every level).
fn cutoff_of(study: &Study, spec: &RunSpec) -> Option<(String, usize, String)> {
    let block = study.file.methods.iter().find(|m| {
        m.get_ref().get("method").and_then(toml::Value::as_str) == Some(spec.method.name())
    })?;
    let (key, values) = block
        .get_ref()
        .iter()
        .find_map(|(k, v)| Some((k, v.as_array().filter(|a| a.len() > 1)?)))?;
    let column = study.parameters.iter().position(|p| p == key)?;
    let value = spec.parameters.get(column)?.as_ref()?;
    let level = values.iter().position(|v| v == value)?;
    Some((
        key.clone(),
        level,
        crate::study::vocabulary::identity::value_text(value),
    ))
}

/// The size stratum of a body of `tets` elastic tets and `dofs` free DOFs.
pub(in crate::study) fn size_of(tets: usize, dofs: usize) -> &'static str {
    let n = if tets > 0 {
        tets as f64
    } else {
        dofs as f64 / 0.6
    };
    SIZES
        .iter()
        .find(|(_, below)| n < *below)
        .map_or("large", |(name, _)| name)
}

/// The suite's cells of a measured run: its strata, level and budget, and whether it solved
/// the problem or how it failed.
fn judge(study: &Study, spec: &RunSpec, problem: &ProblemConfig, m: &mut Measured) {
    let config = &spec.loaded.config;
    let s = settings(&study.file).expect("checked at load");
    let base = study.path.parent().unwrap_or(Path::new("."));
    let hidden = s.hidden.iter().any(|h| {
        let folder = base.join(h);
        spec.loaded.path.starts_with(&folder)
            || folder
                .canonicalize()
                .ok()
                .zip(spec.loaded.path.canonicalize().ok())
                .is_some_and(|(f, p)| p.starts_with(f))
    });
    m.set("tier", if hidden { "hidden" } else { "public" }.into());
    let from_file = config.mesh.as_ref().is_some_and(|mesh| mesh.file.is_some());
    m.set("mesh", if from_file { "file" } else { "generated" }.into());
    m.set("scenario", problem.scenario.clone());
    m.set("difficulty", problem.difficulty.clone());
    let material = match (&config.material, &config.springs, &config.jello) {
        (Some(mat), _, _) => mat.model.to_string(),
        (None, _, Some(_)) | (None, Some(_), _) => "springs".into(),
        _ => "-".into(),
    };
    m.set("material", material);
    m.set(
        "nu",
        config
            .material
            .as_ref()
            .and_then(|mat| mat.poisson_ratio)
            .map_or("-".into(), |nu| nu.to_string()),
    );
    let tets: usize = m.get("tets").and_then(|t| t.parse().ok()).unwrap_or(0);
    m.set("size", size_of(tets, spec.dofs).into());
    match cutoff_of(study, spec) {
        Some((key, level, value)) => {
            m.set("level", s.levels[level].clone());
            m.set("cutoff", format!("{key}={value}"));
        }
        None => {
            m.set("level", "-".into());
            m.set("cutoff", String::new());
        }
    }
    let steps = config.run.steps;
    m.set("steps", steps.to_string());
    m.set(
        "horizon",
        cell(Some(ProblemConfig::horizon(config.run.dt, steps))),
    );
    m.set("tolerance", cell(Some(problem.tolerance)));
    let i = problem.reference.independent;
    m.set(
        "reference_independent",
        format!("{} at dt = {}", i.method.name(), short(i.dt)),
    );
    let get = |m: &Measured, c: &str| m.get(c).and_then(|v| v.parse::<f64>().ok());
    let evaluations =
        get(m, "force_evaluations").unwrap_or(0.0) + get(m, "hessian_evaluations").unwrap_or(0.0);
    m.set("evaluations", cell(Some(evaluations)));
    let budget = config.run.budget.unwrap_or_default();
    for (column, limit) in [
        ("budget_wall_seconds", budget.wall_seconds),
        ("budget_evaluations", budget.evaluations),
        ("budget_factorizations", budget.factorizations),
        ("budget_linear_iterations", budget.linear_iterations),
    ] {
        m.set(column, cell(limit));
    }
    let over = budget
        .exceeded(|key| match key {
            "evaluations" => evaluations,
            other => get(m, other).unwrap_or(0.0),
        })
        .is_some();
    let error = get(m, "error").or_else(|| get(m, "error_unscored"));
    // An accuracy the reference cannot resolve is not judged: where its error bar (times the
    // floor factor, below which errors are not scored) reaches the tolerance, two valid
    // answers differ by more than the tolerance, so a run is judged on reaching the horizon
    // within the budget alone.
    let floor =
        ReferenceSettings::default().floor_factor * get(m, "reference_difference").unwrap_or(0.0);
    let judged = floor < problem.tolerance;
    // `outcome_of` writes a budget stop's message as "budget at step ...".
    let failure = if m.outcome == "horizon-not-reached" && m.message.starts_with("budget") {
        "over-budget".to_owned()
    } else if m.outcome != "completed" {
        m.outcome.clone()
    } else if over {
        "over-budget".to_owned()
    } else if !judged {
        m.message = format!(
            "accuracy not judged: the reference's error bar {} (x {} = {}) reaches the \
             tolerance {}",
            short(floor / ReferenceSettings::default().floor_factor),
            ReferenceSettings::default().floor_factor,
            short(floor),
            short(problem.tolerance)
        );
        String::new()
    } else {
        match error {
            Some(e) if e <= problem.tolerance => String::new(),
            Some(_) => "inaccurate".to_owned(),
            None => "not-scored".to_owned(),
        }
    };
    m.set(
        "solved",
        if failure.is_empty() { "yes" } else { "no" }.into(),
    );
    m.set("failure", failure);
}

/// The `[suite]` table is there and sane; the study's settings are integrator settings only;
/// each method has one block, whose one multi-valued key (its cut-off) has a value per level.
fn check(
    file: &StudyFile,
    ctx: &Context,
    bad: &dyn Fn(&str, String) -> StudyError,
) -> Result<(), StudyError> {
    let Some(s) = settings(file) else {
        return Err(ctx.invalid(
            0,
            NAME,
            "a suite needs a [suite] table with `levels` (the convergence cut-offs, loosest \
             first)",
        ));
    };
    if s.levels.len() < 2 {
        return Err(bad(
            "suite.levels",
            format!(
                "give at least two cut-off levels, so an ordering is not an artifact of one \
                 (got {})",
                s.levels.len()
            ),
        ));
    }
    if let Some(l) = s.levels.iter().find(|l| l.is_empty() || l.as_str() == "-") {
        return Err(bad(
            "suite.levels",
            format!("`{l}` cannot name a level (`-` means every level)"),
        ));
    }
    if !["all", "listed"].contains(&s.methods.as_str()) {
        return Err(bad(
            "suite.methods",
            format!("`{}`: expected `all` or `listed`", s.methods),
        ));
    }
    if !(1..=100).contains(&s.repeats) {
        return Err(bad(
            "suite.repeats",
            format!("must be from 1 to 100 (got {})", s.repeats),
        ));
    }
    for (method, reason) in &s.omit {
        Method::from_name(method).map_err(|e| bad("suite.omit", e.to_string()))?;
        if reason.trim().is_empty() {
            return Err(bad(
                "suite.omit",
                format!("`{method}`: say why it is left out"),
            ));
        }
    }
    if let Some((key, _)) = file.grid.iter().next() {
        return Err(bad(
            "grid",
            format!(
                "`{key}`: a suite has no grid: its runs are the problems × methods × levels; \
                 give each method's settings in its [[methods]] block"
            ),
        ));
    }
    for key in file.set.keys() {
        if !key.starts_with(SETTABLE) {
            return Err(bad(
                "set",
                format!(
                    "`{key}`: a problem fixes its physics and its run; a suite sets only \
                     integrator settings (`integrator.*`)"
                ),
            ));
        }
    }
    let mut seen: Vec<String> = Vec::new();
    for (i, block) in file.methods.iter().enumerate() {
        let table = block.get_ref();
        let at = block.span().start;
        let key = format!("methods[{i}]");
        let Some(name) = table.get("method").and_then(toml::Value::as_str) else {
            return Err(ctx.invalid(at, &key, "each [[methods]] block needs `method = \"...\"`"));
        };
        let method = Method::from_name(name).map_err(|e| ctx.invalid(at, &key, e.to_string()))?;
        if seen.contains(&name.to_owned()) {
            return Err(ctx.invalid(
                at,
                &key,
                format!(
                    "`{name}` has a second block: a suite declares one settings block per method"
                ),
            ));
        }
        if s.omit.contains_key(name) {
            return Err(ctx.invalid(
                at,
                &key,
                format!("`{name}` is both in [suite] omit and given a block"),
            ));
        }
        seen.push(name.to_owned());
        let mut swept = 0;
        for (k, v) in table.iter().filter(|(k, _)| *k != "method") {
            if k == METHOD_KEY || !k.starts_with(SETTABLE) {
                return Err(ctx.invalid(
                    at,
                    &key,
                    format!("`{k}`: a method block sets only integrator settings (`integrator.*`)"),
                ));
            }
            if let Some(values) = v.as_array()
                && values.len() > 1
            {
                swept += 1;
                if values.len() != s.levels.len() {
                    return Err(ctx.invalid(
                        at,
                        &key,
                        format!(
                            "`{name}`: its cut-off `{k}` has {} values; give one per level ({}: \
                             {})",
                            values.len(),
                            s.levels.len(),
                            s.levels.join(", ")
                        ),
                    ));
                }
            }
        }
        if swept > 1 {
            return Err(ctx.invalid(
                at,
                &key,
                format!(
                    "`{name}`: more than one key has several values; a block sweeps one cut-off \
                     (one value per level) and fixes everything else"
                ),
            ));
        }
        let _ = method;
    }
    Ok(())
}
