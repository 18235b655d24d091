//! Diagonally implicit Runge–Kutta methods (SDIRK/ESDIRK) on the one Newton loop, given by
//! their Butcher tableau with an embedded pair: each implicit stage is one minimization of an
//! incremental potential, the same one backward Euler's step is.
//!
//! On `q' = v`, `M v' = f(q, v)` a stage `i` of a tableau `a` (lower triangular with diagonal
//! `a_ii`) has `Q_i = q + h Σ_j a_ij V_j` and `V_i = v + h Σ_j a_ij A_j`. With the known parts
//! `q~ = q + h Σ_(j<i) a_ij V_j`, `v~ = v + h Σ_(j<i) a_ij A_j` and `g = h a_ii` this is
//!
//! `Q_i = argmin 1/2 |x - (q~ + g v~)|²_M + g² V(x)` (+ damping `g/2 (x - q~)ᵀ D (x - q~)`),
//!
//! then `V_i = (Q_i - q~)/g` and `A_i = (V_i - v~)/g`: no mass solve, the same Newton loop,
//! line search, filters and criteria as every other implicit scheme. An explicit first stage
//! (`a_11 = 0`, the "E" of ESDIRK) is `Q_1 = q`, `V_1 = v`, `A_1 = M^(-1) f(q, v)` (one force
//! evaluation and, with consistent mass, one mass solve). The step is
//! `q + h Σ b_j V_j`, `v + h Σ b_j A_j` (for a stiffly accurate tableau, `b` = the last row,
//! exactly the last stage), and `h Σ (b_j - b^_j) [V_j; A_j]` estimates its local error.
//!
//! Damping `D(x)` is evaluated where the stage starts (`q~ + g v~`), within `O(h²)` of the
//! stage; for methods above order 2 on a damped model each stage is solved once more with `D`
//! at the first solution, so the damping term's error stays below the method's order.
//!
//! A `Dirk` is an [`EmbeddedPair`]: at fixed steps (`tr-bdf2`, `esdirk32`, `esdirk43`) it runs
//! in a [`super::embedded::FixedStep`], a failed step retried as two halves
//! (`newton.retry_halvings`) as every scheme on the Newton loop; with error control
//! ([`super::Adaptive`], `adaptive-*`) each attempt is one step of the pair.

use super::embedded::{EmbeddedPair, StageOutput};
use super::mass_inverse::Dynamics;
use super::newton::{IterationRecord, Newton, NewtonSettings, axpy};
use super::scheme::{StepProblem, minimize_problem};
use super::{State, StepError, StepReport};
use crate::model::Model;
use crate::solve::LinearSolver;

/// A diagonally implicit Runge–Kutta tableau with an embedded pair.
#[derive(Clone, Copy, Debug)]
pub struct DirkTableau {
    /// Method name as written in scene files.
    pub name: &'static str,
    /// Order of the solution that is kept.
    pub order: u32,
    /// Order of the embedded solution.
    pub embedded_order: u32,
    /// Lower-triangular stage coefficients with the diagonal: row `i` has `i + 1` entries.
    pub a: &'static [&'static [f64]],
    /// Weights of the solution.
    pub b: &'static [f64],
    /// Weights of the embedded solution.
    pub b_embedded: &'static [f64],
}

impl DirkTableau {
    /// The stage times `c_i = Σ_j a_ij`.
    pub fn c(&self, i: usize) -> f64 {
        self.a[i].iter().sum()
    }

    /// Whether the solution is the last stage (`b` = the last row of `a`).
    pub fn stiffly_accurate(&self) -> bool {
        self.a.last().is_some_and(|row| *row == self.b)
    }

    /// Whether every stage after the first is implicit with one diagonal value (so one
    /// factorization pattern and one `beta` serve every stage).
    pub fn singly_diagonal(&self) -> bool {
        let diag: Vec<f64> = (0..self.a.len()).map(|i| self.a[i][i]).collect();
        diag.iter()
            .skip(1)
            .all(|&d| d == diag[diag.len() - 1] && d > 0.0)
    }
}

/// A DIRK method on the Newton loop (see the module docs).
pub struct Dirk {
    tableau: DirkTableau,
    newton: Newton,
    dynamics: Dynamics,
    problem: StepProblem,
    x: Vec<f64>,
    /// Stage velocities `V_j` and accelerations `A_j`.
    vel: Vec<Vec<f64>>,
    acc: Vec<Vec<f64>>,
    q_tilde: Vec<f64>,
    v_tilde: Vec<f64>,
}

impl Dirk {
    /// `tableau` solving its stages with `solver` and `settings`.
    pub fn new(
        tableau: DirkTableau,
        solver: Box<dyn LinearSolver>,
        settings: NewtonSettings,
    ) -> Self {
        Self {
            tableau,
            newton: Newton::new(solver, settings),
            dynamics: Dynamics::default(),
            problem: StepProblem::default(),
            x: Vec::new(),
            vel: Vec::new(),
            acc: Vec::new(),
            q_tilde: Vec::new(),
            v_tilde: Vec::new(),
        }
    }

    /// The tableau.
    pub fn tableau(&self) -> &DirkTableau {
        &self.tableau
    }

    /// The Newton solver (its settings and the trace of the last stage's solve).
    pub fn newton(&self) -> &Newton {
        &self.newton
    }

    fn ensure_buffers(&mut self, n: usize) {
        let stages = self.tableau.b.len();
        if self.vel.len() != stages || self.q_tilde.len() != n {
            self.vel = vec![vec![0.0; n]; stages];
            self.acc = vec![vec![0.0; n]; stages];
            self.q_tilde = vec![0.0; n];
            self.v_tilde = vec![0.0; n];
        }
    }

    /// Solve implicit stage `i` (diagonal `diag`) into `self.vel[i]`, `self.acc[i]`, with
    /// `self.q_tilde`, `self.v_tilde` holding its known parts.
    fn implicit_stage(
        &mut self,
        model: &mut Model,
        t: f64,
        h: f64,
        i: usize,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let g = h * self.tableau.a[i][i];
        let n = self.q_tilde.len();
        let p = &mut self.problem;
        p.reset(n);
        for k in 0..n {
            p.x_hat[k] = self.q_tilde[k] + g * self.v_tilde[k];
        }
        p.beta = g * g;
        p.force_time = t + self.tableau.c(i) * h;
        p.damping_weight = g;
        p.damping_anchor.copy_from_slice(&self.q_tilde);
        p.damping_at.copy_from_slice(&p.x_hat);
        p.guess.copy_from_slice(&p.x_hat);
        minimize_problem(
            &mut self.newton,
            model,
            p,
            &self.q_tilde,
            &mut self.x,
            report,
        )?;
        // Above order 2, damping evaluated at the predictor would cap the order at 2: solve
        // again with D at the stage's first solution.
        if self.tableau.order > 2 && model.has_damping() {
            p.damping_at.copy_from_slice(&self.x);
            p.guess.copy_from_slice(&self.x);
            minimize_problem(
                &mut self.newton,
                model,
                p,
                &self.q_tilde,
                &mut self.x,
                report,
            )?;
        }
        for k in 0..n {
            let v = (self.x[k] - self.q_tilde[k]) / g;
            self.vel[i][k] = v;
            self.acc[i][k] = (v - self.v_tilde[k]) / g;
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
        for i in 0..t.a.len() {
            StepError::stop_if_requested()?;
            self.q_tilde.copy_from_slice(&start.q);
            self.v_tilde.copy_from_slice(&start.v);
            for j in 0..i {
                let a = t.a[i][j];
                if a != 0.0 {
                    axpy(h * a, &self.vel[j], &mut self.q_tilde);
                    axpy(h * a, &self.acc[j], &mut self.v_tilde);
                }
            }
            if t.a[i][i] == 0.0 {
                // An explicit stage: Q_i = q~, V_i = v~, A_i = M^-1 f(Q_i, V_i).
                model.set_time(start.t + t.c(i) * h);
                self.vel[i].copy_from_slice(&self.v_tilde);
                self.dynamics.acceleration(
                    model,
                    &self.q_tilde,
                    &self.v_tilde,
                    &mut self.acc[i],
                    report,
                )?;
                self.x.clone_from(&self.q_tilde);
            } else {
                self.implicit_stage(model, start.t, h, i, report)?;
            }
        }
        let StageOutput { q, v, error } = out;
        if t.stiffly_accurate() {
            // The last stage itself: its positions are the Newton solution, unrounded.
            q.copy_from_slice(&self.x);
            v.copy_from_slice(&self.vel[t.a.len() - 1]);
        } else {
            q.copy_from_slice(&start.q);
            v.copy_from_slice(&start.v);
            for (j, &b) in t.b.iter().enumerate() {
                if b != 0.0 {
                    axpy(h * b, &self.vel[j], q);
                    axpy(h * b, &self.acc[j], v);
                }
            }
        }
        if let Some(err) = error {
            err.fill(0.0);
            let (eq, ev) = err.split_at_mut(n);
            for (j, (b, b_hat)) in t.b.iter().zip(t.b_embedded).enumerate() {
                let w = h * (b - b_hat);
                if w != 0.0 {
                    axpy(w, &self.vel[j], eq);
                    axpy(w, &self.acc[j], ev);
                }
            }
        }
        Ok(())
    }
}

impl EmbeddedPair for Dirk {
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

    fn drain_iteration_log(&mut self, out: &mut Vec<IterationRecord>) {
        self.newton.drain_log(out);
    }
}
