//! `Model::element_measures`: per-tet det F and elastic energy, as written to VTU frames.

use nalgebra::{Matrix3, Vector3};
use softbench::material::{LameParameters, MaterialModel, StableNeoHookean};
use softbench::mesh::generate::box_mesh;
use softbench::model::{AxisRule, FixedSelection, Model, ModelError, ModelSpec, Side};
use softbench::rng::Rng;

fn material() -> MaterialModel {
    MaterialModel::StableNeoHookean(StableNeoHookean::new(
        LameParameters::from_youngs_poisson(1e5, 0.3).unwrap(),
    ))
}

#[test]
fn element_energies_sum_to_the_elastic_energy_and_det_f_is_the_volume_ratio() {
    let mesh = box_mesh([3, 2, 2], [0.3, 0.2, 0.2]);
    let mut spec = ModelSpec::elastic(mesh.clone(), material(), 1000.0);
    spec.fixed = FixedSelection {
        rules: vec![AxisRule {
            axis: 0,
            side: Side::Min,
            tolerance: 1e-9,
        }],
        ..Default::default()
    };
    let mut model = Model::new(spec).unwrap();
    let mut rng = Rng::new(3);
    let q: Vec<f64> = model
        .rest_state()
        .iter()
        .map(|x| x + rng.range(-0.01, 0.01))
        .collect();
    let m = model.tets().len();
    assert_eq!(model.tets(), mesh.tets.as_slice());
    let (mut det_f, mut energy) = (vec![0.0; m], vec![0.0; m]);
    model.element_measures(&q, &mut det_f, &mut energy).unwrap();
    let elastic = model.potential_parts(&q).unwrap().elastic;
    let sum: f64 = energy.iter().sum();
    assert!(
        elastic > 0.0 && (sum - elastic).abs() <= 1e-12 * elastic,
        "{sum} vs {elastic}"
    );
    let x = model.full_positions(&q);
    let deformed = softbench::mesh::TetMesh {
        positions: x,
        tets: mesh.tets.clone(),
    };
    for (e, j) in det_f.iter().enumerate() {
        let ratio = deformed.signed_volume6(e) / mesh.signed_volume6(e);
        assert!((j - ratio).abs() < 1e-12, "tet {e}: {j} vs {ratio}");
    }
}

#[test]
fn element_measures_of_a_uniform_deformation_are_uniform() {
    let mesh = box_mesh([2, 2, 2], [1.0, 1.0, 1.0]);
    let model = Model::new(ModelSpec::elastic(mesh.clone(), material(), 1000.0)).unwrap();
    let a = Matrix3::new(1.1, 0.05, 0.0, 0.0, 0.95, 0.02, 0.01, 0.0, 1.2);
    let b = Vector3::new(0.3, -0.1, 2.0);
    let q: Vec<f64> = mesh
        .positions
        .iter()
        .flat_map(|p| {
            let y = a * p + b;
            [y.x, y.y, y.z]
        })
        .collect();
    let m = mesh.num_tets();
    let (mut det_f, mut energy) = (vec![0.0; m], vec![0.0; m]);
    model.element_measures(&q, &mut det_f, &mut energy).unwrap();
    let psi = material().energy_density(&a).unwrap();
    for (e, (j, energy)) in det_f.iter().zip(&energy).enumerate() {
        assert!((j - a.determinant()).abs() < 1e-12);
        let expected = mesh.signed_volume(e) * psi;
        assert!((energy - expected).abs() <= 1e-12 * expected, "tet {e}");
    }
}

#[test]
fn element_measures_refuse_a_state_of_the_wrong_length() {
    let model = Model::new(ModelSpec::elastic(
        box_mesh([1, 1, 1], [1.0, 1.0, 1.0]),
        material(),
        1000.0,
    ))
    .unwrap();
    let m = model.tets().len();
    let (mut det_f, mut energy) = (vec![0.0; m], vec![0.0; m]);
    let err = model.element_measures(&[0.0; 5], &mut det_f, &mut energy);
    assert!(
        matches!(err, Err(ModelError::StateLength { got: 5, .. })),
        "{err:?}"
    );
}

/// `inverted_elements` counts the tets whose det F (as `element_measures` gives it) is <= 0:
/// none at rest, and every tet of a free vertex pushed through its neighbours' faces.
#[test]
fn inverted_elements_counts_the_tets_with_nonpositive_det_f() {
    let model = Model::new(ModelSpec::elastic(
        box_mesh([2, 2, 2], [0.2, 0.2, 0.2]),
        material(),
        1000.0,
    ))
    .unwrap();
    let rest = model.rest_state();
    assert_eq!(model.inverted_elements(&rest).unwrap(), 0);
    // The centre vertex (0.1, 0.1, 0.1) moved far out through one side: the tets around it
    // on that side invert.
    let centre = (0..rest.len() / 3)
        .find(|&v| (0..3).all(|k| (rest[3 * v + k] - 0.1).abs() < 1e-12))
        .expect("a centre vertex");
    let mut q = rest.clone();
    q[3 * centre] += 0.25;
    let m = model.tets().len();
    let (mut det_f, mut energy) = (vec![0.0; m], vec![0.0; m]);
    model.element_measures(&q, &mut det_f, &mut energy).unwrap();
    let expected = det_f.iter().filter(|j| **j <= 0.0).count();
    assert!(expected > 0 && expected < m, "{expected} of {m}");
    assert_eq!(model.inverted_elements(&q).unwrap(), expected);
    assert!(matches!(
        model.inverted_elements(&q[1..]),
        Err(ModelError::StateLength { .. })
    ));
}
