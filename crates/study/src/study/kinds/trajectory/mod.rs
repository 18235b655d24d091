//! Trajectory runs: run the scene as configured and summarize energy and momentum drift,
//! time per step and evaluation counts.

use crate::study::kind::{Measure, Plan, Present, RunInputs, number, parse_quick};
use crate::study::present::charts::SceneRows;
use crate::study::present::findings::{self, Ranking};
use crate::study::vocabulary::columns::{self, CAPS, SUMMARY};
use crate::study::vocabulary::config::StudyFile;
use crate::study::vocabulary::context::Context;
use crate::study::vocabulary::error::StudyError;
use crate::study::vocabulary::format::cell;
use crate::study::vocabulary::grid::Axis;
use crate::study::vocabulary::measured::{
    Measured, build, outcome_of, picture_surface, run_observed,
};
use crate::study::vocabulary::meter::StepMeter;
use crate::study::vocabulary::spec::{RunSpec, Study};
use crate::study::vocabulary::table::Table;
use softbench_core::parallel::Parallelism;
use softbench_run::run::Sample;
use softbench_run::scene::SceneConfig;
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

/// A trajectory study (and the runs of a sweep of one): each run as configured.
pub(in crate::study) struct Trajectory;

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

impl Measure for Trajectory {
    fn columns(&self) -> &'static [&'static str] {
        &COLUMNS
    }

    fn own_columns(&self) -> &'static [&'static str] {
        OWN_COLUMNS
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

/// Run one trajectory.
pub fn measure(spec: &RunSpec, parallelism: Parallelism) -> Result<Measured, String> {
    measure_with_state(spec, parallelism, None).map(|(m, _, _)| m)
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
