//! Stable Neo-Hookean (Smith, de Goes, Kim 2018, "Stable Neo-Hookean Flesh Simulation"):
//! psi(F) = mu/2 (I_C - 3) + lambda/2 (J - alpha)^2 - mu/2 log(I_C + 1),
//! with I_C = tr(FᵀF), J = det F and alpha = 1 + 3 mu / (4 lambda).
//!
//! As written the energy is not zero at rest (psi(I) = lambda/2 (1 - alpha)² - mu/2 log 4), so
//! that constant is subtracted: psi(I) = 0, and P and dP/dF are unchanged.
//!
//! alpha makes F = I stress-free (the log term pulls with mu/4 there, the volume term pushes
//! back). The energy is a polynomial plus log(I_C + 1) with I_C + 1 >= 1, so it is defined and
//! smooth for every F, inverted and collapsed ones included.
//!
//! Its own mu and lambda are not the Lamé constants: at F = I,
//! dP/dF = 3/4 mu (I + T) + (lambda - 5/8 mu) vec(I) vec(I)ᵀ (T the transpose permutation), so
//! [`StableNeoHookean::new`] uses the paper's reparameterization
//! mu = 4/3 mu_lame, lambda = lambda_lame + 5/6 mu_lame, which makes the model linearize to the
//! given Lamé constants.

use super::{
    InvalidDeformation, LameParameters, Material, Matrix9, RotationVariantSvd, cofactor,
    det_hessian, vec9,
};
use nalgebra::{Matrix3, SVector, Vector3};

/// The Stable Neo-Hookean energy with its own (reparameterized) constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StableNeoHookean {
    mu: f64,
    lambda: f64,
    alpha: f64,
    /// The paper's energy at F = I, subtracted so that psi(I) = 0.
    rest_energy: f64,
    /// The Lamé parameters given (before the reparameterization above).
    lame: LameParameters,
}

impl StableNeoHookean {
    /// From Lamé parameters, through mu = 4/3 mu_lame and lambda = lambda_lame + 5/6 mu_lame.
    ///
    /// Zero Lamé lambda (Poisson ratio 0) needs no special case: the reparameterized lambda is
    /// then 5/6 mu_lame > 0. The reparameterized lambda is zero only for the void material
    /// mu_lame = lambda_lame = 0, whose energy is identically zero; there 3 mu / (4 lambda) is
    /// 0/0, so alpha = 1 is used (any value gives the same zero energy).
    pub fn new(lame: LameParameters) -> Self {
        let mu = 4.0 / 3.0 * lame.mu;
        let lambda = lame.lambda + 5.0 / 6.0 * lame.mu;
        let alpha = if lambda > 0.0 {
            1.0 + 0.75 * mu / lambda
        } else {
            1.0
        };
        let mut snh = Self {
            mu,
            lambda,
            alpha,
            rest_energy: 0.0,
            lame,
        };
        snh.rest_energy = snh.unshifted_energy(&Matrix3::identity());
        snh
    }

    /// The paper's psi(F), without the rest-energy shift.
    #[inline]
    fn unshifted_energy(&self, f: &Matrix3<f64>) -> f64 {
        let ic = f.norm_squared();
        let dj = f.determinant() - self.alpha;
        0.5 * self.mu * (ic - 3.0) + 0.5 * self.lambda * dj * dj - 0.5 * self.mu * (ic + 1.0).ln()
    }

    /// The model's own shear coefficient mu (= 4/3 mu_lame).
    pub fn mu(&self) -> f64 {
        self.mu
    }

    /// The model's own volume coefficient lambda (= lambda_lame + 5/6 mu_lame).
    pub fn lambda(&self) -> f64 {
        self.lambda
    }

    /// The rest volume ratio offset alpha = 1 + 3 mu / (4 lambda) (1 for the void material).
    pub fn alpha(&self) -> f64 {
        self.alpha
    }
}

impl Material for StableNeoHookean {
    const HANDLES_INVERSION: bool = true;

    fn lame(&self) -> LameParameters {
        self.lame
    }

    #[inline]
    fn energy_density(&self, f: &Matrix3<f64>) -> Result<f64, InvalidDeformation> {
        Ok(self.unshifted_energy(f) - self.rest_energy)
    }

    #[inline]
    fn first_piola(&self, f: &Matrix3<f64>) -> Result<Matrix3<f64>, InvalidDeformation> {
        let ic = f.norm_squared();
        let dj = f.determinant() - self.alpha;
        Ok(f * (self.mu * (1.0 - 1.0 / (ic + 1.0))) + cofactor(f) * (self.lambda * dj))
    }

    #[inline]
    fn first_piola_derivative(&self, f: &Matrix3<f64>) -> Result<Matrix9, InvalidDeformation> {
        let ic1 = f.norm_squared() + 1.0;
        let dj = f.determinant() - self.alpha;
        let fv = vec9(f);
        let gv = vec9(&cofactor(f));
        let mut h = det_hessian(f) * (self.lambda * dj);
        h.ger(2.0 * self.mu / (ic1 * ic1), &fv, &fv, 1.0);
        h.ger(self.lambda, &gv, &gv, 1.0);
        let diagonal = self.mu * (1.0 - 1.0 / ic1);
        for i in 0..9 {
            h[(i, i)] += diagonal;
        }
        Ok(h)
    }

    /// Closed form (Smith, de Goes, Kim 2018, section 4): with F = U diag(σ) Vᵀ (the
    /// rotation-variant SVD), I_C + 1 = |σ|² + 1, J = σ₀σ₁σ₂ and μ' = μ (1 − 1/(I_C + 1)),
    /// - twists `U (e_i e_kᵀ − e_k e_iᵀ) Vᵀ / √2`: `μ' + λ (J − α) σ_m`,
    /// - flips `U (e_i e_kᵀ + e_k e_iᵀ) Vᵀ / √2`: `μ' − λ (J − α) σ_m` (m the third index),
    /// - scalings `U diag(q) Vᵀ`, q the eigenvectors of the 3×3
    ///   `A_ik = 2μ/(I_C + 1)² σ_i σ_k + λ ĉ_i ĉ_k + [i = k] μ' + [i ≠ k] λ (J − α) σ_m`,
    ///   `ĉ_i = J / σ_i` (the cofactor's singular values).
    ///
    /// The rank-one terms vanish on twists and flips (F and cof F are diagonal in the U, V
    /// frame), and d²J/dF² is `±σ_m` on them. `None` when the SVD fails (a non-finite F).
    fn stress_eigensystem(&self, f: &Matrix3<f64>) -> Option<(SVector<f64, 9>, Matrix9)> {
        let svd = RotationVariantSvd::new(f)?;
        let s = svd.sigma;
        let ic1 = s.norm_squared() + 1.0;
        let dj = s[0] * s[1] * s[2] - self.alpha;
        let shear = self.mu * (1.0 - 1.0 / ic1);
        let c = 2.0 * self.mu / (ic1 * ic1);
        let cof = Vector3::new(s[1] * s[2], s[0] * s[2], s[0] * s[1]);
        let a = Matrix3::from_fn(|i, k| {
            c * s[i] * s[k]
                + self.lambda * cof[i] * cof[k]
                + if i == k {
                    shear
                } else {
                    self.lambda * dj * s[3 - i - k]
                }
        });
        let scaling = a.symmetric_eigen();
        let mut values = SVector::<f64, 9>::zeros();
        let mut vectors = Matrix9::zeros();
        let frame = |m: Matrix3<f64>| vec9(&(svd.u * m * svd.v.transpose()));
        for n in 0..3 {
            values[n] = scaling.eigenvalues[n];
            let q: Vector3<f64> = scaling.eigenvectors.column(n).into();
            vectors.set_column(n, &frame(Matrix3::from_diagonal(&q)));
        }
        let r = std::f64::consts::FRAC_1_SQRT_2;
        for (n, (i, k)) in [(0, 1), (0, 2), (1, 2)].into_iter().enumerate() {
            let third = s[3 - i - k];
            let mut twist = Matrix3::zeros();
            twist[(i, k)] = r;
            twist[(k, i)] = -r;
            let mut flip = Matrix3::zeros();
            flip[(i, k)] = r;
            flip[(k, i)] = r;
            values[3 + n] = shear + self.lambda * dj * third;
            values[6 + n] = shear - self.lambda * dj * third;
            vectors.set_column(3 + n, &frame(twist));
            vectors.set_column(6 + n, &frame(flip));
        }
        Some((values, vectors))
    }

    /// Closed form: contracting dP/dF with `n ⊗ n` turns `I` into `|n|² I`, `vec(F) vec(F)ᵀ`
    /// into `(F n)(F n)ᵀ` and `vec(cof F) vec(cof F)ᵀ` into `(cof F n)(cof F n)ᵀ`, and removes
    /// the `d²J/dF²` term (J is affine along `δx nᵀ`).
    #[inline]
    fn vertex_terms(
        &self,
        f: &Matrix3<f64>,
        n: &Vector3<f64>,
    ) -> Result<(Vector3<f64>, Matrix3<f64>), InvalidDeformation> {
        let ic1 = f.norm_squared() + 1.0;
        let dj = f.determinant() - self.alpha;
        let fn_ = f * n;
        let gn = cofactor(f) * n;
        let shear = self.mu * (1.0 - 1.0 / ic1);
        let p = fn_ * shear + gn * (self.lambda * dj);
        let mut h = Matrix3::identity() * (shear * n.norm_squared());
        h.ger(2.0 * self.mu / (ic1 * ic1), &fn_, &fn_, 1.0);
        h.ger(self.lambda, &gn, &gn, 1.0);
        Ok((p, h))
    }
}
