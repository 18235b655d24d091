//! Free and fixed vertices: fixed vertices are eliminated from the unknowns (not penalized),
//! so the state `q` stacks only free vertices, `q = [x_f0 y_f0 z_f0 x_f1 ...]`.

use super::ModelError;
use crate::mesh::TetMesh;
use nalgebra::Vector3;

/// Marker for a fixed vertex in [`DofMap::free_index`].
pub const FIXED: u32 = u32::MAX;

/// The map between mesh vertices and free-vertex indices (free vertex f owns DOFs 3f..3f+3).
#[derive(Clone, Debug, PartialEq)]
pub struct DofMap {
    free_index: Vec<u32>,
    free_vertices: Vec<usize>,
}

impl DofMap {
    /// From a per-vertex "is fixed" flag.
    pub fn new(fixed: &[bool]) -> Self {
        let mut free_index = vec![FIXED; fixed.len()];
        let mut free_vertices = Vec::with_capacity(fixed.len());
        for (v, &is_fixed) in fixed.iter().enumerate() {
            if !is_fixed {
                free_index[v] = free_vertices.len() as u32;
                free_vertices.push(v);
            }
        }
        Self {
            free_index,
            free_vertices,
        }
    }

    /// Number of mesh vertices.
    pub fn num_vertices(&self) -> usize {
        self.free_index.len()
    }

    /// Number of free vertices.
    pub fn num_free(&self) -> usize {
        self.free_vertices.len()
    }

    /// Number of free DOFs (3 per free vertex).
    pub fn num_dofs(&self) -> usize {
        3 * self.free_vertices.len()
    }

    /// Number of fixed vertices.
    pub fn num_fixed(&self) -> usize {
        self.free_index.len() - self.free_vertices.len()
    }

    /// The vertex and DOF counts a run's size is reported by.
    pub fn counts(&self) -> DofCounts {
        DofCounts {
            vertices: self.num_vertices(),
            fixed_vertices: self.num_fixed(),
            free_dofs: self.num_dofs(),
            fixed_dofs: 3 * self.num_fixed(),
        }
    }

    /// Free index of vertex `v`, or [`FIXED`].
    #[inline]
    pub fn free_index(&self, v: usize) -> u32 {
        self.free_index[v]
    }

    /// Whether vertex `v` is fixed.
    pub fn is_fixed(&self, v: usize) -> bool {
        self.free_index[v] == FIXED
    }

    /// Mesh vertex of each free vertex, in DOF order.
    pub fn free_vertices(&self) -> &[usize] {
        &self.free_vertices
    }

    /// Stack the free vertices of `positions` into `q`.
    pub fn gather(&self, positions: &[Vector3<f64>], q: &mut [f64]) {
        for (f, &v) in self.free_vertices.iter().enumerate() {
            q[3 * f..3 * f + 3].copy_from_slice(positions[v].as_slice());
        }
    }

    /// Write `q` into the free vertices of `positions` (fixed ones are left as they are).
    pub fn scatter(&self, q: &[f64], positions: &mut [Vector3<f64>]) {
        for (f, &v) in self.free_vertices.iter().enumerate() {
            positions[v] = Vector3::new(q[3 * f], q[3 * f + 1], q[3 * f + 2]);
        }
    }
}

/// How many vertices a body has, how many are fixed, and the DOFs on either side: the size
/// `summary.json`, `simulate`'s last line and a study's `runs.csv` report, so a run that
/// fixed more (or less) than meant says so.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct DofCounts {
    pub vertices: usize,
    pub fixed_vertices: usize,
    /// 3 per free vertex: the unknowns of every step.
    pub free_dofs: usize,
    /// 3 per fixed vertex.
    pub fixed_dofs: usize,
}

impl std::fmt::Display for DofCounts {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} free and {} fixed DOFs ({} of {} vertices fixed)",
            self.free_dofs, self.fixed_dofs, self.fixed_vertices, self.vertices
        )
    }
}

/// Which side of an axis a [`AxisRule`] selects from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Side {
    Min,
    Max,
}

/// The course rule: fix vertices within `tolerance` of the lowest (or highest) coordinate along
/// an axis (0 = x, 1 = y, 2 = z).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisRule {
    pub axis: usize,
    pub side: Side,
    pub tolerance: f64,
}

/// Which vertices are fixed: the union of explicit indices, axis rules and boxes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FixedSelection {
    pub indices: Vec<usize>,
    pub rules: Vec<AxisRule>,
    /// Axis-aligned boxes `(min, max)`; vertices inside (inclusive) are fixed.
    pub boxes: Vec<(Vector3<f64>, Vector3<f64>)>,
}

impl FixedSelection {
    /// Nothing fixed.
    pub fn none() -> Self {
        Self::default()
    }

    /// Resolve to a per-vertex flag.
    pub fn resolve(&self, mesh: &TetMesh) -> Result<Vec<bool>, ModelError> {
        let n = mesh.num_vertices();
        let mut fixed = vec![false; n];
        for &i in &self.indices {
            *fixed.get_mut(i).ok_or(ModelError::FixedIndexOutOfRange {
                index: i,
                vertices: n,
            })? = true;
        }
        for rule in &self.rules {
            if rule.axis > 2 || rule.tolerance.is_nan() || rule.tolerance < 0.0 {
                return Err(ModelError::InvalidParameter {
                    field: "fixed.rule".into(),
                    value: format!("axis {} tolerance {}", rule.axis, rule.tolerance),
                    expected: "axis x, y or z and a tolerance >= 0".into(),
                });
            }
            let coords = mesh.positions.iter().map(|p| p[rule.axis]);
            let extreme = match rule.side {
                Side::Min => coords.fold(f64::INFINITY, f64::min),
                Side::Max => coords.fold(f64::NEG_INFINITY, f64::max),
            };
            for (v, p) in mesh.positions.iter().enumerate() {
                if (p[rule.axis] - extreme).abs() <= rule.tolerance {
                    fixed[v] = true;
                }
            }
        }
        for (lo, hi) in &self.boxes {
            for (v, p) in mesh.positions.iter().enumerate() {
                if (0..3).all(|k| p[k] >= lo[k] && p[k] <= hi[k]) {
                    fixed[v] = true;
                }
            }
        }
        Ok(fixed)
    }
}
