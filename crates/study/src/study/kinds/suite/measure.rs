//! The suite study kind, measuring: its columns, the work its runs share and one run's
//! measurement.

use super::{Suite, settings};
use crate::study::kind::{Measure, RunInputs, number};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::format::{cell, short};
use crate::study::vocabulary::measured::Measured;
use crate::study::vocabulary::reference::{ReferenceSettings, ScoringSettings};
use crate::study::vocabulary::spec::{RunSpec, Study};
use softbench_core::parallel::Parallelism;
use softbench_run::scene::{ProblemConfig, SceneConfig};
use std::path::Path;
use std::sync::LazyLock;

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

/// A suite's measured columns before the groups: its own ([`SUITE_COLUMNS`]), then a
/// work-precision run's (each run is measured as one), which a table of an earlier softbench
/// may lack.
static WITH_WORK_PRECISION: LazyLock<Vec<&'static str>> = LazyLock::new(|| {
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
    LazyLock::new(|| crate::study::vocabulary::columns::declare(&WITH_WORK_PRECISION, true, true));

/// Size strata by elastic tets (bodies without tets: by free DOFs, at about 0.6 DOF per tet).
const SIZES: [(&str, f64); 3] = [("small", 5e3), ("medium", 5e4), ("large", f64::INFINITY)];

impl Measure for Suite {
    fn columns(&self) -> &'static [&'static str] {
        &COLUMNS
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
