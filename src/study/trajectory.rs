//! Trajectory runs: run the scene as configured and summarize energy and momentum drift,
//! time per step and evaluation counts.

use super::format::cell;
use super::kind::{
    KindSpec, keep_axes, no_charts, no_findings, no_omega, no_quick_check, no_report, no_settings,
    number, run_steps,
};
use super::measured::{
    Measured, build, cap_cells, outcome_of, picture_surface, run_rows, summary_cells,
};
use super::spec::RunSpec;
use crate::parallel::Parallelism;
use crate::run::Sample;

/// Columns of a trajectory study's `runs.csv` after the run's identity.
pub const COLUMNS: &[&str] = &[
    "dt",
    "outcome",
    "energy_drift_max",
    "energy_drift_final",
    "momentum_drift",
    "angular_momentum_drift",
    "step_seconds_median",
    "step_seconds_p95",
    "steps",
    "final_time",
    "wall_seconds",
    "force_evaluations",
    "hessian_evaluations",
    "factorizations",
    "linear_iterations",
    "newton_iterations",
    "newton_iterations_per_step",
    "newton_unconverged_steps",
    "newton_max_iterations",
    "newton_required",
    "newton_refactor_every",
    "energy_excess_peak",
    "energy_limit",
    "assemble_seconds",
    "factor_seconds",
    "solve_seconds",
    "qp_seconds",
    "force_seconds",
    "mass_solves",
    "mass_solve_seconds",
    "internal_dt_min",
    "internal_dt_median",
    "internal_dt_max",
    "tets",
    "free_dofs",
    "linear_solver_used",
    "ordering",
    "factor_nnz",
    "symbolic_analyses",
    "factor_flops",
    "factor_threads",
    "factor_scheduler",
    "amg_operator_complexity",
    "amg_grid_complexity",
    "amg_builds",
    "amg_reuses",
    "amg_strength_threshold",
    "amg_rebuild_every",
    "linear_iterations_per_solve",
    "peak_rss_mib",
];

/// What the rest of the study code asks of a trajectory (and the runs of a sweep) study.
pub(super) const SPEC: KindSpec = KindSpec {
    columns: COLUMNS,
    summary_columns: &[
        "dt",
        "outcome",
        "energy_drift_max",
        "energy_drift_final",
        "momentum_drift",
        "step_seconds_median",
        "step_seconds_p95",
        "newton_iterations_per_step",
        "newton_unconverged_steps",
    ],
    sweep_metrics: &["energy_drift_max", "step_seconds_median"],
    progress: |m| number(m, "energy_drift_max").map(|d| format!(", energy drift {d}")),
    settings_json: no_settings,
    quick_notice: "runs are shortened",
    report_settings: no_report,
    report_findings: no_findings,
    check: |_, _, _| Ok(()),
    check_quick: no_quick_check,
    quick_axes: keep_axes,
    configure: |_, file, config, _, quick| {
        if quick {
            config.run.steps = config.run.steps.min(file.quick.steps.unwrap_or(20));
        }
        Ok(())
    },
    estimated_steps: run_steps,
    needs_omega: no_omega,
    references: None,
    measure: |_, spec, _, parallelism| measure(spec, parallelism),
    scene_charts: no_charts,
    energy_caption: Some(
        "Energy balance over time: |E(t) - E(0) - work done on the body| over the energy budget \
         the blow-up check uses (the scene's energy scale plus the work put in), log scale.",
    ),
    // One chart per time step when the study sweeps it: a chart of every run would be
    // unreadable.
    by_time_step: true,
    picture_rows: super::pictures::PictureRows::All,
    phases_at_smallest_dt: false,
    phase_dt_columns: &["dt"],
};

/// Run one trajectory.
pub fn measure(spec: &RunSpec, parallelism: Parallelism) -> Result<Measured, String> {
    super::measured::reset_peak_rss();
    let mut scene = build(spec, parallelism).map_err(|e| e.to_string())?;
    let run = scene.config.run;
    let surface = picture_surface(&scene, spec)?;
    let (summary, rows, snapshots) = run_rows(&mut scene, &run, surface);
    let (outcome, message) = outcome_of(&summary.outcome);
    let mut m = Measured {
        outcome,
        message,
        cells: summary_cells(&summary),
        ..Measured::default()
    };
    m.cells.extend(cap_cells(spec));
    m.set("dt", cell(Some(run.dt)));
    m.set("peak_rss_mib", cell(super::measured::peak_rss_mib()));
    m.set("tets", scene.model.tets().len().to_string());
    m.set("free_dofs", (3 * scene.model.dofs().num_free()).to_string());
    let conserved = Conservation::of(&scene);
    let (p, l) = momentum_drift(&rows, &conserved);
    m.set("momentum_drift", cell(p));
    m.set("angular_momentum_drift", cell(l));
    m.series = rows;
    m.snapshots = snapshots;
    Ok(m)
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
    pub fn of(scene: &crate::scene::Scene) -> Self {
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
