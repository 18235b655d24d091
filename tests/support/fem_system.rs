//! The backward-Euler system `M + dt² K` of a generated FEM body (Stable Neo-Hookean,
//! E = 1e6 Pa, ν = 0.45, 1000 kg/m³, lumped mass, clamped at x = 0) at a deformed state, for
//! solver tests and benches that need real elasticity rather than a synthetic matrix.

#![allow(dead_code)]

use nalgebra::Vector3;
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::TetMesh;
use softbench::mesh::generate::{ball, box_mesh};
use softbench::model::{
    AxisRule, FixedSelection, HessianOptions, MassKind, Model, ModelSpec, Side,
};
use softbench::sparse::SymmetricMatrix;

/// The system matrix and the free DOFs' positions it was assembled at.
pub struct FemSystem {
    pub matrix: SymmetricMatrix,
    pub positions: Vec<f64>,
}

/// `M + dt² K` with dt = 0.01 for `mesh`, at the rest shape sagged by a smooth displacement
/// (so K is not the rest stiffness). Element Hessians projected, so the matrix is SPD.
pub fn fem_system(mesh: TetMesh) -> FemSystem {
    let lame = LameParameters::from_youngs_poisson(1e6, 0.45).unwrap();
    let material = MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
    let mut spec = ModelSpec::elastic(mesh, material, 1000.0);
    spec.mass_kind = MassKind::Lumped;
    spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
    spec.fixed = FixedSelection {
        rules: vec![AxisRule {
            axis: 0,
            side: Side::Min,
            tolerance: 1e-9,
        }],
        ..Default::default()
    };
    let mut model = Model::new(spec).unwrap();
    let mut x = model.rest_state();
    for k in 0..x.len() / 3 {
        let px = x[3 * k];
        x[3 * k + 1] -= 0.05 * px * px;
    }
    let mut h = model.new_hessian();
    model
        .hessian(&x, &mut h, HessianOptions::projected())
        .unwrap();
    model.mass().scale_and_add_to(1e-4, &mut h);
    FemSystem {
        matrix: h,
        positions: x,
    }
}

/// A box of `cells` (6 tets per cell), 0.1 m per cell along each axis.
pub fn fem_box(cells: [usize; 3]) -> FemSystem {
    fem_box_sized(cells, 0.1)
}

/// A box of `cells` with cells of `h` metres: smaller cells make `dt² K` dominate `M` (at
/// h = 0.02 m, dt² k/m ≈ 250), the regime where one-level preconditioners struggle.
pub fn fem_box_sized(cells: [usize; 3], h: f64) -> FemSystem {
    let size = cells.map(|c| h * c as f64);
    fem_system(box_mesh(cells, size))
}

/// A ball of radius 0.5 m at `resolution` (48 n³ tets); clamped at its smallest x.
pub fn fem_ball(resolution: usize) -> FemSystem {
    fem_system(ball(0.5, resolution))
}
