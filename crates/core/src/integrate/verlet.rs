//! Velocity Verlet (central differences in velocity form, Störmer–Verlet):
//!
//! `v_½ = v + dt/2 a(q, v)`, `q' = q + dt v_½`, `v' = v_½ + dt/2 a(q', v')`.
//!
//! Second order, explicit, symplectic and time-reversible: at a stable step (`dt < 2/ω_max`)
//! its energy error stays bounded, and it conserves linear and angular momentum (lumped mass)
//! to round-off. Without damping the end-of-step acceleration is the next step's first
//! (one force evaluation per step). With damping `a(q', v')` depends on `v'`; it is evaluated
//! at `v_½ + dt/2 a(q', v_½)`, one correction that keeps second order (two evaluations per
//! step).

use super::mass_inverse::Dynamics;
use super::{Integrator, State, StepError, StepReport};
use crate::model::Model;

/// A velocity Verlet integrator.
#[derive(Default)]
pub struct VelocityVerlet {
    dynamics: Dynamics,
    /// The acceleration at the start of the next step, and that step's time and positions'
    /// identity (it is reused only when the state is the one this integrator left).
    a: Vec<f64>,
    a_for: Option<(f64, u64)>,
    v_pred: Vec<f64>,
    /// The start of the step, restored if the step fails.
    start: State,
}

impl VelocityVerlet {
    /// A new integrator.
    pub fn new() -> Self {
        Self::default()
    }
}

/// A cheap fingerprint of a state, so a stored acceleration is never reused for a state
/// changed from outside.
fn fingerprint(state: &State) -> u64 {
    state
        .q
        .iter()
        .chain(&state.v)
        .fold(0xcbf2_9ce4_8422_2325u64, |h, x| {
            (h ^ x.to_bits()).wrapping_mul(0x0100_0000_01b3)
        })
}

impl Integrator for VelocityVerlet {
    fn name(&self) -> &'static str {
        "velocity-verlet"
    }

    fn order(&self) -> u32 {
        2
    }

    fn is_explicit(&self) -> bool {
        true
    }

    fn reset(&mut self) {
        self.a_for = None;
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let n = state.q.len();
        let start = (state.t, fingerprint(state));
        if self.a_for != Some(start) || self.a.len() != n {
            self.a.resize(n, 0.0);
            model.set_time(state.t);
            self.dynamics
                .acceleration(model, &state.q, &state.v, &mut self.a, report)?;
        }
        self.a_for = None;
        self.start.clone_from(state);
        for ((q, v), a) in state.q.iter_mut().zip(state.v.iter_mut()).zip(&self.a) {
            *v += 0.5 * dt * a;
            *q += dt * *v;
        }
        model.set_time(state.t + dt);
        let result = self
            .dynamics
            .acceleration(model, &state.q, &state.v, &mut self.a, report)
            .and_then(|()| {
                if !model.has_damping() {
                    return Ok(());
                }
                self.v_pred.clear();
                self.v_pred
                    .extend(state.v.iter().zip(&self.a).map(|(v, a)| v + 0.5 * dt * a));
                self.dynamics
                    .acceleration(model, &state.q, &self.v_pred, &mut self.a, report)
            });
        if let Err(e) = result {
            state.clone_from(&self.start);
            return Err(e);
        }
        for (v, a) in state.v.iter_mut().zip(&self.a) {
            *v += 0.5 * dt * a;
        }
        self.a_for = Some((state.t + dt, fingerprint(state)));
        report.substeps = 1;
        Ok(())
    }
}
