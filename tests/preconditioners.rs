//! Claims about CG's preconditioners on real backward-Euler systems: smoothed-aggregation AMG
//! with rigid-body modes keeps iterations nearly flat as the mesh grows, where the one-level
//! preconditioners do not; and `auto` picks the solver its prediction says.

#[path = "support/fem_system.rs"]
mod fem_system;

use fem_system::{FemSystem, fem_ball, fem_box, fem_box_sized};
use softbench::parallel::Parallelism;
use softbench::solve::{
    AutoPrediction, AutoSolver, CgSettings, CgSolver, LinearSolver, Preconditioner, SolverSettings,
};

/// CG iterations to 1e-8 on `system` with a smooth right-hand side; `coordinates`: give AMG
/// the positions (rigid-body modes).
fn iterations(system: &FemSystem, preconditioner: Preconditioner, coordinates: bool) -> usize {
    let (_, it, residual) = cg_solve(system, preconditioner, coordinates, Parallelism::Sequential);
    assert!(residual <= 1e-8, "residual {residual:e}");
    it
}

fn cg_solve(
    system: &FemSystem,
    preconditioner: Preconditioner,
    coordinates: bool,
    parallelism: Parallelism,
) -> (Vec<f64>, usize, f64) {
    let a = &system.matrix;
    let mut s = CgSolver::new(CgSettings {
        preconditioner,
        max_iterations: 5000,
        parallelism,
        ..CgSettings::default()
    });
    s.analyze(a.pattern()).unwrap();
    if coordinates {
        s.set_coordinates(&system.positions);
    }
    s.factor(a).unwrap();
    // Gravity-like load plus a twist: excites translation and rotation.
    let mut x: Vec<f64> = (0..a.dim())
        .map(|i| {
            let p = &system.positions[3 * (i / 3)..3 * (i / 3) + 3];
            match i % 3 {
                0 => -p[2],
                1 => -1.0 + 0.1 * p[0],
                _ => p[0],
            }
        })
        .collect();
    let report = s.solve(&mut x).unwrap();
    (x, report.iterations, report.relative_residual)
}

#[test]
fn amg_needs_far_fewer_iterations_than_one_level_preconditioners() {
    // 12,000 tets of 2 cm cells: stiff next to the mass, like a finely meshed body.
    let system = fem_box_sized([20, 10, 10], 0.02);
    let amg = iterations(&system, Preconditioner::Amg, true);
    let ic = iterations(&system, Preconditioner::IncompleteCholesky, true);
    let bj = iterations(&system, Preconditioner::BlockJacobi3, true);
    eprintln!("12k box, 2 cm cells: AMG {amg}, IC(0) {ic}, block-Jacobi {bj}");
    assert!(amg <= 100, "AMG took {amg} iterations on the 12k box");
    assert!(2 * amg < ic, "AMG {amg} vs IC(0) {ic}");
    assert!(5 * amg < bj, "AMG {amg} vs block-Jacobi {bj}");
}

#[test]
fn amg_iterations_stay_nearly_flat_as_the_box_grows() {
    // The same 48 cm body at 2,592 and 20,736 tets (halved cells).
    let small = fem_box_sized([12, 6, 6], 0.04);
    let large = fem_box_sized([24, 12, 12], 0.02);
    let (amg_small, amg_large) = (
        iterations(&small, Preconditioner::Amg, true),
        iterations(&large, Preconditioner::Amg, true),
    );
    let (bj_small, bj_large) = (
        iterations(&small, Preconditioner::BlockJacobi3, true),
        iterations(&large, Preconditioner::BlockJacobi3, true),
    );
    eprintln!("AMG {amg_small} -> {amg_large}, block-Jacobi {bj_small} -> {bj_large}");
    assert!(
        (amg_large as f64) < 1.5 * amg_small as f64,
        "AMG iterations {amg_small} -> {amg_large}"
    );
    // One level: halving h about doubles the iterations.
    assert!((bj_large as f64) > 1.6 * bj_small as f64);
}

#[test]
fn rigid_body_modes_beat_translations_alone() {
    let system = fem_ball(6);
    let with = iterations(&system, Preconditioner::Amg, true);
    let without = iterations(&system, Preconditioner::Amg, false);
    assert!(
        with < without,
        "with rotations {with}, translations only {without}"
    );
}

#[test]
fn amg_cg_gives_the_same_bits_on_any_thread_count() {
    let system = fem_box([16, 8, 8]);
    let (x_seq, it_seq, _) = cg_solve(&system, Preconditioner::Amg, true, Parallelism::Sequential);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let (x_par, it_par, _) =
        pool.install(|| cg_solve(&system, Preconditioner::Amg, true, Parallelism::Rayon));
    assert_eq!(it_seq, it_par);
    assert!(x_seq == x_par);
}

#[test]
fn auto_prediction_prefers_cholesky_for_small_fill_and_cg_for_large() {
    // A factor of 1e6 entries and 1e9 flops next to a 1e6-entry matrix: direct.
    assert!(AutoPrediction::new(1_000_000, 1e9, 1_000_000).direct());
    // 1e8 entries and 1e12 flops (a 200k-tet box): iterative.
    assert!(!AutoPrediction::new(100_000_000, 1e12, 10_000_000).direct());
}

#[test]
fn auto_chooses_cholesky_on_a_small_box_and_reports_it() {
    let system = fem_box([6, 3, 3]);
    let a = &system.matrix;
    let mut s = AutoSolver::new(SolverSettings::default());
    s.analyze(a.pattern()).unwrap();
    s.set_coordinates(&system.positions);
    s.factor(a).unwrap();
    let mut x = vec![1.0; a.dim()];
    let r = s.solve(&mut x).unwrap();
    assert!(r.relative_residual < 1e-12);
    assert_eq!(s.stats().chosen, "cholesky");
    assert!(s.prediction().unwrap().direct());
}
