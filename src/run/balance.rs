//! The energy balance that decides a blow-up.
//!
//! The mechanical energy `H = kinetic + elastic + springs + gravity + per-vertex potentials`
//! changes only by the work done on the body from outside the conservative system: the
//! explicit time dependence of potentials (a drag target that moves does work
//! `V(x_n, t_n+1) - V(x_n, t_n)` over a step, at fixed positions) and the energy damping
//! removes (`dt vᵀ D v` per step). So a correct method keeps the *excess*
//! `H(t) - H(0) - W_driven(t) + W_damping(t)` at or below round-off plus its own truncation
//! error, and an unstable one makes it grow without bound. A run is unstable when the excess
//! exceeds `limit` times the scene's energy scale: the initial kinetic and stored energy, the
//! energy gravity would release if the body fell by its own size (`M |g| L`), the elastic
//! energy of a 0.1 % dilation of the rest shape (a material scale that is never zero, never
//! round-off), and the positive work done on the body so far.
//!
//! Gravity is part of `H`, so an explicit step that gains kinetic energy before the body has
//! moved is balanced by nothing but its own (tiny) truncation error, not compared with a
//! gravity work of zero.

use super::metrics::Energies;
use crate::integrate::State;
use crate::model::{Model, ModelError};

/// The dilation whose elastic energy sets the material part of the energy scale.
pub const REFERENCE_STRAIN: f64 = 1e-3;

/// The parts of a scene's energy scale (J), computed once at the start of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct EnergyScale {
    /// Kinetic + elastic + springs at the start (never below zero).
    pub initial: f64,
    /// `M |g| L`: the energy gravity releases if the body falls by its bounding-box diagonal.
    pub gravity: f64,
    /// Elastic + spring energy of the rest shape dilated by [`REFERENCE_STRAIN`].
    pub material: f64,
}

impl EnergyScale {
    /// The scale of `model` starting from `initial` energies.
    pub fn of(model: &mut Model, initial: &Energies) -> Result<Self, ModelError> {
        let rest = model.rest_state();
        let mass: f64 = model.vertex_masses().iter().sum();
        let g = model.gravity().map_or(0.0, |g| g.norm());
        let positions = model.rest_positions();
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let diagonal = (0..3).map(|k| (hi[k] - lo[k]).powi(2)).sum::<f64>().sqrt();
        let diagonal = if diagonal.is_finite() { diagonal } else { 0.0 };
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
            gravity: mass * g * diagonal,
            material,
        })
    }

    /// The sum of the parts (J).
    pub fn total(&self) -> f64 {
        self.initial + self.gravity + self.material
    }
}

/// The running balance of one run.
#[derive(Clone, Debug)]
pub struct EnergyBalance {
    initial_total: f64,
    scale: EnergyScale,
    limit: f64,
    /// Net work of time-dependent potentials (J).
    driven: f64,
    /// Positive part of that work, summed step by step (J).
    work_in: f64,
    /// Energy removed by damping (J, >= 0).
    dissipated: f64,
    damping: bool,
    force: Vec<f64>,
    /// Largest `excess / budget` so far.
    peak_ratio: f64,
    /// `(t, excess)` at the first step whose excess passed [`ONSET`] budgets, and at the
    /// step before the latest: the ends of the growth-rate estimate.
    onset: Option<(f64, f64)>,
    previous: Option<(f64, f64)>,
    latest: Option<(f64, f64)>,
}

/// The excess (in budgets) from which its growth is timed for [`EnergyBalance::growth_rate`].
pub const ONSET: f64 = 1e-6;

/// Why the balance says a run blew up.
#[derive(Clone, Debug, PartialEq)]
pub struct Violation {
    pub excess: f64,
    pub budget: f64,
    pub energy: f64,
}

impl EnergyBalance {
    /// A balance starting at `initial` with the given scale and limit (0 turns the check off).
    pub fn new(model: &Model, initial: &Energies, scale: EnergyScale, limit: f64) -> Self {
        Self {
            initial_total: initial.total(),
            scale,
            limit,
            driven: 0.0,
            work_in: 0.0,
            dissipated: 0.0,
            damping: model.has_damping(),
            force: Vec::new(),
            peak_ratio: 0.0,
            onset: None,
            previous: None,
            latest: None,
        }
    }

    /// Account the work of time-dependent potentials over the step from `state.t` to
    /// `state.t + dt`, at the start-of-step positions. Call before the step.
    pub fn before_step(&mut self, model: &mut Model, state: &State, dt: f64) {
        if model.vertex_potentials().is_empty() {
            return;
        }
        let before = model.vertex_energy_at(&state.q, state.t);
        let after = model.vertex_energy_at(&state.q, state.t + dt);
        if let (Ok(b), Ok(a)) = (before, after) {
            self.driven += a - b;
            self.work_in += (a - b).max(0.0);
        }
    }

    /// Account the energy damping removed over a step of `dt` ending at `state`, and check
    /// the balance against `energies` (of `state`).
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
        let energy = energies.total();
        let excess = self.excess(energy);
        let budget = self.budget();
        if budget > 0.0 && excess.is_finite() {
            self.peak_ratio = self.peak_ratio.max(excess / budget);
        }
        if excess.is_finite() {
            if self.onset.is_none() && excess > ONSET * budget {
                self.onset = Some((state.t, excess));
            }
            self.previous = self.latest;
            self.latest = Some((state.t, excess));
        }
        if self.limit > 0.0 && (!energy.is_finite() || excess > self.limit * budget) {
            return Err(Violation {
                excess,
                budget,
                energy,
            });
        }
        Ok(())
    }

    /// `H - H(0) - W_driven + W_damping` for a mechanical energy `energy` (J).
    pub fn excess(&self, energy: f64) -> f64 {
        energy - self.initial_total - self.driven + self.dissipated
    }

    /// The energy scale plus the positive work done on the body so far (J).
    pub fn budget(&self) -> f64 {
        self.scale.total() + self.work_in
    }

    /// Net work done by time-dependent potentials so far (J).
    pub fn driven_work(&self) -> f64 {
        self.driven
    }

    /// Energy removed by damping so far (J).
    pub fn dissipated(&self) -> f64 {
        self.dissipated
    }

    /// Largest `excess / budget` seen.
    pub fn peak_ratio(&self) -> f64 {
        self.peak_ratio
    }

    /// The e-folding rate (1/s) at which the excess grew from its onset ([`ONSET`] budgets)
    /// to the latest step, or over the latest step if it jumped past the onset in one step;
    /// `None` while it has not grown past the onset.
    pub fn growth_rate(&self) -> Option<f64> {
        let (t1, e1) = self.latest?;
        let (t0, e0) = match self.onset {
            Some((t, e)) if t < t1 => (t, e),
            _ => self.previous.filter(|(_, e)| *e > 0.0)?,
        };
        (e1 > e0 && e0 > 0.0 && t1 > t0).then(|| (e1 / e0).ln() / (t1 - t0))
    }
}
