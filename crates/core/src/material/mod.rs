//! Strain energy densities psi(F) with the first Piola–Kirchhoff stress P = dpsi/dF and its
//! derivative dP/dF, all in closed form.
//!
//! Index convention: `vec(F)` is column-major, `vec(F)[i + 3 j] = F[(i, j)]` (nalgebra's
//! storage order), and `dP/dF` is the 9×9 matrix `D[(i + 3 j, k + 3 l)] = dP_ij / dF_kl`.
//!
//! Materials are small `Copy` structs behind the [`Material`] trait; element loops are generic
//! over it, and [`MaterialModel`] dispatches once per loop, never per element.

mod constraint_neo_hookean;
mod corotated;
mod lame;
mod material_model;
mod neo_hookean;
mod stable_neo_hookean;
mod stvk;
mod svd;

pub use constraint_neo_hookean::ConstraintNeoHookean;
pub use corotated::{Corotated, TWIST_DENOMINATOR_FLOOR};
pub use lame::{LameParameters, MaterialError};
pub use material_model::{MaterialFacts, MaterialKind, MaterialModel, UnknownMaterialKind};
pub(crate) use material_model::{dispatch_material, material_table, with_material};
pub use neo_hookean::NeoHookean;
pub use stable_neo_hookean::StableNeoHookean;
pub use stvk::StVenantKirchhoff;
pub use svd::RotationVariantSvd;

use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// The 9×9 derivative of the first Piola–Kirchhoff stress with respect to `vec(F)`.
pub type Matrix9 = SMatrix<f64, 9, 9>;

/// A deformation gradient at which a material's energy is undefined (for example J <= 0 for
/// the course Neo-Hookean, whose J^(-2/3) term has no real value there).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("energy undefined at det F = {det_f:.3e} (element inverted or collapsed)")]
pub struct InvalidDeformation {
    /// det F at the offending deformation.
    pub det_f: f64,
}

impl crate::error_class::Classify for InvalidDeformation {
    /// A state the computation reached.
    fn class(&self) -> crate::error_class::ErrorClass {
        crate::error_class::ErrorClass::Failure
    }
}

/// A hyperelastic strain energy density, evaluated per element at the deformation gradient F.
pub trait Material: Copy + Send + Sync + std::fmt::Debug {
    /// Whether the energy is defined for inverted elements (det F <= 0).
    const HANDLES_INVERSION: bool;

    /// The Lamé parameters the model was built from (before any reparameterization of its
    /// own), so that another package's implementation can be given the same material.
    fn lame(&self) -> LameParameters;

    /// psi(F), energy per unit rest volume.
    fn energy_density(&self, f: &Matrix3<f64>) -> Result<f64, InvalidDeformation>;

    /// P(F) = dpsi/dF.
    fn first_piola(&self, f: &Matrix3<f64>) -> Result<Matrix3<f64>, InvalidDeformation>;

    /// dP/dF as a 9×9 matrix over column-major `vec(F)` (symmetric).
    fn first_piola_derivative(&self, f: &Matrix3<f64>) -> Result<Matrix9, InvalidDeformation>;

    /// The eigensystem of dP/dF in closed form, where the model has one: the nine
    /// eigenvalues and, as columns, orthonormal eigenvectors over column-major `vec(F)`.
    /// `None` (the default): Hessian filters in the `stress` space decompose dP/dF
    /// numerically.
    #[inline]
    fn stress_eigensystem(&self, _f: &Matrix3<f64>) -> Option<(SVector<f64, 9>, Matrix9)> {
        None
    }

    /// For one tet vertex with shape gradient `n` (F changes by `δx nᵀ` when the vertex moves
    /// by δx): `P n` and the vertex's 3×3 Hessian block `Σ_{c,d} n_c n_d ∂P_{·c}/∂F_{·d}`
    /// (per unit rest volume). Vertex block descent needs only these; a material with a
    /// closed form overrides the default, which builds the whole 9×9 derivative.
    #[inline]
    fn vertex_terms(
        &self,
        f: &Matrix3<f64>,
        n: &Vector3<f64>,
    ) -> Result<(Vector3<f64>, Matrix3<f64>), InvalidDeformation> {
        let p = self.first_piola(f)?;
        let d = self.first_piola_derivative(f)?;
        Ok((p * n, vertex_block(&d, n)))
    }
}

/// `Bᵀ D B` for one vertex: `H[r, s] = Σ_{c,d} n_c n_d D[3c+r, 3d+s]` over column-major
/// `vec(F)` (F changes by `δx nᵀ` when the vertex moves by δx).
#[inline]
pub fn vertex_block(d: &Matrix9, n: &Vector3<f64>) -> Matrix3<f64> {
    let mut h = Matrix3::zeros();
    for s in 0..3 {
        let col = d.column(s) * n[0] + d.column(s + 3) * n[1] + d.column(s + 6) * n[2];
        for r in 0..3 {
            h[(r, s)] = n[0] * col[r] + n[1] * col[r + 3] + n[2] * col[r + 6];
        }
    }
    h
}

/// `vec(M)`: the 9 entries of a 3×3 matrix in column-major order, `vec(M)[i + 3 j] = M[(i, j)]`.
#[inline]
pub fn vec9(m: &Matrix3<f64>) -> SVector<f64, 9> {
    SVector::<f64, 9>::from_column_slice(m.as_slice())
}

/// The cofactor matrix cof(F) = det(F) F^{-T} = dJ/dF, defined for every F.
#[inline]
pub fn cofactor(f: &Matrix3<f64>) -> Matrix3<f64> {
    let c0 = f.column(1).cross(&f.column(2));
    let c1 = f.column(2).cross(&f.column(0));
    let c2 = f.column(0).cross(&f.column(1));
    Matrix3::from_columns(&[c0, c1, c2])
}

/// d²J/dF² as a 9×9 matrix over column-major `vec(F)`: the block matrix
/// `[[0, -[f2]x, [f1]x], [[f2]x, 0, -[f0]x], [-[f1]x, [f0]x, 0]]` with `fj` the columns of F.
#[inline]
pub fn det_hessian(f: &Matrix3<f64>) -> Matrix9 {
    let mut h = Matrix9::zeros();
    let cross = |v: nalgebra::VectorView3<f64, nalgebra::U1, nalgebra::U3>| v.cross_matrix();
    let f0 = cross(f.column(0));
    let f1 = cross(f.column(1));
    let f2 = cross(f.column(2));
    h.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-f2));
    h.fixed_view_mut::<3, 3>(0, 6).copy_from(&f1);
    h.fixed_view_mut::<3, 3>(3, 0).copy_from(&f2);
    h.fixed_view_mut::<3, 3>(3, 6).copy_from(&(-f0));
    h.fixed_view_mut::<3, 3>(6, 0).copy_from(&(-f1));
    h.fixed_view_mut::<3, 3>(6, 3).copy_from(&f0);
    h
}
