//! nalgebra-sparse interop: the model's Hessian, mass and damping matrices exported as
//! `nalgebra_sparse::CscMatrix` hold exactly the entries of the dense matrices.

use nalgebra::{DMatrix, Vector3};
use nalgebra_sparse::CscMatrix;
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::generate::box_mesh;
use softbench::model::{
    AxisRule, Damping, FixedSelection, HessianOptions, MassKind, Model, ModelSpec, Side,
};

/// A clamped, damped 3×2×2 block of Stable Neo-Hookean rubber.
fn damped_block(mass: MassKind) -> Model {
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
    let mut spec = ModelSpec::elastic(box_mesh([3, 2, 2], [0.3, 0.2, 0.2]), material, 1000.0);
    spec.mass_kind = mass;
    spec.fixed = FixedSelection {
        rules: vec![AxisRule {
            axis: 0,
            side: Side::Min,
            tolerance: 1e-9,
        }],
        ..Default::default()
    };
    spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
    spec.damping = Damping {
        rayleigh: Some((0.3, 0.02)),
        strain_rate: Some((0.5, 1.5)),
    };
    Model::new(spec).unwrap()
}

/// A deformed configuration (every free DOF moved).
fn deformed(model: &Model) -> Vec<f64> {
    model
        .rest_state()
        .iter()
        .enumerate()
        .map(|(i, x)| x + 0.01 * (i as f64 * 0.37).sin())
        .collect()
}

/// Every entry of `csc` equals `dense` exactly, and `csc` stores no entry outside the
/// pattern's both triangles.
fn assert_same(csc: &CscMatrix<f64>, dense: &DMatrix<f64>, what: &str) {
    assert_eq!((csc.nrows(), csc.ncols()), dense.shape(), "{what}");
    let back = DMatrix::from(csc);
    assert_eq!(&back, dense, "{what}");
    assert!(
        dense.iter().any(|&x| x != 0.0),
        "{what}: compared a zero matrix"
    );
}

#[test]
fn csc_hessian_equals_the_dense_hessian() {
    let mut model = damped_block(MassKind::Consistent);
    let q = deformed(&model);
    let mut h = model.new_hessian();
    model
        .hessian(&q, &mut h, HessianOptions::default())
        .unwrap();
    let csc = h.to_csc();
    assert_same(&csc, &h.to_dense(), "Hessian");
    // Both triangles are stored, with the pattern's row order.
    assert_eq!(csc.nnz(), h.pattern().nnz());
    assert_eq!(csc.col_offsets(), h.pattern().col_ptr());
    assert_eq!(csc.row_indices(), h.pattern().row_idx());
    let projected = {
        let mut p = model.new_hessian();
        let options = HessianOptions::projected();
        model.hessian(&q, &mut p, options).unwrap();
        p
    };
    assert_same(
        &projected.to_csc(),
        &projected.to_dense(),
        "projected Hessian",
    );
}

#[test]
fn csc_mass_equals_the_dense_mass_consistent_and_lumped() {
    let model = damped_block(MassKind::Consistent);
    let softbench::model::MassMatrix::Consistent(m) = model.mass() else {
        panic!("consistent mass expected")
    };
    assert_same(&model.mass().to_csc(), &m.to_dense(), "consistent mass");

    let model = damped_block(MassKind::Lumped);
    let softbench::model::MassMatrix::Lumped { diagonal, .. } = model.mass() else {
        panic!("lumped mass expected")
    };
    let csc = model.mass().to_csc();
    assert_eq!(csc.nnz(), diagonal.len());
    assert_same(
        &csc,
        &DMatrix::from_diagonal(&nalgebra::DVector::from_column_slice(diagonal)),
        "lumped mass",
    );
}

#[test]
fn csc_damping_equals_the_dense_damping_matrix() {
    let mut model = damped_block(MassKind::Consistent);
    let q = deformed(&model);
    let mut d = model.new_hessian();
    model.damping_matrix(&q, &mut d).unwrap();
    assert_same(&d.to_csc(), &d.to_dense(), "damping");
}

/// Matrix Market export: the header says `real symmetric`, the entries are the lower
/// triangle, 1-based, and read back (by an independent little parser) to exactly the dense
/// matrix.
#[test]
fn matrix_market_export_reads_back_to_the_same_matrix() {
    let mut model = damped_block(MassKind::Lumped);
    let q = deformed(&model);
    let mut h = model.new_hessian();
    model
        .hessian(&q, &mut h, HessianOptions::projected())
        .unwrap();
    let mut text = Vec::new();
    h.write_matrix_market(&mut text).unwrap();
    let text = String::from_utf8(text).unwrap();
    let mut lines = text
        .lines()
        .filter(|l| !l.starts_with('%') || l.starts_with("%%"));
    assert_eq!(
        lines.next().unwrap(),
        "%%MatrixMarket matrix coordinate real symmetric"
    );
    let size: Vec<usize> = lines
        .next()
        .unwrap()
        .split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect();
    let n = h.dim();
    assert_eq!(&size[..2], &[n, n]);
    let mut read = DMatrix::<f64>::zeros(n, n);
    let mut count = 0;
    for line in lines {
        let t: Vec<&str> = line.split_whitespace().collect();
        let (r, c): (usize, usize) = (t[0].parse().unwrap(), t[1].parse().unwrap());
        let v: f64 = t[2].parse().unwrap();
        assert!(
            r >= c && c >= 1,
            "entry ({r}, {c}) is not in the lower triangle"
        );
        read[(r - 1, c - 1)] = v;
        count += 1;
    }
    assert_eq!(count, size[2]);
    // The lower triangle, bit for bit (the upper is its mirror by the format).
    assert_eq!(read, h.to_dense().lower_triangle());
}
