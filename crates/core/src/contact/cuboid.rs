//! An oriented box.

use super::sdf::{Sdf, SdfValue};
use nalgebra::{Matrix3, Rotation3, Vector3};

/// A box with centre `center`, half-extents `half_extents` along its own axes, and its axes
/// turned by `rotation` (the columns of the rotation matrix are the box axes in the obstacle's
/// frame).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cuboid {
    center: Vector3<f64>,
    half_extents: Vector3<f64>,
    rotation: Rotation3<f64>,
}

impl Cuboid {
    /// Centre, half extents (m) and rotation, in the shape's frame (for drawing).
    pub fn placement(&self) -> (Vector3<f64>, Vector3<f64>, Rotation3<f64>) {
        (self.center, self.half_extents, self.rotation)
    }

    /// # Panics
    /// If a half-extent is not positive and finite.
    pub fn new(center: Vector3<f64>, half_extents: Vector3<f64>, rotation: Rotation3<f64>) -> Self {
        assert!(
            half_extents.iter().all(|h| *h > 0.0 && h.is_finite()),
            "Cuboid: half-extents must be positive and finite, got {half_extents:?}"
        );
        Self {
            center,
            half_extents,
            rotation,
        }
    }

    /// The distance in the box's own frame (axis-aligned, centred at the origin).
    fn eval_local(&self, p: &Vector3<f64>) -> SdfValue {
        let h = &self.half_extents;
        // Per axis: how far outside the slab |p_i| <= h_i the point is (negative inside).
        let excess = p.abs() - h;
        if excess.iter().any(|e| *e > 0.0) {
            // Outside: the distance to the nearest point of the box, round in the axes where
            // the point is outside the slab (an edge or a corner), flat in the others.
            let nearest = Vector3::from_fn(|i, _| p[i].clamp(-h[i], h[i]));
            let outside = Matrix3::from_diagonal(&excess.map(|e| f64::from(u8::from(e > 0.0))));
            SdfValue::rounded(p - nearest, 0.0, outside)
        } else {
            // Inside: the nearest face is the one with the largest (least negative) excess.
            let axis = excess.imax();
            let mut normal = Vector3::zeros();
            normal[axis] = p[axis].signum();
            if p[axis] == 0.0 {
                normal[axis] = 1.0;
            }
            SdfValue::flat(excess[axis], normal)
        }
    }
}

impl Sdf for Cuboid {
    fn eval(&self, p: &Vector3<f64>) -> SdfValue {
        let r = self.rotation.matrix();
        self.eval_local(&(r.transpose() * (p - self.center)))
            .rotated(r)
    }
}
