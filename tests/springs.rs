//! Mass-spring bodies: the generators' topology (spring counts per kind against closed-form
//! formulas, the sphere's centre, poles and antipodes, the course bunny's 3521 edges), the
//! derivatives of a generated body through the Model, free fall, and every integrator on a
//! jello cube.

mod common;

use nalgebra::Vector3;
use softbench::integrate::{Method, State};
use softbench::model::{AxisRule, FixedSelection, HessianOptions, Model, Side};
use softbench::rng::Rng;
use softbench::springs::{
    JelloCube, JelloSphere, ParticleMass, SpringBody, SpringCoefficients, SpringKind, tet_edges,
};
use std::collections::HashSet;

/// Distinct stiffness per kind, so a test can tell which kind a spring got.
fn by_kind(kind: SpringKind) -> SpringCoefficients {
    let k = match kind {
        SpringKind::Structural => 1000.0,
        SpringKind::Shear => 700.0,
        SpringKind::Bending => 300.0,
        SpringKind::Radial => 500.0,
        SpringKind::Antipodal => 100.0,
        SpringKind::Edge => 1.0,
    };
    SpringCoefficients {
        stiffness: k,
        damping: k * 1e-3,
    }
}

fn cube(n: usize) -> SpringBody {
    JelloCube {
        n,
        size: 0.3,
        origin: Vector3::new(1.0, 2.0, 3.0),
    }
    .build(by_kind)
}

fn sphere(rings: usize, segments: usize) -> (JelloSphere, SpringBody) {
    let s = JelloSphere {
        rings,
        segments,
        radius: 0.4,
        center: Vector3::new(0.5, 1.0, -0.5),
    };
    (s, s.build(by_kind))
}

/// Every spring joins two different particles, no pair twice, and has the coefficients of its
/// kind and the rest length of its rest positions.
fn assert_well_formed(body: &SpringBody) {
    assert_eq!(body.springs.len(), body.kinds.len());
    let mut pairs = HashSet::new();
    for (s, kind) in body.springs.iter().zip(&body.kinds) {
        assert_ne!(s.i, s.j);
        assert!(
            pairs.insert((s.i.min(s.j), s.i.max(s.j))),
            "pair {} {} twice",
            s.i,
            s.j
        );
        assert_eq!(s.stiffness, by_kind(*kind).stiffness);
        assert_eq!(s.damping, by_kind(*kind).damping);
        let l = (body.positions[s.i] - body.positions[s.j]).norm();
        assert!((s.rest_length - l).abs() <= 1e-15 * l.max(1.0));
    }
}

#[test]
fn jello_cube_spring_counts_per_kind_match_the_lattice_formulas() {
    for n in 2..=5 {
        let body = cube(n);
        assert_well_formed(&body);
        assert_eq!(body.num_particles(), n * n * n);
        let m = n - 1;
        // Axis neighbours: n - 1 pairs on each of the n^2 lines along each of 3 axes.
        assert_eq!(body.count(SpringKind::Structural), 3 * n * n * m, "n = {n}");
        // Face diagonals: 3 plane families x n planes x (n-1)^2 squares x 2 diagonals;
        // space diagonals: 4 per cell.
        let face = 6 * n * m * m;
        let space = 4 * m * m * m;
        assert_eq!(body.count(SpringKind::Shear), face + space, "n = {n}");
        // Skip-one along the axes: n - 2 pairs per line.
        assert_eq!(
            body.count(SpringKind::Bending),
            3 * n * n * (n - 2),
            "n = {n}"
        );
        // Face and space diagonals told apart by rest length.
        let h = 0.3 / m as f64;
        let with_length = |kind, l: f64| {
            body.springs
                .iter()
                .zip(&body.kinds)
                .filter(|(s, k)| **k == kind && (s.rest_length - l).abs() < 1e-12)
                .count()
        };
        assert_eq!(with_length(SpringKind::Structural, h), 3 * n * n * m);
        assert_eq!(with_length(SpringKind::Shear, 2f64.sqrt() * h), face);
        assert_eq!(with_length(SpringKind::Shear, 3f64.sqrt() * h), space);
        assert_eq!(
            with_length(SpringKind::Bending, 2.0 * h),
            3 * n * n * (n - 2)
        );
    }
    // n = 2: every pair of the 8 corners is joined, 12 + 16 + 0 = 28 = C(8, 2).
    assert_eq!(cube(2).springs.len(), 28);
    // n = 4: 144 structural, 216 + 108 = 324 shear, 96 bending.
    let body = cube(4);
    assert_eq!(
        [
            SpringKind::Structural,
            SpringKind::Shear,
            SpringKind::Bending
        ]
        .map(|k| body.count(k)),
        [144, 324, 96]
    );
}

#[test]
fn jello_cube_particles_form_the_lattice_of_the_box_mesh() {
    let body = cube(3);
    let h = 0.15;
    for k in 0..3 {
        for j in 0..3 {
            for i in 0..3 {
                let p = body.positions[i + 3 * (j + 3 * k)];
                let expected =
                    Vector3::new(1.0, 2.0, 3.0) + Vector3::new(i as f64, j as f64, k as f64) * h;
                assert!((p - expected).norm() < 1e-12, "({i}, {j}, {k})");
            }
        }
    }
    // The display tets: 6 per cell, and every tet edge is a structural or shear spring.
    assert_eq!(body.tets.len(), 6 * 8);
    let springs: HashSet<(usize, usize)> = body
        .springs
        .iter()
        .map(|s| (s.i.min(s.j), s.i.max(s.j)))
        .collect();
    for t in &body.tets {
        for a in 0..4 {
            for b in a + 1..4 {
                assert!(springs.contains(&(t[a].min(t[b]), t[a].max(t[b]))));
            }
        }
    }
}

#[test]
fn jello_sphere_joins_the_centre_to_all_has_single_poles_and_antipodal_pairs() {
    for (rings, segs) in [(2, 6), (3, 8), (8, 12), (5, 10)] {
        let (s, body) = sphere(rings, segs);
        assert_well_formed(&body);
        let (r, n) = (rings, segs);
        assert_eq!(body.num_particles(), r * n + 3);
        let c = s.center;
        let centre = JelloSphere::CENTER;
        let (north, south) = (JelloSphere::NORTH_POLE, s.south_pole());
        assert_eq!(body.positions[centre], c);

        // Every other particle is on the sphere.
        for (v, p) in body.positions.iter().enumerate().skip(1) {
            assert!(((p - c).norm() - 0.4).abs() < 1e-12, "particle {v}");
        }
        // The poles are single particles on the y axis: no other particle is at a pole.
        assert!((body.positions[north] - (c + Vector3::y() * 0.4)).norm() < 1e-12);
        assert!((body.positions[south] - (c - Vector3::y() * 0.4)).norm() < 1e-12);
        for (v, p) in body.positions.iter().enumerate() {
            if v != north && v != south {
                assert!((p - body.positions[north]).norm() > 1e-6);
                assert!((p - body.positions[south]).norm() > 1e-6);
            }
        }

        // Radial: the centre joined to every other particle, and nothing else.
        let radial: Vec<_> = body
            .springs
            .iter()
            .zip(&body.kinds)
            .filter(|(_, k)| **k == SpringKind::Radial)
            .map(|(s, _)| s)
            .collect();
        assert_eq!(radial.len(), body.num_particles() - 1);
        let reached: HashSet<usize> = radial
            .iter()
            .map(|s| {
                assert_eq!(s.i, centre);
                s.j
            })
            .collect();
        assert_eq!(reached.len(), body.num_particles() - 1);
        assert!(
            body.springs
                .iter()
                .zip(&body.kinds)
                .all(|(s, k)| { *k == SpringKind::Radial || (s.i != centre && s.j != centre) })
        );

        // Antipodal: every particle but the centre in exactly one pair, with its mirror image
        // through the centre; the poles are a pair.
        let mut partner = vec![None; body.num_particles()];
        for (sp, k) in body.springs.iter().zip(&body.kinds) {
            if *k == SpringKind::Antipodal {
                assert!(partner[sp.i].replace(sp.j).is_none());
                assert!(partner[sp.j].replace(sp.i).is_none());
                let mirror = c * 2.0 - body.positions[sp.i];
                assert!((body.positions[sp.j] - mirror).norm() < 1e-12);
            }
        }
        assert_eq!(partner[north], Some(south));
        assert_eq!(partner[centre], None);
        assert!(partner.iter().skip(1).all(Option::is_some));

        // Counts per kind (module docs).
        assert_eq!(body.count(SpringKind::Antipodal), r * n / 2 + 1);
        assert_eq!(body.count(SpringKind::Structural), (2 * r + 1) * n);
        assert_eq!(body.count(SpringKind::Shear), 2 * (r - 1) * n);
        assert_eq!(body.count(SpringKind::Bending), 2 * r * n);

        // A pole's direct neighbours are the whole first (last) ring.
        let pole_structural = body
            .springs
            .iter()
            .zip(&body.kinds)
            .filter(|(sp, k)| **k == SpringKind::Structural && (sp.i == north || sp.j == north))
            .count();
        assert_eq!(pole_structural, n);
    }
}

#[test]
fn tet_edge_springs_are_the_unique_edges_of_the_mesh() {
    // One Kuhn-split cube: 12 cube edges, 6 face diagonals, 1 main diagonal.
    let mesh = softbench::mesh::box_mesh([1, 1, 1], [1.0, 1.0, 1.0]);
    let body = tet_edges(&mesh, SpringCoefficients::stiffness(5.0));
    assert_eq!(body.springs.len(), 19);
    assert_eq!(body.count(SpringKind::Edge), 19);
    assert!(body.springs.iter().all(|s| s.i < s.j && s.stiffness == 5.0));
    assert_eq!(body.tets, mesh.tets);
}

#[test]
fn tet_edge_springs_on_the_course_bunny_are_its_3521_unique_edges() {
    let Some(path) = common::reference_mesh("coarse_bunny.mesh") else {
        return;
    };
    let mesh = softbench::mesh::read_tet_mesh(&path).unwrap();
    let body = tet_edges(&mesh, SpringCoefficients::stiffness(1e5));
    assert_eq!(body.num_particles(), 699);
    assert_eq!(
        body.springs.len(),
        3521,
        "the meshes README: 3521 unique edges"
    );
    // The course model: unit particle masses, bottom fixed by the y-min rule, gravity.
    let mut spec = body.into_model_spec(ParticleMass::Each(1.0));
    spec.gravity = Some(Vector3::new(0.0, -9.8, 0.0));
    spec.fixed = FixedSelection {
        rules: vec![AxisRule {
            axis: 1,
            side: Side::Min,
            tolerance: 3.0,
        }],
        ..Default::default()
    };
    let model = Model::new(spec).unwrap();
    assert_eq!(model.vertex_masses().iter().sum::<f64>(), 699.0);
    assert!(model.num_dofs() < 3 * 699);
}

#[test]
fn particle_masses_are_given_each_or_split_evenly() {
    let body = cube(3);
    assert_eq!(body.point_masses(ParticleMass::Each(0.5)), vec![0.5; 27]);
    let split = body.point_masses(ParticleMass::Total(2.7));
    assert!(split.iter().all(|&m| (m - 0.1).abs() < 1e-15));
    let model = Model::new(body.into_model_spec(ParticleMass::Total(2.7))).unwrap();
    assert!((model.vertex_masses().iter().sum::<f64>() - 2.7).abs() < 1e-12);
}

fn relative_error(a: &[f64], b: &[f64]) -> f64 {
    let diff: f64 = a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum();
    let scale: f64 = b.iter().map(|y| y * y).sum();
    (diff / scale).sqrt()
}

/// Gradient and Hessian of `model` at `q` against central differences.
fn check_derivatives(model: &mut Model, q: &[f64], label: &str) {
    let n = q.len();
    let h = 1e-7;
    let mut g = vec![0.0; n];
    model.gradient(q, &mut g).unwrap();
    let mut qp = q.to_vec();
    let fd: Vec<f64> = (0..n)
        .map(|i| {
            qp[i] = q[i] + h;
            let ep = model.potential(&qp).unwrap();
            qp[i] = q[i] - h;
            let em = model.potential(&qp).unwrap();
            qp[i] = q[i];
            (ep - em) / (2.0 * h)
        })
        .collect();
    let err = relative_error(&g, &fd);
    assert!(err < 1e-6, "{label}: relative gradient error {err:.2e}");

    let mut hess = model.new_hessian();
    model
        .hessian(q, &mut hess, HessianOptions::default())
        .unwrap();
    let dense = hess.to_dense();
    assert!((&dense - dense.transpose()).norm() <= 1e-12 * dense.norm());
    let (mut gp, mut gm) = (vec![0.0; n], vec![0.0; n]);
    let mut err2 = 0.0;
    for j in 0..n {
        qp[j] = q[j] + h;
        model.gradient(&qp, &mut gp).unwrap();
        qp[j] = q[j] - h;
        model.gradient(&qp, &mut gm).unwrap();
        qp[j] = q[j];
        for i in 0..n {
            err2 += ((gp[i] - gm[i]) / (2.0 * h) - dense[(i, j)]).powi(2);
        }
    }
    let err = err2.sqrt() / dense.norm();
    assert!(err < 1e-6, "{label}: relative Hessian error {err:.2e}");
}

fn perturbed(model: &Model, amplitude: f64, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    model
        .rest_state()
        .iter()
        .map(|x| x + rng.range(-amplitude, amplitude))
        .collect()
}

#[test]
fn jello_bodies_gradient_and_hessian_match_finite_differences_through_the_model() {
    let (_, sphere_body) = sphere(3, 8);
    for (label, body) in [("cube", cube(3)), ("sphere", sphere_body)] {
        let mut spec = body.into_model_spec(ParticleMass::Total(1.0));
        spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
        spec.fixed = FixedSelection {
            indices: vec![0],
            ..Default::default()
        };
        let mut model = Model::new(spec).unwrap();
        let q = perturbed(&model, 0.03, 7);
        check_derivatives(&mut model, &q, label);
    }
}

/// A small jello cube: 3 × 3 × 3 particles, 0.2 m, 0.27 kg, stiffness 500/300/100 N/m.
fn jello_cube_model(damping: f64, gravity: bool) -> Model {
    let body = JelloCube {
        n: 3,
        size: 0.2,
        origin: Vector3::new(0.0, 1.0, 0.0),
    }
    .build(|kind| SpringCoefficients {
        stiffness: match kind {
            SpringKind::Structural => 500.0,
            SpringKind::Shear => 300.0,
            _ => 100.0,
        },
        damping,
    });
    let mut spec = body.into_model_spec(ParticleMass::Each(0.01));
    if gravity {
        spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
    }
    Model::new(spec).unwrap()
}

fn centre_of_mass(model: &Model, q: &[f64]) -> Vector3<f64> {
    let x = model.full_positions(q);
    let m = model.vertex_masses();
    let total: f64 = m.iter().sum();
    x.iter().zip(m).map(|(p, mi)| p * *mi).sum::<Vector3<f64>>() / total
}

#[test]
fn a_jello_cube_falls_freely_with_its_centre_of_mass_at_g_t2_over_2() {
    // Constant acceleration: methods of order >= 2 integrate it exactly, first-order ones
    // within g t dt.
    let dt = 0.001;
    let steps = 500;
    let t = dt * steps as f64;
    for (method, tolerance) in [
        (Method::from_name("rk4").unwrap(), 1e-10),
        (Method::from_name("midpoint").unwrap(), 1e-10),
        (Method::from_name("implicit-midpoint").unwrap(), 1e-9),
        (
            Method::from_name("symplectic-euler").unwrap(),
            9.81 * t * dt,
        ),
        (Method::from_name("backward-euler").unwrap(), 9.81 * t * dt),
    ] {
        let mut model = jello_cube_model(0.0, true);
        let start = State::at_rest(&model);
        let c0 = centre_of_mass(&model, &start.q);
        let end = common::bodies::integrate(&mut model, method, &start, t, steps);
        let c = centre_of_mass(&model, &end.q);
        let expected = c0 - Vector3::y() * (0.5 * 9.81 * t * t);
        assert!(
            (c - expected).norm() <= tolerance,
            "{method}: centre of mass {c:?}, expected {expected:?}"
        );
        // It falls as a rigid body: the springs stay at rest length.
        let springs = model.potential_parts(&end.q).unwrap().springs;
        assert!(springs < 1e-12, "{method}: spring energy {springs:e}");
    }
}

#[test]
fn every_integrator_runs_a_jello_cube_for_a_few_steps() {
    // Every time integrator (order 0 is the static solve: a free cube has no equilibrium).
    // XPBD has tet constraints only (no springs, no dashpots).
    for method in Method::all()
        .into_iter()
        .filter(|m| m.order() > 0 && m.name() != "xpbd")
    {
        let mut model = jello_cube_model(0.05, true);
        let mut start = State::at_rest(&model);
        // Squeeze it a little so the springs work.
        for (f, &v) in model.dofs().free_vertices().iter().enumerate() {
            start.v[3 * f] = 0.5 * (model.rest_positions()[v].x - 0.1);
        }
        let end = common::bodies::integrate(&mut model, method, &start, 0.005, 5);
        assert!(
            end.q.iter().chain(&end.v).all(|x| x.is_finite()),
            "{method}"
        );
        let drop = centre_of_mass(&model, &start.q).y - centre_of_mass(&model, &end.q).y;
        assert!(drop > 0.0, "{method}: the cube did not fall");
        assert!(
            model.potential_parts(&end.q).unwrap().springs > 0.0,
            "{method}"
        );
    }
}
