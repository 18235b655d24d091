//! Incremental potential contact (`contact.response = "ipc"`) through the model and the run:
//! the barrier's and friction's gradients and Hessians (self-contact blocks outside the
//! element pattern included) against finite differences, the barrier adding exactly nothing
//! where nothing is within d̂, and the scenes of the contact study staying intersection-free.

use nalgebra::Vector3;
use softbench::data::DataPaths;
use softbench::model::{HessianOptions, Model};
use softbench::parallel::Parallelism;
use softbench::scene::{self, LoadedScene, Scene};
use std::path::PathBuf;

fn scene_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("experiments/scenes/contact")
}

/// A shipped contact scene with `--set` style overrides.
fn shipped(name: &str, overrides: &[&str]) -> Scene {
    let path = scene_dir().join(name);
    let text = std::fs::read_to_string(&path).unwrap();
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let config = scene::parse(&text, &path, &overrides).unwrap();
    let loaded = LoadedScene { path, config };
    scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential).unwrap()
}

/// The full Hessian (element pattern plus the contact blocks outside it) as a dense matrix.
fn dense_hessian(model: &mut Model, q: &[f64], options: HessianOptions) -> nalgebra::DMatrix<f64> {
    let mut h = model.new_hessian();
    model.hessian(q, &mut h, options).unwrap();
    let mut d = h.to_dense();
    for b in model.off_pattern_blocks() {
        for i in 0..3 {
            for j in 0..3 {
                d[(3 * b.row as usize + i, 3 * b.col as usize + j)] += b.block[(i, j)];
            }
        }
    }
    d
}

/// The two cubes with the upper one lowered to `gap` (m) above the lower one.
fn stacked(gap: f64, overrides: &[&str]) -> (Scene, Vec<f64>) {
    let scene = shipped("stack.toml", overrides);
    let mut q = scene.model.rest_state();
    for (k, p) in q.chunks_exact_mut(3).enumerate() {
        if k >= 125 {
            p[1] -= 0.1 - gap;
        }
    }
    (scene, q)
}

#[test]
fn barrier_gradient_and_hessian_match_finite_differences_across_self_contact() {
    let (mut scene, q) = stacked(4e-4, &[]);
    let model = &mut scene.model;
    let n = q.len();
    let mut g = vec![0.0; n];
    model.gradient(&q, &mut g).unwrap();
    let h = dense_hessian(model, &q, HessianOptions::default());
    assert!(
        !model.off_pattern_blocks().is_empty(),
        "the cubes share no element: their contact blocks are outside the pattern"
    );
    let step = 1e-8;
    let (mut worst_g, mut worst_h) = (0.0f64, 0.0f64);
    let (mut gp, mut gm) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..n {
        let mut x = q.clone();
        x[i] += step;
        let ep = model.potential(&x).unwrap();
        model.gradient(&x, &mut gp).unwrap();
        x[i] -= 2.0 * step;
        let em = model.potential(&x).unwrap();
        model.gradient(&x, &mut gm).unwrap();
        worst_g = worst_g.max(((ep - em) / (2.0 * step) - g[i]).abs());
        for j in 0..n {
            worst_h = worst_h.max(((gp[j] - gm[j]) / (2.0 * step) - h[(j, i)]).abs());
        }
    }
    let g_scale = g.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let h_scale = h.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    eprintln!("ipc FD: gradient error {worst_g:.2e} of {g_scale:.2e}, Hessian {worst_h:.2e} of {h_scale:.2e}");
    assert!(worst_g < 1e-5 * g_scale, "gradient error {worst_g:e}");
    assert!(worst_h < 1e-4 * h_scale, "Hessian error {worst_h:e}");
    // Projected, the whole matrix is positive semi-definite.
    let p = dense_hessian(model, &q, HessianOptions::projected());
    let min = p.symmetric_eigenvalues().min();
    assert!(min > -1e-8 * h_scale, "projected Hessian eigenvalue {min:e}");
}

#[test]
fn the_barrier_adds_nothing_where_nothing_is_within_dhat() {
    let (mut with, q) = stacked(0.05, &[]);
    let (mut without, _) = stacked(0.05, &["contact.response=penalty"]);
    let (a, b) = (&mut with.model, &mut without.model);
    assert_eq!(a.potential(&q).unwrap().to_bits(), b.potential(&q).unwrap().to_bits());
    let (mut ga, mut gb) = (vec![0.0; q.len()], vec![0.0; q.len()]);
    a.gradient(&q, &mut ga).unwrap();
    b.gradient(&q, &mut gb).unwrap();
    assert!(ga.iter().zip(&gb).all(|(x, y)| x.to_bits() == y.to_bits()));
    let (ha, hb) = (
        dense_hessian(a, &q, HessianOptions::default()),
        dense_hessian(b, &q, HessianOptions::default()),
    );
    assert!(ha.iter().zip(hb.iter()).all(|(x, y)| x.to_bits() == y.to_bits()));
    let _ = Vector3::<f64>::zeros();
}

#[test]
fn the_linear_system_carries_the_self_contact_blocks_outside_the_element_pattern() {
    use softbench::integrate::newton::{ImplicitSystem, NewtonSettings};
    use softbench::integrate::StepReport;
    let (mut scene, q) = stacked(4e-4, &[]);
    let model = &mut scene.model;
    let settings = NewtonSettings::default();
    let solver = softbench::solve::LinearSolverKind::cholesky().build(&Default::default());
    let mut system = ImplicitSystem::new(solver, settings.filter_settings());
    let beta = 1e-4;
    let mut report = StepReport::default();
    let a = system
        .assemble_matrix(model, &q, beta, true, &mut report)
        .unwrap()
        .to_dense();
    let mut expected = dense_hessian(model, &q, HessianOptions::projected()) * beta;
    let mut mass = model.new_hessian();
    model.mass().add_scaled_to(1.0, &mut mass);
    expected += mass.to_dense();
    let worst = (&a - &expected).abs().max();
    assert!(worst <= 1e-12 * expected.abs().max(), "assembled vs expected: {worst:e}");
}
