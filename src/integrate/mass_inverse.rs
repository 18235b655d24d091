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

/// The accelerations of explicit methods, `a = M^{-1} (-grad V(q) - D(q) v)`, with the mass
/// inverse built on first use and a reusable buffer for the damping force.
#[derive(Default)]
pub(crate) struct Dynamics {
    mass: Option<MassInverse>,
    damping_force: Vec<f64>,
}

impl Dynamics {
    /// `a = M^{-1} (-grad V(q) - D(q) v)`; the damping term only when the model has damping.
    pub fn acceleration(
        &mut self,
        model: &mut Model,
        q: &[f64],
        v: &[f64],
        a: &mut [f64],
    ) -> Result<(), StepError> {
        if self.mass.is_none() {
            self.mass = Some(MassInverse::new(model)?);
        }
        model.gradient(q, a)?;
        if model.has_damping() {
            self.damping_force.resize(a.len(), 0.0);
            model.damping_force(q, v, &mut self.damping_force)?;
            a.iter_mut()
                .zip(&self.damping_force)
                .for_each(|(ai, fi)| *ai += fi);
        }
        // A state that overflowed gives infinite forces: report the state, not the mass solve.
        if let Some(index) = a.iter().position(|f| !f.is_finite()) {
            return Err(StepError::NonFinite {
                what: "force",
                index,
            });
        }
        a.iter_mut().for_each(|x| *x = -*x);
        self.mass.as_mut().expect("built above").apply(a)
    }
}
