//! The contact study kind, planning a study: its settings table and `[quick]` keys, its checks
//! and how each run is adapted.

use super::ContactStudy;
use crate::study::kind::Plan;
use crate::study::kinds::trajectory::Trajectory;
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::grid::Axis;
use softbench_run::scene::SceneConfig;

impl Plan for ContactStudy {
    fn name(&self) -> &'static str {
        "contact"
    }

    fn description(&self) -> &'static str {
        "trajectory runs with contact: penetration, intersections (exact check), smallest \
         distance, collision detection, where the body ended"
    }

    fn example(&self) -> &'static str {
        "[grid]\n\"contact.response\" = [\"penalty\", \"constrained\", \"ipc\"]\n"
    }

    fn quick_keys(&self) -> &'static [&'static str] {
        Trajectory.quick_keys()
    }

    fn parse_quick(
        &self,
        text: &str,
    ) -> Result<serde_json::Map<String, serde_json::Value>, toml::de::Error> {
        Trajectory.parse_quick(text)
    }

    fn check_quick_values(
        &self,
        file: &StudyFile,
        bad: &dyn Fn(&str, String) -> StudyError,
    ) -> Result<(), StudyError> {
        Trajectory.check_quick_values(file, bad)
    }

    fn configure(
        &self,
        context: &Context,
        file: &StudyFile,
        config: &mut SceneConfig,
        axes: &[Axis],
        quick: bool,
    ) -> Result<(), StudyError> {
        Trajectory.configure(context, file, config, axes, quick)
    }
}
