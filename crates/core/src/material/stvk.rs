//! St. Venant–Kirchhoff: psi(F) = mu ‖E‖² + lambda/2 tr(E)², E = (FᵀF - I)/2 the Green strain.
//!
//! Linear elasticity's energy written in a rotation-invariant strain, so it linearizes to the
//! Lamé constants exactly. It is a polynomial in F, defined for every F, but it behaves badly
//! under compression:
//! - E stays bounded as F collapses: psi(0) = 3/4 mu + 9/8 lambda is finite, and P = F S
//!   vanishes at F = 0, so a fully collapsed element is an equilibrium;
//! - compressed along one axis (F = diag(s, 1, 1)), the restoring stress peaks at
//!   s = 1/√3 ≈ 0.58 and falls to zero below it (negative stiffness);
//! - a reflected element (F = diag(1, 1, -1)) has E = 0: zero energy and zero stress, so
//!   inversion is not resisted at all.
//!
//! Use it for moderate strains only.

use super::{InvalidDeformation, LameParameters, Material, Matrix9, vec9};
use nalgebra::Matrix3;

/// The St. Venant–Kirchhoff energy with Lamé constants mu and lambda (Pa).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StVenantKirchhoff {
    /// Shear modulus mu.
    pub mu: f64,
    /// Lamé lambda.
    pub lambda: f64,
}

impl StVenantKirchhoff {
    /// From Lamé parameters, used as they are.
    pub fn new(lame: LameParameters) -> Self {
        Self {
            mu: lame.mu,
            lambda: lame.lambda,
        }
    }

    /// The Green strain E and the second Piola–Kirchhoff stress S = 2 mu E + lambda tr(E) I.
    #[inline]
    fn strain_stress(&self, f: &Matrix3<f64>) -> (Matrix3<f64>, Matrix3<f64>) {
        let e = (f.tr_mul(f) - Matrix3::identity()) * 0.5;
        let mut s = e * (2.0 * self.mu);
        let tr = self.lambda * e.trace();
        for i in 0..3 {
            s[(i, i)] += tr;
        }
        (e, s)
    }
}

impl Material for StVenantKirchhoff {
    const HANDLES_INVERSION: bool = true;

    fn lame(&self) -> LameParameters {
        LameParameters {
            mu: self.mu,
            lambda: self.lambda,
        }
    }

    #[inline]
    fn energy_density(&self, f: &Matrix3<f64>) -> Result<f64, InvalidDeformation> {
        let e = (f.tr_mul(f) - Matrix3::identity()) * 0.5;
        let tr = e.trace();
        Ok(self.mu * e.norm_squared() + 0.5 * self.lambda * tr * tr)
    }

    #[inline]
    fn first_piola(&self, f: &Matrix3<f64>) -> Result<Matrix3<f64>, InvalidDeformation> {
        Ok(f * self.strain_stress(f).1)
    }

    /// dP_ij/dF_ab = δ_ia S_bj + mu (F_ib F_aj + (F Fᵀ)_ia δ_bj) + lambda F_ij F_ab, assembled
    /// as 3×3 blocks (j, b) over (i, a).
    #[inline]
    fn first_piola_derivative(&self, f: &Matrix3<f64>) -> Result<Matrix9, InvalidDeformation> {
        let s = self.strain_stress(f).1;
        let fft = f * f.transpose();
        let fv = vec9(f);
        let mut h = Matrix9::zeros();
        h.ger(self.lambda, &fv, &fv, 0.0);
        for j in 0..3 {
            for b in 0..3 {
                let mut block = h.fixed_view_mut::<3, 3>(3 * j, 3 * b);
                block.ger(self.mu, &f.column(b), &f.column(j), 1.0);
                for i in 0..3 {
                    block[(i, i)] += s[(b, j)];
                }
                if j == b {
                    block += fft * self.mu;
                }
            }
        }
        Ok(h)
    }
}
