//! Vertex block descent converges to the backward Euler step (any material, consistent or
//! lumped mass, damping, drag), its colouring is valid, and the thread count does not change
//! its results.

mod common;

use common::bodies::{clamped_at_min_x, distance, kicked};
use nalgebra::Vector3;
use softbench::integrate::acceleration::Acceleration;
use softbench::integrate::vbd::{Vbd, VbdInitialization, VbdSettings};
use softbench::integrate::{Integrator, IntegratorSettings, Method, State};
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::generate::box_mesh;
use softbench::model::{Damping, Drag, DragPath, MassKind, Model, ModelSpec, Waypoint};
use softbench::parallel::Parallelism;

fn body(material: &str, mass: MassKind, cells: [usize; 3], damping: Damping) -> Model {
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name(material, lame).unwrap();
    let size = [
        0.1 * cells[0] as f64,
        0.1 * cells[1] as f64,
        0.1 * cells[2] as f64,
    ];
    let mut spec = ModelSpec::elastic(box_mesh(cells, size), material, 1000.0);
    spec.fixed = clamped_at_min_x();
    spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
    spec.mass_kind = mass;
    spec.damping = damping;
    Model::new(spec).unwrap()
}

/// The backward Euler step from `start`, Newton converged tightly.
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

fn vbd_step(model: &mut Model, start: &State, dt: f64, settings: VbdSettings) -> State {
    let mut state = start.clone();
    Vbd::new(settings).step(model, &mut state, dt).unwrap();
    state
}

/// ‖x_vbd − x_be‖ / ‖x_be − q‖ for a sweep of iteration counts.
fn errors(model: &mut Model, dt: f64, settings: VbdSettings, iterations: &[u32]) -> Vec<f64> {
    let start = kicked(model);
    let reference = backward_euler(model, &start, dt);
    let scale = distance(&reference.q, &start.q);
    iterations
        .iter()
        .map(|&k| {
            let s = VbdSettings {
                iterations: k,
                ..settings
            };
            distance(&vbd_step(model, &start, dt, s).q, &reference.q) / scale
        })
        .collect()
}

fn assert_converges(errors: &[f64], what: &str) {
    for w in errors.windows(2) {
        // Below 1e-12 the error is the reference's round-off.
        assert!(
            w[1] <= w[0] * 1.0001 || w[1] < 1e-12,
            "{what}: error grew with iterations: {errors:?}"
        );
    }
    let last = *errors.last().unwrap();
    assert!(
        last < 1e-6,
        "{what}: final relative error {last:.3e}: {errors:?}"
    );
    assert!(errors[0] > 100.0 * last, "{what}: {errors:?}");
}

const SWEEP: [u32; 7] = [1, 3, 10, 30, 100, 300, 1000];

#[test]
fn vbd_error_against_converged_backward_euler_decreases_below_1e_6() {
    for material in ["stable-neo-hookean", "neo-hookean", "corotated"] {
        for mass in [MassKind::Lumped, MassKind::Consistent] {
            let mut model = body(material, mass, [3, 1, 1], Damping::default());
            let e = errors(&mut model, 0.01, VbdSettings::default(), &SWEEP);
            assert_converges(&e, &format!("{material} {mass:?}"));
        }
    }
}

#[test]
fn vbd_converges_with_every_initialization_and_with_chebyshev_acceleration() {
    let mut model = body(
        "stable-neo-hookean",
        MassKind::Lumped,
        [3, 1, 1],
        Damping::default(),
    );
    for initialization in [
        VbdInitialization::Previous,
        VbdInitialization::Inertia,
        VbdInitialization::Adaptive,
    ] {
        let s = VbdSettings {
            initialization,
            ..Default::default()
        };
        let e = errors(&mut model, 0.01, s, &SWEEP);
        assert_converges(&e, &format!("{initialization:?}"));
    }
    // Acceleration keeps the fixed point (whether it speeds convergence depends on how well
    // rho estimates the sweep's spectral radius).
    let s = VbdSettings {
        acceleration: Acceleration::Chebyshev,
        chebyshev_rho: 0.8,
        ..Default::default()
    };
    let e = errors(&mut model, 0.01, s, &SWEEP);
    assert_converges(&e, "chebyshev");
}

#[test]
fn vbd_converges_to_backward_euler_with_damping_and_drag() {
    let damping = Damping {
        rayleigh: Some((0.5, 0.002)),
        strain_rate: Some((5.0, 5.0)),
    };
    let mut model = body(
        "stable-neo-hookean",
        MassKind::Consistent,
        [3, 1, 1],
        damping,
    );
    let rest = model.rest_positions().to_vec();
    let picked = Drag::pick(&rest, &Vector3::new(0.3, 0.1, 0.1), 0.01);
    assert!(!picked.is_empty());
    let w = |t, x| Waypoint {
        t,
        offset: Vector3::new(x, 0.0, 0.0),
    };
    let path = DragPath::new(vec![w(0.0, 0.0), w(0.1, 0.05)]).unwrap();
    model.add_vertex_potential(Box::new(
        Drag::new(&rest, picked, 50.0, path, None).unwrap(),
    ));
    assert!(model.has_damping());
    let e = errors(&mut model, 0.01, VbdSettings::default(), &SWEEP);
    assert_converges(&e, "damping + drag");
}

#[test]
fn vbd_conserves_linear_momentum_of_a_free_body_when_converged() {
    for mass in [MassKind::Lumped, MassKind::Consistent] {
        let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
        let material = MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
        let mut spec = ModelSpec::elastic(box_mesh([3, 1, 1], [0.3, 0.1, 0.1]), material, 1000.0);
        spec.mass_kind = mass;
        let mut model = Model::new(spec).unwrap();
        let momentum = |model: &Model, s: &State| {
            let mut mv = vec![0.0; s.v.len()];
            model.mass().mul_vec(&s.v, &mut mv);
            Vector3::from_fn(|k, _| mv.iter().skip(k).step_by(3).sum::<f64>())
        };
        let mut state = kicked(&model);
        let p0 = momentum(&model, &state);
        let mut vbd = Vbd::new(VbdSettings {
            iterations: 500,
            ..Default::default()
        });
        for _ in 0..5 {
            vbd.step(&mut model, &mut state, 0.01).unwrap();
        }
        let p = momentum(&model, &state);
        assert!(
            (p - p0).norm() < 1e-8 * p0.norm(),
            "{mass:?}: momentum {p0} -> {p}"
        );
    }
}

/// Every tet's free vertices have distinct colours.
fn assert_valid_colouring(model: &mut Model) {
    let mut state = State::at_rest(model);
    let mut vbd = Vbd::new(VbdSettings {
        iterations: 1,
        ..Default::default()
    });
    vbd.step(model, &mut state, 0.01).unwrap();
    let colouring = vbd.colouring().unwrap();
    assert_eq!(colouring.len(), model.dofs().num_free());
    let dofs = model.dofs();
    let tets = model.elastic_elements().unwrap().tets;
    for t in tets {
        for a in 0..4 {
            for b in a + 1..4 {
                if dofs.is_fixed(t[a]) || dofs.is_fixed(t[b]) {
                    continue;
                }
                let (fa, fb) = (dofs.free_index(t[a]), dofs.free_index(t[b]));
                assert_ne!(
                    colouring.colour_of(fa as usize),
                    colouring.colour_of(fb as usize),
                    "tet {t:?} has two vertices of one colour"
                );
            }
        }
    }
    let total: usize = (0..colouring.num_colours())
        .map(|c| colouring.group(c).len())
        .sum();
    assert_eq!(total, colouring.len());
}

#[test]
fn vbd_vertex_colouring_is_valid() {
    let mut model = body(
        "stable-neo-hookean",
        MassKind::Lumped,
        [20, 10, 10],
        Damping::default(),
    );
    assert_valid_colouring(&mut model);
    let Some(path) = common::reference_mesh("arma_6.node") else {
        return;
    };
    let mesh = softbench::mesh::read_tet_mesh(&path).unwrap();
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name("corotated", lame).unwrap();
    let mut model = Model::new(ModelSpec::elastic(mesh, material, 1000.0)).unwrap();
    assert_valid_colouring(&mut model);
}

#[test]
fn thread_count_does_not_change_vbd_results() {
    let damping = Damping {
        rayleigh: Some((0.1, 0.001)),
        strain_rate: None,
    };
    let mut model = body(
        "stable-neo-hookean",
        MassKind::Consistent,
        [20, 10, 10],
        damping,
    );
    let start = kicked(&model);
    let settings = VbdSettings {
        iterations: 5,
        acceleration: Acceleration::Chebyshev,
        chebyshev_rho: 0.7,
        ..Default::default()
    };
    let run = |model: &mut Model, par: Parallelism| {
        model.set_parallelism(par);
        let mut state = start.clone();
        let mut vbd = Vbd::new(settings);
        for _ in 0..2 {
            vbd.step(model, &mut state, 0.01).unwrap();
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
    assert!(
        sequential
            .q
            .iter()
            .zip(&parallel.q)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
    assert!(
        sequential
            .v
            .iter()
            .zip(&parallel.v)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
    assert!(
        sequential
            .q
            .iter()
            .zip(&three.q)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
    assert_ne!(sequential.q, start.q);
}
