//! One-step methods with an embedded error estimate, the unit [`super::adaptive`] step
//! control works with: explicit Runge–Kutta pairs ([`super::runge_kutta`], DOPRI5),
//! diagonally implicit ones ([`super::dirk`]: TR-BDF2, ESDIRK3(2), ESDIRK4(3)) and Rosenbrock
//! ones ([`super::rosenbrock`]). [`FixedStep`] runs any of them at fixed steps.

use super::newton::{IterationRecord, with_halving};
use super::{Integrator, State, StepError, StepReport};
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

/// The state a fixed step of an [`EmbeddedPair`] writes before it is swapped into the caller's
/// (so a failed attempt leaves the state as it was), with no allocation after the first step.
#[derive(Default)]
pub struct NextState {
    q: Vec<f64>,
    v: Vec<f64>,
}

impl NextState {
    /// One step of `h` with `pair` (its error estimate not asked for): `state.q` and `state.v`
    /// become the new state on success and are unchanged on error; counts one substep.
    pub fn step<P: EmbeddedPair + ?Sized>(
        &mut self,
        pair: &mut P,
        model: &mut Model,
        state: &mut State,
        h: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let n = state.q.len();
        self.q.resize(n, 0.0);
        self.v.resize(n, 0.0);
        let out = StageOutput {
            q: &mut self.q,
            v: &mut self.v,
            error: None,
        };
        pair.attempt(model, state, h, out, report)?;
        std::mem::swap(&mut state.q, &mut self.q);
        std::mem::swap(&mut state.v, &mut self.v);
        report.substeps += 1;
        Ok(())
    }
}

/// An embedded pair at fixed steps, its estimate unused: `tr-bdf2`, `esdirk43`, `rodas3` and
/// the other fixed-step variants of the pairs [`super::Adaptive`] controls. A failed step is
/// retried as two halves up to `retry_halvings` times (`integrator.newton.retry_halvings`).
pub struct FixedStep<P: EmbeddedPair> {
    pair: P,
    next: NextState,
    retry_halvings: u32,
}

impl<P: EmbeddedPair> FixedStep<P> {
    /// `pair` at fixed steps.
    pub fn new(pair: P, retry_halvings: u32) -> Self {
        Self {
            pair,
            next: NextState::default(),
            retry_halvings,
        }
    }

    /// The pair.
    pub fn pair(&self) -> &P {
        &self.pair
    }
}

impl<P: EmbeddedPair> Integrator for FixedStep<P> {
    fn name(&self) -> &'static str {
        self.pair.name()
    }

    fn order(&self) -> u32 {
        self.pair.order()
    }

    fn is_explicit(&self) -> bool {
        self.pair.is_explicit()
    }

    fn check_model(&self, model: &Model) -> Result<(), StepError> {
        self.pair.check_model(model)
    }

    fn reset(&mut self) {
        self.pair.reset();
    }

    fn drain_iteration_log(&mut self, out: &mut Vec<IterationRecord>) {
        self.pair.drain_iteration_log(out);
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let (pair, next) = (&mut self.pair, &mut self.next);
        with_halving(self.retry_halvings, state, dt, report, &mut |s, h, r| {
            next.step(pair, model, s, h, r)
        })
    }
}
