//! The energy balance that decides a blow-up.
//!
//! The mechanical energy `H = kinetic + elastic + springs + gravity + per-vertex potentials`
//! changes only by the work done on the body from outside the conservative system: the
//! explicit time dependence of potentials (a drag target that moves does work
//! `V(x_n, t_n+1) - V(x_n, t_n)` over a step, at fixed positions) and the energy damping
//! removes (`dt vᵀ D v` per step). So a correct method keeps the *excess*
//! `H(t) - H(0) - W_driven(t) + W_damping(t)` at round-off plus its own truncation error
//! (negative when it dissipates), and an unstable one makes it grow without bound.
//!
//! The excess is judged against the energy the body holds or exchanges ([`EnergyScale`]): its
//! kinetic and stored energy at the start, the most gravity has released or taken so far, the
//! most net work the drags have done so far, and (so the scale is never zero) the elastic
//! energy of a 0.1 % dilation of the rest shape. A run is unstable when
//!
//! - its state, an energy, the work done on it, the scale or the excess is no longer finite
//!   (checked whatever the limit, `limit = 0` included: a NaN compares false against any
//!   limit, so it would otherwise pass as success); or
//! - its excess grew past `limit` times that scale *and* is still growing: more than
//!   [`GROWN`] times the largest excess of the run's first half (checked after every step, so
//!   a blow-up stops early; a transient that overshoots at the first step and then decays
//!   never satisfies it); or
//! - at its end, the excess grew exponentially over the run's last half ([`super::growth`]:
//!   sustained growth, however small it still is, is a blow-up the horizon has not reached
//!   yet).
//!
//! A level alone decides nothing: a run that gained more than the scale and kept it without
//! growing (an inexact solver's energy error, a slowly decaying overshoot) completes, and its
//! peak excess says so. Every run reports the fitted growth rate and its peak excess, signed,
//! over the scale.

use super::growth::{Envelope, GrowthFit};
use super::metrics::Energies;
use softbench_core::integrate::State;
use softbench_core::model::{Model, ModelError};

/// The dilation whose elastic energy sets the material part of the energy scale.
pub const REFERENCE_STRAIN: f64 = 1e-3;

/// How much the excess must have grown since the run's first half, past the limit, to stop
/// a run early as a blow-up (see the module docs).
pub const GROWN: f64 = 1e3;

/// The round-off floor of the excess, relative to the magnitudes summed into `H` at the start:
/// below it a logarithm of the excess means nothing.
pub const ROUND_OFF: f64 = 1e-12;

/// The energy the body holds or exchanges (J): the scale the excess is judged against.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct EnergyScale {
    /// Kinetic + elastic + springs at the start (never below zero).
    pub initial: f64,
    /// The largest `|gravity(t) - gravity(0)|` so far: what gravity released or took back.
    pub gravity: f64,
    /// The largest `|W_driven(t)|` so far: net work of the time-dependent potentials (drags).
    pub driven: f64,
    /// Elastic + spring energy of the rest shape dilated by [`REFERENCE_STRAIN`].
    pub material: f64,
}

impl EnergyScale {
    /// The scale of `model` at the start of a run from `initial` energies (nothing exchanged
    /// yet).
    pub fn of(model: &mut Model, initial: &Energies) -> Result<Self, ModelError> {
        let rest = model.rest_state();
        // Dilate the free vertices about their centroid.
        let n = rest.len() / 3;
        let mut centroid = [0.0; 3];
        for x in rest.chunks_exact(3) {
            for k in 0..3 {
                centroid[k] += x[k] / n.max(1) as f64;
            }
        }
        let dilated: Vec<f64> = rest
            .iter()
            .enumerate()
            .map(|(i, x)| centroid[i % 3] + (1.0 + REFERENCE_STRAIN) * (x - centroid[i % 3]))
            .collect();
        let stored = |model: &mut Model, q: &[f64]| -> Result<f64, ModelError> {
            let p = model.potential_parts(q)?;
            Ok(p.elastic + p.springs)
        };
        let material = (stored(model, &dilated)? - stored(model, &rest)?).abs();
        Ok(Self {
            initial: initial.internal().max(0.0),
            gravity: 0.0,
            driven: 0.0,
            material,
        })
    }

    /// The sum of the parts (J).
    pub fn total(&self) -> f64 {
        self.initial + self.gravity + self.driven + self.material
    }
}

/// The running balance of one run.
#[derive(Clone, Debug)]
pub struct EnergyBalance {
    initial_total: f64,
    initial_gravity: f64,
    scale: EnergyScale,
    limit: f64,
    /// Net work of time-dependent potentials (J).
    driven: f64,
    /// Energy removed by damping (J, >= 0).
    dissipated: f64,
    damping: bool,
    force: Vec<f64>,
    /// Steps checked so far.
    steps: usize,
    /// The latest excess (J).
    latest: f64,
    /// The excess over the scale of largest magnitude so far, signed.
    peak: f64,
    /// The largest excess of steps `1..=2^k`, for every `2^k` reached.
    checkpoints: Vec<f64>,
    /// The largest excess so far.
    largest: f64,
    envelope: Envelope,
    /// [`ROUND_OFF`] times the magnitudes summed into the initial energy (J).
    floor: f64,
}

/// Why the balance says a run blew up.
#[derive(Clone, Debug, PartialEq)]
pub enum Violation {
    /// A quantity of the balance (the state, an energy, the work done on the body, the
    /// energy scale or the excess) is no longer finite: whatever the limit, this is never a
    /// completed run.
    NonFinite { what: &'static str, value: f64 },
    /// The excess passed `limit` scales while growing past [`GROWN`] times its first half's.
    Growing { excess: f64, scale: f64, since: f64 },
    /// At the end of the run the excess grew exponentially over the last half.
    Sustained {
        excess: f64,
        scale: f64,
        fit: GrowthFit,
    },
}

impl Violation {
    /// The short cause written in tables.
    pub fn cause(&self) -> &'static str {
        match self {
            Self::NonFinite { .. } => "non-finite state",
            Self::Growing { .. } => "energy growth",
            Self::Sustained { .. } => "sustained energy growth",
        }
    }

    /// The full message, naming the threshold that decided it.
    pub fn message(&self, limit: f64) -> String {
        use super::growth::{MIN_FIT_R2, SUSTAINED_GROWTH};
        match self {
            Self::NonFinite { what, value } => format!("{what} is {value}"),
            Self::Growing {
                excess,
                scale,
                since,
            } => format!(
                "the energy gained beyond the work done on the body, {excess:.4e} J, passed \
                 run.energy_limit = {limit} times the energy the body holds or exchanges \
                 ({scale:.4e} J) and is still growing: {}",
                if *since > 0.0 {
                    format!(
                        "{:.3e} times the most it gained in the first half of the run (more \
                         than {GROWN:e})",
                        excess / since
                    )
                } else {
                    "the first half of the run gained no energy at all".to_owned()
                }
            ),
            Self::Sustained { excess, scale, fit } => format!(
                "the energy gained beyond the work done on the body grew exponentially over \
                 the last half of the run: e-folding rate {:.4e}/s, x{:.3e} (sustained: at \
                 least x{SUSTAINED_GROWTH:e} with R^2 {:.4} >= {MIN_FIT_R2}), to {excess:.4e} J \
                 ({:.3e} of the energy the body holds or exchanges, {scale:.4e} J)",
                fit.rate,
                fit.factor,
                fit.r2,
                excess / scale
            ),
        }
    }
}

impl EnergyBalance {
    /// A balance starting at `initial` with the given scale and limit (0 turns the check off).
    pub fn new(model: &Model, initial: &Energies, scale: EnergyScale, limit: f64) -> Self {
        let magnitudes = initial.kinetic.abs()
            + initial.elastic.abs()
            + initial.springs.abs()
            + initial.gravity.abs()
            + initial.external.abs()
            + scale.total();
        Self {
            initial_total: initial.total(),
            initial_gravity: initial.gravity,
            scale,
            limit,
            driven: 0.0,
            dissipated: 0.0,
            damping: model.has_damping(),
            force: Vec::new(),
            steps: 0,
            latest: 0.0,
            peak: 0.0,
            checkpoints: Vec::with_capacity(64),
            largest: f64::NEG_INFINITY,
            envelope: Envelope::default(),
            floor: (ROUND_OFF * magnitudes).max(f64::MIN_POSITIVE),
        }
    }

    /// Account the work of time-dependent potentials over the step from `state.t` to
    /// `state.t + dt`, at the start-of-step positions. Call before the step.
    pub fn before_step(&mut self, model: &mut Model, state: &State, dt: f64) {
        if model.contact_potential().is_some()
            && let Ok(power) = model.contact_driven_power(&state.q, state.t)
            && power != 0.0
        {
            // Moving obstacles pushing through a contact potential: force times their
            // velocity, at the start of the step.
            self.driven += power * dt;
            self.scale.driven = self.scale.driven.max(self.driven.abs());
        }
        if model.vertex_potentials().is_empty() {
            return;
        }
        let before = model.vertex_energy_at(&state.q, state.t);
        let after = model.vertex_energy_at(&state.q, state.t + dt);
        if let (Ok(b), Ok(a)) = (before, after) {
            self.driven += a - b;
            self.scale.driven = self.scale.driven.max(self.driven.abs());
        }
    }

    /// Account the energy damping removed over a step of `dt` ending at `state`, and check
    /// the balance against `energies` (of `state`) while the run goes on.
    pub fn after_step(
        &mut self,
        model: &mut Model,
        state: &State,
        dt: f64,
        energies: &Energies,
    ) -> Result<(), Violation> {
        if self.damping {
            self.force.resize(state.v.len(), 0.0);
            if model
                .damping_force(&state.q, &state.v, &mut self.force)
                .is_ok()
            {
                // `force` holds D v, so the dissipated power is vᵀ D v.
                let power: f64 = state.v.iter().zip(&self.force).map(|(v, f)| v * f).sum();
                self.dissipated += dt * power.max(0.0);
            }
        }
        // Non-finite is never success, with or without the blow-up limit: a NaN compares
        // false against any limit, so it is checked first and on its own.
        let non_finite = |what, value: f64| {
            if value.is_finite() {
                Ok(())
            } else {
                Err(Violation::NonFinite { what, value })
            }
        };
        if let Some(x) = state.q.iter().chain(&state.v).find(|x| !x.is_finite()) {
            return Err(Violation::NonFinite {
                what: "a coordinate of the state",
                value: *x,
            });
        }
        non_finite("the kinetic energy", energies.kinetic)?;
        let energy = energies.total();
        non_finite("the energy", energy)?;
        non_finite("the work done on the body by drags", self.driven)?;
        non_finite("the energy removed by damping", self.dissipated)?;
        let gravity = (energies.gravity - self.initial_gravity).abs();
        self.scale.gravity = self.scale.gravity.max(gravity);
        non_finite("the energy the body holds or exchanges", self.scale.total())?;
        let excess = self.excess(energy);
        non_finite("the energy gained beyond the work done on the body", excess)?;
        self.steps += 1;
        self.latest = excess;
        let scale = self.scale.total();
        if scale > 0.0 && (excess / scale).abs() > self.peak.abs() {
            self.peak = excess / scale;
        }
        self.largest = self.largest.max(excess);
        if self.steps.is_power_of_two() {
            self.checkpoints.push(self.largest);
        }
        self.envelope.push(state.t, excess);
        if self.limit > 0.0 && self.steps >= 2 && excess > self.limit * scale {
            // The largest excess of steps 1..=2^k with 2^k <= steps / 2.
            let k = (self.steps / 2).ilog2() as usize;
            let since = self.checkpoints[k].max(0.0);
            if excess > GROWN * since {
                return Err(Violation::Growing {
                    excess,
                    scale,
                    since,
                });
            }
        }
        Ok(())
    }

    /// The verdict at the end of a run that took every step: sustained growth (see the
    /// module docs).
    pub fn finish(&self) -> Result<(), Violation> {
        if self.limit <= 0.0 || self.steps == 0 {
            return Ok(());
        }
        let (excess, scale) = (self.latest, self.scale.total());
        match self.growth() {
            Some(fit) if fit.sustained() => Err(Violation::Sustained { excess, scale, fit }),
            _ => Ok(()),
        }
    }

    /// `H - H(0) - W_driven + W_damping` for a mechanical energy `energy` (J).
    pub fn excess(&self, energy: f64) -> f64 {
        energy - self.initial_total - self.driven + self.dissipated
    }

    /// The energy the body holds or exchanges so far (J).
    pub fn scale(&self) -> EnergyScale {
        self.scale
    }

    /// Net work done by time-dependent potentials so far (J).
    pub fn driven_work(&self) -> f64 {
        self.driven
    }

    /// Energy removed by damping so far (J).
    pub fn dissipated(&self) -> f64 {
        self.dissipated
    }

    /// The excess over the scale of largest magnitude so far, signed: positive when energy was
    /// gained, negative when it was lost.
    pub fn peak(&self) -> f64 {
        self.peak
    }

    /// The latest excess over the scale, signed.
    pub fn latest(&self) -> f64 {
        let scale = self.scale.total();
        if scale > 0.0 {
            self.latest / scale
        } else {
            0.0
        }
    }

    /// The exponential fitted to the excess over the last half of the run so far (see
    /// [`super::growth`]); `None` before two windows.
    pub fn growth(&self) -> Option<GrowthFit> {
        self.envelope.fit(self.floor)
    }
}
