//! The trajectory study kind, presenting: verdicts, report paragraphs, charts and pictures.

use super::Trajectory;
use crate::study::kind::Present;
use crate::study::present::charts::SceneRows;
use crate::study::present::findings;
use crate::study::present::findings::Ranking;
use crate::study::vocabulary::table::Table;

impl Present for Trajectory {
    fn summary_columns(&self) -> &'static [&'static str] {
        &[
            "dt",
            "outcome",
            "energy_drift_max",
            "energy_drift_final",
            "momentum_drift",
            "step_seconds_median",
            "step_seconds_p95",
            "newton_iterations_per_step",
            "newton_unconverged_steps",
        ]
    }

    fn sweep_metrics(&self) -> &'static [&'static str] {
        &["energy_drift_max", "step_seconds_median"]
    }

    fn quick_notice(&self) -> &'static str {
        "runs are shortened"
    }

    /// Cost per simulated second and energy drift.
    fn rankings(&self, s: &SceneRows, damped: Option<&str>) -> Vec<Ranking> {
        findings::cost_and_drift(s, damped)
    }

    fn unit_notes(&self, runs: &Table, shown: &dyn Fn(&str) -> bool) -> Vec<String> {
        if !shown("momentum_drift") {
            return Vec::new();
        }
        let all_empty = runs
            .rows
            .iter()
            .all(|r| runs.get(r, "momentum_drift").is_none_or(str::is_empty));
        vec![if all_empty {
            "momentum drift in kg m/s, empty in every row here because no scene conserves \
             momentum (fixed vertices, obstacles or drags act on the body)"
                .into()
        } else {
            "momentum drift in kg m/s (empty where the scene does not conserve momentum)".into()
        }]
    }

    fn energy_caption(&self) -> Option<&'static str> {
        Some(
            "Energy balance over time: |E(t) - E(0) - work done on the body| over the energy \
             the body holds or exchanges, the scale the blow-up check judges it against (log \
             scale); the legend says whether energy was gained or lost (a run whose excess \
             changed sign has a line for each).",
        )
    }

    /// One chart per time step when the study sweeps it: a chart of every run would be
    /// unreadable.
    fn by_time_step(&self) -> bool {
        true
    }
}
