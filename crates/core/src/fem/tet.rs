//! Rest-shape data and kernels of one linear tetrahedron.

use crate::material::Matrix9;
use nalgebra::{Matrix3, SMatrix, Vector3};

/// A 12×12 element matrix.
pub type Matrix12 = SMatrix<f64, 12, 12>;

/// A tet whose rest volume is not positive (given with its signed volume).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
#[error("rest volume {volume:.3e} is not positive")]
pub struct DegenerateTet {
    pub volume: f64,
}

impl crate::error_class::Classify for DegenerateTet {
    /// A mesh's tet without volume.
    fn class(&self) -> crate::error_class::ErrorClass {
        crate::error_class::ErrorClass::BadInput
    }
}

/// Precomputed rest data of a linear tet: its rest volume and `Dm^{-1}`, whose rows are the
/// (constant) gradients of the shape functions N1, N2, N3; `grad N0 = -(grad N1 + grad N2 + grad N3)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TetRest {
    /// Rest volume (positive).
    pub volume: f64,
    /// Inverse of the rest edge matrix `Dm = [X1 - X0, X2 - X0, X3 - X0]`.
    pub dm_inv: Matrix3<f64>,
}

impl TetRest {
    /// From the rest positions of the four vertices; the tet must be positively oriented.
    pub fn new(x: &[Vector3<f64>; 4]) -> Result<Self, DegenerateTet> {
        let dm = Matrix3::from_columns(&[x[1] - x[0], x[2] - x[0], x[3] - x[0]]);
        let volume = dm.determinant() / 6.0;
        // Reject zero and near-zero volumes relative to the edge lengths (a sliver of
        // numerically zero volume has no usable inverse).
        let scale = dm.norm().powi(3);
        if volume.is_nan() || volume <= 1e-14 * scale {
            return Err(DegenerateTet { volume });
        }
        let dm_inv = dm.try_inverse().ok_or(DegenerateTet { volume })?;
        Ok(Self { volume, dm_inv })
    }

    /// Gradient of shape function `a` (constant over the element).
    #[inline]
    pub fn shape_gradient(&self, a: usize) -> Vector3<f64> {
        match a {
            0 => -(self.dm_inv.row(0) + self.dm_inv.row(1) + self.dm_inv.row(2)).transpose(),
            _ => self.dm_inv.row(a - 1).transpose(),
        }
    }

    /// The four shape-function gradients.
    #[inline]
    pub fn shape_gradients(&self) -> [Vector3<f64>; 4] {
        [0, 1, 2, 3].map(|a| self.shape_gradient(a))
    }

    /// The deformation gradient `F = Ds Dm^{-1}` at current positions `x`.
    #[inline]
    pub fn deformation_gradient(&self, x: &[Vector3<f64>; 4]) -> Matrix3<f64> {
        let ds = Matrix3::from_columns(&[x[1] - x[0], x[2] - x[0], x[3] - x[0]]);
        ds * self.dm_inv
    }

    /// Element gradient `dE/dx = volume * P * grad N_a` for each vertex, written to `out[0..12]`.
    #[inline]
    pub fn gradient_from_stress(&self, p: &Matrix3<f64>, out: &mut [f64]) {
        let h = p * self.dm_inv.transpose() * self.volume;
        let mut g0 = Vector3::zeros();
        for a in 1..4 {
            let col = h.column(a - 1);
            out[3 * a..3 * a + 3].copy_from_slice(col.as_slice());
            g0 -= col;
        }
        out[0..3].copy_from_slice(g0.as_slice());
    }

    /// Element Hessian `volume * B^T (dP/dF) B`, written block-major to `out[0..144]`, where
    /// `B = d vec(F) / dx` has entries `dF_ij / dx_{a,i} = grad N_a[j]`.
    #[inline]
    pub fn hessian_from_stress_derivative(&self, d: &Matrix9, out: &mut [f64]) {
        let grads = self.shape_gradients();
        // t = dP/dF * B, a 9×12 matrix: t[m, 3b + k] = sum_l D[m, k + 3l] * gradN_b[l].
        let mut t = SMatrix::<f64, 9, 12>::zeros();
        for (b, gb) in grads.iter().enumerate() {
            for k in 0..3 {
                let col = d.column(k) * gb[0] + d.column(k + 3) * gb[1] + d.column(k + 6) * gb[2];
                t.column_mut(3 * b + k).copy_from(&col);
            }
        }
        // H = volume * B^T t: H[3a + i, c] = volume * sum_j gradN_a[j] * t[i + 3j, c].
        let v = self.volume;
        for c in 0..12 {
            let tc = t.column(c);
            for (a, ga) in grads.iter().enumerate() {
                let s = [ga[0] * v, ga[1] * v, ga[2] * v];
                let o = super::block_offset(4, a, c / 3) + 3 * (c % 3);
                for i in 0..3 {
                    out[o + i] = s[0] * tc[i] + s[1] * tc[i + 3] + s[2] * tc[i + 6];
                }
            }
        }
    }
}
