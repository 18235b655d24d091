//! Adaptive step control. Each call to `advance(dt)` covers exactly `dt` (an output interval)
//! with as many internal steps as the error tolerance needs; the internal step size carries
//! over between calls.
//!
//! The local error comes either from step doubling (the seeds' Baraff–Witkin scheme: one step
//! of h against two of h/2, around any method; the two-half-step result is kept) or from an
//! embedded pair ([`EmbeddedPair`]: Dormand–Prince 5(4), and the implicit TR-BDF2,
//! ESDIRK3(2) and ESDIRK4(3) of [`super::dirk`]). Its size is the RMS over all DOFs of
//! `e_i / (atol + rtol * max(|y_i|, |y_new_i|))` with `y = [q, v]`, as ODE solvers measure it;
//! a step is accepted when that is <= 1. The next step comes from a [`Controller`] (I, PI or
//! PID, `adaptive.controller`), times `safety`, clamped to [`AdaptiveSettings::min_shrink`,
//! `AdaptiveSettings::max_growth`].
//!
//! An attempt that fails — a Newton solve that fails or stops unconverged at its cap, a linear
//! solve that fails, an inverted element, a non-finite state — is rejected like one whose
//! error is too large, retried `min_shrink` times smaller, and counted apart
//! (`failed_substeps`), so Newton's iteration cap decides how many steps are taken, never
//! whether an unconverged stage is kept.

use super::controller::{Controller, StepController};
use super::embedded::{EmbeddedPair, StageOutput};
use super::{Integrator, State, StepError, StepReport};
use crate::model::Model;

/// Knobs of adaptive step control.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AdaptiveSettings {
    /// Relative error tolerance per step (`rtol`). Default 1e-6.
    #[serde(alias = "rtol")]
    pub tolerance: f64,
    /// Absolute error tolerance per step (`atol`, units of q and v). Default 1e-9.
    #[serde(alias = "atol")]
    pub absolute_tolerance: f64,
    /// The step-size controller. Default `i` (elementary).
    pub controller: Controller,
    /// The controller's gains `[k1, k2, k3]`; default: the controller's own.
    pub gains: Option<[f64; 3]>,
    /// Safety factor on the proposed step. Default 0.9.
    pub safety: f64,
    /// Smallest internal step before the step fails with `StepTooSmall` (s). Default 1e-12.
    pub min_dt: f64,
    /// Largest internal step (s). Default: no limit beyond the output interval.
    pub max_dt: Option<f64>,
    /// Largest step growth per step. Default 5.
    pub max_growth: f64,
    /// Largest step reduction per step. Default 0.2.
    pub min_shrink: f64,
    /// Internal steps (accepted + rejected) allowed per call before the step fails with
    /// `TooManySubsteps`, so a method that cannot meet the tolerance does not grind forever
    /// (adaptive explicit Euler on the armadillo needs about a million per 0.01 s). Default
    /// 100,000.
    pub max_substeps: u64,
}

impl Default for AdaptiveSettings {
    fn default() -> Self {
        Self {
            tolerance: 1e-6,
            absolute_tolerance: 1e-9,
            controller: Controller::I,
            gains: None,
            safety: 0.9,
            min_dt: 1e-12,
            max_dt: None,
            max_growth: 5.0,
            min_shrink: 0.2,
            max_substeps: 100_000,
        }
    }
}

impl AdaptiveSettings {
    /// The controller's gains: `gains` if set, else the controller's defaults.
    pub fn controller_gains(&self) -> [f64; 3] {
        self.gains.unwrap_or(self.controller.facts().0)
    }

    /// Check every field's range; the message names the field and the valid range.
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("adaptive.tolerance", self.tolerance),
            ("adaptive.min_dt", self.min_dt),
        ];
        for (key, v) in positive {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{key} must be a positive number (got {v})"));
            }
        }
        if !(self.absolute_tolerance.is_finite() && self.absolute_tolerance >= 0.0) {
            return Err(format!(
                "adaptive.absolute_tolerance must be >= 0 (got {})",
                self.absolute_tolerance
            ));
        }
        if !(self.safety > 0.0 && self.safety <= 1.0) {
            return Err(format!(
                "adaptive.safety must be in (0, 1] (got {})",
                self.safety
            ));
        }
        if !(self.min_shrink > 0.0 && self.min_shrink < 1.0) {
            return Err(format!(
                "adaptive.min_shrink must be in (0, 1) (got {})",
                self.min_shrink
            ));
        }
        if !(self.max_growth > 1.0 && self.max_growth.is_finite()) {
            return Err(format!(
                "adaptive.max_growth must be > 1 (got {})",
                self.max_growth
            ));
        }
        if let Some(g) = self.gains
            && !g.iter().all(|k| k.is_finite() && (-2.0..=2.0).contains(k))
        {
            return Err(format!(
                "adaptive.gains must be three numbers in [-2, 2] (got {g:?})"
            ));
        }
        if let Some(g) = self.gains
            && g[0] <= 0.0
        {
            return Err(format!("adaptive.gains[0] (k1) must be > 0 (got {})", g[0]));
        }
        if self.max_dt.is_some_and(|m| !(m.is_finite() && m > 0.0)) {
            return Err("adaptive.max_dt must be a positive number".into());
        }
        if self.max_substeps == 0 {
            return Err("adaptive.max_substeps must be >= 1".into());
        }
        Ok(())
    }
}

/// Where the error estimate comes from.
pub enum ErrorEstimate {
    /// One step of h against two of h/2 with the given method.
    StepDoubling(Box<dyn Integrator>),
    /// An embedded pair.
    Embedded(Box<dyn EmbeddedPair>),
}

/// An adaptive integrator (see the module docs).
pub struct Adaptive {
    name: &'static str,
    estimate: ErrorEstimate,
    settings: AdaptiveSettings,
    /// The internal step proposed for the next attempt.
    h: Option<f64>,
    full: State,
    half: State,
    current: State,
    error: Vec<f64>,
    /// The accepted internal steps of the last call (see [`Integrator::internal_steps`]).
    accepted: Vec<f64>,
    controller: StepController,
}

impl Adaptive {
    /// Step control by step doubling around `inner`, named `name` (e.g. "adaptive-rk4").
    pub fn step_doubling(
        name: &'static str,
        inner: Box<dyn Integrator>,
        settings: AdaptiveSettings,
    ) -> Self {
        Self::new(name, ErrorEstimate::StepDoubling(inner), settings)
    }

    /// Step control with the embedded error of `pair`, under its name.
    pub fn embedded(pair: Box<dyn EmbeddedPair>, settings: AdaptiveSettings) -> Self {
        Self::new(pair.name(), ErrorEstimate::Embedded(pair), settings)
    }

    /// The same under another name (`adaptive-esdirk43` around `esdirk43`).
    pub fn embedded_named(
        name: &'static str,
        pair: Box<dyn EmbeddedPair>,
        settings: AdaptiveSettings,
    ) -> Self {
        Self::new(name, ErrorEstimate::Embedded(pair), settings)
    }

    fn new(name: &'static str, estimate: ErrorEstimate, settings: AdaptiveSettings) -> Self {
        Self {
            name,
            estimate,
            settings,
            h: None,
            full: State::default(),
            half: State::default(),
            current: State::default(),
            error: Vec::new(),
            accepted: Vec::new(),
            controller: StepController::new(settings.controller_gains()),
        }
    }

    /// The internal step the controller will try next, if it has one.
    pub fn current_step(&self) -> Option<f64> {
        self.h
    }

    /// Order of the error estimate (p in the step-size formula).
    fn error_order(&self) -> u32 {
        match &self.estimate {
            ErrorEstimate::StepDoubling(inner) => inner.order(),
            ErrorEstimate::Embedded(pair) => pair.error_order(),
        }
    }

    /// Whether a failed attempt may be retried smaller: the failures a smaller step can cure.
    fn retriable(&self, e: &StepError) -> bool {
        match e {
            StepError::NonFinite { .. } | StepError::InvertedElement { .. } => true,
            StepError::NewtonFailed { .. } | StepError::Solver(_) => !self.is_explicit(),
            _ => false,
        }
    }

    /// Cover `dt` from `current` (which becomes the end state) with accepted internal steps.
    fn cover(
        &mut self,
        model: &mut Model,
        current: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let s = self.settings;
        let k = self.error_order() as f64 + 1.0;
        let max_dt = s.max_dt.unwrap_or(f64::INFINITY).min(dt);
        let mut proposed = self.h.unwrap_or(dt).min(max_dt);
        let mut remaining = dt;
        let mut attempts = 0u64;
        self.accepted.clear();
        while remaining > 0.0 {
            StepError::stop_if_requested()?;
            // Error control can cover one step with any number of internal steps: the run's
            // budget is checked before each.
            StepError::stop_if_over_budget(model, report)?;
            attempts += 1;
            if attempts > s.max_substeps {
                return Err(StepError::TooManySubsteps {
                    substeps: s.max_substeps,
                    dt: proposed,
                });
            }
            // Finish the interval exactly; a last step within 1e-12 of the rest takes the rest.
            let last = proposed >= remaining * (1.0 - 1e-12);
            let h = if last { remaining } else { proposed };
            let unconverged = report.newton_unconverged;
            let outcome = self.attempt(model, current, h, report);
            // An unconverged stage makes the estimate meaningless: a failed attempt.
            let err = match outcome {
                Ok(e) if e.is_finite() && report.newton_unconverged == unconverged => Some(e),
                Ok(_) => None,
                Err(e) if self.retriable(&e) => None,
                Err(e) => {
                    return Err(e);
                }
            };
            match err {
                Some(e) if e <= 1.0 => {
                    std::mem::swap(current, &mut self.half);
                    current.t += h;
                    remaining = if last { 0.0 } else { remaining - h };
                    report.substeps += 1;
                    self.accepted.push(h);
                    // Keep the proposal (and the controller's history) of a full step: a
                    // truncated last step says nothing new.
                    if !last || h >= proposed {
                        let factor = (s.safety * self.controller.accepted(e, k))
                            .clamp(s.min_shrink, s.max_growth);
                        proposed = (h * factor).min(max_dt);
                    }
                }
                Some(e) => {
                    report.rejected_substeps += 1;
                    let factor = (s.safety * self.controller.rejected(e, k)).max(s.min_shrink);
                    proposed = h * factor;
                }
                None => {
                    report.rejected_substeps += 1;
                    report.failed_substeps += 1;
                    self.controller.failed();
                    proposed = h * s.min_shrink;
                }
            }
            if proposed < s.min_dt {
                return Err(StepError::StepTooSmall {
                    dt: proposed,
                    min_dt: s.min_dt,
                });
            }
        }
        self.h = Some(proposed);
        Ok(())
    }

    /// Try one internal step of `h` from `state`; on success the candidate is in `self.half`
    /// and the scaled error norm is returned.
    fn attempt(
        &mut self,
        model: &mut Model,
        state: &State,
        h: f64,
        report: &mut StepReport,
    ) -> Result<f64, StepError> {
        let n = state.q.len();
        self.half.clone_from(state);
        match &mut self.estimate {
            ErrorEstimate::StepDoubling(inner) => {
                self.full.clone_from(state);
                let mut sub = StepReport::default();
                inner.advance(model, &mut self.full, h, &mut sub)?;
                inner.advance(model, &mut self.half, 0.5 * h, &mut sub)?;
                self.half.t += 0.5 * h;
                inner.advance(model, &mut self.half, 0.5 * h, &mut sub)?;
                self.half.t = state.t;
                report.absorb(&StepReport { substeps: 0, ..sub });
                self.error.resize(2 * n, 0.0);
                let (eq, ev) = self.error.split_at_mut(n);
                for i in 0..n {
                    eq[i] = self.half.q[i] - self.full.q[i];
                    ev[i] = self.half.v[i] - self.full.v[i];
                }
            }
            ErrorEstimate::Embedded(pair) => {
                self.error.resize(2 * n, 0.0);
                let out = StageOutput {
                    q: &mut self.half.q,
                    v: &mut self.half.v,
                    error: Some(&mut self.error),
                };
                pair.attempt(model, state, h, out, report)?;
            }
        }
        let s = &self.settings;
        let mut sum = 0.0;
        for i in 0..n {
            let sq =
                s.absolute_tolerance + s.tolerance * state.q[i].abs().max(self.half.q[i].abs());
            let sv =
                s.absolute_tolerance + s.tolerance * state.v[i].abs().max(self.half.v[i].abs());
            sum += (self.error[i] / sq).powi(2) + (self.error[n + i] / sv).powi(2);
        }
        Ok((sum / (2 * n).max(1) as f64).sqrt())
    }
}

impl Integrator for Adaptive {
    fn name(&self) -> &'static str {
        self.name
    }

    fn order(&self) -> u32 {
        match &self.estimate {
            ErrorEstimate::StepDoubling(inner) => inner.order(),
            ErrorEstimate::Embedded(pair) => pair.order(),
        }
    }

    fn is_explicit(&self) -> bool {
        match &self.estimate {
            ErrorEstimate::StepDoubling(inner) => inner.is_explicit(),
            ErrorEstimate::Embedded(pair) => pair.is_explicit(),
        }
    }

    fn check_model(&self, model: &Model) -> Result<(), StepError> {
        match &self.estimate {
            ErrorEstimate::StepDoubling(inner) => inner.check_model(model),
            ErrorEstimate::Embedded(pair) => pair.check_model(model),
        }
    }

    fn drain_iteration_log(&mut self, out: &mut Vec<super::newton::IterationRecord>) {
        match &mut self.estimate {
            ErrorEstimate::StepDoubling(inner) => inner.drain_iteration_log(out),
            ErrorEstimate::Embedded(pair) => pair.drain_iteration_log(out),
        }
    }

    fn reset(&mut self) {
        self.h = None;
        self.controller.reset();
        match &mut self.estimate {
            ErrorEstimate::StepDoubling(inner) => inner.reset(),
            ErrorEstimate::Embedded(pair) => pair.reset(),
        }
    }

    fn internal_steps(&self) -> &[f64] {
        &self.accepted
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let mut current = std::mem::take(&mut self.current);
        current.clone_from(state);
        let result = self.cover(model, &mut current, dt, report);
        if result.is_ok() {
            state.q.copy_from_slice(&current.q);
            state.v.copy_from_slice(&current.v);
        }
        self.current = current;
        result
    }
}
