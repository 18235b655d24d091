//! One step of every integrator, and one numeric factorization and solve of the backward
//! Euler system M + dt^2 K, on the course armadillo (`arma_6`, when `SOFTBENCH_DATA` is set)
//! and on a generated 50,400-tet box. Course Neo-Hookean, consistent mass, base fixed, gravity.
//!
//! Explicit methods step at a stable dt (1e-6 s on the armadillo, 1e-5 s on the box; adaptive
//! ones cover that interval with as many internal steps as their tolerance needs); implicit
//! methods at 0.01 s (not the implicit ones under error control: their fixed-step variants
//! stand for them). Each step starts from the same state (a copy of it), 0.05 s into a
//! backward-Euler run, so every method sees a deformed, moving body.
//!
//! `cargo bench --bench integrators` (add `-- --quick` for a shorter run).

use criterion::{BatchSize, BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::Vector3;
use softbench::integrate::{IntegratorSettings, Method, State};
use softbench::material::{LameParameters, MaterialModel, NeoHookean};
use softbench::mesh::TetMesh;
use softbench::model::{AxisRule, FixedSelection, HessianOptions, Model, ModelSpec, Side};
use softbench::solve::{LinearSolverKind, SolverSettings};
use std::time::Duration;

struct Case {
    name: &'static str,
    model: Model,
    state: State,
    explicit_dt: f64,
}

fn case(
    name: &'static str,
    mesh: TetMesh,
    e: f64,
    density: f64,
    fix_axis: usize,
    tolerance: f64,
    explicit_dt: f64,
) -> Case {
    let material = MaterialModel::NeoHookean(NeoHookean::new(
        LameParameters::from_youngs_poisson(e, 0.4).unwrap(),
    ));
    let mut spec = ModelSpec::elastic(mesh, material, density);
    spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
    spec.fixed = FixedSelection {
        rules: vec![AxisRule {
            axis: fix_axis,
            side: Side::Min,
            tolerance,
        }],
        ..Default::default()
    };
    let mut model = Model::new(spec).unwrap();
    let mut state = State::at_rest(&model);
    let mut be = IntegratorSettings::default().build();
    for _ in 0..5 {
        be.step(&mut model, &mut state, 0.01).unwrap();
    }
    Case {
        name,
        model,
        state,
        explicit_dt,
    }
}

fn cases() -> Vec<Case> {
    let mut list = Vec::new();
    match std::env::var("SOFTBENCH_DATA") {
        Ok(dir) => {
            let mesh =
                softbench::mesh::read_tet_mesh(std::path::Path::new(&dir).join("arma_6.node"))
                    .unwrap();
            list.push(case("arma_6", mesh, 6e5, 0.1, 1, 0.1, 1e-6));
        }
        Err(_) => eprintln!("skipping arma_6: SOFTBENCH_DATA is not set"),
    }
    let mesh = softbench::mesh::generate::box_mesh([20, 20, 21], [1.0, 1.0, 1.05]);
    list.push(case("box_50k", mesh, 1e6, 1000.0, 0, 1e-9, 1e-5));
    list
}

fn steps(c: &mut Criterion) {
    let mut group = c.benchmark_group("step");
    for mut case in cases() {
        for method in Method::all() {
            // Projective dynamics and XPBD run only on their own energies.
            let own = match method.name() {
                "projective-dynamics" => Some("corotated"),
                "xpbd" => Some("xpbd-neo-hookean"),
                _ => None,
            };
            if own.is_some_and(|own| case.model.material().map(|m| m.name()) != Some(own)) {
                continue;
            }
            // An implicit method under error control has no step of its own: its work per
            // interval is whatever its tolerance asks (experiments/implicit_families.toml
            // measures that); its fixed-step variant is benched here.
            if method.is_adaptive() && !method.is_explicit() {
                continue;
            }
            let mut integ = IntegratorSettings {
                method,
                ..Default::default()
            }
            .build();
            let dt = if method.is_explicit() {
                case.explicit_dt
            } else {
                0.01
            };
            let id = BenchmarkId::new(method.name(), case.name);
            group.bench_function(id, |b| {
                b.iter_batched(
                    || case.state.clone(),
                    |mut s| integ.step(&mut case.model, &mut s, dt).unwrap(),
                    BatchSize::LargeInput,
                )
            });
        }
    }
    group.finish();
}

fn backward_euler_system(c: &mut Criterion) {
    let mut group = c.benchmark_group("be_system");
    for mut case in cases() {
        let mut h = case.model.new_hessian();
        case.model
            .hessian(&case.state.q, &mut h, HessianOptions::default())
            .unwrap();
        case.model.mass().scale_and_add_to(1e-4, &mut h);
        let mut solver = LinearSolverKind::from_name("cholesky")
            .unwrap()
            .build(&SolverSettings::default());
        solver.analyze(h.pattern()).unwrap();
        solver.factor(&h).unwrap();
        eprintln!(
            "{}: {} DOFs, nnz(A) = {}, nnz(L) = {}",
            case.name,
            h.dim(),
            h.pattern().nnz(),
            solver.stats().factor_nnz
        );
        group.bench_function(BenchmarkId::new("cholesky_factor", case.name), |b| {
            b.iter(|| solver.factor(&h).unwrap())
        });
        let rhs: Vec<f64> = (0..h.dim()).map(|i| (i as f64).sin()).collect();
        let mut x = rhs.clone();
        group.bench_function(BenchmarkId::new("cholesky_solve", case.name), |b| {
            b.iter(|| {
                x.copy_from_slice(&rhs);
                solver.solve(&mut x).unwrap()
            })
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(200))
        .measurement_time(Duration::from_millis(1000))
        .without_plots();
    targets = steps, backward_euler_system
}
criterion_main!(benches);
