//! Projection of symmetric element matrices to the nearest positive semi-definite matrix
//! (eigenvalue clamp), so that Newton's method gets a descent direction from non-convex energies.

use nalgebra::{SMatrix, SymmetricEigen};

/// Symmetric matrices that can be projected to positive semi-definite.
pub trait ProjectToPsd {
    /// Replace `self` by `Q max(Lambda, 0) Q^T`, the nearest PSD matrix in the Frobenius norm.
    /// Returns whether anything was clamped; an already PSD matrix is left untouched.
    fn project_to_psd(&mut self) -> bool;
}

macro_rules! impl_project {
    ($($n:literal),*) => {$(
        impl ProjectToPsd for SMatrix<f64, $n, $n> {
            fn project_to_psd(&mut self) -> bool {
                let eig = SymmetricEigen::new(*self);
                if eig.eigenvalues.iter().all(|&l| l >= 0.0) {
                    return false;
                }
                let clamped = eig.eigenvalues.map(|l| l.max(0.0));
                *self = &eig.eigenvectors
                    * SMatrix::<f64, $n, $n>::from_diagonal(&clamped)
                    * eig.eigenvectors.transpose();
                true
            }
        }
    )*};
}

impl_project!(3, 6, 9, 12);

/// Project an element matrix to PSD (see [`ProjectToPsd`]).
pub fn project_to_psd<M: ProjectToPsd>(m: &mut M) -> bool {
    m.project_to_psd()
}
