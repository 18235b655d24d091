//! The course Neo-Hookean model (CSC417 A3):
//! psi(F) = C (J^(-2/3) tr(F^T F) - 3) + D (J - 1)^2.
//!
//! [`NeoHookean::new`] uses the course's constants C = mu/2 and D = lambda/2, so results can
//! be compared with the course's. Note what that implies: the isochoric term contributes
//! -2/3 mu to the linearized lambda, so at small strain this model behaves like linear
//! elasticity with (mu, lambda - 2/3 mu) — softer in volume than the given Poisson ratio says
//! (at nu = 0 the effective Poisson ratio is -0.5). [`NeoHookean::with_matched_linearization`]
//! uses D = lambda/2 + mu/3 (half the bulk modulus) instead, which linearizes to exactly the
//! given mu and lambda.
//!
//! Its isochoric term J^(-2/3) has no real value for J <= 0, so inverted elements are an
//! [`InvalidDeformation`] rather than a NaN.

use super::{InvalidDeformation, LameParameters, Material, Matrix9, cofactor, det_hessian};
use nalgebra::Matrix3;

/// The course Neo-Hookean energy with its constants C and D (Pa).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeoHookean {
    /// Coefficient of the isochoric term, C = mu / 2.
    pub c: f64,
    /// Coefficient of the volumetric term (D = lambda / 2 in the course).
    pub d: f64,
}

impl NeoHookean {
    /// The course's constants from Lamé parameters: C = mu/2, D = lambda/2 (see the module
    /// docs for how this linearizes).
    pub fn new(lame: LameParameters) -> Self {
        Self {
            c: 0.5 * lame.mu,
            d: 0.5 * lame.lambda,
        }
    }

    /// C = mu/2, D = lambda/2 + mu/3, so that dP/dF at F = I is the linear elasticity tensor
    /// of mu and lambda.
    pub fn with_matched_linearization(lame: LameParameters) -> Self {
        Self {
            c: 0.5 * lame.mu,
            d: 0.5 * lame.lambda + lame.mu / 3.0,
        }
    }

    /// From C and D given directly.
    pub fn from_c_d(c: f64, d: f64) -> Self {
        Self { c, d }
    }

    /// J and J^(-1/3), or the error for J <= 0.
    #[inline]
    fn volume_ratio(f: &Matrix3<f64>) -> Result<(f64, f64), InvalidDeformation> {
        let j = f.determinant();
        if j > 0.0 && j.is_finite() {
            Ok((j, 1.0 / j.cbrt()))
        } else {
            Err(InvalidDeformation { det_f: j })
        }
    }
}

impl Material for NeoHookean {
    const HANDLES_INVERSION: bool = false;

    fn lame(&self) -> LameParameters {
        LameParameters {
            mu: 2.0 * self.c,
            lambda: 2.0 * self.d,
        }
    }

    #[inline]
    fn energy_density(&self, f: &Matrix3<f64>) -> Result<f64, InvalidDeformation> {
        let (j, j13) = Self::volume_ratio(f)?;
        let i1 = f.norm_squared();
        Ok(self.c * (j13 * j13 * i1 - 3.0) + self.d * (j - 1.0) * (j - 1.0))
    }

    #[inline]
    fn first_piola(&self, f: &Matrix3<f64>) -> Result<Matrix3<f64>, InvalidDeformation> {
        let (j, j13) = Self::volume_ratio(f)?;
        let j23 = j13 * j13;
        let i1 = f.norm_squared();
        let g = cofactor(f);
        let s = -(2.0 / 3.0) * self.c * j23 / j * i1 + 2.0 * self.d * (j - 1.0);
        Ok(f * (2.0 * self.c * j23) + g * s)
    }

    #[inline]
    fn first_piola_derivative(&self, f: &Matrix3<f64>) -> Result<Matrix9, InvalidDeformation> {
        let (j, j13) = Self::volume_ratio(f)?;
        let j23 = j13 * j13;
        let j53 = j23 / j;
        let j83 = j53 / j;
        let i1 = f.norm_squared();
        let g = cofactor(f);
        let gv = nalgebra::SVector::<f64, 9>::from_column_slice(g.as_slice());
        let fv = nalgebra::SVector::<f64, 9>::from_column_slice(f.as_slice());
        let s = -(2.0 / 3.0) * self.c * j53 * i1 + 2.0 * self.d * (j - 1.0);
        let mixed = -(4.0 / 3.0) * self.c * j53;
        let gg = (10.0 / 9.0) * self.c * j83 * i1 + 2.0 * self.d;
        let mut h = det_hessian(f) * s;
        for col in 0..9 {
            for row in 0..9 {
                h[(row, col)] +=
                    mixed * (fv[row] * gv[col] + gv[row] * fv[col]) + gg * gv[row] * gv[col];
            }
            h[(col, col)] += 2.0 * self.c * j23;
        }
        Ok(h)
    }
}
