//! Rosenbrock(-W) methods: linearly implicit Runge–Kutta methods that solve linear systems
//! with one matrix per step instead of Newton iterations, given by their coefficients in the
//! transformed form of Hairer & Wanner (IV.7) as KPP lists them: per stage `i`,
//!
//! `(1/(hγ) I − J) K_i = f(t + α_i h, y + Σ_(j<i) a_ij K_j) + Σ_(j<i) (c_ij / h) K_j + γ_i h f_t`,
//!
//! then `y' = y + Σ m_j K_j`, with `Σ e_j K_j` the error estimate. On `y = [q, v]`,
//! `f = [v, M⁻¹ F(q, v)]`, `J = [[0, I], [−M⁻¹K, −M⁻¹D]]` (K the Hessian of the potential and D
//! the damping matrix, both at the start of the step), so each stage is one solve with
//! `M + hγ D + (hγ)² K` — the matrix of a backward Euler Newton iteration with step `hγ`,
//! assembled and factored once per step and reused by every stage. With `r = hγ (rhs)` split
//! into `[r_q, r_v]`:
//!
//! `(M + hγ D + (hγ)² K) K_q = M r_q + hγ D r_q + hγ M r_v`, `K_v = (K_q − r_q)/(hγ)`,
//!
//! and `M r_v` needs no mass solve (`M M⁻¹ F = F`). Time-dependent potentials (moving anchors,
//! drags) enter through `f_t`, a central difference of the gradient in time when the model has
//! vertex potentials. `J` is exact only without damping of varying `D(q)` and without a Hessian
//! filter that changes it: a W-method (ROS2) keeps its order with any `J`, RODAS3 needs the
//! exact one.

use super::embedded::{EmbeddedPair, StageOutput};
use super::filter::FilterSettings;
use super::newton::axpy;
use super::system::ImplicitSystem;
use super::{State, StepError, StepReport};
use crate::model::Model;
use crate::solve::LinearSolver;

/// A Rosenbrock method in the transformed form (see the module docs).
#[derive(Clone, Copy, Debug)]
pub struct RosenbrockTableau {
    /// Method name as written in scene files.
    pub name: &'static str,
    /// Order of the solution.
    pub order: u32,
    /// Order of the embedded solution.
    pub embedded_order: u32,
    /// The diagonal `γ`.
    pub gamma: f64,
    /// `a_ij`, strictly lower triangular: row `i` has `i` entries.
    pub a: &'static [&'static [f64]],
    /// `c_ij`, strictly lower triangular.
    pub c: &'static [&'static [f64]],
    /// Weights `m_j` of the solution.
    pub m: &'static [f64],
    /// Weights `e_j` of the error estimate.
    pub e: &'static [f64],
    /// Stage times `α_i`.
    pub alpha: &'static [f64],
    /// `γ_i = Σ_j γ_ij`, the weights of `f_t`.
    pub gamma_sum: &'static [f64],
}

impl RosenbrockTableau {
    /// Whether stage `i` evaluates `f` at the same point as stage `i − 1` (so it reuses it).
    fn reuses_f(&self, i: usize) -> bool {
        i > 0
            && self.alpha[i] == self.alpha[i - 1]
            && self.a[i].iter().zip(self.a[i - 1]).all(|(x, y)| x == y)
            && self.a[i].get(i - 1).is_none_or(|x| *x == 0.0)
    }
}

/// A Rosenbrock method (see the module docs).
pub struct Rosenbrock {
    tableau: RosenbrockTableau,
    system: ImplicitSystem,
    kq: Vec<Vec<f64>>,
    kv: Vec<Vec<f64>>,
    yq: Vec<f64>,
    yv: Vec<f64>,
    force: Vec<f64>,
    damping_force: Vec<f64>,
    force_rate: Vec<f64>,
    scratch: Vec<f64>,
    rq: Vec<f64>,
    rhs: Vec<f64>,
    mass_times: Vec<f64>,
}

impl Rosenbrock {
    /// `tableau` solving its systems with `solver`, element Hessians through `filter`.
    pub fn new(
        tableau: RosenbrockTableau,
        solver: Box<dyn LinearSolver>,
        filter: FilterSettings,
    ) -> Self {
        Self {
            tableau,
            system: ImplicitSystem::new(solver, filter),
            kq: Vec::new(),
            kv: Vec::new(),
            yq: Vec::new(),
            yv: Vec::new(),
            force: Vec::new(),
            damping_force: Vec::new(),
            force_rate: Vec::new(),
            scratch: Vec::new(),
            rq: Vec::new(),
            rhs: Vec::new(),
            mass_times: Vec::new(),
        }
    }

    /// The tableau.
    pub fn tableau(&self) -> &RosenbrockTableau {
        &self.tableau
    }

    fn ensure_buffers(&mut self, n: usize) {
        let stages = self.tableau.m.len();
        if self.kq.len() != stages || self.yq.len() != n {
            self.kq = vec![vec![0.0; n]; stages];
            self.kv = vec![vec![0.0; n]; stages];
            for b in [
                &mut self.yq,
                &mut self.yv,
                &mut self.force,
                &mut self.damping_force,
                &mut self.force_rate,
                &mut self.scratch,
                &mut self.rq,
                &mut self.rhs,
                &mut self.mass_times,
            ] {
                *b = vec![0.0; n];
            }
        }
    }

    /// `F(q, v) = −grad V(q) − D(q) v` at the model's time into `self.force`.
    fn force(&mut self, model: &mut Model) -> Result<(), StepError> {
        model.gradient(&self.yq, &mut self.force)?;
        if model.has_damping() {
            model.damping_force(&self.yq, &self.yv, &mut self.damping_force)?;
            axpy(1.0, &self.damping_force, &mut self.force);
        }
        self.force.iter_mut().for_each(|f| *f = -*f);
        if let Some(index) = self.force.iter().position(|f| !f.is_finite()) {
            return Err(StepError::NonFinite {
                what: "force",
                index,
            });
        }
        Ok(())
    }

    /// `∂F/∂t` at `(q, t)` into `self.force_rate` (zero for a model whose potential does not
    /// depend on time: one without vertex potentials).
    fn force_rate(
        &mut self,
        model: &mut Model,
        q: &[f64],
        t: f64,
        h: f64,
    ) -> Result<(), StepError> {
        self.force_rate.fill(0.0);
        if model.vertex_potentials().is_empty() {
            return Ok(());
        }
        let delta = 1e-3 * h;
        model.set_time(t + delta);
        model.gradient(q, &mut self.force_rate)?;
        model.set_time(t - delta);
        model.gradient(q, &mut self.scratch)?;
        for (r, s) in self.force_rate.iter_mut().zip(&self.scratch) {
            *r = -(*r - s) / (2.0 * delta);
        }
        Ok(())
    }

    /// One step of `h` from `start` into `out` (see [`EmbeddedPair::attempt`]).
    fn stages(
        &mut self,
        model: &mut Model,
        start: &State,
        h: f64,
        out: StageOutput<'_>,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let n = start.q.len();
        self.ensure_buffers(n);
        let t = self.tableau;
        let hg = h * t.gamma;
        // The step's one matrix: M + hγ D(q) + (hγ)² K(q) at the start.
        model.set_time(start.t);
        self.system.set_damping(model, &start.q, hg, report)?;
        self.system.begin_solve();
        self.system.factor(model, &start.q, hg * hg, report)?;
        self.force_rate(model, &start.q, start.t, h)?;
        for i in 0..t.m.len() {
            StepError::stop_if_requested()?;
            if !t.reuses_f(i) {
                self.yq.copy_from_slice(&start.q);
                self.yv.copy_from_slice(&start.v);
                for (j, &a) in t.a[i].iter().enumerate() {
                    if a != 0.0 {
                        axpy(a, &self.kq[j], &mut self.yq);
                        axpy(a, &self.kv[j], &mut self.yv);
                    }
                }
                model.set_time(start.t + t.alpha[i] * h);
                self.force(model)?;
            }
            // r_q = hγ (v_Y + Σ c_ij/h K_q,j); M r_v = hγ (F + M Σ c_ij/h K_v,j + γ_i h F_t).
            self.rq.copy_from_slice(&self.yv);
            self.scratch.fill(0.0);
            for (j, &c) in t.c[i].iter().enumerate() {
                if c != 0.0 {
                    axpy(c / h, &self.kq[j], &mut self.rq);
                    axpy(c / h, &self.kv[j], &mut self.scratch);
                }
            }
            self.rq.iter_mut().for_each(|r| *r *= hg);
            model.mass().mul_vec(&self.scratch, &mut self.mass_times);
            let gi = t.gamma_sum[i] * h;
            // rhs = M r_q + hγ D r_q + hγ · hγ (F + M Σ c/h K_v + γ_i h F_t).
            model.mass().mul_vec(&self.rq, &mut self.rhs);
            for k in 0..n {
                self.rhs[k] +=
                    hg * hg * (self.force[k] + self.mass_times[k] + gi * self.force_rate[k]);
            }
            if let Some((d, _)) = self.system.damping() {
                d.mul_vec(&self.rq, &mut self.scratch);
                axpy(hg, &self.scratch, &mut self.rhs);
            }
            self.system.solve(model, &start.q, &mut self.rhs, report)?;
            self.kq[i].copy_from_slice(&self.rhs);
            for k in 0..n {
                self.kv[i][k] = (self.kq[i][k] - self.rq[k]) / hg;
            }
        }
        let StageOutput { q, v, error } = out;
        q.copy_from_slice(&start.q);
        v.copy_from_slice(&start.v);
        for (j, &m) in t.m.iter().enumerate() {
            if m != 0.0 {
                axpy(m, &self.kq[j], q);
                axpy(m, &self.kv[j], v);
            }
        }
        if let Some(err) = error {
            err.fill(0.0);
            let (eq, ev) = err.split_at_mut(n);
            for (j, &e) in t.e.iter().enumerate() {
                if e != 0.0 {
                    axpy(e, &self.kq[j], eq);
                    axpy(e, &self.kv[j], ev);
                }
            }
        }
        Ok(())
    }
}

impl EmbeddedPair for Rosenbrock {
    fn name(&self) -> &'static str {
        self.tableau.name
    }

    fn order(&self) -> u32 {
        self.tableau.order
    }

    fn embedded_order(&self) -> u32 {
        self.tableau.embedded_order
    }

    fn is_explicit(&self) -> bool {
        false
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
