//! The mass matrix over free DOFs: consistent (sparse, same pattern as the Hessian) or lumped
//! (diagonal), and its inverse as an operator ([`MassInverse`]).

use crate::solve::{CholeskySolver, DirectSettings, LinearSolver, SolveError};
use crate::sparse::SymmetricMatrix;

/// Which mass discretization a model uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MassKind {
    /// `rho vol / 20 (1 + delta_ab)` per tet: exact for linear shape functions.
    #[default]
    Consistent,
    /// `rho vol / 4` per vertex of each tet: diagonal, cheap to invert.
    Lumped,
}

/// The mass matrix over free DOFs.
#[derive(Clone, Debug)]
pub enum MassMatrix {
    /// Sparse, over the Hessian's pattern.
    Consistent(SymmetricMatrix),
    /// Diagonal entries per DOF, plus where they sit in the Hessian pattern.
    Lumped {
        diagonal: Vec<f64>,
        diagonal_slots: Vec<usize>,
    },
}

impl MassMatrix {
    /// The mass matrix as a [`nalgebra_sparse::CscMatrix`]: the consistent matrix with its
    /// pattern and values copied once ([`SymmetricMatrix::to_csc`]), a lumped one as a
    /// diagonal matrix (one entry per column).
    pub fn to_csc(&self) -> nalgebra_sparse::CscMatrix<f64> {
        match self {
            Self::Consistent(m) => m.to_csc(),
            Self::Lumped { diagonal, .. } => {
                let n = diagonal.len();
                nalgebra_sparse::CscMatrix::try_from_csc_data(
                    n,
                    n,
                    (0..=n).collect(),
                    (0..n).collect(),
                    diagonal.clone(),
                )
                .expect("a diagonal is a valid CSC matrix")
            }
        }
    }

    /// Which discretization this is.
    pub fn kind(&self) -> MassKind {
        match self {
            Self::Consistent(_) => MassKind::Consistent,
            Self::Lumped { .. } => MassKind::Lumped,
        }
    }

    /// `y = M x`.
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) {
        match self {
            Self::Consistent(m) => m.mul_vec(x, y),
            Self::Lumped { diagonal, .. } => {
                for ((yi, xi), mi) in y.iter_mut().zip(x).zip(diagonal) {
                    *yi = mi * xi;
                }
            }
        }
    }

    /// `a = s * a + M` for a matrix over the Hessian pattern (e.g. `dt^2 K + M`).
    pub fn scale_and_add_to(&self, s: f64, a: &mut SymmetricMatrix) {
        match self {
            Self::Consistent(m) => a.axpby(s, 1.0, m),
            Self::Lumped {
                diagonal,
                diagonal_slots,
            } => {
                let values = a.values_mut();
                values.iter_mut().for_each(|v| *v *= s);
                for (&slot, &m) in diagonal_slots.iter().zip(diagonal) {
                    values[slot] += m;
                }
            }
        }
    }

    /// `a += alpha M` for a matrix over the Hessian pattern.
    pub fn add_scaled_to(&self, alpha: f64, a: &mut SymmetricMatrix) {
        match self {
            Self::Consistent(m) => a.axpby(1.0, alpha, m),
            Self::Lumped {
                diagonal,
                diagonal_slots,
            } => {
                let values = a.values_mut();
                for (&slot, &m) in diagonal_slots.iter().zip(diagonal) {
                    values[slot] += alpha * m;
                }
            }
        }
    }

    /// Sum of `x^T M x` style row sums: the diagonal of the lumped matrix, or the row sums of
    /// the consistent one (equal for linear tets).
    pub fn row_sums(&self) -> Vec<f64> {
        match self {
            Self::Consistent(m) => {
                let ones = vec![1.0; m.dim()];
                let mut y = vec![0.0; m.dim()];
                m.mul_vec(&ones, &mut y);
                y
            }
            Self::Lumped { diagonal, .. } => diagonal.clone(),
        }
    }
}

/// Applying `M^{-1}` to vectors: a division for lumped mass, a solve with the sparse Cholesky
/// factorization of the (constant) consistent mass matrix, computed once. Explicit integrators
/// and the spectrum estimate both use it.
pub(crate) enum MassInverse {
    Lumped(Vec<f64>),
    Consistent(Box<CholeskySolver>),
}

impl MassInverse {
    /// Factor (or invert) `mass`. Fails only if the consistent matrix is not positive definite.
    pub fn new(mass: &MassMatrix) -> Result<Self, SolveError> {
        Ok(match mass {
            MassMatrix::Lumped { diagonal, .. } => {
                Self::Lumped(diagonal.iter().map(|m| 1.0 / m).collect())
            }
            MassMatrix::Consistent(m) => {
                let mut solver = CholeskySolver::new(DirectSettings::default());
                solver.analyze(m.pattern())?;
                solver.factor(m)?;
                Self::Consistent(Box::new(solver))
            }
        })
    }

    /// Whether applying the inverse is a linear solve (consistent mass), not a division.
    pub fn is_solve(&self) -> bool {
        matches!(self, Self::Consistent(_))
    }

    /// `x = M^{-1} x` in place. Fails on a wrong length or a non-finite entry of `x`
    /// (consistent mass; the lumped division passes them through).
    pub fn apply(&mut self, x: &mut [f64]) -> Result<(), SolveError> {
        match self {
            Self::Lumped(inv) => x.iter_mut().zip(inv.iter()).for_each(|(xi, mi)| *xi *= mi),
            Self::Consistent(solver) => {
                solver.solve(x)?;
            }
        }
        Ok(())
    }
}
