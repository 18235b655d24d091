//! What studies measure, against known answers: the stability search brackets the explicit
//! limit of a spring system; work-precision errors shrink at each method's order.

mod common;

use common::{TempDir, run_study_ok};
use nalgebra::{Matrix3, Vector3};
use softbench::study::table::Table;

/// One free particle (vertex 3 of a single tet) held by springs to three fixed ones.
const PARTICLE_MESH: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0.3 0.2 0.8\nt 0 1 2 3\n";
const SPRING_K: f64 = 400.0;
const PARTICLE_M: f64 = 0.25;

fn particle_scene() -> String {
    format!(
        r#"
[mesh]
file = "particle.mesh"
[springs]
from_tets = true
stiffness = {SPRING_K}
particle_mass = {PARTICLE_M}
[fixed]
indices = [0, 1, 2]
[initial]
velocity = [1e-4, 2e-4, -1e-4]
[integrator]
method = "symplectic-euler"
[run]
dt = 0.001
steps = 10
"#
    )
}

/// omega_max of the particle: the largest eigenvalue of K = k sum n n^T over its three
/// springs, over m.
fn particle_omega() -> f64 {
    let p = Vector3::new(0.3, 0.2, 0.8);
    let mut k = Matrix3::zeros();
    for q in [Vector3::zeros(), Vector3::x(), Vector3::y()] {
        let n = (p - q).normalize();
        k += SPRING_K * n * n.transpose();
    }
    let lambda = k.symmetric_eigenvalues().max() / PARTICLE_M;
    lambda.sqrt()
}

#[test]
fn stability_search_brackets_the_symplectic_euler_limit_of_a_spring_system() {
    let tmp = TempDir::new("study-spring");
    tmp.write("particle.mesh", PARTICLE_MESH);
    tmp.write("particle.toml", &particle_scene());
    let study = tmp.write(
        "study.toml",
        r#"name = "spring"
study = "stability"
scenes = ["particle.toml"]
[grid]
"integrator.method" = ["symplectic-euler", "rk4"]
[stability]
dt_min = 1e-3
dt_max = 1.0
horizon = 20.0
max_steps = 4000
energy_factor = 1e4
relative_precision = 1e-3
"#,
    );
    let out = tmp.path().join("results");
    run_study_ok(&study, &out, &[]);
    let runs = Table::read(&out.join("spring/runs.csv")).unwrap().unwrap();
    let omega = particle_omega();
    for (row, method, limit) in [
        (&runs.rows[0], "symplectic-euler", 2.0 / omega),
        // RK4's interval of absolute stability on the imaginary axis ends at 2 sqrt(2).
        (&runs.rows[1], "rk4", 2.0 * 2f64.sqrt() / omega),
    ] {
        assert_eq!(runs.get(row, "method"), Some(method));
        let omega_reported = runs.number(row, "omega_max").unwrap();
        assert!(
            (omega_reported / omega - 1.0).abs() < 1e-8,
            "omega_max {omega_reported} vs {omega}"
        );
        let found = runs.number(row, "max_stable_dt").unwrap();
        let unstable = runs.number(row, "first_unstable_dt").unwrap();
        println!("{method}: limit {limit:.6e}, bracket [{found:.6e}, {unstable:.6e}]");
        assert!(
            (found / limit - 1.0).abs() < 0.01,
            "{method}: largest stable dt {found} vs the limit {limit}"
        );
        assert!(found < unstable && unstable / limit < 1.01);
    }
    let theory = runs.number(&runs.rows[0], "dt_theory").unwrap();
    assert!((theory * omega / 2.0 - 1.0).abs() < 1e-8);
}

/// Run a one-method stability study of the particle with `bracket` (TOML lines) and return
/// its row.
fn particle_stability(bracket: &str) -> (Table, Vec<String>) {
    let tmp = TempDir::new("study-widen");
    tmp.write("particle.mesh", PARTICLE_MESH);
    tmp.write("particle.toml", &particle_scene());
    let study = tmp.write(
        "study.toml",
        &format!(
            "name = \"widen\"\nstudy = \"stability\"\nscenes = [\"particle.toml\"]\n\
             [grid]\n\"integrator.method\" = [\"symplectic-euler\"]\n\
             [stability]\nhorizon = 20.0\nmax_steps = 4000\nenergy_factor = 1e4\n\
             relative_precision = 1e-3\n{bracket}\n"
        ),
    );
    let out = tmp.path().join("results");
    run_study_ok(&study, &out, &[]);
    let runs = Table::read(&out.join("widen/runs.csv")).unwrap().unwrap();
    let row = runs.rows[0].clone();
    (runs, row)
}

#[test]
fn an_unstable_lower_bound_widens_the_bracket_downward() {
    let limit = 2.0 / particle_omega();
    // dt_min = 0.1 is above the limit (0.0367 s): the search widens to 0.01 and finds it.
    let (runs, row) = particle_stability("dt_min = 0.1\ndt_max = 1.0\ndt_floor = 1e-3");
    assert_eq!(runs.get(&row, "stability"), Some("limit-found"));
    let found = runs.number(&row, "max_stable_dt").unwrap();
    assert!((found / limit - 1.0).abs() < 0.01, "{found} vs {limit}");
    // With the floor above the limit, every step in range gains energy: the row says so with
    // the range and the growth rate, and does not call the method unstable at every dt (its
    // limit lies below the range).
    let (runs, row) = particle_stability("dt_min = 0.1\ndt_max = 1.0\ndt_floor = 0.05");
    assert_eq!(runs.get(&row, "stability"), Some("no-stable-dt-in-range"));
    assert_eq!(runs.get(&row, "outcome"), Some("unstable"));
    assert_eq!(runs.get(&row, "max_stable_dt"), Some(""));
    assert_eq!(runs.number(&row, "lowest_dt"), Some(0.05));
    assert!(runs.number(&row, "energy_growth_rate").unwrap() > 0.0);
    assert!(
        runs.get(&row, "message")
            .unwrap()
            .starts_with("no-stable-dt-in-range in [0.05, 1] s"),
        "{:?}",
        runs.get(&row, "message")
    );
}

#[test]
fn work_precision_errors_shrink_at_the_method_order() {
    let tmp = TempDir::new("study-wp-order");
    tmp.write(
        "beam.toml",
        r#"
[mesh]
generate = { box = [4, 1, 1], size = [1.0, 0.25, 0.25] }
[material]
model = "stable-neo-hookean"
youngs_modulus = 2e4
poisson_ratio = 0.3
density = 1000.0
mass = "lumped"
[fixed]
rule = { axis = "x", side = "min", tolerance = 1e-6 }
[forces]
gravity = [0.0, -9.81, 0.0]
[run]
dt = 0.01
steps = 1
"#,
    );
    let study = tmp.write(
        "study.toml",
        r#"name = "order"
study = "work-precision"
scenes = ["beam.toml"]
[set]
"integrator.newton.tolerance" = 1e-12
"integrator.newton.max_iterations" = 30
[grid]
"integrator.method" = ["midpoint", "rk4", "backward-euler", "implicit-midpoint", "bdf2"]
"run.dt" = [0.008, 0.004, 0.002, 0.001]
[work-precision]
horizon = 0.16
samples = 2
reference = { method = "rk4", dt_factor = 8 }
"#,
    );
    let out = tmp.path().join("results");
    run_study_ok(&study, &out, &[]);
    let runs = Table::read(&out.join("order/runs.csv")).unwrap().unwrap();
    for (method, order) in [
        ("midpoint", 2.0),
        ("rk4", 4.0),
        ("backward-euler", 1.0),
        ("implicit-midpoint", 2.0),
        ("bdf2", 2.0),
    ] {
        let mut points: Vec<(f64, f64)> = runs
            .rows
            .iter()
            .filter(|r| runs.get(r, "method") == Some(method))
            .filter_map(|r| Some((runs.number(r, "dt")?, runs.number(r, "error")?)))
            .collect();
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        assert!(
            points.len() >= 2,
            "{method}: fewer than two scored errors: {points:?}"
        );
        // The slope over the smallest steps (the asymptotic regime).
        let ((d1, e1), (d2, e2)) = (points[0], points[1]);
        let observed = (e2 / e1).ln() / (d2 / d1).ln();
        println!("{method}: observed order {observed:.2} from {points:?}");
        assert!(
            (observed - order).abs() < 0.3,
            "{method}: observed order {observed:.2}, expected {order}"
        );
    }
}

#[test]
fn work_precision_repeats_give_the_median_time_and_the_same_results() {
    let tmp = TempDir::new("wp-repeats");
    tmp.write("beam.toml", DRAGGED_BEAM);
    let study = tmp.write(
        "study.toml",
        r#"name = "repeats"
study = "work-precision"
scenes = ["beam.toml"]
[grid]
"integrator.method" = ["backward-euler", "adaptive-esdirk43"]
"run.dt" = [0.01]
[work-precision]
horizon = 0.04
samples = 2
repeats = 3
"#,
    );
    let out = tmp.path().join("results");
    run_study_ok(&study, &out, &[]);
    let runs = Table::read(&out.join("repeats/runs.csv")).unwrap().unwrap();
    assert_eq!(runs.rows.len(), 2);
    for r in &runs.rows {
        assert_eq!(runs.get(r, "repeats"), Some("3"));
        assert_eq!(runs.get(r, "repeatable"), Some("yes"));
        let (lo, mid, hi) = (
            runs.number(r, "wall_seconds_min").unwrap(),
            runs.number(r, "wall_seconds").unwrap(),
            runs.number(r, "wall_seconds_max").unwrap(),
        );
        assert!(lo <= mid && mid <= hi, "{lo} {mid} {hi}");
    }
}

/// A clamped beam sagging under a drag: the scene of the same-dt test.
const DRAGGED_BEAM: &str = r#"
[mesh]
generate = { box = [4, 1, 1], size = [0.4, 0.1, 0.1] }
[material]
model = "stable-neo-hookean"
youngs_modulus = 1e5
poisson_ratio = 0.4
density = 1000.0
mass = "lumped"
[fixed]
rule = { axis = "x", side = "min", tolerance = 1e-6 }
[forces]
gravity = [0.0, -9.81, 0.0]
[[drag]]
point = [0.4, 0.1, 0.1]
radius = 0.01
stiffness = 50.0
path = [{ t = 0.0, offset = [0.0, 0.0, 0.0] }, { t = 0.04, offset = [0.05, 0.0, 0.0] }]
[run]
dt = 0.01
steps = 1
"#;

#[test]
fn same_dt_references_score_local_solvers_against_the_converged_step_of_their_own_energy() {
    let tmp = TempDir::new("study-same-dt");
    tmp.write("beam.toml", DRAGGED_BEAM);
    let study = tmp.write(
        "study.toml",
        r#"name = "local"
study = "work-precision"
scenes = ["beam.toml"]
[grid]
"run.dt" = [0.01]
[[methods]]
method = "vbd"
"integrator.vbd.iterations" = [2, 20, 200, 2000]
[[methods]]
method = "projective-dynamics"
"material.model" = "corotated"
"integrator.projective_dynamics.iterations" = [2, 20, 200, 2000]
[[methods]]
method = "xpbd"
"material.model" = "xpbd-neo-hookean"
"integrator.xpbd.substeps" = [10, 100]
[[methods]]
method = "backward-euler"
"integrator.newton.tolerance" = 1e-10
[work-precision]
horizon = 0.04
samples = 2
reference = { same_dt = true }
"#,
    );
    let out = tmp.path().join("results");
    run_study_ok(&study, &out, &[]);
    let dir = out.join("local");
    let runs = Table::read(&dir.join("runs.csv")).unwrap().unwrap();
    let rows = |method: &str, knob: &str| -> Vec<(f64, Option<f64>)> {
        let mut v: Vec<(f64, Option<f64>)> = runs
            .rows
            .iter()
            .filter(|r| runs.get(r, "method") == Some(method))
            .map(|r| {
                assert_eq!(runs.number(r, "reference_dt"), Some(0.01), "{method}");
                assert_eq!(runs.get(r, "outcome"), Some("completed"), "{method}");
                // Scored or not (below the reference's own accuracy), the error is recorded.
                let error = runs
                    .number(r, "error")
                    .or_else(|| runs.number(r, "error_unscored"));
                (runs.number(r, knob).unwrap_or(0.0), error)
            })
            .collect();
        v.sort_by(|a, b| a.0.total_cmp(&b.0));
        v
    };
    // The error of VBD and PD falls as their iterations grow, below 1e-6 relative at the end.
    for (method, knob) in [
        ("vbd", "integrator.vbd.iterations"),
        (
            "projective-dynamics",
            "integrator.projective_dynamics.iterations",
        ),
    ] {
        let e = rows(method, knob);
        let errors: Vec<f64> = e.iter().map(|(_, e)| e.unwrap()).collect();
        println!("{method}: {errors:?}");
        assert!(
            errors.windows(2).all(|w| w[1] < w[0] || w[1] < 1e-12),
            "{method}: {errors:?}"
        );
        assert!(errors[0] > 1e-3, "{method}: {errors:?}");
        assert!(*errors.last().unwrap() < 1e-6, "{method}: {errors:?}");
        // Every run counted its iterations per step.
        for r in runs
            .rows
            .iter()
            .filter(|r| runs.get(r, "method") == Some(method))
        {
            assert_eq!(
                runs.number(r, "local_iterations_per_step"),
                runs.number(r, knob),
                "{method}"
            );
        }
    }
    // Backward Euler converged as tightly as the reference is the reference: within its
    // accuracy, so not scored.
    let be = runs
        .rows
        .iter()
        .find(|r| runs.get(r, "method") == Some("backward-euler"))
        .unwrap();
    assert_eq!(
        runs.get(be, "scored"),
        Some("no"),
        "{:?}",
        runs.get(be, "error_unscored")
    );
    // XPBD has its own reference (its energy), so it is scored and finite.
    assert!(
        rows("xpbd", "integrator.xpbd.substeps")
            .iter()
            .all(|(_, e)| e.is_some_and(f64::is_finite))
    );
    // One reference per material: three in the report, each converged at the runs' dt.
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert_eq!(
        report.matches("converged at the runs' own dt").count(),
        3,
        "{report}"
    );
    for material in ["stable-neo-hookean", "corotated", "xpbd-neo-hookean"] {
        assert!(
            report.contains(&format!("beam ({material}, dt = 0.01 s)")),
            "{report}"
        );
    }
    // The charts against time per step and against iterations are drawn.
    for chart in [
        "work-precision-step-time-beam.png",
        "work-precision-iterations-beam.png",
    ] {
        assert!(dir.join(chart).is_file(), "{chart}");
    }
}

#[test]
fn same_dt_is_refused_outside_work_precision_and_with_a_fixed_reference_dt() {
    let tmp = TempDir::new("study-same-dt-bad");
    tmp.write("beam.toml", DRAGGED_BEAM);
    let study = tmp.write(
        "study.toml",
        r#"name = "local"
study = "work-precision"
scenes = ["beam.toml"]
[grid]
"run.dt" = [0.01]
[work-precision]
horizon = 0.04
reference = { same_dt = true, dt = 0.001 }
"#,
    );
    let o = common::softbench(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        tmp.path().join("out").to_str().unwrap(),
    ]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("reference.dt") && err.contains("same_dt"),
        "{err}"
    );
}

/// A reference checked against an independent solution (another method at its own step):
/// its error bar is their difference, which is exactly the error a run of that method at that
/// step gets against it; the reference is the declared method at its own step.
#[test]
fn an_independent_solution_is_the_reference_error_bar() {
    let tmp = TempDir::new("study-independent");
    tmp.write("beam.toml", DRAGGED_BEAM);
    let study = tmp.write(
        "study.toml",
        r#"name = "independent"
study = "work-precision"
scenes = ["beam.toml"]
[grid]
"run.dt" = [0.001]
"integrator.method" = ["implicit-midpoint", "backward-euler"]
[set]
"integrator.newton.tolerance" = 1e-10
[work-precision]
horizon = 0.04
samples = 2
reference = { method = "rk4", dt = 1e-4, floor_factor = 0.5, independent = { method = "implicit-midpoint", dt = 0.001 } }
"#,
    );
    let out = tmp.path().join("results");
    run_study_ok(&study, &out, &[]);
    let dir = out.join("independent");
    let runs = Table::read(&dir.join("runs.csv")).unwrap().unwrap();
    let row = |m: &str| {
        runs.rows
            .iter()
            .find(|r| runs.get(r, "method") == Some(m))
            .unwrap()
    };
    let midpoint = row("implicit-midpoint");
    let difference = runs.number(midpoint, "reference_difference").unwrap();
    assert_eq!(runs.number(midpoint, "reference_dt"), Some(1e-4));
    assert_eq!(runs.get(midpoint, "reference_method"), Some("rk4"));
    // The same solve as the check, scored against the same reference: the same number.
    assert_eq!(runs.number(midpoint, "error"), Some(difference));
    // Backward Euler is first order: far from both.
    assert!(runs.number(row("backward-euler"), "error").unwrap() > 10.0 * difference);
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(
        report.contains("an independent solution (implicit-midpoint at dt = 0.001 s)"),
        "{report}"
    );
}
