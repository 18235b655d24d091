//! The energy of Macklin & Müller's XPBD Neo-Hookean constraints (2021, "A Constraint-based
//! Formulation of Stable Neo-Hookean Materials"):
//! psi(F) = mu/2 (‖F‖² − 3) + lambda/2 (J − alpha)² − lambda/2 (1 − alpha)², alpha = 1 + mu/lambda.
//!
//! Per tet it is the constraint energy `1/(2 compliance) C²` of C_D = ‖F‖_F with compliance
//! 1/(mu V) and C_H = det F − alpha with compliance 1/(lambda V) (up to constants), so
//! `backward-euler` on this material is what `xpbd` converges to. alpha makes F = I
//! stress-free; the constant makes psi(I) = 0. Defined for every F (a polynomial).
//! At F = I, dP/dF maps δF to mu (δF + δFᵀ) + (lambda − mu) tr(δF) I, so
//! [`ConstraintNeoHookean::new`] takes mu = mu_lame and lambda = lambda_lame + mu_lame, which
//! linearizes to the given Lamé constants (and keeps lambda > 0 at Poisson ratio 0). Only the
//! void material (both zero) has lambda = 0; it uses alpha = 1 (its energy is zero anyway).

use super::{InvalidDeformation, LameParameters, Material, Matrix9, cofactor, det_hessian, vec9};
use nalgebra::{Matrix3, Vector3};

/// The XPBD constraint Neo-Hookean energy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstraintNeoHookean {
    /// Shear weight mu (Pa): the compliance of C_D is 1/(mu V).
    pub mu: f64,
    /// Volume weight lambda (Pa): the compliance of C_H is 1/(lambda V).
    pub lambda: f64,
    /// The rest volume ratio alpha = 1 + mu/lambda.
    pub alpha: f64,
    /// The Lamé parameters given (lambda before the shift above).
    pub lame: LameParameters,
}

impl ConstraintNeoHookean {
    /// From Lamé parameters: mu = mu_lame, lambda = lambda_lame + mu_lame (see the module docs).
    pub fn new(lame: LameParameters) -> Self {
        let lambda = lame.lambda + lame.mu;
        let alpha = if lambda > 0.0 {
            1.0 + lame.mu / lambda
        } else {
            1.0
        };
        Self {
            mu: lame.mu,
            lambda,
            alpha,
            lame,
        }
    }
}

impl Material for ConstraintNeoHookean {
    const HANDLES_INVERSION: bool = true;

    fn lame(&self) -> LameParameters {
        self.lame
    }

    #[inline]
    fn energy_density(&self, f: &Matrix3<f64>) -> Result<f64, InvalidDeformation> {
        let dj = f.determinant() - self.alpha;
        let rest = 1.0 - self.alpha;
        Ok(0.5 * self.mu * (f.norm_squared() - 3.0) + 0.5 * self.lambda * (dj * dj - rest * rest))
    }

    #[inline]
    fn first_piola(&self, f: &Matrix3<f64>) -> Result<Matrix3<f64>, InvalidDeformation> {
        let dj = f.determinant() - self.alpha;
        Ok(f * self.mu + cofactor(f) * (self.lambda * dj))
    }

    #[inline]
    fn first_piola_derivative(&self, f: &Matrix3<f64>) -> Result<Matrix9, InvalidDeformation> {
        let dj = f.determinant() - self.alpha;
        let g = vec9(&cofactor(f));
        let mut h = det_hessian(f) * (self.lambda * dj);
        h.ger(self.lambda, &g, &g, 1.0);
        for i in 0..9 {
            h[(i, i)] += self.mu;
        }
        Ok(h)
    }

    /// Closed form, as for Stable Neo-Hookean: `mu |n|² I + lambda (cof F n)(cof F n)ᵀ`.
    #[inline]
    fn vertex_terms(
        &self,
        f: &Matrix3<f64>,
        n: &Vector3<f64>,
    ) -> Result<(Vector3<f64>, Matrix3<f64>), InvalidDeformation> {
        let dj = f.determinant() - self.alpha;
        let gn = cofactor(f) * n;
        let p = f * n * self.mu + gn * (self.lambda * dj);
        let mut h = Matrix3::identity() * (self.mu * n.norm_squared());
        h.ger(self.lambda, &gn, &gn, 1.0);
        Ok((p, h))
    }
}
