//! The constrained response: non-penetration constraints inside the one Newton loop of any
//! scheme whose unknown is the end-of-step position (backward Euler, BDF-k, the Newmark
//! family, static). They choose the Newton direction and filter the line search
//! ([`StepConstraints`]); the loop, its halving retries and its damping are the integrator's.
//!
//! Each iteration with (vertex, convex piece) pairs within the margin minimizes the quadratic
//! model of the incremental potential (Hessian `M + beta K` with element Hessians projected to
//! PSD, so the QP is convex) subject to `n . dx >= -sdf` for each pair, solved by clarabel
//! ([`super::qp`]). Iterations without such pairs take the plain Newton step through the
//! linear solver. Every piece's signed distance is convex, so its linearization is
//! conservative: a QP step that satisfies the linearized constraints is outside every piece,
//! and so is every point between a feasible iterate and it. So
//! 1. the solve starts from the guess if it is outside every obstacle, else from the
//!    start-of-step positions;
//! 2. after each QP (or plain step), the full step is checked against every piece and, if a
//!    vertex that had no constraint would end inside, its linearization is added and the QP
//!    solved again (at most [`MAX_EXPANSIONS`] times);
//! 3. the line search backtracks on `E` and rejects infeasible points; an infeasible iterate
//!    (a scene that starts inside an obstacle) takes the full step, which restores
//!    feasibility.
//!
//! Convergence: `|g + A^T z| <= tolerance * scale` (the Lagrangian gradient, with `z` the QP
//! multipliers; the same relative test as Newton's) at a feasible iterate.

use super::obstacle::Obstacles;
use super::qp::{ContactQp, ContactRow};
use crate::integrate::StepError;
use crate::integrate::StepReport;
use crate::integrate::newton::{Linearization, StepConstraints};
use crate::integrate::system::ImplicitSystem;
use crate::model::Model;
use nalgebra::Vector3;
use std::collections::HashSet;
use std::sync::Arc;

pub use crate::integrate::newton::PENETRATION_TOLERANCE;

/// Re-solves per iteration when the step would take an unconstrained vertex inside.
pub const MAX_EXPANSIONS: usize = 8;

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

/// Linearized non-penetration constraints for the Newton loop (see the module docs).
pub struct ContactConstraints {
    obstacles: Arc<Obstacles>,
    margin: f64,
    qp: ContactQp,
    rows: Rows,
    trial: Vec<f64>,
    residual: Vec<f64>,
}

impl ContactConstraints {
    /// Constraints for free vertices within `margin` (m) of `obstacles`.
    pub fn new(obstacles: Arc<Obstacles>, margin: f64) -> Self {
        Self {
            obstacles,
            margin,
            qp: ContactQp::default(),
            rows: Rows::default(),
            trial: Vec::new(),
            residual: Vec::new(),
        }
    }
}

fn norm(a: &[f64]) -> f64 {
    a.iter().map(|x| x * x).sum::<f64>().sqrt()
}

impl StepConstraints for ContactConstraints {
    fn min_distance(&self, x: &[f64], t: f64) -> f64 {
        x.chunks_exact(3)
            .map(|p| self.obstacles.distance(&Vector3::new(p[0], p[1], p[2]), t))
            .fold(f64::INFINITY, f64::min)
    }

    fn direction(
        &mut self,
        model: &mut Model,
        system: &mut ImplicitSystem,
        at: &Linearization<'_>,
        dx: &mut [f64],
        report: &mut StepReport,
    ) -> Result<f64, StepError> {
        let (obstacles, margin, t, x, g) = (&*self.obstacles, self.margin, at.t, at.x, at.gradient);
        self.trial.resize(x.len(), 0.0);
        self.rows.clear();
        if self.rows.add(obstacles, x, t, margin, None) == 0 {
            system.factor(model, x, at.beta, report)?;
            for (d, g) in dx.iter_mut().zip(g) {
                *d = -g;
            }
            system.solve(model, x, dx, report)?;
            // Keep the step if no vertex ends inside; otherwise constrain those vertices.
            for ((t, x), d) in self.trial.iter_mut().zip(x).zip(dx.iter()) {
                *t = x + d;
            }
            if self.rows.add(obstacles, x, t, margin, Some(&self.trial)) == 0 {
                return Ok(norm(g));
            }
        }
        let h = system.assemble_matrix(model, x, at.beta, true, report)?;
        let mut expansions = 0;
        loop {
            let solution =
                self.qp
                    .solve(h, g, &self.rows.rows)
                    .map_err(|reason| StepError::NewtonFailed {
                        iterations: report.newton_iterations,
                        reason,
                    })?;
            report.qp_solves += 1;
            report.times.qp += solution.seconds;
            dx.copy_from_slice(&solution.dx);
            for ((t, x), d) in self.trial.iter_mut().zip(x).zip(dx.iter()) {
                *t = x + d;
            }
            let added = if expansions < MAX_EXPANSIONS {
                self.rows.add(obstacles, x, t, margin, Some(&self.trial))
            } else {
                0
            };
            expansions += 1;
            if added == 0 {
                // The Lagrangian gradient g + A^T z (A's rows are -n^T).
                let r = &mut self.residual;
                r.clear();
                r.extend_from_slice(g);
                for (row, z) in self.rows.rows.iter().zip(&solution.multipliers) {
                    for i in 0..3 {
                        r[row.dof + i] -= z * row.normal[i];
                    }
                }
                return Ok(norm(r));
            }
        }
    }

    fn record_contacts(&self, q: &[f64], t: f64, report: &mut StepReport) {
        let stats = self.obstacles.stats(q, t, self.margin);
        report.contacts = stats.contacts;
        report.max_penetration = stats.max_penetration;
    }
}

/// The constrained response: the scene's method with [`ContactConstraints`] inside its Newton
/// loop (the constraints record contacts; the wrapper adds the frame check).
pub(super) fn integrator(
    contact: &super::Contact,
    settings: &crate::integrate::IntegratorSettings,
) -> Box<dyn crate::integrate::Integrator> {
    let constraints = ContactConstraints::new(contact.obstacles.clone(), contact.config.margin);
    let inner = settings
        .build_constrained(crate::integrate::newton::NewtonContact::Constraints(
            Box::new(constraints),
        ))
        .expect("scene validation admits constrained contact only for such methods");
    contact.wrapped(inner, super::Response::ReportOnly)
}
