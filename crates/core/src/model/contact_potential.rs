//! A contact potential: one energy over stencils of up to four vertices that change with the
//! configuration (the barrier and friction of incremental potential contact). Unlike a
//! [`super::VertexPotential`] it couples vertices that share no element (self-contact), so
//! its Hessian may need blocks outside the element pattern: [`super::Model::hessian`] adds the
//! blocks the pattern has and keeps the others as [`OffPatternBlock`]s for the linear system
//! to extend its pattern with (see [`crate::integrate::ImplicitSystem`]).

use nalgebra::{Matrix3, Vector3};

/// A configuration-dependent potential over vertex stencils.
pub trait ContactPotential: Send + Sync + std::fmt::Debug {
    /// A short name for reports.
    fn name(&self) -> &str;

    /// The energy at time `t` for positions `x` (every vertex of the mesh); `+inf` where the
    /// configuration is not admissible (two primitives touch or cross).
    fn energy(&self, t: f64, x: &[Vector3<f64>]) -> f64;

    /// The part of the energy that is stored (the barrier; lagged friction is a dissipation
    /// potential of the current step, not a stored energy), for energy reports.
    fn stored_energy(&self, t: f64, x: &[Vector3<f64>]) -> f64;

    /// The power (W) moving obstacles put into the body through the potential at positions
    /// `x` and time `t`: the sum over contacts of the contact force times the obstacle's
    /// velocity (the energy balance counts it as work done on the body). Default: 0.
    fn driven_power(&self, _t: f64, _x: &[Vector3<f64>]) -> f64 {
        0.0
    }

    /// Call `add(v, dphi/dx_v)` for each vertex with a non-zero gradient.
    fn gradient(&self, t: f64, x: &[Vector3<f64>], add: &mut dyn FnMut(usize, Vector3<f64>));

    /// Call `add(a, b, d2phi/dx_a dx_b)` for every ordered pair of vertices of every stencil
    /// (both `(a, b)` and `(b, a)`, and `(a, a)`); with `project`, each stencil's matrix is
    /// positive semi-definite.
    fn hessian(
        &self,
        t: f64,
        x: &[Vector3<f64>],
        project: bool,
        add: &mut dyn FnMut(usize, usize, &Matrix3<f64>),
    );
}

/// A Hessian block of the contact potential between free vertices `row` and `col` (indices
/// into the free vertices) that the element pattern does not store.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OffPatternBlock {
    pub row: u32,
    pub col: u32,
    pub block: Matrix3<f64>,
}
