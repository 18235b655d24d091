//! Claims about CG's preconditioners on real backward-Euler systems: smoothed-aggregation AMG
//! with rigid-body modes keeps iterations nearly flat as the mesh grows, where the one-level
//! preconditioners do not; and `auto` picks the solver its prediction says.

#[path = "support/fem_system.rs"]
mod fem_system;

use fem_system::{FemSystem, fem_ball, fem_box, fem_box_sized};
use softbench::parallel::Parallelism;
use softbench::solve::{
    AmgSettings, AmgSmoother, AmgStats, AutoPrediction, AutoSolver, CgSettings, CgSolver,
    LinearSolver, Preconditioner, SolverSettings,
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
    let (x, it, residual, _) = cg_solve_with(
        system,
        CgSettings {
            preconditioner,
            parallelism,
            ..CgSettings::default()
        },
        coordinates,
    );
    (x, it, residual)
}

/// AMG-preconditioned CG at strength threshold `theta`: iterations to 1e-8 and the
/// hierarchy's statistics.
fn amg_at(system: &FemSystem, theta: f64) -> (usize, AmgStats) {
    let settings = CgSettings {
        preconditioner: Preconditioner::Amg,
        amg: AmgSettings {
            strength_threshold: theta,
            ..AmgSettings::default()
        },
        ..CgSettings::default()
    };
    let (_, it, residual, stats) = cg_solve_with(system, settings, true);
    assert!(residual <= 1e-8, "residual {residual:e}");
    (it, stats)
}

fn cg_solve_with(
    system: &FemSystem,
    settings: CgSettings,
    coordinates: bool,
) -> (Vec<f64>, usize, f64, AmgStats) {
    let a = &system.matrix;
    let mut s = CgSolver::new(CgSettings {
        max_iterations: 5000,
        ..settings
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
    (
        x,
        report.iterations,
        report.relative_residual,
        s.stats().amg,
    )
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
fn filtered_amg_stays_cheap_and_flat_on_a_refinement_ladder() {
    // The same 48 cm body at 2,592, 20,736 and 69,984 tets (cells 4, 2 and 1.33 cm).
    let ladder = [
        ([12, 6, 6], 0.04),
        ([24, 12, 12], 0.02),
        ([36, 18, 18], 0.04 / 3.0),
    ];
    let theta = AmgSettings::DEFAULT_THETA;
    let mut first_iterations = 0;
    for (k, (cells, h)) in ladder.into_iter().enumerate() {
        let system = fem_box_sized(cells, h);
        let (it, stats) = amg_at(&system, theta);
        let (it0, stats0) = amg_at(&system, 0.0);
        eprintln!(
            "{cells:?}: θ = {theta}: {it} iterations, operator complexity {:.2}, grid {:.2}, \
             {} levels; θ = 0: {it0} iterations, operator complexity {:.2}",
            stats.operator_complexity,
            stats.grid_complexity,
            stats.levels,
            stats0.operator_complexity
        );
        assert!(
            stats.operator_complexity < 1.6,
            "operator complexity {:.2} at {cells:?}",
            stats.operator_complexity
        );
        assert!(stats.grid_complexity < 1.3);
        // Filtering pays in iterations (measured with `--example amg_ladder`: 30 vs 36 at
        // 20k tets, 31 vs 41 at 70k); the operator complexity stays about 1.4 either way.
        if k > 0 {
            assert!(it < it0, "θ = {theta}: {it} iterations, θ = 0: {it0}");
        }
        if k == 0 {
            first_iterations = it;
        } else {
            // Nearly flat: 27× the tets costs less than 1.5× the iterations.
            assert!(
                (it as f64) < 1.5 * first_iterations as f64,
                "{first_iterations} -> {it} iterations"
            );
        }
        assert!(it <= 100, "{it} iterations at {cells:?}");
    }
}

#[test]
fn a_reused_hierarchy_follows_new_values_and_still_converges() {
    let system = fem_box_sized([20, 10, 10], 0.02);
    let a = &system.matrix;
    let settings = |rebuild_every| CgSettings {
        preconditioner: Preconditioner::Amg,
        amg: AmgSettings {
            rebuild_every,
            ..AmgSettings::default()
        },
        ..CgSettings::default()
    };
    let mut reused = CgSolver::new(settings(3));
    reused.analyze(a.pattern()).unwrap();
    reused.set_coordinates(&system.positions);
    // Matrices that differ in more than scale: (1 + k) A plus k times its diagonal.
    let diagonal: Vec<usize> = (0..a.dim())
        .map(|i| a.pattern().find(i, i).unwrap())
        .collect();
    for k in 0..4 {
        let mut m = a.clone();
        m.values_mut().iter_mut().for_each(|v| *v *= 1.0 + k as f64);
        for &d in &diagonal {
            m.values_mut()[d] += k as f64 * a.values()[d];
        }
        let rhs: Vec<f64> = (0..a.dim()).map(|i| (i % 7) as f64 - 3.0).collect();
        reused.factor(&m).unwrap();
        let mut x = rhs.clone();
        let r = reused.solve(&mut x).unwrap();
        assert!(r.relative_residual <= 1e-8);
        // A hierarchy built for this very matrix.
        let mut fresh = CgSolver::new(settings(1));
        fresh.analyze(a.pattern()).unwrap();
        fresh.set_coordinates(&system.positions);
        fresh.factor(&m).unwrap();
        let mut y = rhs.clone();
        let f = fresh.solve(&mut y).unwrap();
        eprintln!(
            "k = {k}: reused {} iterations, fresh {}",
            r.iterations, f.iterations
        );
        assert!(
            r.iterations as f64 <= 1.3 * f.iterations as f64 + 2.0,
            "reused {} vs fresh {}",
            r.iterations,
            f.iterations
        );
    }
    let amg = reused.stats().amg;
    assert_eq!((amg.builds, amg.reuses), (2, 2), "{amg:?}");
}

#[test]
fn amg_settings_out_of_range_are_refused_with_the_key() {
    let bad = AmgSettings {
        strength_threshold: 1.5,
        ..AmgSettings::default()
    };
    let e = bad.validate().unwrap_err();
    assert!(e.contains("solver.cg.amg.strength_threshold"), "{e}");
    assert!(AmgSettings::default().validate().is_ok());
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
fn threads_move_autos_crossover_by_each_solvers_measured_speed_up() {
    // The 48k-tet ball of solver_scaling (METIS: nnz(L) 10.7 M, 8.66e9 flops; nnz(A) 1.16 M,
    // as `fem_ball(10)` has it): CG + AMG on one thread and on two (measured at d15dfe3 on two
    // threads: 0.43 s per steady step against Cholesky's 0.52 s).
    let one = AutoPrediction::new(10_728_963, 8.66e9, 1_157_058);
    assert!(!one.direct(), "{one:?}");
    let two = one.with_factor_threads(2).with_iterative_threads(2);
    assert!(!two.direct(), "{two:?}");
    assert!((one.direct_seconds / two.direct_seconds - 1.8).abs() < 1e-12);
    assert!((one.iterative_seconds / two.iterative_seconds - 1.5).abs() < 1e-12);
    assert_eq!(one.with_factor_threads(1).with_iterative_threads(1), one);
    // Where only the factorization gains threads (AMG's levels below `parallel_min_rows`), a
    // close call moves to Cholesky; where both do, the larger speed-up decides.
    let close = AutoPrediction {
        direct_seconds: 1.2,
        iterative_seconds: 1.0,
    };
    assert!(!close.direct());
    assert!(close.with_factor_threads(2).direct());
    assert!(
        close
            .with_factor_threads(2)
            .with_iterative_threads(2)
            .direct()
    );
    let closer = AutoPrediction {
        direct_seconds: 1.25,
        iterative_seconds: 1.0,
    };
    assert!(
        !closer
            .with_factor_threads(2)
            .with_iterative_threads(2)
            .direct()
    );
    // The 211k box stays on CG + AMG however many threads factor it.
    let big = AutoPrediction::new(94_090_410, 2.04e11, 5_000_000).with_factor_threads(2);
    assert!(!big.direct(), "{big:?}");
}

#[test]
fn auto_chooses_cg_with_amg_on_a_large_box_from_the_analysis_alone() {
    // 96k tets: predicted Cholesky 4.4e10 flops against CG's O(nnz(A)) work (measured with
    // `--example auto_calibrate`: 2.5 s vs 0.78 s per Newton iteration).
    let system = fem_box([40, 20, 20]);
    let mut s = AutoSolver::new(SolverSettings::default());
    s.analyze(system.matrix.pattern()).unwrap();
    let p = s.prediction().unwrap();
    assert!(!p.direct(), "{p:?}");
    assert_eq!(s.stats().chosen, "cg");
    assert_eq!(s.stats().ordering, "amg");
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

/// The multicolour smoother (the default) gives the same bits on one thread and on a pool of
/// three with every level parallel, and costs at most a few more CG iterations than the
/// DOF-order Gauss–Seidel sweep it replaces (31 against 29 on this box).
#[test]
fn the_multicolour_smoother_is_thread_count_independent_and_close_to_dof_order_gauss_seidel() {
    let system = fem_box_sized([20, 10, 10], 0.02);
    let settings = |smoother, parallelism| CgSettings {
        preconditioner: Preconditioner::Amg,
        amg: AmgSettings {
            smoother,
            parallel_min_rows: 0,
            ..AmgSettings::default()
        },
        parallelism,
        ..CgSettings::default()
    };
    let (x1, it1, r1, stats) = cg_solve_with(
        &system,
        settings(AmgSmoother::MulticolourGaussSeidel, Parallelism::Sequential),
        true,
    );
    assert!(r1 <= 1e-8);
    assert!(stats.fine_colours > 1, "{stats:?}");
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap();
    let (x3, it3, _, _) = pool.install(|| {
        cg_solve_with(
            &system,
            settings(AmgSmoother::MulticolourGaussSeidel, Parallelism::Rayon),
            true,
        )
    });
    assert_eq!(it1, it3);
    assert!(x1 == x3, "the solution differs between 1 and 3 threads");
    let (_, it_dof, r_dof, stats_dof) = cg_solve_with(
        &system,
        settings(AmgSmoother::GaussSeidel, Parallelism::Sequential),
        true,
    );
    assert!(r_dof <= 1e-8);
    assert_eq!(stats_dof.fine_colours, 1);
    eprintln!("DOF-order Gauss-Seidel {it_dof}, multicolour {it1} iterations");
    assert!(
        (it1 as f64) <= 1.3 * it_dof as f64 + 2.0,
        "multicolour {it1} against DOF order {it_dof}"
    );
}

/// A forcing term set before `auto` has chosen (Newton sets it before the first factorization)
/// reaches the CG it builds: the first solve stops at the forcing term, not at `cg.tolerance`.
#[test]
fn auto_passes_a_forcing_term_set_before_its_choice_to_the_cg_it_builds() {
    let system = fem_box([40, 20, 20]);
    let a = &system.matrix;
    let solve = |forcing: Option<f64>| {
        let mut s = AutoSolver::new(SolverSettings::default());
        s.set_forcing(forcing);
        s.analyze(a.pattern()).unwrap();
        s.set_coordinates(&system.positions);
        s.factor(a).unwrap();
        assert_eq!(s.stats().chosen, "cg");
        let mut x = vec![1.0; a.dim()];
        s.solve(&mut x).unwrap()
    };
    let exact = solve(None);
    let forced = solve(Some(0.1));
    assert!(exact.relative_residual <= 1e-8);
    assert!(forced.relative_residual <= 0.1 && forced.relative_residual > 1e-8);
    assert!(forced.iterations < exact.iterations);
}
