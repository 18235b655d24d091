//! Projective dynamics converges to backward Euler on its projective energy (corotated
//! elasticity), conserves the momentum of a free body, does not depend on the thread count,
//! and refuses scenes whose energy has no projective form here.

mod common;

use common::bodies::{clamped_at_min_x, distance, kicked};
use nalgebra::Vector3;
use softbench::integrate::projective_dynamics::{ProjectiveDynamics, ProjectiveDynamicsSettings};
use softbench::integrate::{Integrator, IntegratorSettings, Method, State};
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::generate::box_mesh;
use softbench::model::{Damping, Drag, DragPath, MassKind, Model, ModelSpec, Waypoint};
use softbench::parallel::Parallelism;
use softbench::solve::LinearSolverKind;

fn body(material: &str, mass: MassKind, cells: [usize; 3], clamped: bool) -> Model {
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name(material, lame).unwrap();
    let size = [
        0.1 * cells[0] as f64,
        0.1 * cells[1] as f64,
        0.1 * cells[2] as f64,
    ];
    let mut spec = ModelSpec::elastic(box_mesh(cells, size), material, 1000.0);
    if clamped {
        spec.fixed = clamped_at_min_x();
        spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
    }
    spec.mass_kind = mass;
    Model::new(spec).unwrap()
}

fn pd(iterations: u32) -> ProjectiveDynamics {
    let settings = IntegratorSettings::default();
    ProjectiveDynamics::new(
        ProjectiveDynamicsSettings {
            iterations,
            ..Default::default()
        },
        LinearSolverKind::cholesky().build(&settings.solver),
    )
}

fn backward_euler(model: &mut Model, start: &State, dt: f64) -> State {
    let mut settings = IntegratorSettings {
        method: Method::from_name("backward-euler").unwrap(),
        ..Default::default()
    };
    settings.newton.tolerance = 1e-13;
    settings.newton.max_iterations = 50;
    let mut state = start.clone();
    settings.build().step(model, &mut state, dt).unwrap();
    state
}

#[test]
fn pd_error_against_backward_euler_on_the_corotated_energy_decreases_below_1e_6() {
    for mass in [MassKind::Lumped, MassKind::Consistent] {
        let mut model = body("corotated", mass, [3, 1, 1], true);
        let start = kicked(&model);
        let reference = backward_euler(&mut model, &start, 0.01);
        let scale = distance(&reference.q, &start.q);
        let errors: Vec<f64> = [1, 3, 10, 30, 100, 300, 1000]
            .iter()
            .map(|&k| {
                let mut state = start.clone();
                pd(k).step(&mut model, &mut state, 0.01).unwrap();
                distance(&state.q, &reference.q) / scale
            })
            .collect();
        for w in errors.windows(2) {
            assert!(
                w[1] <= w[0] * 1.0001 || w[1] < 1e-12,
                "{mass:?}: error grew with iterations: {errors:?}"
            );
        }
        assert!(*errors.last().unwrap() < 1e-6, "{mass:?}: {errors:?}");
        assert!(
            errors[0] > 100.0 * errors.last().unwrap(),
            "{mass:?}: {errors:?}"
        );
    }
}

#[test]
fn pd_conserves_linear_momentum_of_a_free_body_at_every_iteration_count() {
    let mut model = body("corotated", MassKind::Consistent, [3, 1, 1], false);
    let momentum = |model: &Model, s: &State| {
        let mut mv = vec![0.0; s.v.len()];
        model.mass().mul_vec(&s.v, &mut mv);
        Vector3::from_fn(|k, _| mv.iter().skip(k).step_by(3).sum::<f64>())
    };
    let start = kicked(&model);
    let p0 = momentum(&model, &start);
    for iterations in [1, 5] {
        let mut state = start.clone();
        let mut integ = pd(iterations);
        for _ in 0..10 {
            integ.step(&mut model, &mut state, 0.01).unwrap();
        }
        let p = momentum(&model, &state);
        assert!((p - p0).norm() < 1e-10 * p0.norm(), "{p0} -> {p}");
    }
}

#[test]
fn thread_count_does_not_change_pd_results() {
    let mut model = body("corotated", MassKind::Lumped, [20, 10, 10], true);
    let start = kicked(&model);
    let run = |model: &mut Model, par: Parallelism| {
        model.set_parallelism(par);
        let mut state = start.clone();
        let mut integ = pd(3);
        for _ in 0..2 {
            integ.step(model, &mut state, 0.01).unwrap();
        }
        state
    };
    let sequential = run(&mut model, Parallelism::Sequential);
    let parallel = run(&mut model, Parallelism::Rayon);
    let three = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap()
        .install(|| run(&mut model, Parallelism::Rayon));
    for other in [&parallel, &three] {
        assert!(
            sequential
                .q
                .iter()
                .zip(&other.q)
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
        assert!(
            sequential
                .v
                .iter()
                .zip(&other.v)
                .all(|(a, b)| a.to_bits() == b.to_bits())
        );
    }
    assert_ne!(sequential.q, start.q);
}

#[test]
fn pd_converges_to_backward_euler_with_damping() {
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name("corotated", lame).unwrap();
    let mut spec = ModelSpec::elastic(box_mesh([3, 1, 1], [0.3, 0.1, 0.1]), material, 1000.0);
    spec.fixed = clamped_at_min_x();
    spec.damping = Damping {
        rayleigh: Some((0.5, 0.002)),
        strain_rate: Some((5.0, 5.0)),
    };
    let mut model = Model::new(spec).unwrap();
    let start = kicked(&model);
    let reference = backward_euler(&mut model, &start, 0.01);
    let mut state = start.clone();
    pd(1000).step(&mut model, &mut state, 0.01).unwrap();
    let error = distance(&state.q, &reference.q) / distance(&reference.q, &start.q);
    assert!(error < 1e-6, "{error:.3e}");
}

#[test]
fn pd_refuses_a_material_without_a_projective_form() {
    let mut model = body("stable-neo-hookean", MassKind::Lumped, [2, 1, 1], false);
    let mut state = State::at_rest(&model);
    let err = pd(3)
        .step(&mut model, &mut state, 0.01)
        .unwrap_err()
        .to_string();
    assert!(err.contains("corotated"), "{err}");
    assert_eq!(state, State::at_rest(&model));
}

/// A drag on the free end of `model` along +x, released at `release`.
fn drag(model: &mut Model, release: Option<f64>) {
    let rest = model.rest_positions().to_vec();
    let picked = Drag::pick(&rest, &Vector3::new(0.3, 0.1, 0.1), 0.01);
    assert!(!picked.is_empty());
    let w = |t, x| Waypoint {
        t,
        offset: Vector3::new(x, 0.0, 0.0),
    };
    let path = DragPath::new(vec![w(0.0, 0.0), w(0.1, 0.05)]).unwrap();
    model.add_vertex_potential(Box::new(
        Drag::new(&rest, picked, 50.0, path, release).unwrap(),
    ));
}

#[test]
fn pd_converges_to_backward_euler_with_a_drag_and_refactors_only_when_it_is_released() {
    let mut model = body("corotated", MassKind::Lumped, [3, 1, 1], true);
    drag(&mut model, Some(0.025));
    let start = kicked(&model);
    let mut reference = start.clone();
    let mut state = start.clone();
    let mut integ = pd(2000);
    let mut factorizations = Vec::new();
    let mut analyses = Vec::new();
    for _ in 0..4 {
        let be = backward_euler(&mut model, &reference, 0.01);
        // Both from the same start, so the comparison is of one step each.
        let mut from = reference.clone();
        let report = integ.step(&mut model, &mut from, 0.01).unwrap();
        factorizations.push(report.factorizations);
        analyses.push(report.symbolic_analyses);
        let error = distance(&from.q, &be.q) / distance(&be.q, &reference.q);
        assert!(error < 1e-6, "t = {}: {error:.3e}", reference.t);
        reference = be;
        state = from;
    }
    assert_ne!(state.q, start.q);
    // Factored at the first step and again when the drag lets go (end of step 3: t = 0.03).
    assert_eq!(factorizations, vec![1, 0, 1, 0]);
    // One symbolic analysis: the pattern never changes.
    assert_eq!(analyses, vec![1, 0, 0, 0]);
}

/// Backward Euler analyses its pattern once and reuses it at every later step.
#[test]
fn backward_euler_counts_one_symbolic_analysis_for_a_run() {
    let mut model = body("corotated", MassKind::Lumped, [3, 1, 1], true);
    let mut settings = IntegratorSettings {
        method: Method::from_name("backward-euler").unwrap(),
        ..Default::default()
    };
    settings.newton.tolerance = 1e-10;
    let mut integ = settings.build();
    let mut state = kicked(&model);
    let analyses: Vec<u32> = (0..3)
        .map(|_| {
            integ
                .step(&mut model, &mut state, 0.01)
                .unwrap()
                .symbolic_analyses
        })
        .collect();
    assert_eq!(analyses, vec![1, 0, 0]);
}

#[test]
fn pd_refuses_a_penalty_potential_and_names_the_responses_that_work() {
    use softbench::model::VertexPotential;
    #[derive(Debug)]
    struct Penalty;
    impl VertexPotential for Penalty {
        fn name(&self) -> &str {
            "contact"
        }
        fn energy(&self, _: f64, _: &[Vector3<f64>]) -> f64 {
            0.0
        }
        fn gradient(&self, _: f64, _: &[Vector3<f64>], _: &mut dyn FnMut(usize, Vector3<f64>)) {}
        fn hessian(
            &self,
            _: f64,
            _: &[Vector3<f64>],
            _: bool,
            _: &mut dyn FnMut(usize, nalgebra::Matrix3<f64>),
        ) {
        }
    }
    let mut model = body("corotated", MassKind::Lumped, [2, 1, 1], false);
    model.add_vertex_potential(Box::new(Penalty));
    let err = pd(3).check_model(&model).unwrap_err().to_string();
    assert!(
        err.contains("contact") && err.contains("projection"),
        "{err}"
    );
}
