//! One-step methods with an embedded error estimate, the unit [`super::adaptive`] step
//! control works with: explicit Runge–Kutta pairs ([`super::runge_kutta`], DOPRI5) and
//! diagonally implicit ones ([`super::dirk`]: TR-BDF2, ESDIRK3(2), ESDIRK4(3)).

use super::newton::IterationRecord;
use super::{State, StepError, StepReport};
use crate::model::Model;

/// Where an attempt writes the new state and the difference between the main and the
/// embedded solutions (stacked `[dq, dv]`, length `2n`; `None` when no estimate is wanted).
pub struct StageOutput<'a> {
    pub q: &'a mut [f64],
    pub v: &'a mut [f64],
    pub error: Option<&'a mut [f64]>,
}

/// A one-step method that estimates its own local error.
pub trait EmbeddedPair: Send {
    /// Name as written in scene files.
    fn name(&self) -> &'static str;

    /// Order of the solution that is kept.
    fn order(&self) -> u32;

    /// Order of the embedded solution.
    fn embedded_order(&self) -> u32;

    /// The order of the error estimate: the estimate is `O(h^(p + 1))` with `p` the smaller
    /// of the two orders.
    fn error_order(&self) -> u32 {
        self.order().min(self.embedded_order())
    }

    /// Whether it never solves a linear system with the stiffness.
    fn is_explicit(&self) -> bool;

    /// Refuse a model it cannot integrate (see [`super::Integrator::check_model`]).
    fn check_model(&self, _model: &Model) -> Result<(), StepError> {
        Ok(())
    }

    /// One step of `h` from `start` (whose `t` is the start time) into `out`, recording work
    /// in `report`. A Newton solve that stopped unconverged counts in
    /// `report.newton_unconverged`.
    fn attempt(
        &mut self,
        model: &mut Model,
        start: &State,
        h: f64,
        out: StageOutput<'_>,
        report: &mut StepReport,
    ) -> Result<(), StepError>;

    /// Forget history kept between steps.
    fn reset(&mut self) {}

    /// Move Newton iteration records into `out` (implicit pairs with `log_iterations`).
    fn drain_iteration_log(&mut self, _out: &mut Vec<IterationRecord>) {}
}
