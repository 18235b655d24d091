//! Potentials that act on vertices one at a time — contact penalties against obstacles, drag
//! springs to moving targets. They couple no two vertices, so their Hessian is block-diagonal
//! and fits the pattern the elements already built; they may depend on time.

use nalgebra::{Matrix3, Vector3};

/// A per-vertex potential `sum_v phi_v(x_v, t)`.
pub trait VertexPotential: Send + Sync + std::fmt::Debug {
    /// A short name for reports ("contact", "drag").
    fn name(&self) -> &str;

    /// The energy at time `t` for positions `x` (every vertex of the mesh).
    fn energy(&self, t: f64, x: &[Vector3<f64>]) -> f64;

    /// Call `add(v, dphi/dx_v)` for each vertex with a non-zero gradient.
    fn gradient(&self, t: f64, x: &[Vector3<f64>], add: &mut dyn FnMut(usize, Vector3<f64>));

    /// Call `add(v, d2phi/dx_v^2)` for each vertex with a non-zero Hessian block; with
    /// `project`, each block must be positive semi-definite.
    fn hessian(
        &self,
        t: f64,
        x: &[Vector3<f64>],
        project: bool,
        add: &mut dyn FnMut(usize, Matrix3<f64>),
    );
}
