//! Explicit Runge–Kutta methods on the first-order system `q' = v, v' = a(q)`, given by their
//! Butcher tableau. Explicit Euler, midpoint, RK4 and Dormand–Prince are tableaus run here.

use super::embedded::{EmbeddedPair, NextState, StageOutput};
use super::mass_inverse::Dynamics;
use super::{Integrator, State, StepError, StepReport};
use crate::model::Model;

/// A Butcher tableau, optionally with embedded weights for an error estimate.
#[derive(Clone, Copy, Debug)]
pub struct Tableau {
    /// Method name as written in scene files.
    pub name: &'static str,
    /// Order of the main weights.
    pub order: u32,
    /// Strictly lower-triangular stage coefficients, row `s` has `s` entries.
    pub a: &'static [&'static [f64]],
    /// Weights of the solution.
    pub b: &'static [f64],
    /// Weights of the embedded solution of order `order - 1`, if any.
    pub b_embedded: Option<&'static [f64]>,
}

/// An explicit Runge–Kutta integrator with preallocated stage storage.
pub struct ExplicitRungeKutta {
    tableau: Tableau,
    dynamics: Dynamics,
    /// Stage derivatives: `kq[s]` (velocities) and `kv[s]` (accelerations).
    kq: Vec<Vec<f64>>,
    kv: Vec<Vec<f64>>,
    q_stage: Vec<f64>,
    v_stage: Vec<f64>,
    /// The next state, swapped with the current one after a successful step.
    next: NextState,
}

impl ExplicitRungeKutta {
    /// An integrator for `tableau`.
    pub fn new(tableau: Tableau) -> Self {
        Self {
            tableau,
            dynamics: Dynamics::default(),
            kq: Vec::new(),
            kv: Vec::new(),
            q_stage: Vec::new(),
            v_stage: Vec::new(),
            next: NextState::default(),
        }
    }

    /// The tableau.
    pub fn tableau(&self) -> &Tableau {
        &self.tableau
    }

    fn ensure_buffers(&mut self, n: usize) {
        let stages = self.tableau.b.len();
        if self.kq.len() != stages || self.q_stage.len() != n {
            self.kq = vec![vec![0.0; n]; stages];
            self.kv = vec![vec![0.0; n]; stages];
            self.q_stage = vec![0.0; n];
            self.v_stage = vec![0.0; n];
        }
    }

    /// Compute all stages from `(q, v)` and write the new state (and the embedded error, if
    /// asked and the tableau has one) into `out`, recording mass solves in `report`.
    pub(crate) fn stages(
        &mut self,
        model: &mut Model,
        start: &State,
        dt: f64,
        out: StageOutput<'_>,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let (q, v) = (&start.q, &start.v);
        let StageOutput {
            q: q_out,
            v: v_out,
            error,
        } = out;
        let n = q.len();
        self.ensure_buffers(n);
        let t = self.tableau;
        for (s, row) in t.a.iter().enumerate() {
            // Stage time t + c_s dt with c_s = sum_j a_sj (time-dependent potentials).
            model.set_time(start.t + dt * row.iter().sum::<f64>());
            self.q_stage.copy_from_slice(q);
            self.v_stage.copy_from_slice(v);
            for (j, &a) in row.iter().enumerate() {
                if a != 0.0 {
                    axpy(dt * a, &self.kq[j], &mut self.q_stage);
                    axpy(dt * a, &self.kv[j], &mut self.v_stage);
                }
            }
            self.kq[s].copy_from_slice(&self.v_stage);
            self.dynamics.acceleration(
                model,
                &self.q_stage,
                &self.v_stage,
                &mut self.kv[s],
                report,
            )?;
        }
        q_out.copy_from_slice(q);
        v_out.copy_from_slice(v);
        for (s, &b) in t.b.iter().enumerate() {
            if b != 0.0 {
                axpy(dt * b, &self.kq[s], q_out);
                axpy(dt * b, &self.kv[s], v_out);
            }
        }
        if let (Some(err), Some(be)) = (error, t.b_embedded) {
            err.fill(0.0);
            let (eq, ev) = err.split_at_mut(n);
            for (((b, b_hat), kq), kv) in t.b.iter().zip(be).zip(&self.kq).zip(&self.kv) {
                let w = dt * (b - b_hat);
                if w != 0.0 {
                    axpy(w, kq, eq);
                    axpy(w, kv, ev);
                }
            }
        }
        Ok(())
    }
}

/// `y += a x`.
#[inline]
pub(crate) fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    y.iter_mut().zip(x).for_each(|(yi, xi)| *yi += a * xi);
}

impl EmbeddedPair for ExplicitRungeKutta {
    fn name(&self) -> &'static str {
        self.tableau.name
    }

    fn order(&self) -> u32 {
        self.tableau.order
    }

    fn embedded_order(&self) -> u32 {
        self.tableau.order - 1
    }

    fn is_explicit(&self) -> bool {
        true
    }

    fn attempt(
        &mut self,
        model: &mut Model,
        start: &State,
        h: f64,
        out: StageOutput<'_>,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.stages(model, start, h, out, report)
    }
}

impl Integrator for ExplicitRungeKutta {
    fn name(&self) -> &'static str {
        self.tableau.name
    }

    fn order(&self) -> u32 {
        self.tableau.order
    }

    fn is_explicit(&self) -> bool {
        true
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let mut next = std::mem::take(&mut self.next);
        let result = next.step(self, model, state, dt, report);
        self.next = next;
        result
    }
}
