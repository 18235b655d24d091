//! Applying M^{-1} for explicit methods: the model's [`MassInverse`] (a division for lumped
//! mass, a Cholesky solve with the factorization of the constant consistent mass matrix),
//! built on first use. Consistent-mass solves are counted and timed in the step's report
//! (`mass_solves`, the `mass_solve` phase), so a study shows what the mass matrix costs.

use super::{StepError, StepReport};
use crate::model::{MassInverse, Model};
use std::time::Instant;

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
    /// [`Model::set_time`]); the damping term only when the model has damping. With
    /// consistent mass, records one mass solve and its time in `report`, and on first use
    /// the mass matrix's symbolic analysis and factorization (time in the `factor` phase).
    pub fn acceleration(
        &mut self,
        model: &mut Model,
        q: &[f64],
        v: &[f64],
        a: &mut [f64],
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        if self.mass.is_none() {
            let start = Instant::now();
            let mass = MassInverse::new(model.mass())?;
            if mass.is_solve() {
                report.times.factor += start.elapsed().as_secs_f64();
                report.symbolic_analyses += 1;
                report.factorizations += 1;
            }
            self.mass = Some(mass);
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
        let mass = self.mass.as_mut().expect("built above");
        if mass.is_solve() {
            let start = Instant::now();
            mass.apply(a)?;
            report.times.mass_solve += start.elapsed().as_secs_f64();
            report.mass_solves += 1;
        } else {
            mass.apply(a)?;
        }
        Ok(())
    }
}
