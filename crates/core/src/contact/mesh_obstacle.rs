//! Static triangle-mesh obstacles (`kind = "mesh"`): triangles read from an OBJ file and
//! placed in the world, which incremental potential contact and the frame check see.

use nalgebra::Vector3;

/// A static triangle mesh obstacle (read from OBJ, placed in the world).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshObstacle {
    pub positions: Vec<Vector3<f64>>,
    pub triangles: Vec<[usize; 3]>,
}
