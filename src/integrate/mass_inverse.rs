//! Applying M^{-1} for explicit methods: the model's [`MassInverse`] (a division for lumped
//! mass, a Cholesky solve with the factorization of the constant consistent mass matrix),
//! built on first use.

use super::StepError;
use crate::model::{MassInverse, Model};

/// The accelerations of explicit methods, `a = M^{-1} (-grad V(q) - D(q) v)`, with the mass
/// inverse built on first use and a reusable buffer for the damping force. Public so a method
/// written outside the crate gets the same forces, damping and mass solve as the built-in ones.
#[derive(Default)]
pub struct Dynamics {
    mass: Option<MassInverse>,
    damping_force: Vec<f64>,
}

impl Dynamics {
    /// `a = M^{-1} (-grad V(q) - D(q) v)` at the model's current time (set it with
    /// [`Model::set_time`]); the damping term only when the model has damping.
    pub fn acceleration(
        &mut self,
        model: &mut Model,
        q: &[f64],
        v: &[f64],
        a: &mut [f64],
    ) -> Result<(), StepError> {
        if self.mass.is_none() {
            self.mass = Some(MassInverse::new(model.mass())?);
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
        self.mass.as_mut().expect("built above").apply(a)?;
        Ok(())
    }
}
