//! Adaptive step control. Each call to `advance(dt)` covers exactly `dt` (an output interval)
//! with as many internal steps as the error tolerance needs; the internal step size carries
//! over between calls.
//!
//! The local error comes either from step doubling (the seeds' Baraff–Witkin scheme: one step
//! of h against two of h/2, for any explicit method; the two-half-step result is kept) or from
//! an embedded Runge–Kutta pair (Dormand–Prince 5(4)). Its size is the RMS over all DOFs of
//! `e_i / (atol + rtol * max(|y_i|, |y_new_i|))` with `y = [q, v]`; a step is accepted when
//! that is <= 1, and the next step is `h * safety * (1 / err)^(1 / (p + 1))`, with p the order
//! of the error estimate, the change clamped to [`AdaptiveSettings::min_shrink`,
//! `AdaptiveSettings::max_growth`].

use super::runge_kutta::{ExplicitRungeKutta, StageOutput};
use super::{Integrator, State, StepError, StepReport};
use crate::model::Model;

/// Knobs of adaptive step control.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AdaptiveSettings {
    /// Relative error tolerance per step. Default 1e-6.
    pub tolerance: f64,
    /// Absolute error tolerance per step (units of q and v). Default 1e-9.
    pub absolute_tolerance: f64,
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
            safety: 0.9,
            min_dt: 1e-12,
            max_dt: None,
            max_growth: 5.0,
            min_shrink: 0.2,
            max_substeps: 100_000,
        }
    }
}

/// Where the error estimate comes from.
pub enum ErrorEstimate {
    /// One step of h against two of h/2 with the given method.
    StepDoubling(Box<dyn Integrator>),
    /// The embedded pair of an explicit Runge–Kutta tableau.
    Embedded(Box<ExplicitRungeKutta>),
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

    /// Step control with the embedded error of `rk` (its tableau must have embedded weights).
    pub fn embedded(rk: ExplicitRungeKutta, settings: AdaptiveSettings) -> Self {
        assert!(
            rk.tableau().b_embedded.is_some(),
            "{} has no embedded pair",
            rk.tableau().name
        );
        Self::new(
            rk.tableau().name,
            ErrorEstimate::Embedded(Box::new(rk)),
            settings,
        )
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
            ErrorEstimate::Embedded(rk) => rk.tableau().order - 1,
        }
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
            ErrorEstimate::Embedded(rk) => {
                self.error.resize(2 * n, 0.0);
                let out = StageOutput {
                    q: &mut self.half.q,
                    v: &mut self.half.v,
                    error: Some(&mut self.error),
                };
                rk.stages(model, state, h, out, report)?;
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
            ErrorEstimate::Embedded(rk) => rk.tableau().order,
        }
    }

    fn is_explicit(&self) -> bool {
        true
    }

    fn reset(&mut self) {
        self.h = None;
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
        let s = self.settings;
        let exponent = 1.0 / (self.error_order() as f64 + 1.0);
        let max_dt = s.max_dt.unwrap_or(f64::INFINITY).min(dt);
        let mut proposed = self.h.unwrap_or(dt).min(max_dt);
        let mut current = std::mem::take(&mut self.current);
        current.clone_from(state);
        let mut remaining = dt;
        let mut attempts = 0u64;
        self.accepted.clear();
        while remaining > 0.0 {
            StepError::stop_if_requested()?;
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
            let outcome = self.attempt(model, &current, h, report);
            let err = match outcome {
                Ok(e) if e.is_finite() => Some(e),
                // A failed or non-finite attempt is a rejection with the largest reduction.
                Ok(_) | Err(StepError::NonFinite { .. } | StepError::InvertedElement { .. }) => {
                    None
                }
                Err(e) => return Err(e),
            };
            let factor = match err {
                Some(e) if e > 0.0 => {
                    (s.safety * e.powf(-exponent)).clamp(s.min_shrink, s.max_growth)
                }
                Some(_) => s.max_growth,
                None => s.min_shrink,
            };
            if matches!(err, Some(e) if e <= 1.0) {
                std::mem::swap(&mut current, &mut self.half);
                current.t += h;
                remaining = if last { 0.0 } else { remaining - h };
                report.substeps += 1;
                self.accepted.push(h);
                // Keep the proposal of a full step: a truncated last step says nothing new.
                if !last || h >= proposed {
                    proposed = (h * factor).min(max_dt);
                }
            } else {
                report.rejected_substeps += 1;
                proposed = h * factor;
            }
            if proposed < s.min_dt {
                return Err(StepError::StepTooSmall {
                    dt: proposed,
                    min_dt: s.min_dt,
                });
            }
        }
        self.h = Some(proposed);
        state.q.copy_from_slice(&current.q);
        state.v.copy_from_slice(&current.v);
        self.current = current;
        Ok(())
    }
}
