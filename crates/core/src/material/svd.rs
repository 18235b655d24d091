//! The rotation-variant SVD of a 3×3 deformation gradient, for models built on the polar
//! rotation R of F = R S.

use nalgebra::{Matrix3, Vector3};

/// F = U diag(sigma) Vᵀ with U and V proper rotations (det = +1).
///
/// Where det F < 0 the sign is moved onto the smallest singular value, so `sigma` may hold one
/// negative entry; then R = U Vᵀ is a rotation for every F and S = V diag(sigma) Vᵀ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RotationVariantSvd {
    /// Left singular vectors as columns, det U = +1.
    pub u: Matrix3<f64>,
    /// Singular values, the smallest one signed by det F; not sorted.
    pub sigma: Vector3<f64>,
    /// Right singular vectors as columns, det V = +1.
    pub v: Matrix3<f64>,
}

impl RotationVariantSvd {
    /// The rotation-variant SVD of `f`, or `None` if `f` is not finite (nalgebra's iteration
    /// would not converge) or the SVD fails to converge.
    #[inline]
    pub fn new(f: &Matrix3<f64>) -> Option<Self> {
        if !f.iter().all(|x| x.is_finite()) {
            return None;
        }
        // nalgebra's 3×3 SVD: eigenvectors of FᵀF, then a QR of F V. `max_niter` bounds the
        // eigen-solver's iterations so a pathological input cannot loop forever.
        let svd = f.try_svd_unordered(true, true, 5.0 * f64::EPSILON, 1000)?;
        let mut u = svd.u?;
        let mut v = svd.v_t?.transpose();
        let mut sigma = svd.singular_values;
        let k = sigma.imin();
        if u.determinant() < 0.0 {
            u.column_mut(k).neg_mut();
            sigma[k] = -sigma[k];
        }
        if v.determinant() < 0.0 {
            v.column_mut(k).neg_mut();
            sigma[k] = -sigma[k];
        }
        Some(Self { u, sigma, v })
    }

    /// The polar rotation R = U Vᵀ.
    #[inline]
    pub fn rotation(&self) -> Matrix3<f64> {
        self.u * self.v.transpose()
    }
}
