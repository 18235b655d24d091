//! Scripted drag: picking, the piecewise-linear path, derivatives against finite differences,
//! nothing after release, and that it moves the picked vertices towards their targets.

mod common;

use nalgebra::{Matrix3, Vector3};
use softbench::integrate::{IntegratorSettings, Method, State};
use softbench::model::{
    AxisRule, Drag, DragPath, FixedSelection, Model, ModelError, Side, VertexPotential, Waypoint,
};
use softbench::rng::Rng;
use softbench::springs::{JelloCube, ParticleMass, SpringCoefficients};

fn waypoint(t: f64, x: f64, y: f64, z: f64) -> Waypoint {
    Waypoint {
        t,
        offset: Vector3::new(x, y, z),
    }
}

fn path() -> DragPath {
    DragPath::new(vec![
        waypoint(0.1, 0.0, 0.0, 0.0),
        waypoint(0.5, 0.2, 0.0, 0.0),
        waypoint(0.7, 0.2, 0.1, -0.1),
    ])
    .unwrap()
}

#[test]
fn drag_path_is_piecewise_linear_and_holds_its_ends() {
    let p = path();
    assert_eq!(p.offset(-1.0), Vector3::zeros());
    assert_eq!(p.offset(0.1), Vector3::zeros());
    assert!((p.offset(0.3) - Vector3::new(0.1, 0.0, 0.0)).norm() < 1e-15);
    assert_eq!(p.offset(0.5), Vector3::new(0.2, 0.0, 0.0));
    assert!((p.offset(0.6) - Vector3::new(0.2, 0.05, -0.05)).norm() < 1e-15);
    assert_eq!(p.offset(0.7), Vector3::new(0.2, 0.1, -0.1));
    assert_eq!(p.offset(5.0), Vector3::new(0.2, 0.1, -0.1));
    let single = DragPath::new(vec![waypoint(0.0, 1.0, 2.0, 3.0)]).unwrap();
    assert_eq!(single.offset(-1.0), Vector3::new(1.0, 2.0, 3.0));
    assert_eq!(single.offset(1.0), Vector3::new(1.0, 2.0, 3.0));
}

#[test]
fn drag_paths_need_waypoints_with_increasing_finite_times() {
    let field = |r: Result<DragPath, ModelError>| match r {
        Err(ModelError::InvalidParameter { field, .. }) => field,
        other => panic!("expected an invalid parameter, got {other:?}"),
    };
    assert_eq!(field(DragPath::new(vec![])), "drag.path");
    assert_eq!(
        field(DragPath::new(vec![
            waypoint(0.0, 0.0, 0.0, 0.0),
            waypoint(0.0, 1.0, 0.0, 0.0)
        ])),
        "drag.path[1].t"
    );
    assert_eq!(
        field(DragPath::new(vec![waypoint(f64::NAN, 0.0, 0.0, 0.0)])),
        "drag.path[0]"
    );
}

fn grid() -> Vec<Vector3<f64>> {
    (0..27)
        .map(|v| Vector3::new((v % 3) as f64, ((v / 3) % 3) as f64, (v / 9) as f64))
        .collect()
}

#[test]
fn drag_picks_the_vertices_within_the_radius_or_else_the_nearest() {
    let x = grid();
    // Around vertex 13 = (1, 1, 1): itself and its 6 axis neighbours within 1.
    assert_eq!(
        Drag::pick(&x, &Vector3::new(1.0, 1.0, 1.0), 1.0),
        vec![4, 10, 12, 13, 14, 16, 22]
    );
    // Nothing within 0.1 of (2.4, 0.1, 0.0): the nearest, vertex 2 = (2, 0, 0).
    assert_eq!(Drag::pick(&x, &Vector3::new(2.4, 0.1, 0.0), 0.1), vec![2]);
    assert_eq!(Drag::pick(&x, &Vector3::new(9.0, 9.0, 9.0), 0.0), vec![26]);
    assert!(Drag::pick(&[], &Vector3::zeros(), 1.0).is_empty());
}

fn drag_on_grid(release: Option<f64>) -> Drag {
    let x = grid();
    let picked = Drag::pick(&x, &Vector3::new(2.0, 2.0, 2.0), 1.0);
    Drag::new(&x, picked, 40.0, path(), release).unwrap()
}

fn perturbed(x: &[Vector3<f64>], seed: u64) -> Vec<Vector3<f64>> {
    let mut rng = Rng::new(seed);
    x.iter()
        .map(|p| p + Vector3::from_fn(|_, _| rng.range(-0.2, 0.2)))
        .collect()
}

#[test]
fn drag_gradient_and_hessian_match_finite_differences() {
    let drag = drag_on_grid(Some(1.0));
    assert_eq!(drag.vertices(), &[17, 23, 25, 26]);
    let x = perturbed(&grid(), 3);
    for t in [0.0, 0.3, 0.55, 0.9] {
        let mut g = vec![Vector3::zeros(); x.len()];
        drag.gradient(t, &x, &mut |v, gv| g[v] += gv);
        let mut h = vec![Matrix3::zeros(); x.len()];
        drag.hessian(t, &x, false, &mut |v, hv| h[v] += hv);
        let step = 1e-6;
        for v in 0..x.len() {
            for i in 0..3 {
                let mut xp = x.clone();
                xp[v][i] += step;
                let mut xm = x.clone();
                xm[v][i] -= step;
                let fd = (drag.energy(t, &xp) - drag.energy(t, &xm)) / (2.0 * step);
                assert!((fd - g[v][i]).abs() < 1e-6, "t = {t}: gradient {v}.{i}");
                let mut gp = Vector3::zeros();
                drag.gradient(t, &xp, &mut |w, gw| {
                    if w == v {
                        gp += gw
                    }
                });
                let mut gm = Vector3::zeros();
                drag.gradient(t, &xm, &mut |w, gw| {
                    if w == v {
                        gm += gw
                    }
                });
                let column = (gp - gm) / (2.0 * step);
                assert!(
                    (column - h[v].column(i)).norm() < 1e-6,
                    "t = {t}: Hessian {v}.{i}"
                );
            }
        }
        // The Hessian is k I on the picked vertices.
        for &v in drag.vertices() {
            assert_eq!(h[v], Matrix3::identity() * 40.0);
        }
    }
}

#[test]
fn after_release_the_drag_contributes_nothing() {
    let drag = drag_on_grid(Some(0.6));
    let x = perturbed(&grid(), 5);
    assert!(drag.is_active(0.59) && drag.energy(0.59, &x) > 0.0);
    for t in [0.6, 0.7, 10.0] {
        assert!(!drag.is_active(t));
        assert_eq!(drag.energy(t, &x), 0.0);
        drag.gradient(t, &x, &mut |v, _| panic!("gradient at {t} for vertex {v}"));
        drag.hessian(t, &x, true, &mut |v, _| {
            panic!("Hessian at {t} for vertex {v}")
        });
    }
    // Never released without a release time.
    assert!(drag_on_grid(None).is_active(1e9));
}

#[test]
fn bad_drags_are_errors_naming_the_field() {
    let x = grid();
    let field = |r: Result<Drag, ModelError>| match r {
        Err(ModelError::InvalidParameter { field, .. }) => field,
        other => panic!("expected an invalid parameter, got {other:?}"),
    };
    assert_eq!(
        field(Drag::new(&x, vec![], 1.0, path(), None)),
        "drag.vertices"
    );
    assert_eq!(
        field(Drag::new(&x, vec![27], 1.0, path(), None)),
        "drag.vertices"
    );
    assert_eq!(
        field(Drag::new(&x, vec![0], -1.0, path(), None)),
        "drag.stiffness"
    );
}

/// A 4 × 4 × 4 jello cube (0.3 m, 64 g) under gravity, its bottom face fixed, with a drag on
/// its top corner at (0.3, 0.3, 0.3) that moves 0.1 m along +x over 0.2 s.
///
/// (Gravity also keeps Newton well-posed once the cube is back at rest: without it every
/// energy term is near zero there, and the line search chases round-off.)
fn dragged_cube(release: Option<f64>) -> (Model, Vec<usize>) {
    let body = JelloCube {
        n: 4,
        size: 0.3,
        origin: Vector3::zeros(),
    }
    .build(|_| SpringCoefficients::stiffness(200.0));
    let mut spec = body.into_model_spec(ParticleMass::Each(0.001));
    spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
    spec.fixed = FixedSelection {
        rules: vec![AxisRule {
            axis: 1,
            side: Side::Min,
            tolerance: 1e-9,
        }],
        ..Default::default()
    };
    let mut model = Model::new(spec).unwrap();
    let rest = model.rest_positions().to_vec();
    let picked = Drag::pick(&rest, &Vector3::new(0.3, 0.3, 0.3), 0.11);
    let path = DragPath::new(vec![
        waypoint(0.0, 0.0, 0.0, 0.0),
        waypoint(0.2, 0.1, 0.0, 0.0),
    ])
    .unwrap();
    let drag = Drag::new(&rest, picked.clone(), 1000.0, path, release).unwrap();
    model.add_vertex_potential(Box::new(drag));
    (model, picked)
}

#[test]
fn drag_enters_the_model_gradient_and_hessian() {
    let (mut model, picked) = dragged_cube(None);
    assert_eq!(
        picked.len(),
        4,
        "the corner and its 3 neighbours: {picked:?}"
    );
    model.set_time(0.1);
    let mut rng = Rng::new(9);
    let q: Vec<f64> = model
        .rest_state()
        .iter()
        .map(|x| x + rng.range(-0.02, 0.02))
        .collect();
    let parts = model.potential_parts(&q).unwrap();
    assert!(parts.vertex > 0.0);
    let mut g = vec![0.0; q.len()];
    model.gradient(&q, &mut g).unwrap();
    let h = 1e-7;
    let mut qp = q.clone();
    for i in 0..q.len() {
        qp[i] = q[i] + h;
        let ep = model.potential(&qp).unwrap();
        qp[i] = q[i] - h;
        let em = model.potential(&qp).unwrap();
        qp[i] = q[i];
        let fd = (ep - em) / (2.0 * h);
        assert!((fd - g[i]).abs() < 1e-6 * (1.0 + g[i].abs()), "dof {i}");
    }
}

#[test]
fn drag_moves_the_picked_vertices_towards_their_targets() {
    let (mut model, picked) = dragged_cube(Some(0.8));
    let start = State::at_rest(&model);
    let rest = model.rest_positions().to_vec();
    let mean_dx = |model: &Model, state: &State, vertices: &[usize]| {
        let x = model.full_positions(&state.q);
        vertices.iter().map(|&v| x[v].x - rest[v].x).sum::<f64>() / vertices.len() as f64
    };
    // Held from t = 0.2 to 0.6: the picked vertices settle most of the way to their targets,
    // 0.1 m along +x (springs of the body pull back, so not all the way).
    let held = common::bodies::integrate(
        &mut model,
        Method::from_name("backward-euler").unwrap(),
        &start,
        0.6,
        60,
    );
    let dx = mean_dx(&model, &held, &picked);
    assert!(dx > 0.05 && dx < 0.1, "picked vertices moved {dx} m");
    // The bottom stays; the vertices far from the drag move less.
    let far: Vec<usize> = (0..rest.len())
        .filter(|&v| rest[v].y > 0.0 && rest[v].x < 0.05 && !model.dofs().is_fixed(v))
        .collect();
    assert!(mean_dx(&model, &held, &far) < dx / 2.0);
    // After the release at 0.8 s the body swings back towards rest (backward Euler damps it;
    // default Newton settings, which need not converge tightly in the step of the release).
    let mut integ = IntegratorSettings {
        method: Method::from_name("backward-euler").unwrap(),
        ..Default::default()
    }
    .build();
    let mut state = held;
    for _ in 0..140 {
        integ.step(&mut model, &mut state, 0.01).unwrap();
    }
    assert!(state.t > 1.9);
    let back = mean_dx(&model, &state, &picked);
    assert!(
        back.abs() < dx / 4.0,
        "after release the picked vertices are at {back}"
    );
    model.set_time(state.t);
    assert_eq!(model.potential_parts(&state.q).unwrap().vertex, 0.0);
}
