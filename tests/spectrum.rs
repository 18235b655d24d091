//! The highest natural frequency `omega_max` (Lanczos on K v = lambda M v): closed forms for
//! springs, the dense generalized eigenproblem for small boxes, a long power iteration for a
//! larger box, and the course armadillo's explicit limit `2 / omega_max`.

mod common;

use common::{assert_close, reference_mesh};
use nalgebra::{DMatrix, Vector3};
use softbench::data::DataPaths;
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::TetMesh;
use softbench::mesh::generate::box_mesh;
use softbench::model::{
    Damping, FixedSelection, InvertedTets, MassKind, MassMatrix, Model, ModelSpec, SpectrumError,
    SpectrumSettings, Spring, highest_mode,
};
use softbench::parallel::Parallelism;
use softbench::rng::Rng;
use softbench::scene;
use softbench::solve::{CholeskySolver, DirectSettings, LinearSolver};
use std::time::Instant;

/// Two particles of mass `m` joined by a spring of stiffness `k` at its rest length, along a
/// direction that is not a coordinate axis; particle 0 fixed or not.
fn spring_pair(k: f64, m: f64, fix_first: bool, mass_kind: MassKind) -> Model {
    let a = Vector3::new(0.1, 0.2, 0.3);
    let b = a + Vector3::new(0.3, -0.5, 0.8);
    let spec = ModelSpec {
        mesh: TetMesh {
            positions: vec![a, b],
            tets: Vec::new(),
        },
        material: None,
        density: None,
        mass_kind,
        point_masses: Some(vec![m, m]),
        springs: vec![Spring {
            i: 0,
            j: 1,
            rest_length: (b - a).norm(),
            stiffness: k,
            damping: 0.0,
        }],
        gravity: Some(Vector3::new(0.0, -9.81, 0.0)),
        fixed: FixedSelection {
            indices: if fix_first { vec![0] } else { Vec::new() },
            ..Default::default()
        },
        inverted_tets: InvertedTets::Refuse,
        parallelism: Parallelism::Rayon,
        damping: Damping::default(),
    };
    Model::new(spec).unwrap()
}

/// A Neo-Hookean box (E = 1e5 Pa, nu = 0.4, 1000 kg/m^3), clamped at x = 0 or free.
fn rubber_box(cells: [usize; 3], clamped: bool, mass_kind: MassKind) -> Model {
    let lame = LameParameters::from_youngs_poisson(1e5, 0.4).unwrap();
    let material = MaterialModel::from_name("neo-hookean", lame).unwrap();
    let size = [
        0.1 * cells[0] as f64,
        0.1 * cells[1] as f64,
        0.1 * cells[2] as f64,
    ];
    let mut spec = ModelSpec::elastic(box_mesh(cells, size), material, 1000.0);
    spec.mass_kind = mass_kind;
    if clamped {
        spec.fixed = common::bodies::clamped_at_min_x();
    }
    Model::new(spec).unwrap()
}

fn highest_at_rest(model: &mut Model) -> softbench::model::HighestMode {
    let q = model.rest_state();
    highest_mode(model, &q, &SpectrumSettings::default()).unwrap()
}

/// The largest eigenvalue of K v = lambda M v at rest, densely: M = L L^T, then the largest
/// eigenvalue of L^-1 K L^-T.
fn dense_highest_eigenvalue(model: &mut Model) -> f64 {
    let q = model.rest_state();
    let mut k = model.new_hessian();
    model.hessian(&q, &mut k, Default::default()).unwrap();
    let m = match model.mass() {
        MassMatrix::Consistent(m) => m.to_dense(),
        MassMatrix::Lumped { diagonal, .. } => {
            DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(diagonal))
        }
    };
    let l_inv = m.cholesky().unwrap().l().try_inverse().unwrap();
    let a = &l_inv * k.to_dense() * l_inv.transpose();
    let a = (&a + a.transpose()) * 0.5;
    a.symmetric_eigenvalues().max()
}

#[test]
fn a_particle_on_a_spring_to_a_fixed_one_has_omega_squared_k_over_m() {
    let (k, m) = (250.0, 0.4);
    for mass_kind in [MassKind::Lumped, MassKind::Consistent] {
        let mut model = spring_pair(k, m, true, mass_kind);
        let mode = highest_at_rest(&mut model);
        assert!(mode.converged, "{mass_kind:?}: {mode:?}");
        assert_close(mode.omega_squared, k / m, 1e-12);
        assert_close(mode.omega, (k / m).sqrt(), 1e-12);
        assert_close(mode.explicit_limit(), 2.0 / (k / m).sqrt(), 1e-12);
        // Eigenvalues {k/m, 0, 0}: two distinct values, so the Krylov space ends after 2 steps.
        assert_eq!(mode.iterations, 2, "{mass_kind:?}: {mode:?}");
    }
}

#[test]
fn two_free_particles_on_a_spring_have_omega_squared_2k_over_m() {
    let (k, m) = (250.0, 0.4);
    let mut model = spring_pair(k, m, false, MassKind::Lumped);
    let mode = highest_at_rest(&mut model);
    assert!(mode.converged, "{mode:?}");
    assert_close(mode.omega_squared, 2.0 * k / m, 1e-12);
}

#[test]
fn small_boxes_match_the_dense_generalized_eigenproblem() {
    for clamped in [true, false] {
        for mass_kind in [MassKind::Consistent, MassKind::Lumped] {
            let mut model = rubber_box([4, 3, 2], clamped, mass_kind);
            let dense = dense_highest_eigenvalue(&mut model);
            let mode = highest_at_rest(&mut model);
            println!(
                "box 4x3x2 clamped {clamped} {mass_kind:?}: {} DOFs, omega^2 {:.10e} (dense \
                 {dense:.10e}), {} steps, last change {:.1e}",
                model.num_dofs(),
                mode.omega_squared,
                mode.iterations,
                mode.relative_change
            );
            assert!(mode.converged, "{mode:?}");
            assert!(
                mode.iterations < model.num_dofs(),
                "converged by the tolerance, not by exhausting the space"
            );
            assert_close(mode.omega_squared, dense, 1e-8);
        }
    }
}

#[test]
fn small_models_exhaust_the_krylov_space_and_give_the_exact_value() {
    // 2x1x1 cells clamped at x = 0: 6 free vertices, 18 DOFs, fewer than the iteration cap.
    let mut model = rubber_box([2, 1, 1], true, MassKind::Consistent);
    let dense = dense_highest_eigenvalue(&mut model);
    let q = model.rest_state();
    let settings = SpectrumSettings {
        tolerance: 0.0,
        ..Default::default()
    };
    let mode = highest_mode(&mut model, &q, &settings).unwrap();
    assert!(
        mode.converged && mode.iterations <= model.num_dofs(),
        "{mode:?}"
    );
    assert_close(mode.omega_squared, dense, 1e-12);
}

/// `lambda_max` of M^-1 K at rest by plain power iteration in the M inner product (Rayleigh
/// quotient after `steps` steps), with consistent mass.
fn power_iteration(model: &mut Model, steps: usize) -> f64 {
    let q = model.rest_state();
    let mut k = model.new_hessian();
    model.hessian(&q, &mut k, Default::default()).unwrap();
    let MassMatrix::Consistent(m) = model.mass() else {
        panic!("consistent mass expected")
    };
    let mut solver = CholeskySolver::new(DirectSettings::default());
    solver.analyze(m.pattern()).unwrap();
    solver.factor(m).unwrap();
    let n = q.len();
    let mut rng = Rng::new(7);
    let mut x: Vec<f64> = (0..n).map(|_| rng.range(-1.0, 1.0)).collect();
    let (mut kx, mut mx) = (vec![0.0; n], vec![0.0; n]);
    let mut lambda = 0.0;
    for _ in 0..steps {
        k.mul_vec(&x, &mut kx);
        m.mul_vec(&x, &mut mx);
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(p, q)| p * q).sum::<f64>();
        let xmx = dot(&x, &mx);
        lambda = dot(&x, &kx) / xmx;
        solver.solve(&mut kx).unwrap();
        let scale = 1.0 / (lambda * xmx.sqrt());
        x.iter_mut().zip(&kx).for_each(|(xi, yi)| *xi = yi * scale);
    }
    lambda
}

#[test]
fn a_larger_box_converges_within_200_steps_and_agrees_with_power_iteration() {
    let mut model = rubber_box([16, 8, 8], true, MassKind::Consistent);
    let start = Instant::now();
    let mode = highest_at_rest(&mut model);
    let lanczos_time = start.elapsed();
    let start = Instant::now();
    // The top of this box's spectrum is dense: the Rayleigh quotient stalls near 2e-3 below
    // lambda_max for ~1000 steps and reaches it to 13 digits after ~7000.
    let power = power_iteration(&mut model, 8000);
    println!(
        "box 16x8x8: {} DOFs, Lanczos omega^2 {:.10e} in {} steps ({:.3} s, last change {:.1e}); \
         power iteration {power:.10e} ({:.3} s)",
        model.num_dofs(),
        mode.omega_squared,
        mode.iterations,
        lanczos_time.as_secs_f64(),
        mode.relative_change,
        start.elapsed().as_secs_f64()
    );
    assert!(mode.converged && mode.iterations < 200, "{mode:?}");
    assert_close(mode.omega_squared, power, 1e-4);
    // Lanczos stops on a change below 1e-8 in one step while still converging, so its error is
    // somewhat larger than that change (1.2e-8 here, 1.5 times the last change); it is a lower
    // bound.
    assert!(mode.omega_squared <= power * (1.0 + 1e-12));
    assert_close(mode.omega_squared, power, 3e-8);

    // Cut short, it says so and still gives a lower bound.
    let q = model.rest_state();
    let settings = SpectrumSettings {
        max_iterations: 5,
        ..Default::default()
    };
    let early = highest_mode(&mut model, &q, &settings).unwrap();
    assert!(!early.converged && early.iterations == 5, "{early:?}");
    assert!(early.omega_squared < mode.omega_squared);
}

#[test]
fn a_model_without_free_dofs_or_with_bad_settings_is_refused() {
    let mut model = spring_pair(1.0, 1.0, true, MassKind::Lumped);
    let q = model.rest_state();
    for settings in [
        SpectrumSettings {
            max_iterations: 0,
            ..Default::default()
        },
        SpectrumSettings {
            tolerance: f64::NAN,
            ..Default::default()
        },
    ] {
        let err = highest_mode(&mut model, &q, &settings).unwrap_err();
        assert!(matches!(err, SpectrumError::InvalidSetting { .. }), "{err}");
    }
    let err = highest_mode(&mut model, &[0.0; 2], &SpectrumSettings::default()).unwrap_err();
    assert!(matches!(err, SpectrumError::Model(_)), "{err}");

    let mesh = TetMesh {
        positions: vec![Vector3::zeros(), Vector3::x()],
        tets: Vec::new(),
    };
    let mut fixed = Model::new(ModelSpec {
        mesh,
        material: None,
        density: None,
        mass_kind: MassKind::Lumped,
        point_masses: Some(vec![1.0, 1.0]),
        springs: Vec::new(),
        gravity: None,
        fixed: FixedSelection {
            indices: vec![0, 1],
            ..Default::default()
        },
        inverted_tets: InvertedTets::Refuse,
        parallelism: Parallelism::Sequential,
        damping: Damping::default(),
    })
    .unwrap();
    let err = highest_mode(&mut fixed, &[], &SpectrumSettings::default()).unwrap_err();
    assert!(matches!(err, SpectrumError::NoFreeDofs), "{err}");
}

#[test]
fn the_course_armadillo_has_an_explicit_limit_of_a_few_microseconds() {
    if reference_mesh("arma_6.node").is_none() {
        return;
    }
    let loaded = scene::load(&common::scene("armadillo.toml"), &[]).unwrap();
    let mut built = scene::build(&loaded, &DataPaths::from_env(), Parallelism::Rayon).unwrap();
    let model = &mut built.model;
    assert_eq!(model.mass().kind(), MassKind::Consistent);
    let start = Instant::now();
    let mode = highest_at_rest(model);
    let time = start.elapsed();
    let dt = mode.explicit_limit();
    println!(
        "armadillo: {} DOFs, omega_max^2 = {:.6e} 1/s^2, omega_max = {:.6e} rad/s, \
         2/omega_max = {dt:.4e} s, {} Lanczos steps (converged {}, last change {:.1e}), {:.1} ms",
        model.num_dofs(),
        mode.omega_squared,
        mode.omega,
        mode.iterations,
        mode.converged,
        mode.relative_change,
        time.as_secs_f64() * 1e3
    );
    assert!(mode.converged, "{mode:?}");
    assert!((1e-7..1e-4).contains(&dt), "2/omega_max = {dt} s");
    // 699 DOFs are few enough for the dense generalized eigenproblem.
    assert_close(mode.omega_squared, dense_highest_eigenvalue(model), 1e-8);
}
