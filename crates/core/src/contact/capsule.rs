//! A capsule: the points within a radius of a segment.

use super::sdf::{Sdf, SdfValue};
use nalgebra::{Matrix3, Vector3};

/// `{x : dist(x, [a, b]) <= radius}`: a cylinder with hemispherical caps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Capsule {
    a: Vector3<f64>,
    b: Vector3<f64>,
    radius: f64,
}

impl Capsule {
    /// Axis end points and radius (m), in the shape's frame (for drawing).
    pub fn axis_radius(&self) -> (Vector3<f64>, Vector3<f64>, f64) {
        (self.a, self.b, self.radius)
    }

    /// The capsule around the segment from `a` to `b` (`a == b` gives a sphere).
    ///
    /// # Panics
    /// If `radius` is not positive and finite.
    pub fn new(a: Vector3<f64>, b: Vector3<f64>, radius: f64) -> Self {
        assert!(
            radius > 0.0 && radius.is_finite(),
            "Capsule: the radius must be positive and finite, got {radius}"
        );
        Self { a, b, radius }
    }
}

impl Sdf for Capsule {
    fn eval(&self, p: &Vector3<f64>) -> SdfValue {
        let axis = self.b - self.a;
        let len2 = axis.norm_squared();
        let s = if len2 > 0.0 {
            (p - self.a).dot(&axis) / len2
        } else {
            0.0
        };
        if s > 0.0 && s < 1.0 {
            // Beside the segment: a cylinder, flat along the axis.
            let u = axis / len2.sqrt();
            let q = p - (self.a + s * axis);
            SdfValue::rounded(q, self.radius, Matrix3::identity() - u * u.transpose())
        } else {
            // Beyond an end: a hemisphere around it.
            let end = if s <= 0.0 { self.a } else { self.b };
            SdfValue::rounded(p - end, self.radius, Matrix3::identity())
        }
    }
}
