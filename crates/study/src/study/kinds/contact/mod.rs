//! Contact studies: each run as a trajectory run, plus what contact did — contacts, the
//! deepest penetration into analytic obstacles, the smallest distance incremental potential
//! contact kept, how many sampled frames the independent exact check found intersecting,
//! collision-detection work, barrier stiffness, and where the body ended (its centroid's
//! height along −gravity, which tells a body that went through a thin obstacle, and how far
//! it moved: sticking or sliding).
//!
//! Grid `contact.response` over the responses to compare them on the same scenes.

use crate::study::kind::{Measure, Plan, Present, RunInputs, number};
use crate::study::kinds::trajectory::{OWN_COLUMNS as TRAJECTORY, Trajectory, measure_with_state};
use crate::study::present::charts::SceneRows;
use crate::study::present::findings::Ranking;
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::format::cell;
use crate::study::vocabulary::grid::Axis;
use crate::study::vocabulary::measured::Measured;
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_core::parallel::Parallelism;
use softbench_run::scene::SceneConfig;
use std::sync::LazyLock;

/// The columns a contact study adds to a trajectory study's.
const CONTACT: &[&str] = &[
    "response",
    "contacts_max",
    "max_penetration",
    "min_distance",
    "frames_checked",
    "intersecting_frames",
    "intersection_free",
    "ccd_queries",
    "ccd_limited_steps",
    "barrier_stiffness",
    "contact_energy_max",
    "centroid_height_initial",
    "centroid_height_final",
    "centroid_displacement",
    "speed_final",
    "seconds_per_simulated_second",
];

/// A contact study's own columns: a trajectory study's, then what contact did.
static OWN_COLUMNS: LazyLock<Vec<&'static str>> =
    LazyLock::new(|| TRAJECTORY.iter().chain(CONTACT).copied().collect());

/// Every measured column: its own, the run's summary and the integrator's caps.
static COLUMNS: LazyLock<Vec<&'static str>> =
    LazyLock::new(|| crate::study::vocabulary::columns::declare(&OWN_COLUMNS, true, true));

/// A contact study.
pub(in crate::study) struct ContactStudy;

/// The mass-weighted centroid of every vertex (m).
fn centroid(model: &softbench_core::model::Model, q: &[f64]) -> nalgebra::Vector3<f64> {
    let x = model.full_positions(q);
    let m = model.vertex_masses();
    let total: f64 = m.iter().sum();
    x.iter()
        .zip(m)
        .map(|(p, m)| p * *m)
        .sum::<nalgebra::Vector3<f64>>()
        / total
}

/// The centroid's height along −gravity (along +y without gravity), mass-weighted (m).
fn centroid_height(model: &softbench_core::model::Model, q: &[f64]) -> f64 {
    let up = model
        .gravity()
        .filter(|g| g.norm() > 0.0)
        .map_or(nalgebra::Vector3::y(), |g| -g.normalize());
    let x = model.full_positions(q);
    let m = model.vertex_masses();
    let total: f64 = m.iter().sum();
    x.iter().zip(m).map(|(p, m)| m * p.dot(&up)).sum::<f64>() / total
}

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

impl Measure for ContactStudy {
    fn columns(&self) -> &'static [&'static str] {
        &COLUMNS
    }

    fn own_columns(&self) -> &'static [&'static str] {
        &OWN_COLUMNS
    }

    fn progress(&self, m: &Measured) -> Option<String> {
        number(m, "intersecting_frames").map(|n| format!(", {n} intersecting frame(s)"))
    }

    fn measure(
        &self,
        _: &Study,
        spec: &RunSpec,
        inputs: &RunInputs,
        parallelism: Parallelism,
    ) -> Result<Measured, String> {
        let (mut m, scene, state) = measure_with_state(spec, parallelism, inputs.meter)?;
        let series = std::mem::take(&mut m.series);
        let rows = &series;
        let max = |f: &dyn Fn(&softbench_run::run::Sample) -> f64| {
            rows.iter().map(f).fold(0.0_f64, f64::max)
        };
        let checked: Vec<bool> = rows
            .iter()
            .filter_map(|r| r.intersection_free.map(|f| f == 1))
            .collect();
        let intersecting = checked.iter().filter(|free| !**free).count();
        let min_distance = rows.iter().filter_map(|r| r.min_distance).reduce(f64::min);
        let has_contact = scene.contact.is_some();
        let response = if has_contact {
            scene.config.contact.response.name().to_owned()
        } else {
            "none".to_owned()
        };
        let simulated = state.t - scene.initial.t;
        let wall: f64 = rows.iter().map(|r| r.wall_seconds).sum();
        m.set("response", response);
        m.set("contacts_max", format!("{}", max(&|r| r.contacts as f64)));
        m.set("max_penetration", cell(Some(max(&|r| r.max_penetration))));
        m.set("min_distance", cell(min_distance));
        m.set("frames_checked", checked.len().to_string());
        m.set("intersecting_frames", intersecting.to_string());
        m.set(
            "intersection_free",
            if checked.is_empty() {
                String::new()
            } else {
                (intersecting == 0).to_string()
            },
        );
        m.set(
            "ccd_queries",
            rows.iter().map(|r| r.ccd_queries).sum::<u64>().to_string(),
        );
        m.set(
            "ccd_limited_steps",
            rows.iter()
                .map(|r| r.ccd_limited_steps)
                .sum::<u64>()
                .to_string(),
        );
        m.set(
            "barrier_stiffness",
            cell(Some(max(&|r| r.barrier_stiffness))),
        );
        m.set("contact_energy_max", cell(Some(max(&|r| r.contact_energy))));
        m.set(
            "centroid_height_initial",
            cell(Some(centroid_height(&scene.model, &scene.initial.q))),
        );
        m.set(
            "centroid_height_final",
            cell(Some(centroid_height(&scene.model, &state.q))),
        );
        m.set(
            "centroid_displacement",
            cell(Some(
                (centroid(&scene.model, &state.q) - centroid(&scene.model, &scene.initial.q))
                    .norm(),
            )),
        );
        let mass: f64 = scene.model.vertex_masses().iter().sum();
        let kinetic = rows.last().map_or(0.0, |r| r.kinetic);
        m.set("speed_final", cell(Some((2.0 * kinetic / mass).sqrt())));
        m.set(
            "seconds_per_simulated_second",
            cell((simulated > 0.0).then(|| wall / simulated)),
        );
        m.series = series;
        Ok(m)
    }
}

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
    }
}
