//! The constrained response: backward Euler whose step is a sequence of convex QPs (SQP).
//!
//! Each iteration minimizes the quadratic model of the incremental potential
//! `E(x) = 1/2 |x - x_hat|_M^2 + dt^2 V(x)` (Hessian `M + dt^2 K` with element Hessians projected
//! to PSD, so the QP is convex) subject to `n . dx >= -sdf` for each (vertex, convex piece) pair
//! within the margin, solved by clarabel ([`super::qp`]). Iterations without such pairs take a
//! plain Newton step through the linear solver.
//!
//! Why a separate loop rather than [`crate::integrate::newton`]: the direction comes from a QP,
//! and the iterates are kept feasible. Every piece's signed distance is convex, so its
//! linearization is conservative: a QP step that satisfies the linearized constraints is
//! outside every piece, and so is every point between a feasible iterate and it. The loop
//! therefore
//! 1. starts from `x_hat` if it is outside every obstacle, else from the start-of-step `q`;
//! 2. after each QP, checks the full step against every piece and, if a vertex that had no
//!    constraint would end inside, adds its linearization and solves again (at most
//!    [`MAX_EXPANSIONS`] times);
//! 3. backtracks on `E` alone (Armijo), which keeps feasibility; an infeasible iterate (a
//!    scene that starts inside an obstacle) takes the full step, which restores feasibility.
//!
//! Convergence: `|g + A^T z| <= tolerance * scale` (the Lagrangian gradient, with `z` the QP
//! multipliers; the same relative test as Newton's) at a feasible iterate.

use super::obstacle::Obstacles;
use super::qp::{ContactQp, ContactRow};
use crate::integrate::newton::{IncrementalPotential, NewtonSettings, Problem, dot, norm};
use crate::integrate::system::ImplicitSystem;
use crate::integrate::{Integrator, State, StepError, StepReport};
use crate::model::{Model, ModelError};
use crate::solve::LinearSolver;
use nalgebra::Vector3;
use std::collections::HashSet;
use std::sync::Arc;

/// Re-solves per iteration when the step would take an unconstrained vertex inside.
pub const MAX_EXPANSIONS: usize = 8;

/// Penetration (m) below which an iterate counts as feasible (the QP meets its constraints
/// to about clarabel's tolerance, not exactly).
pub const PENETRATION_TOLERANCE: f64 = 1e-8;

/// The linearized constraints of one iteration, one per (free vertex, obstacle, piece).
#[derive(Debug, Default)]
struct Rows {
    rows: Vec<ContactRow>,
    keys: HashSet<(usize, usize, usize)>,
}

impl Rows {
    fn clear(&mut self) {
        self.rows.clear();
        self.keys.clear();
    }

    /// Linearize at `x` every pair within `margin` — or, with `probe`, every pair not yet
    /// constrained that is inside its piece at `probe`. Returns how many rows were added.
    fn add(
        &mut self,
        obstacles: &Obstacles,
        x: &[f64],
        t: f64,
        margin: f64,
        probe: Option<&[f64]>,
    ) -> usize {
        let before = self.rows.len();
        let mut inside = Vec::new();
        for (f, p) in x.chunks_exact(3).enumerate() {
            let p = Vector3::new(p[0], p[1], p[2]);
            let y = probe.map(|y| Vector3::new(y[3 * f], y[3 * f + 1], y[3 * f + 2]));
            for (o, obstacle) in obstacles.iter().enumerate() {
                if let Some(y) = y {
                    inside.clear();
                    obstacle.for_each_piece(&y, t, &mut |piece, s| {
                        if s.sdf.distance < 0.0 && !self.keys.contains(&(f, o, piece)) {
                            inside.push(piece);
                        }
                    });
                    if inside.is_empty() {
                        continue;
                    }
                }
                obstacle.for_each_piece(&p, t, &mut |piece, s| {
                    let wanted = match y {
                        Some(_) => inside.contains(&piece),
                        None => s.sdf.distance < margin,
                    };
                    if wanted && self.keys.insert((f, o, piece)) {
                        self.rows.push(ContactRow {
                            dof: 3 * f,
                            normal: s.sdf.gradient,
                            distance: s.sdf.distance,
                        });
                    }
                });
            }
        }
        self.rows.len() - before
    }
}

/// Backward Euler with linearized non-penetration constraints (see the module docs).
pub struct ConstrainedBackwardEuler {
    obstacles: Arc<Obstacles>,
    margin: f64,
    settings: NewtonSettings,
    system: ImplicitSystem,
    qp: ContactQp,
    rows: Rows,
    x: Vec<f64>,
    x_hat: Vec<f64>,
    potential: IncrementalPotential,
    dx: Vec<f64>,
    trial: Vec<f64>,
    residual: Vec<f64>,
}

impl ConstrainedBackwardEuler {
    /// Constraints for vertices within `margin` (m) of `obstacles`; unconstrained iterations
    /// solve with `solver`; `settings` as for Newton (`project_hessian` applies to those).
    pub fn new(
        obstacles: Arc<Obstacles>,
        margin: f64,
        solver: Box<dyn LinearSolver>,
        settings: NewtonSettings,
    ) -> Self {
        Self {
            obstacles,
            margin,
            settings,
            system: ImplicitSystem::new(solver, settings.project_hessian),
            qp: ContactQp::default(),
            rows: Rows::default(),
            x: Vec::new(),
            x_hat: Vec::new(),
            potential: IncrementalPotential::default(),
            dx: Vec::new(),
            trial: Vec::new(),
            residual: Vec::new(),
        }
    }

    /// `E(x)` and the scale of its round-off (the evaluator Newton uses, without damping).
    fn objective(
        &mut self,
        model: &mut Model,
        p: &Problem<'_>,
        x: &[f64],
    ) -> Result<(f64, f64), ModelError> {
        self.potential
            .objective(model, None, p, x)
            .map(|o| (o.value, o.roundoff))
    }

    /// The smallest signed distance of any free vertex at `x` to any obstacle.
    fn min_distance(&self, x: &[f64], t: f64) -> f64 {
        x.chunks_exact(3)
            .map(|p| self.obstacles.distance(&Vector3::new(p[0], p[1], p[2]), t))
            .fold(f64::INFINITY, f64::min)
    }

    /// The search direction at `self.x` into `self.dx`; returns the norm of the Lagrangian
    /// gradient `g + A^T z` (just `g` without constraints).
    fn direction(
        &mut self,
        model: &mut Model,
        beta: f64,
        t: f64,
        report: &mut StepReport,
    ) -> Result<f64, StepError> {
        let (obstacles, margin) = (&*self.obstacles, self.margin);
        self.rows.clear();
        if self.rows.add(obstacles, &self.x, t, margin, None) == 0 {
            self.system.factor(model, &self.x, beta, report)?;
            for (dx, g) in self.dx.iter_mut().zip(&self.potential.g) {
                *dx = -g;
            }
            self.system.solve(model, &self.x, &mut self.dx, report)?;
            // Keep the step if no vertex ends inside; otherwise constrain those vertices.
            for ((t, x), dx) in self.trial.iter_mut().zip(&self.x).zip(&self.dx) {
                *t = x + dx;
            }
            if self
                .rows
                .add(obstacles, &self.x, t, margin, Some(&self.trial))
                == 0
            {
                return Ok(norm(&self.potential.g));
            }
        }
        let h = self
            .system
            .assemble_matrix(model, &self.x, beta, true, report)?;
        let mut expansions = 0;
        loop {
            let solution = self
                .qp
                .solve(h, &self.potential.g, &self.rows.rows)
                .map_err(|reason| StepError::NewtonFailed {
                    iterations: report.newton_iterations,
                    reason,
                })?;
            report.qp_solves += 1;
            report.times.qp += solution.seconds;
            self.dx.copy_from_slice(&solution.dx);
            for ((t, x), dx) in self.trial.iter_mut().zip(&self.x).zip(&self.dx) {
                *t = x + dx;
            }
            let added = if expansions < MAX_EXPANSIONS {
                self.rows
                    .add(obstacles, &self.x, t, margin, Some(&self.trial))
            } else {
                0
            };
            expansions += 1;
            if added == 0 {
                // The Lagrangian gradient g + A^T z (A's rows are -n^T).
                let r = &mut self.residual;
                r.clone_from(&self.potential.g);
                for (row, z) in self.rows.rows.iter().zip(&solution.multipliers) {
                    for i in 0..3 {
                        r[row.dof + i] -= z * row.normal[i];
                    }
                }
                return Ok(norm(r));
            }
        }
    }

    /// One step; leaves `state` unchanged on error.
    fn single(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        if model.has_damping() {
            // The SQP loop has no damping term: refuse rather than silently drop it.
            return Err(StepError::Model(ModelError::InvalidParameter {
                field: "contact.response".into(),
                value: "constrained".into(),
                expected: "a model without damping (the constrained step has no damping term)"
                    .into(),
            }));
        }
        // x_hat leaves `self` for the step so the problem can borrow it beside `&mut self`.
        let mut x_hat = std::mem::take(&mut self.x_hat);
        x_hat.clear();
        x_hat.extend(state.q.iter().zip(&state.v).map(|(q, v)| q + dt * v));
        let result = self.solve_step(model, state, dt, &x_hat, report);
        self.x_hat = x_hat;
        result
    }

    /// [`Self::single`] for a given `x_hat = q + dt v`.
    fn solve_step(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        x_hat: &[f64],
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let n = state.q.len();
        self.potential.resize(n);
        self.dx.resize(n, 0.0);
        self.trial.resize(n, 0.0);
        let s = self.settings;
        let beta = dt * dt;
        let t = state.t + dt;
        model.set_time(t);
        let p = Problem {
            x_hat,
            x_ref: &state.q,
            beta,
            damping_anchor: &state.q,
        };
        let start = if self.min_distance(x_hat, t) >= 0.0 {
            x_hat
        } else {
            &state.q
        };
        let mut x = std::mem::take(&mut self.x);
        x.clear();
        x.extend_from_slice(start);
        let first = self.objective(model, &p, &x);
        self.x = x;
        let (mut energy, mut roundoff) = match first {
            Ok(e) => e,
            Err(ModelError::InvertedElement { .. }) => {
                // x_hat inverts an element; the start-of-step state does not.
                self.x.clone_from(&state.q);
                self.objective(model, &p, &state.q)?
            }
            Err(e) => return Err(e.into()),
        };
        // The convergence scale: inertial term plus the force term at the first iterate.
        let inertial = self.potential.inertial_scale(model, &p);
        let mut scale = None;
        let mut converged = false;
        for iteration in 0..s.max_iterations {
            self.potential.gradient(model, None, &p, &self.x)?;
            let scale = *scale.get_or_insert(inertial + beta * norm(&self.potential.grad_v));
            let feasible = self.min_distance(&self.x, t) >= -PENETRATION_TOLERANCE;
            let residual = self.direction(model, beta, t, report)?;
            report.newton_iterations += 1;
            let slope = dot(&self.potential.g, &self.dx);
            let small = residual <= s.tolerance * scale || -slope <= roundoff;
            if !feasible || small || slope >= 0.0 {
                // Restoration, convergence or no predicted decrease: the full step.
                for ((t, x), dx) in self.trial.iter_mut().zip(&self.x).zip(&self.dx) {
                    *t = x + dx;
                }
                let trial = std::mem::take(&mut self.trial);
                let outcome = self.objective(model, &p, &trial);
                self.trial = trial;
                match outcome {
                    Ok((e, r)) => (energy, roundoff) = (e, r),
                    Err(ModelError::InvertedElement { .. }) if feasible => {
                        return Err(StepError::NewtonFailed {
                            iterations: iteration + 1,
                            reason: "the constrained step inverts an element".into(),
                        });
                    }
                    Err(e) => return Err(e.into()),
                }
                self.x.copy_from_slice(&self.trial);
                if small && feasible {
                    converged = true;
                    break;
                }
                continue;
            }
            let mut alpha = s.initial_step;
            let mut backtracks = 0;
            loop {
                for ((t, x), dx) in self.trial.iter_mut().zip(&self.x).zip(&self.dx) {
                    *t = x + alpha * dx;
                }
                let trial = std::mem::take(&mut self.trial);
                let outcome = self.objective(model, &p, &trial);
                self.trial = trial;
                match outcome {
                    Ok((e, r)) if e <= energy + s.sufficient_decrease * alpha * slope => {
                        (energy, roundoff) = (e, r);
                        break;
                    }
                    Ok(_) | Err(ModelError::InvertedElement { .. }) => {}
                    Err(e) => return Err(e.into()),
                }
                backtracks += 1;
                report.line_search_backtracks += 1;
                if backtracks > s.max_backtracks {
                    return Err(StepError::NewtonFailed {
                        iterations: iteration + 1,
                        reason: format!(
                            "line search found no sufficient decrease in {} backtracks",
                            s.max_backtracks
                        ),
                    });
                }
                alpha *= s.shrink;
            }
            self.x.copy_from_slice(&self.trial);
        }
        if !converged {
            if s.require_convergence {
                return Err(StepError::NewtonFailed {
                    iterations: s.max_iterations,
                    reason: format!(
                        "tolerance {:.1e} not met in {} iterations",
                        s.tolerance, s.max_iterations
                    ),
                });
            }
            report.newton_unconverged += 1;
        }
        for ((q, v), x) in state.q.iter_mut().zip(state.v.iter_mut()).zip(&self.x) {
            *v = (x - *q) / dt;
            *q = *x;
        }
        report.substeps += 1;
        Ok(())
    }
}

impl Integrator for ConstrainedBackwardEuler {
    fn name(&self) -> &'static str {
        "backward-euler"
    }

    fn order(&self) -> u32 {
        1
    }

    fn is_explicit(&self) -> bool {
        false
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.single(model, state, dt, report)?;
        let t = state.t + dt;
        let stats = self.obstacles.stats(&state.q, t, self.margin);
        report.contacts = stats.contacts;
        report.max_penetration = stats.max_penetration;
        Ok(())
    }
}
