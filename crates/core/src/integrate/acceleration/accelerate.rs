//! The [`Accelerate`] trait: what every acceleration of a local solver's iteration does.

use crate::integrate::{StepError, StepReport};

/// One acceleration of a fixed-point iteration `x_{k+1} = G(x_k)` over free DOFs.
pub trait Accelerate: Send + std::fmt::Debug {
    /// Start a step at the first iterate `x0` (its buffers sized for `x0.len()` DOFs,
    /// reallocated only when that changes), forgetting the previous step's history.
    fn start(&mut self, x0: &[f64]);

    /// `x` holds the plain iterate `G(x_k)` of the last accepted iterate on entry and the
    /// accepted `x_{k+1}` on return. `energy(y)` is the incremental potential at `y` (only
    /// safeguarded accelerations call it).
    fn update(
        &mut self,
        x: &mut [f64],
        energy: &mut dyn FnMut(&[f64]) -> Result<f64, StepError>,
    ) -> Result<(), StepError>;

    /// Add what this step did (ρ used, fallbacks) to `report`.
    fn report(&self, report: &mut StepReport);
}
