//! The contact study kind, measuring: its columns, the work its runs share and one run's
//! measurement.

use super::ContactStudy;
use crate::study::kind::{Measure, RunInputs, number};
use crate::study::kinds::trajectory::{OWN_COLUMNS as TRAJECTORY, measure_with_state};
use crate::study::vocabulary::format::cell;
use crate::study::vocabulary::measured::Measured;
use crate::study::vocabulary::spec::{RunSpec, Study};
use softbench_core::parallel::Parallelism;
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

impl Measure for ContactStudy {
    fn columns(&self) -> &'static [&'static str] {
        &COLUMNS
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
