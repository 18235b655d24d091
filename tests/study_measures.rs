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
    // With the floor above the limit, every step in range gains energy, and the row says so
    // with the range and the growth rate.
    let (runs, row) = particle_stability("dt_min = 0.1\ndt_max = 1.0\ndt_floor = 0.05");
    assert_eq!(runs.get(&row, "stability"), Some("unstable-at-every-dt"));
    assert_eq!(runs.get(&row, "outcome"), Some("unstable"));
    assert_eq!(runs.get(&row, "max_stable_dt"), Some(""));
    assert_eq!(runs.number(&row, "lowest_dt"), Some(0.05));
    assert!(runs.number(&row, "energy_growth_rate").unwrap() > 0.0);
    assert!(
        runs.get(&row, "message")
            .unwrap()
            .starts_with("unstable-at-every-dt in [0.05, 1] s"),
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
