//! The trajectory study kind, planning a study: its settings table and `[quick]` keys, its
//! checks and how each run is adapted.

use super::Trajectory;
use crate::study::kind::{Plan, parse_quick};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::grid::Axis;
use softbench_run::scene::SceneConfig;

/// The `[quick]` keys a trajectory study reads.
#[derive(Default, serde::Serialize, serde::Deserialize)]
struct Quick {
    /// Runs take at most this many steps. Default 20.
    steps: Option<usize>,
}

impl Plan for Trajectory {
    fn name(&self) -> &'static str {
        "trajectory"
    }

    fn description(&self) -> &'static str {
        "each run as configured: energy and momentum drift, time per step, evaluation counts"
    }

    fn example(&self) -> &'static str {
        "[grid]\n\"integrator.method\" = [\"symplectic-euler\", \"backward-euler\"]\n"
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
        _: &Context,
        file: &StudyFile,
        config: &mut SceneConfig,
        _: &[Axis],
        quick: bool,
    ) -> Result<(), StudyError> {
        if quick {
            let steps = file.quick.get::<usize>("steps").unwrap_or(20);
            config.run.steps = config.run.steps.min(steps);
        }
        Ok(())
    }
}
