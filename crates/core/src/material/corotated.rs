//! Corotated linear elasticity: psi(F) = mu ‖F - R‖² + lambda/2 tr(RᵀF - I)², with R the
//! rotation of the polar decomposition F = R S.
//!
//! Through the rotation-variant SVD F = U Σ Vᵀ (det U = det V = +1, the smallest singular value
//! negative for inverted F): R = U Vᵀ, psi = mu Σ (σ_i - 1)² + lambda/2 (Σ σ_i - 3)²,
//! P = 2 mu (F - R) + lambda tr(S - I) R. It linearizes to the Lamé constants exactly and is
//! defined for every F.
//!
//! dP/dF = 2 mu I + lambda vec(R) vec(R)ᵀ + (lambda tr(S - I) - 2 mu) dR/dF, with dR/dF in the
//! twist-mode closed form (Kim & Eberle, "Dynamic Deformables", SIGGRAPH course 2022):
//! dR/dF = Σ_{i<j} 2/(σ_i + σ_j) vec(Q_ij) vec(Q_ij)ᵀ, Q_ij = U (e_i e_jᵀ - e_j e_iᵀ) Vᵀ / √2.
//!
//! Where σ_i + σ_j = 0 (for example F = diag(1, 1, -1)) R is not unique and dR/dF is
//! unbounded. The denominator's magnitude is clamped to at least [`TWIST_DENOMINATOR_FLOOR`]
//! (keeping its sign, positive at exactly zero), so dP/dF stays finite there: a twist mode's
//! eigenvalue is then at most 2/1e-6 · |lambda tr(S - I) - 2 mu|. P and psi are not clamped.

use super::{InvalidDeformation, LameParameters, Material, Matrix9, RotationVariantSvd, vec9};
use nalgebra::Matrix3;

/// Smallest magnitude of σ_i + σ_j used in the twist-mode eigenvalues 2/(σ_i + σ_j).
pub const TWIST_DENOMINATOR_FLOOR: f64 = 1e-6;

/// The corotated linear elasticity energy with Lamé constants mu and lambda (Pa).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corotated {
    /// Shear modulus mu.
    pub mu: f64,
    /// Lamé lambda.
    pub lambda: f64,
}

impl Corotated {
    /// From Lamé parameters, used as they are.
    pub fn new(lame: LameParameters) -> Self {
        Self {
            mu: lame.mu,
            lambda: lame.lambda,
        }
    }

    #[inline]
    fn svd(f: &Matrix3<f64>) -> Result<RotationVariantSvd, InvalidDeformation> {
        RotationVariantSvd::new(f).ok_or(InvalidDeformation {
            det_f: f.determinant(),
        })
    }
}

impl Material for Corotated {
    const HANDLES_INVERSION: bool = true;

    fn lame(&self) -> LameParameters {
        LameParameters {
            mu: self.mu,
            lambda: self.lambda,
        }
    }

    /// `Err` only for a non-finite F (the SVD has no answer there).
    #[inline]
    fn energy_density(&self, f: &Matrix3<f64>) -> Result<f64, InvalidDeformation> {
        let sigma = Self::svd(f)?.sigma;
        let tr = sigma.sum() - 3.0;
        let shear = sigma.map(|s| (s - 1.0) * (s - 1.0)).sum();
        Ok(self.mu * shear + 0.5 * self.lambda * tr * tr)
    }

    /// `Err` only for a non-finite F.
    #[inline]
    fn first_piola(&self, f: &Matrix3<f64>) -> Result<Matrix3<f64>, InvalidDeformation> {
        let svd = Self::svd(f)?;
        let r = svd.rotation();
        let tr = svd.sigma.sum() - 3.0;
        Ok((f - r) * (2.0 * self.mu) + r * (self.lambda * tr))
    }

    /// `Err` only for a non-finite F.
    #[inline]
    fn first_piola_derivative(&self, f: &Matrix3<f64>) -> Result<Matrix9, InvalidDeformation> {
        let svd = Self::svd(f)?;
        let (u, sigma, v) = (svd.u, svd.sigma, svd.v);
        let rv = vec9(&svd.rotation());
        let mut h = Matrix9::identity() * (2.0 * self.mu);
        h.ger(self.lambda, &rv, &rv, 1.0);
        let twist_scale = self.lambda * (sigma.sum() - 3.0) - 2.0 * self.mu;
        for (i, j) in [(0, 1), (0, 2), (1, 2)] {
            // Q = (u_i v_jᵀ - u_j v_iᵀ) / √2.
            let mut q = Matrix3::zeros();
            q.ger(
                std::f64::consts::FRAC_1_SQRT_2,
                &u.column(i),
                &v.column(j),
                0.0,
            );
            q.ger(
                -std::f64::consts::FRAC_1_SQRT_2,
                &u.column(j),
                &v.column(i),
                1.0,
            );
            let qv = vec9(&q);
            let sum = sigma[i] + sigma[j];
            let denominator = if sum.abs() < TWIST_DENOMINATOR_FLOOR {
                TWIST_DENOMINATOR_FLOOR.copysign(sum)
            } else {
                sum
            };
            h.ger(twist_scale * 2.0 / denominator, &qv, &qv, 1.0);
        }
        Ok(h)
    }
}
