//! Physical quantities of a state: energies and momenta over the free DOFs.

use softbench_core::integrate::State;
use softbench_core::model::{Model, ModelError, PotentialParts};

/// Energies of a state (J).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Energies {
    pub kinetic: f64,
    pub elastic: f64,
    pub springs: f64,
    pub gravity: f64,
    /// Per-vertex potentials: contact penalties and drag springs.
    pub external: f64,
    /// The contact barrier's stored energy (incremental potential contact; 0 otherwise).
    pub contact: f64,
}

impl Energies {
    /// Kinetic plus potential.
    pub fn total(&self) -> f64 {
        self.kinetic + self.elastic + self.springs + self.gravity + self.external + self.contact
    }

    /// Kinetic plus stored (elastic and spring) energy: what blows up when a method is
    /// unstable, independent of where the gravity potential's zero is.
    pub fn internal(&self) -> f64 {
        self.kinetic + self.elastic + self.springs
    }
}

/// Computes energies and momenta with reusable buffers.
#[derive(Debug, Default)]
pub struct Metrics {
    mv: Vec<f64>,
}

impl Metrics {
    /// Energies of `state` (one potential evaluation).
    pub fn energies(&mut self, model: &mut Model, state: &State) -> Result<Energies, ModelError> {
        model.set_time(state.t);
        let PotentialParts {
            elastic,
            springs,
            gravity,
            vertex,
            contact: _,
        } = model.potential_parts(&state.q)?;
        let contact = model.contact_stored_energy(&state.q)?;
        self.mv.resize(state.v.len(), 0.0);
        model.mass().mul_vec(&state.v, &mut self.mv);
        let kinetic = 0.5
            * state
                .v
                .iter()
                .zip(&self.mv)
                .map(|(v, p)| v * p)
                .sum::<f64>();
        Ok(Energies {
            kinetic,
            elastic,
            springs,
            gravity,
            external: vertex,
            contact,
        })
    }

    /// Linear momentum `sum_i (M v)_i` per axis, and angular momentum about the origin
    /// `sum_vertices x × (M v)` (kg m/s and kg m^2/s), over free vertices. With consistent
    /// mass these are the discrete quantities the methods conserve.
    pub fn momenta(&mut self, model: &Model, state: &State) -> ([f64; 3], [f64; 3]) {
        self.mv.resize(state.v.len(), 0.0);
        model.mass().mul_vec(&state.v, &mut self.mv);
        let mut p = [0.0; 3];
        let mut l = [0.0; 3];
        for (x, mv) in state.q.chunks_exact(3).zip(self.mv.chunks_exact(3)) {
            for k in 0..3 {
                p[k] += mv[k];
            }
            l[0] += x[1] * mv[2] - x[2] * mv[1];
            l[1] += x[2] * mv[0] - x[0] * mv[2];
            l[2] += x[0] * mv[1] - x[1] * mv[0];
        }
        (p, l)
    }
}
