//! A solid sphere.

use super::sdf::{Sdf, SdfValue};
use nalgebra::{Matrix3, Vector3};

/// The ball `{x : |x - center| <= radius}`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    center: Vector3<f64>,
    radius: f64,
}

impl Sphere {
    /// Centre and radius (m), in the shape's frame (for drawing).
    pub fn center_radius(&self) -> (Vector3<f64>, f64) {
        (self.center, self.radius)
    }

    /// # Panics
    /// If `radius` is not positive and finite.
    pub fn new(center: Vector3<f64>, radius: f64) -> Self {
        assert!(
            radius > 0.0 && radius.is_finite(),
            "Sphere: the radius must be positive and finite, got {radius}"
        );
        Self { center, radius }
    }
}

impl Sdf for Sphere {
    fn eval(&self, p: &Vector3<f64>) -> SdfValue {
        SdfValue::rounded(p - self.center, self.radius, Matrix3::identity())
    }
}
