//! The assembled model: gradient and Hessian against finite differences, symmetry, the patch
//! test, rigid motions, mass totals, fixed-vertex elimination and determinism.

use nalgebra::{Matrix3, Rotation3, Vector3};
use softbench::material::{LameParameters, MaterialModel, NeoHookean};
use softbench::mesh::generate::box_mesh;
use softbench::model::{
    AxisRule, FixedSelection, HessianOptions, InvertedTets, MassKind, Model, ModelError, ModelSpec,
    Side, Spring,
};
use softbench::parallel::Parallelism;
use softbench::rng::Rng;

mod common;

fn neo_hookean() -> MaterialModel {
    MaterialModel::NeoHookean(NeoHookean::new(
        LameParameters::from_youngs_poisson(1e5, 0.4).unwrap(),
    ))
}

/// A 2×2×3 box with the bottom fixed, gravity, and a few springs (rest length 0 and > 0).
fn test_model(par: Parallelism) -> Model {
    test_model_with(par, neo_hookean())
}

fn every_material() -> Vec<MaterialModel> {
    let lame = LameParameters::from_youngs_poisson(1e5, 0.4).unwrap();
    MaterialModel::NAMES
        .iter()
        .map(|name| MaterialModel::from_name(name, lame).unwrap())
        .collect()
}

fn test_model_with(par: Parallelism, material: MaterialModel) -> Model {
    let mesh = box_mesh([2, 2, 3], [0.2, 0.2, 0.3]);
    let mut spec = ModelSpec::elastic(mesh, material, 1000.0);
    spec.gravity = Some(Vector3::new(0.0, 0.0, -9.81));
    spec.fixed = FixedSelection {
        rules: vec![AxisRule {
            axis: 2,
            side: Side::Min,
            tolerance: 1e-9,
        }],
        ..Default::default()
    };
    spec.springs = vec![
        Spring {
            i: 0,
            j: 35,
            rest_length: 0.1,
            stiffness: 5e3,
            damping: 0.0,
        },
        Spring {
            i: 20,
            j: 33,
            rest_length: 0.0,
            stiffness: 2e3,
            damping: 0.0,
        },
    ];
    spec.parallelism = par;
    Model::new(spec).unwrap()
}

fn perturbed_state(model: &Model, amplitude: f64, seed: u64) -> Vec<f64> {
    let mut rng = Rng::new(seed);
    model
        .rest_state()
        .iter()
        .map(|x| x + rng.range(-amplitude, amplitude))
        .collect()
}

fn relative_error(a: &[f64], b: &[f64]) -> f64 {
    let diff: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt();
    let scale: f64 = b.iter().map(|y| y * y).sum::<f64>().sqrt();
    diff / scale
}

#[test]
fn assembled_gradient_matches_finite_differences() {
    for material in every_material() {
        assembled_gradient_matches_finite_differences_for(material);
    }
}

fn assembled_gradient_matches_finite_differences_for(material: MaterialModel) {
    let mut model = test_model_with(Parallelism::Rayon, material);
    let q = perturbed_state(&model, 0.01, 1);
    check_gradient(&mut model, &q, material.name());
}

fn check_gradient(model: &mut Model, q: &[f64], label: &str) {
    let q = q.to_vec();
    let mut g = vec![0.0; model.num_dofs()];
    model.gradient(&q, &mut g).unwrap();
    let h = 1e-7;
    let fd: Vec<f64> = (0..q.len())
        .map(|i| {
            let mut qp = q.clone();
            qp[i] += h;
            let ep = model.potential(&qp).unwrap();
            qp[i] -= 2.0 * h;
            let em = model.potential(&qp).unwrap();
            (ep - em) / (2.0 * h)
        })
        .collect();
    let err = relative_error(&g, &fd);
    assert!(err < 1e-6, "{label}: relative gradient error {err:.2e}");
}

#[test]
fn assembled_hessian_matches_finite_differences_and_is_symmetric() {
    for material in every_material() {
        assembled_hessian_matches_finite_differences_for(material);
    }
}

fn assembled_hessian_matches_finite_differences_for(material: MaterialModel) {
    let mut model = test_model_with(Parallelism::Rayon, material);
    let q = perturbed_state(&model, 0.01, 2);
    check_hessian(&mut model, &q, material.name());
}

fn check_hessian(model: &mut Model, q: &[f64], label: &str) {
    let q = q.to_vec();
    let mut hess = model.new_hessian();
    model
        .hessian(&q, &mut hess, HessianOptions::default())
        .unwrap();
    let dense = hess.to_dense();
    assert!(
        (&dense - dense.transpose()).norm() <= 1e-12 * dense.norm(),
        "Hessian not symmetric"
    );
    let n = q.len();
    let h = 1e-7;
    let (mut gp, mut gm) = (vec![0.0; n], vec![0.0; n]);
    let mut err2 = 0.0;
    for j in 0..n {
        let mut qp = q.clone();
        qp[j] += h;
        model.gradient(&qp, &mut gp).unwrap();
        qp[j] -= 2.0 * h;
        model.gradient(&qp, &mut gm).unwrap();
        for i in 0..n {
            let fd = (gp[i] - gm[i]) / (2.0 * h);
            err2 += (fd - dense[(i, j)]).powi(2);
        }
    }
    let err = err2.sqrt() / dense.norm();
    assert!(err < 1e-6, "{label}: relative Hessian error {err:.2e}");
}

#[test]
fn patch_test_affine_deformation_leaves_interior_nodes_force_free() {
    let mesh = box_mesh([3, 3, 3], [1.0, 1.0, 1.0]);
    let interior: Vec<usize> = (0..mesh.num_vertices())
        .filter(|&v| {
            mesh.positions[v]
                .iter()
                .all(|&c| c > 1e-9 && c < 1.0 - 1e-9)
        })
        .collect();
    assert_eq!(interior.len(), 8);
    let mut model = Model::new(ModelSpec::elastic(mesh, neo_hookean(), 1000.0)).unwrap();
    let a = Matrix3::new(1.1, 0.05, -0.02, 0.03, 0.95, 0.04, -0.01, 0.02, 1.05);
    let x: Vec<Vector3<f64>> = model
        .rest_positions()
        .iter()
        .map(|p| a * p + Vector3::new(0.3, -0.1, 0.2))
        .collect();
    let mut q = vec![0.0; model.num_dofs()];
    model.dofs().gather(&x, &mut q);
    let mut g = vec![0.0; q.len()];
    model.gradient(&q, &mut g).unwrap();
    let scale = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 1.0, "the affine deformation must load the boundary");
    for v in interior {
        let f = model.dofs().free_index(v) as usize;
        let force = Vector3::new(g[3 * f], g[3 * f + 1], g[3 * f + 2]).norm();
        assert!(
            force <= 1e-10 * scale,
            "interior vertex {v} has force {force:.2e} (boundary scale {scale:.2e})"
        );
    }
}

#[test]
fn rigid_motions_have_zero_energy_and_force() {
    let mut model = Model::new(ModelSpec::elastic(
        box_mesh([2, 3, 2], [0.5, 0.7, 0.4]),
        neo_hookean(),
        10.0,
    ))
    .unwrap();
    let r = Rotation3::from_euler_angles(0.7, -1.1, 2.3);
    let x: Vec<Vector3<f64>> = model
        .rest_positions()
        .iter()
        .map(|p| r * p + Vector3::new(1.0, 2.0, -3.0))
        .collect();
    let mut q = vec![0.0; model.num_dofs()];
    model.dofs().gather(&x, &mut q);
    let energy = model.potential(&q).unwrap();
    let mut g = vec![0.0; q.len()];
    model.gradient(&q, &mut g).unwrap();
    // Scale: what a 1% stretch would give.
    let e_scale = 1e5 * 0.01f64.powi(2) * 0.5 * 0.7 * 0.4;
    assert!(
        energy.abs() < 1e-10 * e_scale,
        "rigid motion energy {energy:.3e}"
    );
    let gmax = g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(
        gmax < 1e-9 * 1e5 * 0.01 * 0.04,
        "rigid motion force {gmax:.3e}"
    );
}

#[test]
fn total_mass_equals_density_times_volume_for_both_mass_kinds() {
    let mesh = box_mesh([3, 2, 2], [0.3, 0.2, 0.25]);
    let volume = mesh.total_volume();
    assert!((volume - 0.3 * 0.2 * 0.25).abs() < 1e-15);
    for kind in [MassKind::Consistent, MassKind::Lumped] {
        let mut spec = ModelSpec::elastic(mesh.clone(), neo_hookean(), 1200.0);
        spec.mass_kind = kind;
        let model = Model::new(spec).unwrap();
        let vertex_total: f64 = model.vertex_masses().iter().sum();
        let ones = vec![1.0; model.num_dofs()];
        let mut m1 = vec![0.0; model.num_dofs()];
        model.mass().mul_vec(&ones, &mut m1);
        let matrix_total: f64 = m1.iter().sum::<f64>() / 3.0;
        for total in [vertex_total, matrix_total] {
            assert!(
                (total - 1200.0 * volume).abs() < 1e-12 * total,
                "{kind:?}: {total} vs {}",
                1200.0 * volume
            );
        }
    }
}

#[test]
fn consistent_mass_is_symmetric_positive_definite() {
    let model = Model::new(ModelSpec::elastic(
        box_mesh([2, 2, 2], [1.0, 1.0, 1.0]),
        neo_hookean(),
        1.0,
    ))
    .unwrap();
    let softbench::model::MassMatrix::Consistent(m) = model.mass() else {
        panic!("expected consistent mass")
    };
    let d = m.to_dense();
    assert_eq!(d, d.transpose());
    assert!(d.cholesky().is_some());
}

#[test]
fn fixed_vertices_are_eliminated_not_penalized() {
    let mesh = box_mesh([2, 2, 2], [1.0, 1.0, 1.0]);
    let fixed = FixedSelection {
        indices: vec![0, 5],
        ..Default::default()
    };
    let mut free_spec = ModelSpec::elastic(mesh.clone(), neo_hookean(), 10.0);
    free_spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
    let mut fixed_spec = free_spec.clone();
    fixed_spec.fixed = fixed;
    let mut full = Model::new(free_spec).unwrap();
    let mut reduced = Model::new(fixed_spec).unwrap();
    assert_eq!(reduced.num_dofs(), full.num_dofs() - 6);
    let q_full = perturbed_state(&full, 0.02, 3);
    // The reduced state: same positions, vertices 0 and 5 at rest.
    let mut x = full.full_positions(&q_full);
    x[0] = mesh.positions[0];
    x[5] = mesh.positions[5];
    let mut q_full = vec![0.0; full.num_dofs()];
    full.dofs().gather(&x, &mut q_full);
    let mut q_red = vec![0.0; reduced.num_dofs()];
    reduced.dofs().gather(&x, &mut q_red);
    assert_eq!(
        full.potential(&q_full).unwrap(),
        reduced.potential(&q_red).unwrap()
    );
    let (mut g_full, mut g_red) = (vec![0.0; full.num_dofs()], vec![0.0; reduced.num_dofs()]);
    full.gradient(&q_full, &mut g_full).unwrap();
    reduced.gradient(&q_red, &mut g_red).unwrap();
    for (f, &v) in reduced.dofs().free_vertices().iter().enumerate() {
        for i in 0..3 {
            assert_eq!(g_red[3 * f + i], g_full[3 * v + i]);
        }
    }
}

#[test]
fn parallel_and_sequential_assembly_are_bitwise_identical() {
    // Large enough that the parallel split really happens (many chunks and columns).
    let mesh = box_mesh([10, 8, 8], [1.0, 0.8, 0.8]);
    let build = |par| {
        let mut spec = ModelSpec::elastic(mesh.clone(), neo_hookean(), 100.0);
        spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
        spec.parallelism = par;
        Model::new(spec).unwrap()
    };
    let mut seq = build(Parallelism::Sequential);
    let mut par = build(Parallelism::Rayon);
    let q = perturbed_state(&seq, 0.01, 4);
    let mut outputs = Vec::new();
    for model in [&mut seq, &mut par] {
        let e = model.potential(&q).unwrap();
        let mut g = vec![0.0; q.len()];
        model.gradient(&q, &mut g).unwrap();
        let mut h = model.new_hessian();
        model
            .hessian(&q, &mut h, HessianOptions::default())
            .unwrap();
        outputs.push((
            e.to_bits(),
            g.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            h.values().iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        ));
    }
    assert!(
        outputs[0] == outputs[1],
        "sequential and parallel results differ"
    );
}

#[test]
fn projected_hessian_is_positive_semidefinite_under_compression() {
    let mut model = test_model(Parallelism::Rayon);
    // Squash every free vertex towards the fixed base to get indefinite element Hessians.
    let q: Vec<f64> = model
        .rest_state()
        .iter()
        .enumerate()
        .map(|(i, x)| if i % 3 == 2 { x * 0.6 } else { *x })
        .collect();
    let mut h = model.new_hessian();
    model
        .hessian(&q, &mut h, HessianOptions::default())
        .unwrap();
    let raw_min = h.to_dense().symmetric_eigenvalues().min();
    model
        .hessian(&q, &mut h, HessianOptions::projected())
        .unwrap();
    let projected_min = h.to_dense().symmetric_eigenvalues().min();
    let scale = h.to_dense().norm();
    assert!(
        raw_min < 0.0,
        "the test state should be indefinite without projection ({raw_min:.3e})"
    );
    assert!(
        projected_min >= -1e-10 * scale,
        "projected Hessian has eigenvalue {projected_min:.3e}"
    );
}

#[test]
fn inverted_rest_tets_are_refused_with_their_indices_or_reoriented() {
    let mut mesh = box_mesh([2, 1, 1], [1.0, 1.0, 1.0]);
    mesh.tets[3].swap(0, 1);
    mesh.tets[7].swap(1, 2);
    let err = Model::new(ModelSpec::elastic(mesh.clone(), neo_hookean(), 1.0)).unwrap_err();
    match &err {
        ModelError::InvertedTets { count, first } => {
            assert_eq!(*count, 2);
            assert_eq!(first, &vec![3, 7]);
        }
        other => panic!("expected InvertedTets, got {other}"),
    }
    assert!(err.to_string().contains("[3, 7]"), "{err}");
    let mut spec = ModelSpec::elastic(mesh, neo_hookean(), 1.0);
    spec.inverted_tets = InvertedTets::Reorient;
    let mut model = Model::new(spec).unwrap();
    let q = model.rest_state();
    assert!(model.potential(&q).unwrap().abs() < 1e-9);
}

#[test]
fn inverting_an_element_of_the_course_model_is_an_error_naming_the_tet() {
    let mesh = box_mesh([1, 1, 1], [1.0, 1.0, 1.0]);
    let mut model = Model::new(ModelSpec::elastic(mesh, neo_hookean(), 1.0)).unwrap();
    let mut q = model.rest_state();
    // Push vertex 7 (the far corner) through the opposite corner: inverts tets that contain it.
    q[3 * 7] = -1.0;
    q[3 * 7 + 1] = -1.0;
    q[3 * 7 + 2] = -1.0;
    let err = model.potential(&q).unwrap_err();
    assert!(matches!(err, ModelError::InvertedElement { .. }), "{err}");
    let mut g = vec![0.0; q.len()];
    assert!(matches!(
        model.gradient(&q, &mut g).unwrap_err(),
        ModelError::InvertedElement { .. }
    ));
}

#[test]
fn bad_parameters_are_errors_naming_the_field() {
    let mesh = box_mesh([1, 1, 1], [1.0, 1.0, 1.0]);
    let err = Model::new(ModelSpec::elastic(mesh.clone(), neo_hookean(), -1.0)).unwrap_err();
    assert!(err.to_string().contains("density"), "{err}");
    let mut spec = ModelSpec::elastic(mesh.clone(), neo_hookean(), 1.0);
    spec.fixed.indices = vec![99];
    assert!(Model::new(spec).unwrap_err().to_string().contains("99"));
    let mut spec = ModelSpec::elastic(mesh, neo_hookean(), 1.0);
    spec.springs = vec![Spring {
        i: 0,
        j: 0,
        rest_length: 1.0,
        stiffness: 1.0,
        damping: 0.0,
    }];
    assert!(matches!(
        Model::new(spec).unwrap_err(),
        ModelError::InvalidSpring { .. }
    ));
}

#[test]
fn evaluations_are_counted_by_kind() {
    let mut model = test_model(Parallelism::Sequential);
    let q = model.rest_state();
    let mut g = vec![0.0; q.len()];
    model.potential(&q).unwrap();
    model.gradient(&q, &mut g).unwrap();
    model.gradient(&q, &mut g).unwrap();
    let c = model.counters();
    assert_eq!((c.potential, c.gradient, c.hessian), (1, 2, 0));
}

/// The course armadillo with its parameters (E = 6e5, nu = 0.4, density 0.1, vertices within
/// 0.1 of the lowest y fixed) and gravity.
fn armadillo_model(material: MaterialModel) -> Option<Model> {
    let path = common::reference_mesh("arma_6.node")?;
    let mesh = softbench::mesh::read_tet_mesh(path).unwrap();
    let mut spec = ModelSpec::elastic(mesh, material, 0.1);
    spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
    spec.fixed = FixedSelection {
        rules: vec![AxisRule {
            axis: 1,
            side: Side::Min,
            tolerance: 0.1,
        }],
        ..Default::default()
    };
    Some(Model::new(spec).unwrap())
}

#[test]
fn armadillo_gradient_and_hessian_match_finite_differences() {
    let lame = LameParameters::from_youngs_poisson(6e5, 0.4).unwrap();
    for name in MaterialModel::NAMES {
        let material = MaterialModel::from_name(name, lame).unwrap();
        let Some(mut model) = armadillo_model(material) else {
            return;
        };
        assert!(
            model.num_dofs() < 3 * 259,
            "the course rule fixes some vertices"
        );
        // Perturb by 0.1% of the armadillo's size so every element is strained.
        let q = perturbed_state(&model, 1e-3, 11);
        check_gradient(&mut model, &q, &format!("arma_6 {name}"));
        check_hessian(&mut model, &q, &format!("arma_6 {name}"));
    }
}

#[test]
fn vertex_potentials_enter_the_gradient_and_hessian() {
    let mut model = test_model(Parallelism::Rayon);
    let center = model.rest_positions()[30];
    model.add_vertex_potential(Box::new(common::bodies::MovingAnchor {
        vertex: 30,
        stiffness: 3e3,
        center,
        radius: 0.05,
        angular_speed: 2.0,
    }));
    model.set_time(0.3);
    let q = perturbed_state(&model, 0.01, 21);
    check_gradient(&mut model, &q, "with anchor");
    check_hessian(&mut model, &q, "with anchor");
    assert!(model.potential_parts(&q).unwrap().vertex > 0.0);
}
