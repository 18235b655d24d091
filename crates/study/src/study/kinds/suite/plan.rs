//! The suite study kind, planning a study: its settings table and `[quick]` keys, its checks
//! and how each run is adapted.

use super::{NAME, Suite, SuiteSettings, settings};
use crate::study::kind::{OwnKey, Plan, parse_quick};
use crate::study::vocabulary::config::{METHOD_KEY, StudyFile};
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use softbench_core::integrate::Method;
use softbench_run::scene::SceneConfig;

/// The settings keys a suite may set (in `[set]` and `[[methods]]`): a problem fixes its
/// physics and its run, so only the integrator's settings are the suite's.
const SETTABLE: &str = "integrator.";

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

/// The methods named by the study's `[[methods]]` blocks.
fn listed_methods(file: &StudyFile) -> Vec<String> {
    file.methods
        .iter()
        .filter_map(|m| m.get_ref().get("method")?.as_str().map(str::to_owned))
        .collect()
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
