//! The one interface every obstacle shape implements: a signed distance with its gradient and
//! Hessian, in the shape's own frame.

use nalgebra::{Matrix3, Vector3};

/// A signed distance and its first two derivatives at a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SdfValue {
    /// Signed distance (m): positive outside the obstacle, negative inside.
    pub distance: f64,
    /// Gradient of the distance: the unit outward normal of the nearest surface point, where
    /// the distance is differentiable (on a medial surface, one of the one-sided gradients).
    pub gradient: Vector3<f64>,
    /// Hessian of the distance (1/m): zero on flat faces, `(I - n n^T) / r` at distance `r`
    /// from a sphere's centre. Always has `gradient` in its null space.
    pub hessian: Matrix3<f64>,
}

impl SdfValue {
    /// A flat (affine) distance: zero Hessian.
    pub fn flat(distance: f64, gradient: Vector3<f64>) -> Self {
        Self {
            distance,
            gradient,
            hessian: Matrix3::zeros(),
        }
    }

    /// The same distance seen from a frame rotated by `r` (columns: the shape's axes).
    pub fn rotated(&self, r: &Matrix3<f64>) -> Self {
        Self {
            distance: self.distance,
            gradient: r * self.gradient,
            hessian: r * self.hessian * r.transpose(),
        }
    }

    /// The distance `|q| - radius` to a round surface, where `q` is the vector from the
    /// nearest point of a core (a point, a segment, a box) to `p`, and `curved` projects onto
    /// the directions in which the core is a point (identity for a point core; the plane
    /// across the axis for a segment; the axes outside the slab for a box). Deep inside a
    /// point core (`q = 0`) the gradient is taken as +y and the Hessian as zero.
    pub fn rounded(q: Vector3<f64>, radius: f64, curved: Matrix3<f64>) -> Self {
        let r = q.norm();
        if r <= f64::MIN_POSITIVE.sqrt() {
            return Self::flat(-radius, Vector3::y());
        }
        let n = q / r;
        Self {
            distance: r - radius,
            gradient: n,
            hessian: (curved - n * n.transpose()) / r,
        }
    }
}

/// A shape described by its signed distance function.
pub trait Sdf {
    /// The signed distance and its derivatives at `p`, in the shape's own frame.
    fn eval(&self, p: &Vector3<f64>) -> SdfValue;
}
