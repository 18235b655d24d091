//! The contact study kind, presenting: verdicts, report paragraphs, charts and pictures.

use super::ContactStudy;
use crate::study::kind::Present;
use crate::study::kinds::trajectory::Trajectory;
use crate::study::present::charts::SceneRows;
use crate::study::present::findings::Ranking;
use crate::study::vocabulary::table::Table;

impl Present for ContactStudy {
    fn summary_columns(&self) -> &'static [&'static str] {
        &[
            "response",
            "outcome",
            "intersecting_frames",
            "max_penetration",
            "min_distance",
            "centroid_height_final",
            "energy_drift_final",
            "newton_iterations_per_step",
            "seconds_per_simulated_second",
        ]
    }

    fn sweep_metrics(&self) -> &'static [&'static str] {
        &["seconds_per_simulated_second", "max_penetration"]
    }

    fn quick_notice(&self) -> &'static str {
        Trajectory.quick_notice()
    }

    fn rankings(&self, s: &SceneRows, damped: Option<&str>) -> Vec<Ranking> {
        Trajectory.rankings(s, damped)
    }

    fn unit_notes(&self, runs: &Table, shown: &dyn Fn(&str) -> bool) -> Vec<String> {
        let mut notes = Trajectory.unit_notes(runs, shown);
        notes.push(
            "max_penetration: deepest vertex inside an analytic obstacle (m); min_distance: \
             the smallest distance between contact primitives incremental potential contact \
             measured, capped at its d̂ (m; empty for other responses); intersecting_frames: \
             sampled frames the exact triangle test found intersecting (self, mesh and box \
             obstacles) or with a vertex inside an obstacle; centroid height along −gravity (m)"
                .into(),
        );
        notes
    }

    fn energy_caption(&self) -> Option<&'static str> {
        Trajectory.energy_caption()
    }

    /// Per scene: which runs the independent check found intersection-free at every sampled
    /// frame, which not (and how many frames), and where each body ended.
    fn report_findings(
        &self,
        out: &mut String,
        runs: &Table,
        _: &crate::study::vocabulary::meta::StudyMeta,
    ) {
        use std::fmt::Write;
        let mut scenes: Vec<&str> = runs
            .rows
            .iter()
            .filter_map(|r| runs.get(r, "scene"))
            .collect();
        scenes.dedup();
        if scenes.is_empty() {
            return;
        }
        let _ = writeln!(
            out,
            "## Intersections
"
        );
        let _ = writeln!(
            out,
            "Each sampled frame checked by exact triangle–triangle and edge–triangle tests \
             (self, mesh and box obstacles) and every vertex's signed distance to the analytic \
             obstacles, independently of the response.\n"
        );
        for scene in scenes {
            let rows: Vec<&Vec<String>> = runs
                .rows
                .iter()
                .filter(|r| runs.get(r, "scene") == Some(scene))
                .collect();
            let label = |r: &[String]| {
                let mut l = runs.get(r, "run_id").unwrap_or("?").to_owned();
                if let Some(p) = l.find("response=") {
                    l = l[p + "response=".len()..].to_owned();
                }
                l
            };
            let (free, crossed): (Vec<&&Vec<String>>, Vec<&&Vec<String>>) = rows
                .iter()
                .partition(|r| runs.get(r, "intersecting_frames") == Some("0"));
            let free: Vec<String> = free.iter().map(|r| label(r)).collect();
            let crossed: Vec<String> = crossed
                .iter()
                .map(|r| {
                    format!(
                        "{} ({} of {} frames; centroid ended at {} m)",
                        label(r),
                        runs.get(r, "intersecting_frames").unwrap_or("?"),
                        runs.get(r, "frames_checked").unwrap_or("?"),
                        runs.get(r, "centroid_height_final").unwrap_or("?"),
                    )
                })
                .collect();
            let none = || "none".to_owned();
            let _ = writeln!(
                out,
                "- {scene}: intersection-free at every frame: {}; intersecting: {}.",
                if free.is_empty() {
                    none()
                } else {
                    free.join(", ")
                },
                if crossed.is_empty() {
                    none()
                } else {
                    crossed.join(", ")
                },
            );
        }
        let _ = writeln!(out);
        let _ = writeln!(
            out,
            "The response `ipc` is checked against ipc-toolkit (`ipctk`), the reference \
             implementation, on configurations from its own runs with self-contact and a thin \
             triangle-mesh plate (`python/tests/test_ipctk.py`): the barrier and its gradient \
             agree to 1e-9 relative, the smallest distance to 1e-12 m, and the collision-free \
             step to 15 % of ipctk's additive CCD, safe by ipctk's own distances along the \
             path ([Contact](../../docs/contact.md#checked-against-ipc-toolkit)).\n"
        );
    }
}
