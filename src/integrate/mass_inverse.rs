//! Applying M^{-1} for explicit methods: a division for lumped mass, a Cholesky solve with
//! the factorization of the (constant) consistent mass matrix computed once.

use super::StepError;
use crate::model::{MassMatrix, Model};
use crate::solve::{CholeskySolver, DirectSettings, LinearSolver};

/// M^{-1} for one model, built on first use.
pub(crate) enum MassInverse {
    Lumped(Vec<f64>),
    Consistent(Box<CholeskySolver>),
}

impl MassInverse {
    /// Factor (or invert) the model's mass matrix.
    pub fn new(model: &Model) -> Result<Self, StepError> {
        Ok(match model.mass() {
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

    /// `x = M^{-1} x` in place.
    pub fn apply(&mut self, x: &mut [f64]) -> Result<(), StepError> {
        match self {
            Self::Lumped(inv) => x.iter_mut().zip(inv.iter()).for_each(|(xi, mi)| *xi *= mi),
            Self::Consistent(solver) => {
                solver.solve(x)?;
            }
        }
        Ok(())
    }
}

/// The accelerations `a = -M^{-1} grad V(q)`, with the mass inverse built on first use.
pub(crate) fn acceleration(
    model: &mut Model,
    mass: &mut Option<MassInverse>,
    q: &[f64],
    a: &mut [f64],
) -> Result<(), StepError> {
    if mass.is_none() {
        *mass = Some(MassInverse::new(model)?);
    }
    model.gradient(q, a)?;
    // A state that overflowed gives infinite forces: report the state, not the mass solve.
    if let Some(index) = a.iter().position(|f| !f.is_finite()) {
        return Err(StepError::NonFinite {
            what: "force",
            index,
        });
    }
    a.iter_mut().for_each(|x| *x = -*x);
    mass.as_mut().expect("built above").apply(a)
}
