//! The trajectory study kind, measuring: its columns, the work its runs share and one run's
//! measurement.

use super::Trajectory;
use crate::study::kind::{Measure, RunInputs, number};
use crate::study::vocabulary::columns;
use crate::study::vocabulary::columns::{CAPS, SUMMARY};
use crate::study::vocabulary::format::cell;
use crate::study::vocabulary::measured::{
    Measured, build, outcome_of, picture_surface, run_observed,
};
use crate::study::vocabulary::meter::StepMeter;
use crate::study::vocabulary::spec::{RunSpec, Study};
use softbench_core::parallel::Parallelism;
use softbench_run::run::Sample;
use std::sync::LazyLock;

/// A trajectory study's own columns of `runs.csv` (after the identity and parameters; the
/// run's summary and the integrator's caps follow, [`COLUMNS`]).
pub const OWN_COLUMNS: &[&str] = &[
    "dt",
    "outcome",
    "momentum_drift",
    "angular_momentum_drift",
    "tets",
    "free_dofs",
    "fixed_dofs",
    "peak_rss_mib",
];

/// Every measured column of a trajectory study's `runs.csv`: its own, the run's summary and
/// the integrator's caps.
pub static COLUMNS: LazyLock<Vec<&'static str>> =
    LazyLock::new(|| columns::declare(OWN_COLUMNS, true, true));

impl Measure for Trajectory {
    fn columns(&self) -> &'static [&'static str] {
        &COLUMNS
    }

    fn progress(&self, m: &Measured) -> Option<String> {
        number(m, "energy_drift_max").map(|d| format!(", energy drift {d}"))
    }

    fn measure(
        &self,
        _: &Study,
        spec: &RunSpec,
        inputs: &RunInputs,
        parallelism: Parallelism,
    ) -> Result<Measured, String> {
        measure_with_state(spec, parallelism, inputs.meter).map(|(m, _, _)| m)
    }
}

/// Run one trajectory, counting its steps on `meter`; also return the scene and its final
/// state (for kinds that add columns of their own).
pub(in crate::study) fn measure_with_state(
    spec: &RunSpec,
    parallelism: Parallelism,
    meter: Option<&StepMeter>,
) -> Result<
    (
        Measured,
        softbench_run::scene::Scene,
        softbench_core::integrate::State,
    ),
    String,
> {
    crate::study::vocabulary::measured::reset_peak_rss();
    let mut scene = build(spec, parallelism).map_err(|e| e.to_string())?;
    let run = scene.config.run;
    let surface = picture_surface(&scene, spec)?;
    let mut rows = Vec::new();
    let mut keep = |s: &Sample| {
        rows.push(s.clone());
        Ok(())
    };
    let (summary, state, snapshots) = run_observed(&mut scene, &run, surface, &mut keep, meter);
    let (outcome, message) = outcome_of(&summary.outcome);
    let mut m = Measured {
        outcome,
        message,
        cells: SUMMARY.cells(&summary),
        ..Measured::default()
    };
    m.cells.extend(CAPS.cells(spec));
    m.set("dt", cell(Some(run.dt)));
    m.set(
        "peak_rss_mib",
        cell(crate::study::vocabulary::measured::peak_rss_mib()),
    );
    m.set("tets", scene.model.tets().len().to_string());
    let dofs = scene.model.dofs().counts();
    m.set("free_dofs", dofs.free_dofs.to_string());
    m.set("fixed_dofs", dofs.fixed_dofs.to_string());
    let conserved = Conservation::of(&scene);
    let (p, l) = momentum_drift(&rows, &conserved);
    m.set("momentum_drift", cell(p));
    m.set("angular_momentum_drift", cell(l));
    m.series = rows;
    m.snapshots = snapshots;
    Ok((m, scene, state))
}

/// Which momenta a scene conserves, and the force that changes linear momentum.
pub struct Conservation {
    /// No fixed vertices and no obstacles: linear momentum changes only by gravity.
    pub linear: bool,
    /// Additionally no gravity: angular momentum about the origin is conserved.
    pub angular: bool,
    /// Total gravity force (N).
    pub gravity_force: [f64; 3],
}

impl Conservation {
    /// For a built scene.
    pub fn of(scene: &softbench_run::scene::Scene) -> Self {
        let model = &scene.model;
        let free = model.dofs().num_free() == model.dofs().num_vertices();
        let linear = free && scene.contact.is_none() && model.vertex_potentials().is_empty();
        let mass: f64 = model.vertex_masses().iter().sum();
        let g = model.gravity().map_or([0.0; 3], |g| [g.x, g.y, g.z]);
        Self {
            linear,
            angular: linear && g == [0.0; 3],
            gravity_force: g.map(|g| g * mass),
        }
    }
}

/// Largest deviation of linear momentum from `p(0) + t F_gravity` (kg m/s) and of angular
/// momentum from its initial value (kg m^2/s), over the rows; `None` where the scene does not
/// conserve it (fixed vertices, obstacles, drags).
pub fn momentum_drift(rows: &[Sample], c: &Conservation) -> (Option<f64>, Option<f64>) {
    let Some(first) = rows.first() else {
        return (None, None);
    };
    let p0 = [first.momentum_x, first.momentum_y, first.momentum_z];
    let l0 = [
        first.angular_momentum_x,
        first.angular_momentum_y,
        first.angular_momentum_z,
    ];
    let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let mut p_drift = 0.0f64;
    let mut l_drift = 0.0f64;
    for r in rows {
        let dt = r.t - first.t;
        let p = [r.momentum_x, r.momentum_y, r.momentum_z];
        let expected = [0, 1, 2].map(|k| p0[k] + dt * c.gravity_force[k]);
        p_drift = p_drift.max(norm([0, 1, 2].map(|k| p[k] - expected[k])));
        let l = [
            r.angular_momentum_x,
            r.angular_momentum_y,
            r.angular_momentum_z,
        ];
        l_drift = l_drift.max(norm([0, 1, 2].map(|k| l[k] - l0[k])));
    }
    (c.linear.then_some(p_drift), c.angular.then_some(l_drift))
}
