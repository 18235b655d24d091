//! A half-space: everything below a plane (the ground).

use super::sdf::{Sdf, SdfValue};
use nalgebra::Vector3;

/// The half-space `{x : n . (x - point) <= 0}`: solid on the side opposite to its unit
/// normal `n`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfSpace {
    point: Vector3<f64>,
    normal: Vector3<f64>,
}

impl HalfSpace {
    /// A point on the boundary plane (m), in the shape's frame (for drawing).
    pub fn point(&self) -> Vector3<f64> {
        self.point
    }

    /// The half-space through `point` whose outward normal is `normal` (normalized here).
    ///
    /// # Panics
    /// If `normal` is zero or not finite.
    pub fn new(point: Vector3<f64>, normal: Vector3<f64>) -> Self {
        let len = normal.norm();
        assert!(
            len > 0.0 && len.is_finite(),
            "HalfSpace: the normal must be non-zero and finite, got {normal:?}"
        );
        Self {
            point,
            normal: normal / len,
        }
    }

    /// The unit outward normal.
    pub fn normal(&self) -> Vector3<f64> {
        self.normal
    }
}

impl Sdf for HalfSpace {
    fn eval(&self, p: &Vector3<f64>) -> SdfValue {
        SdfValue::flat(self.normal.dot(&(p - self.point)), self.normal)
    }
}
