//! The generated box the local-solver benches step: `cells` cells over 1 m × 0.5 m × 0.5 m,
//! `material` with E = 1e6 Pa, ν = 0.45, 1000 kg/m³, lumped mass, gravity, the x = 0 end fixed.

use nalgebra::Vector3;
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::generate::box_mesh;
use softbench::model::{AxisRule, FixedSelection, MassKind, Model, ModelSpec, Side};

pub fn clamped_box(material: &str, cells: [usize; 3]) -> Model {
    let lame = LameParameters::from_youngs_poisson(1e6, 0.45).unwrap();
    let material = MaterialModel::from_name(material, lame).unwrap();
    let mut spec = ModelSpec::elastic(box_mesh(cells, [1.0, 0.5, 0.5]), material, 1000.0);
    spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
    spec.mass_kind = MassKind::Lumped;
    spec.fixed = FixedSelection {
        rules: vec![AxisRule {
            axis: 0,
            side: Side::Min,
            tolerance: 1e-9,
        }],
        ..Default::default()
    };
    Model::new(spec).unwrap()
}
