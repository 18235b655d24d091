//! An energy–momentum scheme (Gonzalez 2000; Simo & Tarnow 1992): the implicit midpoint rule
//! with the potential's gradient replaced by its discrete gradient
//! ([`crate::model::Model::discrete_gradient`], Gonzalez's algorithmic stress per tet):
//!
//! `q' = q + h (v + v')/2`, `M (v' − v)/h = −ḡ(q, q') − D(q_m) (q' − q)/h`.
//!
//! Without damping and time-dependent loads the total energy `½ v'ᵀ M v' + V(q')` equals
//! `½ vᵀ M v + V(q)` to the tolerance of the solve, whatever the step. On a free body linear
//! and angular momentum are conserved to round-off at any tolerance: the algorithmic stress is
//! symmetric and acts through the midpoint's deformation gradient, and a final translation and
//! turn remove what the residual leaves of linear and angular momentum (see
//! [`EnergyMomentum::conserve_linear_momentum`] and
//! [`EnergyMomentum::conserve_angular_momentum`]). Damping only removes energy
//! (`(q' − q)ᵀ D (q' − q) >= 0`). Second order.
//!
//! **How it is solved.** The discrete gradient is not the gradient of a potential in `q'`, so
//! there is no incremental potential to minimize: Newton solves the residual
//! `r(q') = M (q' − q − h v) + h²/2 ḡ(q, q') + h/2 D(q_m) (q' − q)` (scaled by `h²/2`), from
//! `q + h v` (shortened to `q + h v/2`, `q + h v/4`, `q` while that inverts an element).
//! Its Jacobian is not formed: each Newton direction solves `J dx = −r` by GMRES
//! ([`crate::solve::Gmres`]) with `J v` a finite difference of the residual (exact to
//! ~1e-8), right-preconditioned by the symmetric approximation `P = M + h²/4 K(q_m) + h/2
//! D(q_m)` (`∂ḡ/∂q' = K(q_m)/2 + O(|q' − q|²)`), assembled and factored at every iteration by
//! the settings' linear solver and Hessian filter, to the forcing term
//! `min(0.1, ‖r‖/‖r₀‖)`. At small steps `P` is nearly `J` and one GMRES iteration does; at
//! large rotations the `O(|q' − q|²)` term is not small, and `P⁻¹ r` alone is no descent
//! direction for `‖r‖` (a tumbling body at 0.27 rad per step failed at step 15 with it).
//! The update is halved while it inverts an element
//! or does not reduce `‖r‖` (at most `newton.max_backtracks` times, then the step fails). It
//! has converged when `‖r‖ <= tol (‖M h v‖ + h²/2 ‖grad V(q)‖)` (`tol` =
//! `integrator.newton.tolerance`, the scaled-gradient criterion's reference terms) or when its
//! update is below the round-off of the positions (`16 ε ‖q'‖_∞`); at
//! `integrator.newton.max_iterations` it is counted unconverged (and fails under
//! `require_convergence`), as for every Newton solve. A failed step is retried as two halves
//! up to `newton.retry_halvings` times.

use super::newton::{NewtonSettings, axpy, with_halving};
use super::system::ImplicitSystem;
use super::{Integrator, State, StepError, StepReport};
use crate::model::Model;
use crate::solve::{Gmres, LinearSolver};
use nalgebra::Vector3;

/// The energy–momentum scheme (see the module docs).
pub struct EnergyMomentum {
    newton: NewtonSettings,
    system: ImplicitSystem,
    q1: Vec<f64>,
    mid: Vec<f64>,
    dq: Vec<f64>,
    gradient: Vec<f64>,
    residual: Vec<f64>,
    scratch: Vec<f64>,
    step_dir: Vec<f64>,
    /// The Newton–Krylov direction's solver, its right-hand side and solution, and the
    /// iterate it is taken at (positions, residual, midpoint).
    gmres: Gmres,
    krylov_rhs: Vec<f64>,
    krylov_x: Vec<f64>,
    base_q1: Vec<f64>,
    base_residual: Vec<f64>,
    base_mid: Vec<f64>,
}

/// GMRES restarts after this many steps, and stops after [`KRYLOV_MAX`] in all.
const KRYLOV_RESTART: usize = 20;
const KRYLOV_MAX: usize = 60;
/// The largest forcing term of the Newton–Krylov directions.
const KRYLOV_FORCING: f64 = 0.1;

fn norm(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>().sqrt()
}

impl EnergyMomentum {
    /// The scheme solving with `solver` under `newton`'s tolerance, cap and filter.
    pub fn new(solver: Box<dyn LinearSolver>, newton: NewtonSettings) -> Self {
        Self {
            newton,
            system: ImplicitSystem::new(solver, newton.filter_settings()),
            q1: Vec::new(),
            mid: Vec::new(),
            dq: Vec::new(),
            gradient: Vec::new(),
            residual: Vec::new(),
            scratch: Vec::new(),
            step_dir: Vec::new(),
            gmres: Gmres::new(KRYLOV_RESTART),
            krylov_rhs: Vec::new(),
            krylov_x: Vec::new(),
            base_q1: Vec::new(),
            base_residual: Vec::new(),
            base_mid: Vec::new(),
        }
    }

    /// `w = J P⁻¹ v` at the iterate saved in `base_*`: `z = P⁻¹ v` by the factored
    /// approximation, then a forward difference of the residual along `z`.
    fn jacobian_times_preconditioned(
        &mut self,
        model: &mut Model,
        state: &State,
        h: f64,
        v: &[f64],
        w: &mut [f64],
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.step_dir.copy_from_slice(v);
        self.system
            .solve(model, &self.base_mid, &mut self.step_dir, report)?;
        let z_norm = norm(&self.step_dir);
        if z_norm == 0.0 {
            w.iter_mut().for_each(|x| *x = 0.0);
            return Ok(());
        }
        let eps = f64::EPSILON.sqrt() * (1.0 + norm(&self.base_q1)) / z_norm;
        for ((q, b), z) in self.q1.iter_mut().zip(&self.base_q1).zip(&self.step_dir) {
            *q = b + eps * z;
        }
        self.residual(model, state, h)?;
        for ((wi, r), r0) in w.iter_mut().zip(&self.residual).zip(&self.base_residual) {
            *wi = (r - r0) / eps;
        }
        Ok(())
    }

    /// The Newton direction into `step_dir`: `J dx = −r` by preconditioned GMRES to
    /// `forcing`, or `P⁻¹(−r)` when a difference step leaves the material's domain. Leaves
    /// `q1`, `residual` and `mid` as they were.
    fn direction(
        &mut self,
        model: &mut Model,
        state: &State,
        h: f64,
        forcing: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let n = self.q1.len();
        for v in [
            &mut self.krylov_rhs,
            &mut self.krylov_x,
            &mut self.base_q1,
            &mut self.base_residual,
            &mut self.base_mid,
        ] {
            v.resize(n, 0.0);
        }
        self.base_q1.copy_from_slice(&self.q1);
        self.base_residual.copy_from_slice(&self.residual);
        self.base_mid.copy_from_slice(&self.mid);
        for (b, r) in self.krylov_rhs.iter_mut().zip(&self.residual) {
            *b = -r;
        }
        let mut gmres = std::mem::take(&mut self.gmres);
        let rhs = std::mem::take(&mut self.krylov_rhs);
        let mut x = std::mem::take(&mut self.krylov_x);
        let solved = gmres.solve(
            &mut |v, w| self.jacobian_times_preconditioned(model, state, h, v, w, report),
            &rhs,
            &mut x,
            forcing,
            KRYLOV_MAX,
        );
        self.q1.copy_from_slice(&self.base_q1);
        self.residual.copy_from_slice(&self.base_residual);
        self.mid.copy_from_slice(&self.base_mid);
        let result = match solved {
            Ok(r) => {
                report.linear_iterations += r.iterations as u64;
                self.step_dir.copy_from_slice(&x);
                Ok(())
            }
            Err(StepError::InvertedElement { .. } | StepError::NonFinite { .. }) => {
                self.step_dir.copy_from_slice(&rhs);
                Ok(())
            }
            Err(e) => Err(e),
        };
        self.gmres = gmres;
        self.krylov_rhs = rhs;
        self.krylov_x = x;
        result?;
        self.system
            .solve(model, &self.base_mid, &mut self.step_dir, report)
    }

    /// The residual at `self.q1` into `self.residual` (see the module docs).
    fn residual(&mut self, model: &mut Model, state: &State, h: f64) -> Result<(), StepError> {
        model.discrete_gradient(&state.q, &self.q1, &mut self.gradient)?;
        let n = state.q.len();
        for k in 0..n {
            self.dq[k] = self.q1[k] - state.q[k];
            self.scratch[k] = self.dq[k] - h * state.v[k];
            self.mid[k] = 0.5 * (self.q1[k] + state.q[k]);
        }
        model.mass().mul_vec(&self.scratch, &mut self.residual);
        axpy(0.5 * h * h, &self.gradient, &mut self.residual);
        if model.has_damping() {
            model.damping_force(&self.mid, &self.dq, &mut self.scratch)?;
            axpy(0.5 * h, &self.scratch, &mut self.residual);
        }
        if let Some(index) = self.residual.iter().position(|r| !r.is_finite()) {
            return Err(StepError::NonFinite {
                what: "residual",
                index,
            });
        }
        Ok(())
    }

    fn step(
        &mut self,
        model: &mut Model,
        state: &mut State,
        h: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let n = state.q.len();
        for v in [
            &mut self.q1,
            &mut self.mid,
            &mut self.dq,
            &mut self.gradient,
            &mut self.residual,
            &mut self.scratch,
            &mut self.step_dir,
        ] {
            v.resize(n, 0.0);
        }
        // Loads at the midpoint time; the reference size of the step's terms.
        model.set_time(state.t + 0.5 * h);
        model.gradient(&state.q, &mut self.gradient)?;
        model.mass().mul_vec(&state.v, &mut self.scratch);
        let scale = h * norm(&self.scratch) + 0.5 * h * h * norm(&self.gradient);
        // Predictor q + a h v, a = 1, 1/2, 1/4, 0: shortened while it inverts an element.
        let mut along = 1.0;
        loop {
            for k in 0..n {
                self.q1[k] = state.q[k] + along * h * state.v[k];
            }
            match self.residual(model, state, h) {
                Ok(()) => break,
                Err(StepError::InvertedElement { .. } | StepError::NonFinite { .. })
                    if along > 0.0 =>
                {
                    along = if along > 0.25 { 0.5 * along } else { 0.0 };
                }
                Err(e) => return Err(e),
            }
        }
        self.system.begin_solve();
        let mut iterations = 0;
        let mut size = norm(&self.residual);
        let first_size = size.max(f64::MIN_POSITIVE);
        let converged = loop {
            StepError::stop_if_requested()?;
            if size <= self.newton.tolerance * scale {
                break true;
            }
            if iterations >= self.newton.max_iterations {
                break false;
            }
            iterations += 1;
            // M + h²/4 K(q_m) + h/2 D(q_m) at the current midpoint.
            self.system.set_damping(model, &self.mid, 0.5 * h, report)?;
            self.system.factor(model, &self.mid, 0.25 * h * h, report)?;
            let forcing = KRYLOV_FORCING.min(size / first_size);
            self.direction(model, state, h, forcing, report)?;
            // An update below the round-off of the positions: nothing more to gain.
            let q_size = self.q1.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            let dx_size = self.step_dir.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            if dx_size <= 16.0 * f64::EPSILON * q_size {
                break true;
            }
            // Backtrack while the update inverts an element or does not reduce |r|.
            let mut length = 1.0;
            let mut backtracks = 0;
            loop {
                axpy(length, &self.step_dir, &mut self.q1);
                let reduced = match self.residual(model, state, h) {
                    Ok(()) => {
                        let new_size = norm(&self.residual);
                        (new_size < size).then_some(new_size)
                    }
                    Err(StepError::InvertedElement { .. } | StepError::NonFinite { .. }) => None,
                    Err(e) => return Err(e),
                };
                if let Some(new_size) = reduced {
                    size = new_size;
                    break;
                }
                axpy(-length, &self.step_dir, &mut self.q1);
                backtracks += 1;
                if backtracks > self.newton.max_backtracks {
                    return Err(StepError::NewtonFailed {
                        iterations,
                        reason: format!(
                            "no step along the energy-momentum Newton direction reduced the residual in {} backtracks",
                            self.newton.max_backtracks
                        ),
                    });
                }
                length *= 0.5;
            }
        };
        report.newton_iterations += iterations;
        if !converged {
            report.newton_unconverged += 1;
            if self.newton.require_convergence {
                return Err(StepError::NewtonFailed {
                    iterations,
                    reason: "the energy-momentum residual did not meet the tolerance".into(),
                });
            }
        }
        if is_free(model) {
            self.conserve_linear_momentum(model, state, h);
            self.conserve_angular_momentum(model, state, h);
        }
        for k in 0..n {
            let dq = self.q1[k] - state.q[k];
            state.v[k] = 2.0 * dq / h - state.v[k];
        }
        std::mem::swap(&mut state.q, &mut self.q1);
        report.substeps += 1;
        Ok(())
    }
}

/// A free body: nothing fixed, no gravity, loads or damping, so its momenta are conserved.
fn is_free(model: &Model) -> bool {
    model.dofs().num_free() == model.dofs().num_vertices()
        && model.gravity().is_none()
        && model.vertex_potentials().is_empty()
        && !model.has_damping()
}

fn cross_at(x: &[f64], y: &[f64], k: usize) -> Vector3<f64> {
    let a = Vector3::new(x[3 * k], x[3 * k + 1], x[3 * k + 2]);
    let b = Vector3::new(y[3 * k], y[3 * k + 1], y[3 * k + 2]);
    a.cross(&b)
}

impl EnergyMomentum {
    /// On a free body, translate the end positions so the step changes no linear momentum:
    /// `p' − p = (2/h) Σ M (q' − q − h v)` (summed per axis), and a translation `δ` changes
    /// that sum by `m δ` (`m` the total mass), so `δ = −Σ M (q' − q − h v) / m`. Newton
    /// updates keep it with exact directions; the Newton–Krylov directions carry the finite
    /// differences' round-off (1e-12 over 40 steps at tolerance 1e-8), which this removes.
    fn conserve_linear_momentum(&mut self, model: &Model, state: &State, h: f64) {
        let n = state.q.len();
        for k in 0..n {
            self.scratch[k] = self.q1[k] - state.q[k] - h * state.v[k];
        }
        model.mass().mul_vec(&self.scratch, &mut self.residual);
        let (masses, free) = (model.vertex_masses(), model.dofs().free_vertices());
        let total: f64 = free.iter().map(|&v| masses[v]).sum();
        if total <= 0.0 {
            return;
        }
        let mut defect = Vector3::zeros();
        for k in 0..n / 3 {
            defect += Vector3::new(
                self.residual[3 * k],
                self.residual[3 * k + 1],
                self.residual[3 * k + 2],
            );
        }
        let delta = -defect / total;
        for k in 0..n / 3 {
            for i in 0..3 {
                self.q1[3 * k + i] += delta[i];
            }
        }
    }

    /// The change of angular momentum over the step, `(h/2)(L' − L)`, for the end positions in
    /// `self.q1`: `Σ q_m × M (q' − q − h v)` (exact algebra of the midpoint rule with a
    /// symmetric mass; the discrete gradient adds no moment about `q_m`).
    fn angular_defect(&mut self, model: &Model, state: &State, h: f64) -> Vector3<f64> {
        let n = state.q.len();
        for k in 0..n {
            self.scratch[k] = self.q1[k] - state.q[k] - h * state.v[k];
            self.mid[k] = 0.5 * (self.q1[k] + state.q[k]);
        }
        model.mass().mul_vec(&self.scratch, &mut self.residual);
        (0..n / 3)
            .map(|k| cross_at(&self.mid, &self.residual, k))
            .sum()
    }

    /// On a free body, move the end positions by a rotation `δ_k = θ × (q_m,k − x̄)` about the
    /// midpoint's centre of mass that makes the step's angular-momentum defect zero. The defect
    /// is linear in `δ` (the quadratic part `Σ m_ij δ_i × δ_j` vanishes), so one 3×3 solve
    /// removes it to round-off whatever the Newton tolerance; `δ` is of the size of the
    /// residual's moment, and it leaves linear momentum unchanged (`Σ M δ = 0`).
    fn conserve_angular_momentum(&mut self, model: &Model, state: &State, h: f64) {
        let n = state.q.len();
        let defect = self.angular_defect(model, state, h);
        // Lumped vertex masses (the consistent mass's row sums for linear tets).
        let (masses, free) = (model.vertex_masses(), model.dofs().free_vertices());
        let total: f64 = free.iter().map(|&v| masses[v]).sum();
        if total <= 0.0 || defect.norm() == 0.0 {
            return;
        }
        let centre: Vector3<f64> = free
            .iter()
            .enumerate()
            .map(|(k, &v)| {
                Vector3::new(self.mid[3 * k], self.mid[3 * k + 1], self.mid[3 * k + 2]) * masses[v]
            })
            .sum::<Vector3<f64>>()
            / total;
        // The defect's change for θ = e_x, e_y, e_z (it is linear): one column each.
        let mut columns = [Vector3::zeros(); 3];
        for (axis, column) in columns.iter_mut().enumerate() {
            let theta = Vector3::ith_axis(axis).into_inner();
            for k in 0..n / 3 {
                let c = Vector3::new(self.mid[3 * k], self.mid[3 * k + 1], self.mid[3 * k + 2])
                    - centre;
                let d = theta.cross(&c);
                self.step_dir[3 * k..3 * k + 3].copy_from_slice(d.as_slice());
            }
            // Σ q_m × M δ + Σ δ/2 × M a, with M a in self.residual from angular_defect.
            model.mass().mul_vec(&self.step_dir, &mut self.gradient);
            *column = (0..n / 3)
                .map(|k| {
                    cross_at(&self.mid, &self.gradient, k)
                        + cross_at(&self.step_dir, &self.residual, k) * 0.5
                })
                .sum();
        }
        let a = nalgebra::Matrix3::from_columns(&columns);
        let Some(theta) = a.lu().solve(&(-defect)) else {
            return;
        };
        for k in 0..n / 3 {
            let c =
                Vector3::new(self.mid[3 * k], self.mid[3 * k + 1], self.mid[3 * k + 2]) - centre;
            let d = theta.cross(&c);
            for i in 0..3 {
                self.q1[3 * k + i] += d[i];
            }
        }
    }
}

impl Integrator for EnergyMomentum {
    fn name(&self) -> &'static str {
        "energy-momentum"
    }

    fn order(&self) -> u32 {
        2
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
        let halvings = self.newton.retry_halvings;
        with_halving(halvings, state, dt, report, &mut |s, h, r| {
            self.step(model, s, h, r)
        })
    }
}
