//! XPBD follows the dynamics of its own constraint energy (material `xpbd-neo-hookean`):
//! with many substeps it matches backward Euler on that energy within backward Euler's
//! discretization error; it conserves the momentum of a free body; its tet colouring is
//! valid; the thread count does not change its results.

mod common;

use common::bodies::{clamped_at_min_x, distance, kicked};
use nalgebra::Vector3;
use softbench::integrate::xpbd::{Xpbd, XpbdSettings};
use softbench::integrate::{Integrator, IntegratorSettings, Method, State};
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::generate::box_mesh;
use softbench::model::{Drag, DragPath, MassKind, Model, ModelSpec, Waypoint};
use softbench::parallel::Parallelism;

fn body(cells: [usize; 3], clamped: bool) -> Model {
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name("xpbd-neo-hookean", lame).unwrap();
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
    spec.mass_kind = MassKind::Lumped;
    Model::new(spec).unwrap()
}

fn run(
    model: &mut Model,
    integ: &mut dyn Integrator,
    start: &State,
    dt: f64,
    steps: usize,
) -> State {
    let mut state = start.clone();
    for _ in 0..steps {
        integ.step(model, &mut state, dt).unwrap();
    }
    state
}

fn backward_euler() -> Box<dyn Integrator> {
    let mut settings = IntegratorSettings {
        method: Method::from_name("backward-euler").unwrap(),
        ..Default::default()
    };
    settings.newton.tolerance = 1e-12;
    settings.newton.max_iterations = 50;
    settings.build()
}

#[test]
fn xpbd_with_many_substeps_matches_backward_euler_on_its_energy() {
    let mut model = body([3, 1, 1], true);
    let start = kicked(&model);
    let (dt, steps) = (0.01, 5);
    let be = run(&mut model, backward_euler().as_mut(), &start, dt, steps);
    let fine = run(
        &mut model,
        backward_euler().as_mut(),
        &start,
        dt / 64.0,
        64 * steps,
    );
    let settings = XpbdSettings {
        substeps: 200,
        iterations: 2,
        ..Default::default()
    };
    let xpbd = run(&mut model, &mut Xpbd::new(settings), &start, dt, steps);
    let be_error = distance(&be.q, &fine.q);
    let xpbd_to_be = distance(&xpbd.q, &be.q);
    let xpbd_to_fine = distance(&xpbd.q, &fine.q);
    let moved = distance(&be.q, &start.q);
    eprintln!(
        "moved {moved:.3e}; backward Euler error {be_error:.3e}; xpbd to BE {xpbd_to_be:.3e}, \
         to the dt/64 solution {xpbd_to_fine:.3e}"
    );
    assert!(be_error > 1e-3 * moved, "the test needs a visible BE error");
    assert!(
        xpbd_to_be < 1.5 * be_error,
        "xpbd differs from backward Euler by {xpbd_to_be:.3e}, more than its error {be_error:.3e}"
    );
    assert!(
        xpbd_to_fine < 0.2 * be_error,
        "xpbd is {xpbd_to_fine:.3e} from the fine solution (backward Euler: {be_error:.3e})"
    );
}

#[test]
fn xpbd_conserves_linear_momentum_of_a_free_body() {
    let mut model = body([3, 1, 1], false);
    let momentum = |model: &Model, s: &State| {
        let mut mv = vec![0.0; s.v.len()];
        model.mass().mul_vec(&s.v, &mut mv);
        Vector3::from_fn(|k, _| mv.iter().skip(k).step_by(3).sum::<f64>())
    };
    let start = kicked(&model);
    let p0 = momentum(&model, &start);
    let end = run(
        &mut model,
        &mut Xpbd::new(XpbdSettings::default()),
        &start,
        0.01,
        10,
    );
    let p = momentum(&model, &end);
    assert!((p - p0).norm() < 1e-12 * p0.norm(), "{p0} -> {p}");
}

#[test]
fn xpbd_tet_colouring_is_valid_and_thread_count_does_not_change_results() {
    let mut model = body([20, 10, 10], true);
    let start = kicked(&model);
    let settings = XpbdSettings {
        substeps: 3,
        iterations: 2,
        ..Default::default()
    };
    // Every colour split as finely as the pool allows, and by the default rule.
    let go_split = |model: &mut Model, par: Parallelism, parallel_min_tets: usize| {
        model.set_parallelism(par);
        let mut integ = Xpbd::new(XpbdSettings {
            parallel_min_tets,
            ..settings
        });
        let end = run(model, &mut integ, &start, 0.01, 2);
        (end, integ.colouring().unwrap().clone())
    };
    let go = |model: &mut Model, par: Parallelism| {
        model.set_parallelism(par);
        let mut integ = Xpbd::new(settings);
        let end = run(model, &mut integ, &start, 0.01, 2);
        (end, integ.colouring().unwrap().clone())
    };
    let (sequential, colouring) = go(&mut model, Parallelism::Sequential);
    let (parallel, _) = go(&mut model, Parallelism::Rayon);
    let (three, _) = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap()
        .install(|| go(&mut model, Parallelism::Rayon));
    let (three_finest, _) = rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap()
        .install(|| go_split(&mut model, Parallelism::Rayon, 1));
    for other in [&parallel, &three, &three_finest] {
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
    // No two tets sharing a free vertex have one colour.
    let dofs = model.dofs();
    let tets = model.elastic_elements().unwrap().tets;
    let mut by_vertex = vec![Vec::new(); dofs.num_vertices()];
    for (e, t) in tets.iter().enumerate() {
        for &v in t {
            if !dofs.is_fixed(v) {
                by_vertex[v].push(e);
            }
        }
    }
    for list in &by_vertex {
        for (i, &a) in list.iter().enumerate() {
            for &b in &list[i + 1..] {
                assert_ne!(
                    colouring.colour_of(a),
                    colouring.colour_of(b),
                    "tets {a}, {b}"
                );
            }
        }
    }
    assert!(colouring.num_colours() > 1);
}

#[test]
fn xpbd_refuses_a_material_that_is_not_its_constraint_energy() {
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
    let mut model = Model::new(ModelSpec::elastic(
        box_mesh([2, 1, 1], [0.2, 0.1, 0.1]),
        material,
        1000.0,
    ))
    .unwrap();
    let mut state = State::at_rest(&model);
    let err = Xpbd::new(XpbdSettings::default())
        .step(&mut model, &mut state, 0.01)
        .unwrap_err()
        .to_string();
    assert!(err.contains("xpbd-neo-hookean"), "{err}");
}

#[test]
fn xpbd_with_a_drag_matches_backward_euler_on_its_energy() {
    let mut model = body([3, 1, 1], true);
    let rest = model.rest_positions().to_vec();
    let picked = Drag::pick(&rest, &Vector3::new(0.3, 0.1, 0.1), 0.01);
    let w = |t, x| Waypoint {
        t,
        offset: Vector3::new(x, 0.0, 0.0),
    };
    let path = DragPath::new(vec![w(0.0, 0.0), w(0.05, 0.05)]).unwrap();
    model.add_vertex_potential(Box::new(
        Drag::new(&rest, picked, 200.0, path, None).unwrap(),
    ));
    let start = State::at_rest(&model);
    let (dt, steps) = (0.01, 5);
    let be = run(&mut model, backward_euler().as_mut(), &start, dt, steps);
    let fine = run(
        &mut model,
        backward_euler().as_mut(),
        &start,
        dt / 64.0,
        64 * steps,
    );
    let settings = XpbdSettings {
        substeps: 200,
        iterations: 2,
        ..Default::default()
    };
    let xpbd = run(&mut model, &mut Xpbd::new(settings), &start, dt, steps);
    let be_error = distance(&be.q, &fine.q);
    let xpbd_to_fine = distance(&xpbd.q, &fine.q);
    let moved = distance(&fine.q, &start.q);
    eprintln!("moved {moved:.3e}; BE error {be_error:.3e}; xpbd to fine {xpbd_to_fine:.3e}");
    assert!(be_error > 1e-3 * moved, "the test needs a visible BE error");
    assert!(
        xpbd_to_fine < 0.2 * be_error,
        "xpbd is {xpbd_to_fine:.3e} from the fine solution (backward Euler: {be_error:.3e})"
    );
}

#[test]
fn xpbd_refuses_consistent_mass() {
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name("xpbd-neo-hookean", lame).unwrap();
    let mut spec = ModelSpec::elastic(box_mesh([2, 1, 1], [0.2, 0.1, 0.1]), material, 1000.0);
    spec.mass_kind = MassKind::Consistent;
    let model = Model::new(spec).unwrap();
    let err = Xpbd::new(XpbdSettings::default())
        .check_model(&model)
        .unwrap_err()
        .to_string();
    assert!(err.contains("lumped"), "{err}");
}
