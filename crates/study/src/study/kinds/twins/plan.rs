//! The twins study kind, planning a study: its `[twins]` table, `[quick]` keys and the check
//! that every run's method has a partner.

use super::{NAME, Twins, TwinsSettings, settings};
use crate::study::kind::{Plan, parse_quick};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::grid::Axis;
use softbench_core::integrate::Method;
use softbench_run::scene::SceneConfig;

/// The `[twins]` table of a study file (its other keys are the study's).
#[derive(serde::Deserialize)]
struct FileTable {
    #[serde(default)]
    twins: Option<TwinsSettings>,
}

/// The `[quick]` keys a twins study reads.
#[derive(Default, serde::Serialize, serde::Deserialize)]
struct Quick {
    /// Runs take at most this many steps. Default 5.
    steps: Option<usize>,
}

/// The partner of `method`: the study's `[twins] partners` entry, else a peer's twin.
pub(super) fn partner(file: &StudyFile, method: Method) -> Option<String> {
    settings(file)
        .partners
        .get(method.name())
        .cloned()
        .or_else(|| method.entry().peer.and_then(|p| p.twin.clone()))
}

impl Plan for Twins {
    fn name(&self) -> &'static str {
        NAME
    }

    fn description(&self) -> &'static str {
        "a method beside its twin (a peer's softbench counterpart, or a named partner): the \
         conventions checked, then per step the trajectories' distance, energies, iterations \
         and cost"
    }

    fn example(&self) -> &'static str {
        "[grid]\n\"integrator.method\" = [\"vbd\"]\n\n[twins]\npartners = { vbd = \
         \"backward-euler\" }\n"
    }

    fn table_names(&self) -> &'static [&'static str] {
        &[NAME]
    }

    fn parse_table(&self, text: &str) -> Result<serde_json::Value, toml::de::Error> {
        let file: FileTable = toml::from_str(text)?;
        Ok(serde_json::to_value(file.twins.unwrap_or_default()).unwrap_or_default())
    }

    fn check(
        &self,
        file: &StudyFile,
        ctx: &Context,
        _bad: &dyn Fn(&str, String) -> StudyError,
    ) -> Result<(), StudyError> {
        for (method, partner) in &settings(file).partners {
            for name in [method, partner] {
                if Method::from_name(name).is_err() {
                    return Err(ctx.invalid(
                        0,
                        "twins.partners",
                        format!(
                            "`{name}` is not a method (methods: {})",
                            Method::names().join(", ")
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    fn quick_keys(&self) -> &'static [&'static str] {
        &["steps"]
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
        if file.quick.get::<usize>("steps") == Some(0) {
            return Err(bad("quick.steps", "must be at least 1".into()));
        }
        Ok(())
    }

    fn configure(
        &self,
        ctx: &Context,
        file: &StudyFile,
        config: &mut SceneConfig,
        _: &[Axis],
        quick: bool,
    ) -> Result<(), StudyError> {
        let method = config.integrator.method;
        if partner(file, method).is_none() {
            return Err(ctx.invalid(
                0,
                "integrator.method",
                format!(
                    "`{method}` has no twin: a twins study runs peer methods (whose twin is the \
                     softbench method they implement) or methods given a partner in \
                     `[twins] partners = {{ {method} = \"...\" }}`"
                ),
            ));
        }
        if quick {
            let steps = file.quick.get::<usize>("steps").unwrap_or(5);
            config.run.steps = config.run.steps.min(steps);
        }
        Ok(())
    }
}
