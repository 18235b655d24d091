//! The Newmark family: Newmark(β, γ), and generalized-α (Chung & Hulbert 1993) with HHT-α
//! (Hilber, Hughes & Taylor 1977) as its `α_m = 0` member — one scheme, four parameters.
//!
//! With the state's acceleration `a_n` carried along, the Newmark updates
//!
//! `q' = q + dt v + dt² ((1/2 - β) a_n + β a')`, `v' = v + dt ((1 - γ) a_n + γ a')`
//!
//! and the balance at the generalized midpoints
//!
//! `(1 - α_m) M a' + α_m M a_n = (1 - α_f) f(q', v') + α_f f(q, v)`
//!
//! make `q'` the minimizer of an incremental potential on the one Newton loop: with the
//! Newmark predictor `x_N = q + dt v + dt² (1/2 - β) a_n` and `c = β dt² / (1 - α_m)`,
//! `x_hat = x_N - c α_m a_n`, `beta = c (1 - α_f)` and the constant force term
//! `l = c α_f (grad V(q) + D v)` at the start time. Forces are averaged (`f(q')` and `f(q)`,
//! not `f` at an averaged position), which keeps the step a minimization.
//!
//! - Newmark: `α_m = α_f = 0`. Trapezoidal (average acceleration, β = 1/4, γ = 1/2) is
//!   second order, unconditionally stable and conserves the energy of a linear system
//!   exactly; γ > 1/2 damps high frequencies at the cost of first order; 2β ≥ γ ≥ 1/2 is
//!   needed for unconditional stability.
//! - Generalized-α from the spectral radius at infinite frequency ρ∞ ∈ [0, 1]:
//!   `α_m = (2ρ∞ - 1)/(ρ∞ + 1)`, `α_f = ρ∞/(ρ∞ + 1)`, `γ = 1/2 - α_m + α_f`,
//!   `β = (1 - α_m + α_f)²/4`: second order, ρ∞ = 1 is trapezoidal, smaller values damp the
//!   highest modes more while leaving the low ones nearly untouched.
//! - HHT-α with α ∈ [-1/3, 0]: `α_m = 0`, `α_f = -α`, `γ = 1/2 - α`, `β = (1 - α)²/4`.
//!
//! The first step (and any after a reset) starts from the acceleration `M⁻¹ f(q, v)`.

use super::mass_inverse::Dynamics;
use super::scheme::{Scheme, StepProblem};
use super::{State, StepError};
use crate::model::Model;

/// `[integrator.newmark]`: β and γ of plain Newmark. Default trapezoidal (1/4, 1/2).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NewmarkSettings {
    /// β in (0, 1]. Default 1/4.
    pub beta: f64,
    /// γ in [1/2, 1]. Default 1/2.
    pub gamma: f64,
}

impl Default for NewmarkSettings {
    fn default() -> Self {
        Self {
            beta: 0.25,
            gamma: 0.5,
        }
    }
}

/// `[integrator.generalized_alpha]`. Default ρ∞ = 0.8.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GeneralizedAlphaSettings {
    /// Spectral radius at infinite frequency, in [0, 1]. Default 0.8.
    pub rho_infinity: f64,
}

impl Default for GeneralizedAlphaSettings {
    fn default() -> Self {
        Self { rho_infinity: 0.8 }
    }
}

/// `[integrator.hht]`. Default α = -0.1.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HhtSettings {
    /// α in [-1/3, 0]. Default -0.1.
    pub alpha: f64,
}

impl Default for HhtSettings {
    fn default() -> Self {
        Self { alpha: -0.1 }
    }
}

impl NewmarkSettings {
    /// Check the ranges; the message names the field and the valid range.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.beta > 0.0 && self.beta <= 1.0) {
            return Err(format!(
                "newmark.beta = {} must lie in (0, 1] (β = 0 is an explicit method)",
                self.beta
            ));
        }
        if !(0.5..=1.0).contains(&self.gamma) {
            return Err(format!(
                "newmark.gamma = {} must lie in [0.5, 1] (γ < 1/2 amplifies every mode)",
                self.gamma
            ));
        }
        Ok(())
    }
}

impl GeneralizedAlphaSettings {
    /// Check the range.
    pub fn validate(&self) -> Result<(), String> {
        if !(0.0..=1.0).contains(&self.rho_infinity) {
            return Err(format!(
                "generalized_alpha.rho_infinity = {} must lie in [0, 1]",
                self.rho_infinity
            ));
        }
        Ok(())
    }
}

impl HhtSettings {
    /// Check the range.
    pub fn validate(&self) -> Result<(), String> {
        if !(-1.0 / 3.0..=0.0).contains(&self.alpha) {
            return Err(format!("hht.alpha = {} must lie in [-1/3, 0]", self.alpha));
        }
        Ok(())
    }
}

/// The four parameters of the family.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NewmarkParameters {
    pub beta: f64,
    pub gamma: f64,
    pub alpha_m: f64,
    pub alpha_f: f64,
}

impl NewmarkParameters {
    /// Plain Newmark.
    pub fn newmark(s: NewmarkSettings) -> Self {
        Self {
            beta: s.beta,
            gamma: s.gamma,
            alpha_m: 0.0,
            alpha_f: 0.0,
        }
    }

    /// Generalized-α from ρ∞.
    pub fn generalized_alpha(s: GeneralizedAlphaSettings) -> Self {
        let r = s.rho_infinity;
        let alpha_m = (2.0 * r - 1.0) / (r + 1.0);
        let alpha_f = r / (r + 1.0);
        let d = 1.0 - alpha_m + alpha_f;
        Self {
            beta: 0.25 * d * d,
            gamma: 0.5 - alpha_m + alpha_f,
            alpha_m,
            alpha_f,
        }
    }

    /// HHT-α.
    pub fn hht(s: HhtSettings) -> Self {
        let a = s.alpha;
        Self {
            beta: 0.25 * (1.0 - a) * (1.0 - a),
            gamma: 0.5 - a,
            alpha_m: 0.0,
            alpha_f: -a,
        }
    }

    /// 2 when γ = 1/2 - α_m + α_f (second-order condition), else 1.
    pub fn order(&self) -> u32 {
        if (self.gamma - (0.5 - self.alpha_m + self.alpha_f)).abs() < 1e-12 {
            2
        } else {
            1
        }
    }
}

/// A member of the Newmark family with the acceleration it carries.
pub struct Newmark {
    name: &'static str,
    params: NewmarkParameters,
    dynamics: Dynamics,
    /// `a_n` and the time it belongs to.
    a: Vec<f64>,
    a_time: Option<f64>,
    /// This step's Newmark predictor `x_N` and `v + dt (1 - γ) a_n`.
    x_newmark: Vec<f64>,
    v_tilde: Vec<f64>,
    damping_force: Vec<f64>,
}

impl Newmark {
    /// The scheme `name` with `params`.
    pub fn new(name: &'static str, params: NewmarkParameters) -> Self {
        Self {
            name,
            params,
            dynamics: Dynamics::default(),
            a: Vec::new(),
            a_time: None,
            x_newmark: Vec::new(),
            v_tilde: Vec::new(),
            damping_force: Vec::new(),
        }
    }

    /// The parameters.
    pub fn parameters(&self) -> NewmarkParameters {
        self.params
    }
}

impl Scheme for Newmark {
    fn name(&self) -> &'static str {
        self.name
    }

    fn order(&self) -> u32 {
        self.params.order()
    }

    fn prepare(
        &mut self,
        model: &mut Model,
        state: &State,
        dt: f64,
        p: &mut StepProblem,
    ) -> Result<(), StepError> {
        let n = state.q.len();
        let NewmarkParameters {
            beta,
            gamma,
            alpha_m,
            alpha_f,
        } = self.params;
        let current = matches!(self.a_time,
            Some(t) if (t - state.t).abs() <= 1e-12 * (state.t.abs() + dt));
        if !current || self.a.len() != n {
            self.a.resize(n, 0.0);
            model.set_time(state.t);
            self.dynamics
                .acceleration(model, &state.q, &state.v, &mut self.a, &mut p.work)?;
            self.a_time = Some(state.t);
        }
        self.x_newmark.resize(n, 0.0);
        self.v_tilde.resize(n, 0.0);
        let c = beta * dt * dt / (1.0 - alpha_m);
        for i in 0..n {
            let (q, v, a) = (state.q[i], state.v[i], self.a[i]);
            self.x_newmark[i] = q + dt * v + dt * dt * (0.5 - beta) * a;
            self.v_tilde[i] = v + dt * (1.0 - gamma) * a;
            p.x_hat[i] = self.x_newmark[i] - c * alpha_m * a;
        }
        p.beta = c * (1.0 - alpha_f);
        p.force_time = state.t + dt;
        if alpha_f > 0.0 {
            // l = c α_f (grad V(q) + D v), the start-of-step force at the start time.
            p.linear.resize(n, 0.0);
            model.set_time(state.t);
            model.gradient(&state.q, &mut p.linear)?;
            if model.has_damping() {
                self.damping_force.resize(n, 0.0);
                model.damping_force(&state.q, &state.v, &mut self.damping_force)?;
                p.linear
                    .iter_mut()
                    .zip(&self.damping_force)
                    .for_each(|(l, f)| *l += f);
            }
            p.linear.iter_mut().for_each(|l| *l *= c * alpha_f);
        }
        // Damping -D v' with v' = ṽ + γ/(β dt) (x - x_N): weight beta γ/(β dt), zero at
        // x = x_N - β dt ṽ / γ.
        p.damping_weight = p.beta * gamma / (beta * dt);
        for i in 0..n {
            p.damping_anchor[i] = self.x_newmark[i] - beta * dt * self.v_tilde[i] / gamma;
        }
        p.damping_at.copy_from_slice(&self.x_newmark);
        p.guess.copy_from_slice(&self.x_newmark);
        Ok(())
    }

    fn finish(&mut self, state: &mut State, dt: f64, x: &[f64], _p: &StepProblem) {
        let NewmarkParameters { beta, gamma, .. } = self.params;
        for (i, &x) in x.iter().enumerate() {
            let a = (x - self.x_newmark[i]) / (beta * dt * dt);
            self.a[i] = a;
            state.v[i] = self.v_tilde[i] + gamma * dt * a;
            state.q[i] = x;
        }
        self.a_time = Some(state.t + dt);
    }

    fn reset(&mut self) {
        self.a_time = None;
    }
}
