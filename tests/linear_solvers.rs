//! Claims about the linear solvers, checked on synthetic elasticity-like systems.

#[path = "support/grid_spd.rs"]
mod grid_spd;

mod common;

use std::sync::Arc;

use grid_spd::{Grid, Spec, add_block, add_diagonal, relative_residual, rhs};
use nalgebra::Matrix3;
use softbench::parallel::Parallelism;
use softbench::solve::{
    CgSettings, CgSolver, CholeskySolver, DenseCholeskySolver, DirectSettings, LdltSolver,
    LinearSolver, LinearSolverKind, Ordering, Preconditioner, SolveError, SolverSettings,
    Supernodal, symmetric_mul_vec,
};
use softbench::sparse::{SparsityPattern, SymmetricMatrix};

fn system(grid: &Grid, seed: u64) -> (Arc<SparsityPattern>, SymmetricMatrix) {
    let p = grid.pattern();
    let a = grid.matrix(&p, seed, &Spec::default());
    (p, a)
}

fn cg(tolerance: f64, preconditioner: Preconditioner) -> CgSolver {
    CgSolver::new(CgSettings {
        tolerance,
        preconditioner,
        ..Default::default()
    })
}

/// Every direct-solver configuration worth distinguishing: both faer code paths, both
/// orderings, and threads.
fn direct_settings() -> Vec<DirectSettings> {
    let mut v = Vec::new();
    for ordering in [
        Ordering::Amd,
        Ordering::Metis,
        Ordering::Auto,
        Ordering::Identity,
    ] {
        for supernodal in [
            Supernodal::Supernodal,
            Supernodal::Simplicial,
            Supernodal::Auto,
        ] {
            v.push(DirectSettings {
                ordering,
                supernodal,
                parallelism: Parallelism::Sequential,
                ..Default::default()
            });
        }
    }
    v.push(DirectSettings {
        parallelism: Parallelism::Rayon,
        ..DirectSettings::default()
    });
    v
}

/// Every preconditioner of CG (the match makes a new one a compile error here).
fn every_preconditioner() -> Vec<Preconditioner> {
    let all = [
        Preconditioner::None,
        Preconditioner::Jacobi,
        Preconditioner::BlockJacobi3,
        Preconditioner::IncompleteCholesky,
        Preconditioner::Amg,
    ];
    for p in all {
        match p {
            Preconditioner::None
            | Preconditioner::Jacobi
            | Preconditioner::BlockJacobi3
            | Preconditioner::IncompleteCholesky
            | Preconditioner::Amg => {}
        }
    }
    all.to_vec()
}

/// Every registered solver, with CG once per preconditioner, tight enough to compare.
fn every_solver() -> Vec<Box<dyn LinearSolver>> {
    let mut settings = SolverSettings::default();
    settings.cg.tolerance = 1e-12;
    let mut v: Vec<Box<dyn LinearSolver>> = LinearSolverKind::all()
        .into_iter()
        .filter(|k| k.name() != "cg")
        .map(|k| k.build(&settings))
        .collect();
    for p in every_preconditioner() {
        v.push(Box::new(cg(1e-12, p)));
    }
    v
}

fn solve_once(s: &mut dyn LinearSolver, a: &SymmetricMatrix, b: &[f64]) -> Vec<f64> {
    s.analyze(a.pattern()).unwrap();
    s.factor(a).unwrap();
    let mut x = b.to_vec();
    s.solve(&mut x).unwrap();
    x
}

fn max_rel_diff(x: &[f64], y: &[f64]) -> f64 {
    let scale = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    x.iter()
        .zip(y)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
        / scale
}

#[test]
fn all_solvers_agree_on_an_spd_system() {
    let grid = Grid::new(4, 4, 5);
    let (_, a) = system(&grid, 1);
    let b = rhs(grid.dofs(), 2);
    let reference = solve_once(&mut DenseCholeskySolver::new(), &a, &b);
    for mut s in every_solver() {
        let x = solve_once(s.as_mut(), &a, &b);
        assert!(relative_residual(&a, &x, &b) < 1e-11, "{}", s.name());
        assert!(
            max_rel_diff(&x, &reference) < 1e-9,
            "{}: {}",
            s.name(),
            max_rel_diff(&x, &reference)
        );
    }
}

#[test]
fn every_direct_configuration_solves_to_rounding_error() {
    let grid = Grid::new(5, 4, 6);
    let (_, a) = system(&grid, 3);
    let b = rhs(grid.dofs(), 4);
    for settings in direct_settings() {
        for mut s in [
            Box::new(CholeskySolver::new(settings)) as Box<dyn LinearSolver>,
            Box::new(LdltSolver::new(settings)),
        ] {
            s.analyze(a.pattern()).unwrap();
            s.factor(&a)
                .unwrap_or_else(|e| panic!("{} {settings:?}: {e}", s.name()));
            let mut x = b.clone();
            let report = s.solve(&mut x).unwrap();
            assert_eq!(report.iterations, 1);
            let independent = relative_residual(&a, &x, &b);
            assert!(
                independent < 1e-11,
                "{} {settings:?}: {independent}",
                s.name()
            );
            assert!(report.relative_residual < 1e-11);
        }
    }
}

#[test]
fn cholesky_reuses_symbolic_analysis_across_factorizations() {
    let grid = Grid::new(4, 5, 4);
    let (p, a1) = system(&grid, 5);
    let a2 = grid.matrix(
        &p,
        6,
        &Spec {
            mass: 2.0,
            ..Spec::default()
        },
    );
    let b = rhs(grid.dofs(), 7);
    let mut s = CholeskySolver::new(DirectSettings::default());
    s.analyze(&p).unwrap();
    s.analyze(&p).unwrap();
    // A pattern with equal content in another Arc is recognized too.
    s.analyze(&Arc::new((*p).clone())).unwrap();
    assert_eq!(s.stats().analyses, 1);
    assert_eq!(s.stats().analyses_reused, 2);
    for a in [&a1, &a2, &a1] {
        s.factor(a).unwrap();
        let mut x = b.clone();
        s.solve(&mut x).unwrap();
        assert!(relative_residual(a, &x, &b) < 1e-11);
    }
    let st = s.stats();
    assert_eq!(
        (
            st.analyses,
            st.factorizations,
            st.solves,
            st.linear_iterations
        ),
        (1, 3, 3, 3)
    );
    assert!(st.factor_nnz >= p.nnz().div_ceil(2) && st.factor_nnz <= st.factor_storage);
}

#[test]
fn refactoring_with_new_values_solves_the_new_system() {
    let grid = Grid::new(4, 4, 4);
    let (p, a1) = system(&grid, 8);
    let a2 = grid.matrix(
        &p,
        9,
        &Spec {
            mass: 0.5,
            anisotropy: 10.0,
            contrast: 3.0,
        },
    );
    let b = rhs(grid.dofs(), 10);
    for mut s in every_solver() {
        let x1 = solve_once(s.as_mut(), &a1, &b);
        s.analyze(&p).unwrap();
        s.factor(&a2).unwrap();
        let mut x2 = b.clone();
        s.solve(&mut x2).unwrap();
        assert!(relative_residual(&a2, &x2, &b) < 1e-11, "{}", s.name());
        assert!(
            max_rel_diff(&x1, &x2) > 1e-3,
            "{}: the new solution should differ",
            s.name()
        );
        assert_eq!(s.stats().analyses, 1, "{}", s.name());
    }
}

/// Making `A[k, k]` very negative makes pivot `k` the first non-positive one in any
/// elimination order (earlier pivots belong to SPD principal submatrices).
#[test]
fn cholesky_reports_indefinite_matrix_at_the_original_column() {
    let grid = Grid::new(8, 8, 8);
    let (_, a) = system(&grid, 11);
    let n = grid.dofs();
    for settings in direct_settings() {
        let mut s = CholeskySolver::new(settings);
        s.analyze(a.pattern()).unwrap();
        for k in [0, 1, n / 2, n / 2 + 1, n - 100, n - 2, n - 1] {
            let mut bad = a.clone();
            add_diagonal(&mut bad, k, -1e6);
            assert_eq!(
                s.factor(&bad),
                Err(SolveError::NotPositiveDefinite { column: k }),
                "{settings:?}"
            );
            // A failed factorization leaves nothing to solve with.
            assert!(matches!(
                s.solve(&mut vec![1.0; n]),
                Err(SolveError::OutOfOrder { .. })
            ));
        }
        assert_eq!(s.stats().failed_factorizations, 7);
        s.factor(&a).unwrap();
    }
}

#[test]
fn dense_reports_indefinite_matrix_at_its_column() {
    let grid = Grid::new(3, 3, 3);
    let (_, a) = system(&grid, 12);
    for k in [0, 40, 80] {
        let mut bad = a.clone();
        add_diagonal(&mut bad, k, -1e6);
        let mut s = DenseCholeskySolver::new();
        s.analyze(bad.pattern()).unwrap();
        assert_eq!(
            s.factor(&bad),
            Err(SolveError::NotPositiveDefinite { column: k })
        );
    }
}

/// `A − σI` with σ between two eigenvalues of `A`: the number of negative eigenvalues is known.
fn shifted_system(grid: &Grid, seed: u64, index: usize) -> (SymmetricMatrix, usize) {
    let (_, mut a) = system(grid, seed);
    let mut eig = a.to_dense().symmetric_eigenvalues().as_slice().to_vec();
    eig.sort_by(f64::total_cmp);
    let sigma = 0.5 * (eig[index - 1] + eig[index]);
    for i in 0..grid.dofs() {
        add_diagonal(&mut a, i, -sigma);
    }
    (a, index)
}

#[test]
fn ldlt_counts_negative_pivots_equal_to_negative_eigenvalues() {
    let grid = Grid::new(3, 4, 3);
    let b = rhs(grid.dofs(), 13);
    for (seed, negatives) in [(14, 5), (15, 17), (16, 60)] {
        let (a, expected) = shifted_system(&grid, seed, negatives);
        for settings in direct_settings() {
            let mut s = LdltSolver::new(settings);
            s.analyze(a.pattern()).unwrap();
            let report = s.factor(&a).unwrap();
            assert_eq!(report.negative_pivots, Some(expected), "{settings:?}");
            let mut x = b.clone();
            s.solve(&mut x).unwrap();
            assert!(
                relative_residual(&a, &x, &b) < 1e-9,
                "{settings:?}: {}",
                relative_residual(&a, &x, &b)
            );
        }
        let mut chol = CholeskySolver::new(DirectSettings::default());
        chol.analyze(a.pattern()).unwrap();
        assert!(matches!(
            chol.factor(&a),
            Err(SolveError::NotPositiveDefinite { .. })
        ));
    }
}

#[test]
fn ldlt_reports_no_negative_pivots_for_an_spd_matrix() {
    let grid = Grid::new(6, 5, 4);
    let (_, a) = system(&grid, 17);
    for settings in direct_settings() {
        let mut s = LdltSolver::new(settings);
        s.analyze(a.pattern()).unwrap();
        assert_eq!(
            s.factor(&a).unwrap().negative_pivots,
            Some(0),
            "{settings:?}"
        );
    }
}

#[test]
fn ldlt_reports_a_singular_matrix() {
    // diag(1, 0, 1) with the zero in the middle: no ordering avoids the zero pivot.
    let p = Arc::new(SparsityPattern::from_csc(
        3,
        vec![0, 1, 2, 3],
        vec![0, 1, 2],
    ));
    let mut a = SymmetricMatrix::zeros(p.clone());
    a.values_mut().copy_from_slice(&[1.0, 0.0, 1.0]);
    let mut s = LdltSolver::new(DirectSettings::default());
    s.analyze(&p).unwrap();
    assert_eq!(s.factor(&a), Err(SolveError::SingularMatrix { column: 1 }));
}

#[test]
fn cg_meets_its_relative_tolerance() {
    let grid = Grid::new(8, 7, 6);
    let (_, a) = system(&grid, 18);
    let b = rhs(grid.dofs(), 19);
    for p in [
        Preconditioner::None,
        Preconditioner::Jacobi,
        Preconditioner::BlockJacobi3,
        Preconditioner::IncompleteCholesky,
    ] {
        for tol in [1e-4, 1e-8, 1e-12] {
            let mut s = cg(tol, p);
            let x = solve_once(&mut s, &a, &b);
            let independent = relative_residual(&a, &x, &b);
            assert!(independent <= tol, "{p:?} {tol}: {independent}");
            assert!(s.stats().linear_iterations > 0);
        }
    }
}

#[test]
fn cg_reports_non_convergence_with_its_last_iterate() {
    let grid = Grid::new(6, 6, 6);
    let (_, a) = system(&grid, 20);
    let b = rhs(grid.dofs(), 21);
    let mut s = CgSolver::new(CgSettings {
        max_iterations: 3,
        ..Default::default()
    });
    s.analyze(a.pattern()).unwrap();
    s.factor(&a).unwrap();
    let mut x = b.clone();
    match s.solve(&mut x) {
        Err(SolveError::NotConverged {
            iterations,
            relative_residual: r,
        }) => {
            assert_eq!(iterations, 3);
            assert!(r > 1e-8 && r < 1.0);
            assert!((relative_residual(&a, &x, &b) - r).abs() < 1e-12 * r.max(1.0));
        }
        other => panic!("expected NotConverged, got {other:?}"),
    }
}

#[test]
fn block_jacobi_needs_fewer_iterations_than_jacobi_on_elasticity_like_system() {
    let grid = Grid::new(10, 10, 10);
    let (_, a) = system(&grid, 22);
    let b = rhs(grid.dofs(), 23);
    let mut iterations = Vec::new();
    for p in [
        Preconditioner::None,
        Preconditioner::Jacobi,
        Preconditioner::BlockJacobi3,
        Preconditioner::IncompleteCholesky,
    ] {
        let mut s = cg(1e-8, p);
        s.analyze(a.pattern()).unwrap();
        s.factor(&a).unwrap();
        let mut x = b.clone();
        iterations.push(s.solve(&mut x).unwrap().iterations);
    }
    eprintln!("CG iterations (none, jacobi, block-jacobi, ic0): {iterations:?}");
    let [none, jacobi, block, ic0] = iterations[..] else {
        unreachable!()
    };
    assert!(jacobi < none);
    assert!((block as f64) < 0.9 * jacobi as f64);
    assert!(ic0 < block);
}

#[test]
fn cg_warm_start_from_the_previous_solution_needs_no_iterations() {
    let grid = Grid::new(5, 5, 5);
    let (_, a) = system(&grid, 24);
    let b = rhs(grid.dofs(), 25);
    let mut s = CgSolver::new(CgSettings {
        warm_start: true,
        ..Default::default()
    });
    s.analyze(a.pattern()).unwrap();
    s.factor(&a).unwrap();
    let mut x = b.clone();
    assert!(s.solve(&mut x).unwrap().iterations > 0);
    let mut again = b.clone();
    assert_eq!(s.solve(&mut again).unwrap().iterations, 0);
    assert_eq!(again, x);
    // An explicit guess: the solution itself.
    let mut cold = CgSolver::new(CgSettings::default());
    cold.analyze(a.pattern()).unwrap();
    cold.factor(&a).unwrap();
    let mut guess = x.clone();
    assert_eq!(cold.solve_with_guess(&b, &mut guess).unwrap().iterations, 0);
}

#[test]
fn cg_reports_negative_curvature_on_an_indefinite_matrix() {
    let grid = Grid::new(4, 4, 4);
    let (a, _) = shifted_system(&grid, 26, 40);
    let b = rhs(grid.dofs(), 27);
    let mut s = cg(1e-8, Preconditioner::None);
    s.analyze(a.pattern()).unwrap();
    s.factor(&a).unwrap();
    assert!(matches!(
        s.solve(&mut b.clone()),
        Err(SolveError::NegativeCurvature { .. })
    ));
}

#[test]
fn preconditioners_report_a_non_positive_diagonal() {
    let grid = Grid::new(3, 3, 3);
    let (_, mut a) = system(&grid, 28);
    let k = 31;
    let d = a.get(k, k);
    add_diagonal(&mut a, k, -d);
    for p in [
        Preconditioner::Jacobi,
        Preconditioner::BlockJacobi3,
        Preconditioner::IncompleteCholesky,
    ] {
        let mut s = cg(1e-8, p);
        s.analyze(a.pattern()).unwrap();
        assert_eq!(
            s.factor(&a),
            Err(SolveError::NotPositiveDefinite { column: k }),
            "{p:?}"
        );
    }
}

#[test]
fn block_jacobi_falls_back_to_the_diagonal_for_a_block_that_is_not_spd() {
    let grid = Grid::new(3, 3, 3);
    let (_, mut a) = system(&grid, 29);
    // Vertex 4's block gets an off-diagonal coupling larger than its diagonal.
    let d = a.get(12, 12).max(a.get(13, 13));
    let coupling = Matrix3::new(0.0, 2.0 * d, 0.0, 2.0 * d, 0.0, 0.0, 0.0, 0.0, 0.0);
    add_block(&mut a, 4, 4, &coupling);
    let mut s = cg(1e-8, Preconditioner::BlockJacobi3);
    s.analyze(a.pattern()).unwrap();
    assert_eq!(s.factor(&a).unwrap().fallback_blocks, 1);
}

#[test]
fn factor_rejects_a_matrix_over_another_pattern() {
    let (p, _) = system(&Grid::new(3, 3, 3), 30);
    let (_, other) = system(&Grid::new(3, 3, 4), 30);
    for mut s in every_solver() {
        s.analyze(&p).unwrap();
        assert!(
            matches!(s.factor(&other), Err(SolveError::PatternMismatch { .. })),
            "{}",
            s.name()
        );
    }
}

#[test]
fn non_finite_input_is_reported_not_propagated() {
    let grid = Grid::new(3, 3, 3);
    let (p, a) = system(&grid, 31);
    let mut nan_matrix = a.clone();
    let k = p.find(20, 22).unwrap();
    nan_matrix.values_mut()[k] = f64::NAN;
    let mut b = rhs(grid.dofs(), 32);
    b[7] = f64::INFINITY;
    for mut s in every_solver() {
        s.analyze(&p).unwrap();
        let expected = SolveError::NonFiniteInput {
            input: "matrix",
            index: 22,
        };
        assert_eq!(s.factor(&nan_matrix), Err(expected), "{}", s.name());
        s.factor(&a).unwrap();
        let expected = SolveError::NonFiniteInput {
            input: "right-hand side",
            index: 7,
        };
        assert_eq!(s.solve(&mut b.clone()), Err(expected), "{}", s.name());
    }
}

#[test]
fn phases_out_of_order_and_wrong_lengths_are_errors() {
    let grid = Grid::new(3, 3, 3);
    let (p, a) = system(&grid, 33);
    for mut s in every_solver() {
        assert!(
            matches!(s.factor(&a), Err(SolveError::OutOfOrder { .. })),
            "{}",
            s.name()
        );
        s.analyze(&p).unwrap();
        assert!(matches!(
            s.solve(&mut vec![1.0; grid.dofs()]),
            Err(SolveError::OutOfOrder { .. })
        ));
        s.factor(&a).unwrap();
        let wrong = s.solve(&mut [1.0; 5]);
        assert_eq!(
            wrong,
            Err(SolveError::DimensionMismatch {
                expected: grid.dofs(),
                found: 5
            })
        );
    }
}

#[test]
fn zero_rhs_gives_zero_solution() {
    let (p, a) = system(&Grid::new(3, 3, 3), 34);
    for mut s in every_solver() {
        let x = solve_once(s.as_mut(), &a, &vec![0.0; p.dim()]);
        assert!(x.iter().all(|&v| v == 0.0), "{}", s.name());
    }
}

#[test]
fn symmetric_mul_vec_matches_the_scatter_mul_vec() {
    let grid = Grid::new(7, 6, 5);
    let (_, a) = system(&grid, 35);
    let x = rhs(grid.dofs(), 36);
    let mut y0 = vec![0.0; x.len()];
    a.mul_vec(&x, &mut y0);
    for par in [Parallelism::Sequential, Parallelism::Rayon] {
        let mut y = vec![0.0; x.len()];
        symmetric_mul_vec(&a, &x, &mut y, par);
        assert!(max_rel_diff(&y, &y0) < 1e-14);
    }
}

#[test]
fn solver_kinds_parse_from_their_names_and_build() {
    for kind in LinearSolverKind::all() {
        let parsed: LinearSolverKind = kind.name().parse().unwrap();
        assert_eq!(parsed, kind);
        assert_eq!(kind.build(&SolverSettings::default()).name(), kind.name());
    }
    let err = "lu".parse::<LinearSolverKind>().unwrap_err().to_string();
    assert!(
        err.contains("`lu`") && err.contains("cholesky, ldlt, cg, auto, dense"),
        "{err}"
    );
    let err = "cholesk"
        .parse::<LinearSolverKind>()
        .unwrap_err()
        .to_string();
    assert!(err.contains("did you mean `cholesky`?"), "{err}");
}

#[test]
fn solver_built_by_kind_solves() {
    let grid = Grid::new(4, 3, 3);
    let (_, a) = system(&grid, 37);
    let b = rhs(grid.dofs(), 38);
    for kind in LinearSolverKind::all() {
        let mut s = kind.build(&SolverSettings::default());
        let x = solve_once(s.as_mut(), &a, &b);
        assert!(relative_residual(&a, &x, &b) <= 1e-8, "{kind}");
    }
}

#[test]
fn settings_deserialize_with_documented_defaults() {
    let s: SolverSettings = serde_json::from_str("{}").unwrap();
    assert_eq!(s, SolverSettings::default());
    assert_eq!(s.direct.parallelism, Parallelism::Sequential);
    assert_eq!(s.cg.parallelism, Parallelism::Sequential);
    assert_eq!(
        (
            s.cg.tolerance,
            s.cg.max_iterations,
            s.cg.preconditioner,
            s.cg.warm_start
        ),
        (1e-8, 2000, Preconditioner::BlockJacobi3, false)
    );
    let s: SolverSettings = serde_json::from_str(
        r#"{"direct": {"supernodal": "simplicial"},
            "cg": {"preconditioner": "incomplete_cholesky", "tolerance": 1e-6}}"#,
    )
    .unwrap();
    assert_eq!(s.direct.supernodal, Supernodal::Simplicial);
    assert_eq!(s.cg.preconditioner, Preconditioner::IncompleteCholesky);
    assert_eq!(s.cg.max_iterations, 2000);
    let kind: LinearSolverKind = serde_json::from_str(r#""ldlt""#).unwrap();
    assert_eq!(kind, LinearSolverKind::from_name("ldlt").unwrap());
    let err = serde_json::from_str::<LinearSolverKind>(r#""qr""#)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("valid: cholesky, ldlt, cg, auto, dense"),
        "{err}"
    );
    assert!(serde_json::from_str::<SolverSettings>(r#"{"cg": {"tol": 1e-6}}"#).is_err());
}

/// A StVK box squashed to 35% of its length: strongly negative stiffness, so with a large
/// step `M + dt^2 K` is indefinite (the case of `tests/newton.rs`'s Cholesky fallback).
fn squashed_stvk_step(solver: LinearSolverKind) -> (softbench::integrate::StepReport, Vec<f64>) {
    use softbench::integrate::{IntegratorSettings, Method, State};
    let lame = softbench::material::LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = softbench::material::MaterialModel::from_name("stvk", lame).unwrap();
    let mesh = softbench::mesh::generate::box_mesh([2, 1, 1], [0.2, 0.1, 0.1]);
    let mut model =
        softbench::model::Model::new(softbench::model::ModelSpec::elastic(mesh, material, 1000.0))
            .unwrap();
    let mut state = State::at_rest(&model);
    state.q.iter_mut().step_by(3).for_each(|x| *x *= 0.35);
    let mut integ = IntegratorSettings {
        method: Method::from_name("backward-euler").unwrap(),
        linear_solver: solver,
        ..Default::default()
    }
    .build();
    let report = integ
        .step(&mut model, &mut state, 0.1)
        .unwrap_or_else(|e| panic!("{solver:?}: {e}"));
    (report, state.q)
}

/// LDLᵀ factors an indefinite `M + dt^2 K` without failing, but Newton needs a descent
/// direction: its negative pivots trigger the same projected-Hessian fallback as a failed
/// Cholesky pivot, so both solvers take the same step and count the same fallbacks.
#[test]
fn ldlt_negative_pivots_fall_back_to_projected_hessians_like_cholesky() {
    let (chol, q_chol) = squashed_stvk_step(LinearSolverKind::from_name("cholesky").unwrap());
    let (ldlt, q_ldlt) = squashed_stvk_step(LinearSolverKind::from_name("ldlt").unwrap());
    eprintln!(
        "squashed StVK, backward Euler dt 0.1: indefinite fallbacks cholesky {} ldlt {}, \
         newton iterations {} / {}",
        chol.indefinite_fallbacks,
        ldlt.indefinite_fallbacks,
        chol.newton_iterations,
        ldlt.newton_iterations
    );
    assert!(ldlt.indefinite_fallbacks > 0, "{ldlt:?}");
    assert_eq!(ldlt.indefinite_fallbacks, chol.indefinite_fallbacks);
    let scale = q_chol.iter().map(|x| x * x).sum::<f64>().sqrt();
    let diff = q_chol
        .iter()
        .zip(&q_ldlt)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    assert!(
        diff <= 1e-10 * scale,
        "ldlt differs from cholesky by {diff:e}"
    );
}

/// The course armadillo yanked by its hand (`armadillo_drag.toml`, backward Euler): with
/// LDLᵀ it used to fail at step 6 ("not a descent direction") where Cholesky, CG and dense
/// finish. It now finishes like Cholesky, and summary.json counts the fallbacks.
#[test]
fn the_dragged_armadillo_finishes_with_ldlt_like_with_cholesky() {
    if common::reference_mesh("arma_6.node").is_none() {
        return;
    }
    let dir = common::TempDir::new("ldlt-drag");
    let mut fallbacks = Vec::new();
    for solver in ["cholesky", "ldlt"] {
        let out = dir.path().join(solver);
        let set = format!("integrator.linear_solver={solver}");
        let result = common::simulate(
            &common::scene("armadillo_drag.toml"),
            &out,
            &["--set", &set],
        );
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert!(result.status.success(), "{solver}: {stderr}");
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap())
                .unwrap();
        let s = &summary["summary"];
        assert_eq!(s["steps_completed"], 150, "{solver}");
        let n = s["totals"]["indefinite_fallbacks"].as_u64().unwrap();
        eprintln!(
            "dragged armadillo, {solver}: 150 steps, {n} indefinite fallbacks, final elastic {} J",
            s["final_energy"]["elastic"]
        );
        fallbacks.push(n);
    }
    assert!(fallbacks[1] > 0, "ldlt never fell back: {fallbacks:?}");
    assert_eq!(fallbacks[0], fallbacks[1]);
}
