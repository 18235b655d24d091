//! Radau IIA of order 5 (three stages, collocation at `c = (4 − √6)/10, (4 + √6)/10, 1`;
//! stiffly accurate, L-stable): the reference integrator for stiff problems (Hairer & Wanner,
//! *Solving ODEs II*, IV.5 and IV.8, whose RADAU5 this follows).
//!
//! **How the coupled stages are solved.** On `y = [q, v]`, `y' = F(y) = [v, M⁻¹ f(q, v, t)]`,
//! the stage increments `Z_i = Y_i − y` solve `Z = h (A ⊗ I) F(y + Z)` — `6n` unknowns coupled
//! through `A`. Simplified Newton keeps `J = [[0, I], [−M⁻¹K, −M⁻¹D]]` at the step's start
//! (K the Hessian through the settings' filter, D the damping matrix) and changes variables to
//! `W = (T⁻¹ ⊗ I) Z` with `T⁻¹ A⁻¹ T = Λ`: one real eigenvalue `γ` and a complex pair. The
//! iteration matrix `h⁻¹ Λ ⊗ I − I ⊗ J` then splits into one real system
//! `K + (γ/h)² M + (γ/h) D` — symmetric, the matrix of a backward Euler step of `h/γ`, factored
//! by the settings' linear solver with its filters and fallbacks — and one complex symmetric
//! system `K + ν² M + ν D`, `ν = λ/h`, factored by a sparse LU
//! ([`super::complex_shifted`]). Each iteration costs three force evaluations (one per stage),
//! one real and one complex solve; each step one Hessian assembly and the two
//! factorizations. The fixed point is the exact stage solution whatever `J` was, so a frozen
//! Jacobian changes how many iterations a step takes, not its result.
//!
//! **When it stops.** The iteration starts from `Z_q,i = c_i h v`, `Z_v,i = 0` and converges
//! when `η ‖ΔZ_q‖_∞ <= tol ‖Z_q‖_∞` (`tol` = `integrator.newton.tolerance`; `η = θ/(1 − θ)` with
//! `θ` the observed contraction, 1 on the first iteration) or when `ΔZ_q` is at round-off of
//! `q`. A contraction `θ >= 1` fails the attempt; a stop at `integrator.newton.max_iterations`
//! is counted as unconverged (and fails the attempt under `require_convergence` or error
//! control), as for every Newton solve.
//!
//! **Error estimate** (Hairer & Wanner IV.8, (8.19)–(8.20)): the embedded third-order solution
//! with `b̂₀ = 1/γ`, filtered through the real factor:
//! `err = (γ/h I − J)⁻¹ [F(y) + (γ/h) Σ e_j Z_j]` — one extra force evaluation and one solve.

use super::complex_shifted::ComplexShifted;
use super::embedded::{EmbeddedPair, StageOutput};
use super::newton::{NewtonSettings, axpy};
use super::system::ImplicitSystem;
use super::{State, StepError, StepReport};
use crate::model::Model;
use crate::solve::LinearSolver;
use crate::sparse::SymmetricMatrix;
use faer::c64;
use nalgebra::{Complex, Matrix3, Vector3};
use std::sync::Arc;

/// The method's constants, computed from its Butcher tableau.
#[derive(Clone, Debug)]
pub struct RadauCoefficients {
    /// The Butcher matrix `A`.
    pub a: Matrix3<f64>,
    /// The stage times.
    pub c: [f64; 3],
    /// `T` with `T⁻¹ A⁻¹ T = Λ` (block diagonal: `γ`, then the complex pair as a real 2×2).
    pub t: Matrix3<f64>,
    /// `T⁻¹`.
    pub t_inv: Matrix3<f64>,
    /// `Λ = T⁻¹ A⁻¹ T`.
    pub lambda_matrix: Matrix3<f64>,
    /// The real eigenvalue `γ` of `A⁻¹`.
    pub gamma: f64,
    /// The complex eigenvalue `λ` acting on `W₂ + i W₃`.
    pub lambda: Complex<f64>,
    /// The error weights `e_j` on `Z_j` (with `b̂₀ = 1/γ` on `h F(y)`).
    pub e: [f64; 3],
}

/// `r0 × r1` without conjugation: orthogonal (in the bilinear sense) to both rows, so the
/// null vector of a rank-2 complex 3×3 matrix with those rows.
fn complex_cross(r0: [Complex<f64>; 3], r1: [Complex<f64>; 3]) -> [Complex<f64>; 3] {
    [
        r0[1] * r1[2] - r0[2] * r1[1],
        r0[2] * r1[0] - r0[0] * r1[2],
        r0[0] * r1[1] - r0[1] * r1[0],
    ]
}

impl RadauCoefficients {
    /// The three-stage Radau IIA tableau and its transformation.
    pub fn new() -> Self {
        let s6 = 6f64.sqrt();
        let a = Matrix3::new(
            (88.0 - 7.0 * s6) / 360.0,
            (296.0 - 169.0 * s6) / 1800.0,
            (-2.0 + 3.0 * s6) / 225.0,
            (296.0 + 169.0 * s6) / 1800.0,
            (88.0 + 7.0 * s6) / 360.0,
            (-2.0 - 3.0 * s6) / 225.0,
            (16.0 - s6) / 36.0,
            (16.0 + s6) / 36.0,
            1.0 / 9.0,
        );
        let c = [(4.0 - s6) / 10.0, (4.0 + s6) / 10.0, 1.0];
        let a_inv = a.try_inverse().expect("A is invertible");
        let eig = a_inv.complex_eigenvalues();
        let gamma = eig
            .iter()
            .find(|z| z.im.abs() < 1e-9)
            .expect("one real eigenvalue")
            .re;
        let mu = *eig.iter().find(|z| z.im > 1e-9).expect("a complex pair");
        // Real eigenvector: the cross product of two rows of A⁻¹ − γI.
        let shifted = a_inv - Matrix3::identity() * gamma;
        let t1: Vector3<f64> = shifted
            .row(0)
            .transpose()
            .cross(&shifted.row(1).transpose());
        // Complex eigenvector u + i w for μ.
        let row = |i: usize| -> [Complex<f64>; 3] {
            std::array::from_fn(|j| {
                Complex::new(a_inv[(i, j)], 0.0) - if i == j { mu } else { Complex::new(0.0, 0.0) }
            })
        };
        let v = complex_cross(row(0), row(1));
        let t = Matrix3::from_columns(&[
            t1,
            Vector3::new(v[0].re, v[1].re, v[2].re),
            Vector3::new(v[0].im, v[1].im, v[2].im),
        ]);
        let t_inv = t.try_inverse().expect("T is invertible");
        let lambda_matrix = t_inv * a_inv * t;
        // A⁻¹ u = Re μ u − Im μ w and A⁻¹ w = Im μ u + Re μ w: Λ acts on W₂ + i W₃ as conj(μ).
        let lambda = mu.conj();
        // b̂ (with b̂₀ = 1/γ on h F(y)) of order 3: Σ b̂_i c_i^(k−1) = 1/k − b̂₀ [k = 1].
        let gamma0 = 1.0 / gamma;
        let vandermonde = Matrix3::from_fn(|k, i| c[i].powi(k as i32));
        let rhs = Vector3::new(1.0 - gamma0, 0.5, 1.0 / 3.0);
        let b_hat = vandermonde.lu().solve(&rhs).expect("distinct stage times");
        let b = a.row(2).transpose();
        let e = (b_hat - b).transpose() * a_inv;
        Self {
            a,
            c,
            t,
            t_inv,
            lambda_matrix,
            gamma,
            lambda,
            e: [e[0], e[1], e[2]],
        }
    }
}

impl Default for RadauCoefficients {
    fn default() -> Self {
        Self::new()
    }
}

/// Per-stage vectors.
type Stages = [Vec<f64>; 3];

/// Radau IIA of order 5 (see the module docs).
pub struct RadauIIA {
    k: RadauCoefficients,
    newton: NewtonSettings,
    system: ImplicitSystem,
    complex: ComplexShifted,
    /// `M` over the Hessian pattern, for the complex matrix.
    mass: Option<SymmetricMatrix>,
    zq: Stages,
    zv: Stages,
    wq: Stages,
    wv: Stages,
    force: Stages,
    rq: Stages,
    rv: Stages,
    yq: Vec<f64>,
    yv: Vec<f64>,
    scratch: Vec<f64>,
    rhs: Vec<f64>,
    im: Vec<f64>,
    im_scratch: Vec<f64>,
    dq_real: Vec<f64>,
    dv_real: Vec<f64>,
}

impl RadauIIA {
    /// Radau IIA solving its real systems with `solver`, with `newton`'s tolerance, iteration
    /// cap and filter.
    pub fn new(solver: Box<dyn LinearSolver>, newton: NewtonSettings) -> Self {
        Self {
            k: RadauCoefficients::new(),
            newton,
            system: ImplicitSystem::new(solver, newton.filter_settings()),
            complex: ComplexShifted::default(),
            mass: None,
            zq: Default::default(),
            zv: Default::default(),
            wq: Default::default(),
            wv: Default::default(),
            force: Default::default(),
            rq: Default::default(),
            rv: Default::default(),
            yq: Vec::new(),
            yv: Vec::new(),
            scratch: Vec::new(),
            rhs: Vec::new(),
            im: Vec::new(),
            im_scratch: Vec::new(),
            dq_real: Vec::new(),
            dv_real: Vec::new(),
        }
    }

    /// The coefficients.
    pub fn coefficients(&self) -> &RadauCoefficients {
        &self.k
    }

    fn ensure_buffers(&mut self, n: usize) {
        if self.yq.len() == n {
            return;
        }
        for set in [
            &mut self.zq,
            &mut self.zv,
            &mut self.wq,
            &mut self.wv,
            &mut self.force,
            &mut self.rq,
            &mut self.rv,
        ] {
            for v in set.iter_mut() {
                *v = vec![0.0; n];
            }
        }
        for v in [
            &mut self.yq,
            &mut self.yv,
            &mut self.scratch,
            &mut self.rhs,
            &mut self.im,
            &mut self.im_scratch,
            &mut self.dq_real,
            &mut self.dv_real,
        ] {
            *v = vec![0.0; n];
        }
    }

    /// `f(q, v, t) = −grad V(q) − D(q) v` at `(yq, yv)` and the model's time into `out`.
    fn force_at(
        model: &mut Model,
        yq: &[f64],
        yv: &[f64],
        scratch: &mut [f64],
        out: &mut [f64],
    ) -> Result<(), StepError> {
        model.gradient(yq, out)?;
        if model.has_damping() {
            model.damping_force(yq, yv, scratch)?;
            axpy(1.0, scratch, out);
        }
        out.iter_mut().for_each(|f| *f = -*f);
        if let Some(index) = out.iter().position(|f| !f.is_finite()) {
            return Err(StepError::NonFinite {
                what: "force",
                index,
            });
        }
        Ok(())
    }

    /// The real and complex factors of the step's simplified Newton matrix at `start`.
    fn factor(
        &mut self,
        model: &mut Model,
        start: &State,
        h: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let g = h / self.k.gamma;
        model.set_time(start.t);
        self.system.set_damping(model, &start.q, g, report)?;
        self.system.begin_solve();
        self.system.factor(model, &start.q, g * g, report)?;
        let pattern = model.hessian_pattern().clone();
        if self
            .mass
            .as_ref()
            .is_none_or(|m| !Arc::ptr_eq(m.pattern(), &pattern))
        {
            let mut m = model.new_hessian();
            model.mass().add_scaled_to(1.0, &mut m);
            self.mass = Some(m);
        }
        if self.complex.prepare(&pattern)? {
            report.symbolic_analyses += 1;
        }
        let h_values = self.system.matrix().expect("factored").values();
        let m_values = self.mass.as_ref().expect("set above").values();
        let damping = self.system.damping().map(|(d, _)| d.values());
        let nu = c64::new(self.k.lambda.re / h, self.k.lambda.im / h);
        let nu2 = nu * nu;
        for (k, out) in self.complex.values.iter_mut().enumerate() {
            let d = damping.map_or(0.0, |d| d[k]);
            let stiffness = (h_values[k] - m_values[k] - g * d) / (g * g);
            *out = c64::new(stiffness, 0.0) + nu2 * m_values[k] + nu * d;
        }
        self.complex.factor()?;
        report.factorizations += 1;
        Ok(())
    }

    /// Solve `(μ I − J) [dq; dv] = [r_q; M⁻¹ m_rv]` with the real factor (`μ = γ/h`): `dq`
    /// into `rhs`, then `dv = μ dq − r_q` into `dv`.
    #[allow(clippy::too_many_arguments)]
    fn solve_real(
        system: &mut ImplicitSystem,
        model: &mut Model,
        q0: &[f64],
        mu: f64,
        rq: &[f64],
        m_rv: &[f64],
        scratch: &mut [f64],
        rhs: &mut [f64],
        dv: &mut [f64],
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        // rhs = M r_v + μ M r_q + D r_q, then (K + μ² M + μ D) dq = rhs with H = g² (...).
        model.mass().mul_vec(rq, scratch);
        for k in 0..rhs.len() {
            rhs[k] = m_rv[k] + mu * scratch[k];
        }
        if let Some((d, _)) = system.damping() {
            d.mul_vec(rq, scratch);
            axpy(1.0, scratch, rhs);
        }
        let g2 = 1.0 / (mu * mu);
        rhs.iter_mut().for_each(|r| *r *= g2);
        system.solve(model, q0, rhs, report)?;
        for k in 0..rhs.len() {
            dv[k] = mu * rhs[k] - rq[k];
        }
        Ok(())
    }

    /// One step (see [`EmbeddedPair::attempt`]).
    fn step(
        &mut self,
        model: &mut Model,
        start: &State,
        h: f64,
        out: StageOutput<'_>,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let n = start.q.len();
        self.ensure_buffers(n);
        self.factor(model, start, h, report)?;
        let k = self.k.clone();
        let mu = k.gamma / h;
        let nu = c64::new(k.lambda.re / h, k.lambda.im / h);
        // Predictor: positions along the start velocity, no velocity change.
        for i in 0..3 {
            self.zv[i].fill(0.0);
            for (z, v) in self.zq[i].iter_mut().zip(&start.v) {
                *z = k.c[i] * h * v;
            }
        }
        for j in 0..3 {
            for (set_w, set_z) in [(&mut self.wq, &self.zq), (&mut self.wv, &self.zv)] {
                set_w[j].fill(0.0);
                for (i, z) in set_z.iter().enumerate() {
                    axpy(k.t_inv[(j, i)], z, &mut set_w[j]);
                }
            }
        }
        let q_scale = start.q.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        let mut previous = f64::INFINITY;
        let mut theta = 1.0;
        let mut converged = false;
        let mut iterations = 0;
        while iterations < self.newton.max_iterations.max(1) {
            StepError::stop_if_requested()?;
            iterations += 1;
            // Forces at the stages.
            for i in 0..3 {
                for kk in 0..n {
                    self.yq[kk] = start.q[kk] + self.zq[i][kk];
                    self.yv[kk] = start.v[kk] + self.zv[i][kk];
                }
                model.set_time(start.t + k.c[i] * h);
                Self::force_at(
                    model,
                    &self.yq,
                    &self.yv,
                    &mut self.scratch,
                    &mut self.force[i],
                )?;
            }
            // Residuals in W: r_q = T⁻¹ (v + Z_v) − Λ W_q / h; M r_v = T⁻¹ f − Λ M W_v / h.
            for j in 0..3 {
                let row_sum: f64 = (0..3).map(|i| k.t_inv[(j, i)]).sum();
                for kk in 0..n {
                    self.rq[j][kk] = row_sum * start.v[kk];
                }
                self.rv[j].fill(0.0);
                for i in 0..3 {
                    axpy(k.t_inv[(j, i)], &self.zv[i], &mut self.rq[j]);
                    axpy(k.t_inv[(j, i)], &self.force[i], &mut self.rv[j]);
                    let l = k.lambda_matrix[(j, i)] / h;
                    if l != 0.0 {
                        axpy(-l, &self.wq[i], &mut self.rq[j]);
                    }
                }
            }
            for i in 0..3 {
                model.mass().mul_vec(&self.wv[i], &mut self.scratch);
                for j in 0..3 {
                    let l = k.lambda_matrix[(j, i)] / h;
                    if l != 0.0 {
                        axpy(-l, &self.scratch, &mut self.rv[j]);
                    }
                }
            }
            // Real block: ΔW₁.
            Self::solve_real(
                &mut self.system,
                model,
                &start.q,
                mu,
                &self.rq[0],
                &self.rv[0],
                &mut self.scratch,
                &mut self.dq_real,
                &mut self.dv_real,
                report,
            )?;
            // Complex block: ΔW₂ + i ΔW₃ with rhs M r_v + ν M r_q + D r_q (complex).
            let (rq_re, rq_im) = (&self.rq[1], &self.rq[2]);
            model.mass().mul_vec(rq_re, &mut self.scratch);
            model.mass().mul_vec(rq_im, &mut self.im_scratch);
            for kk in 0..n {
                let m_rq = c64::new(self.scratch[kk], self.im_scratch[kk]);
                let value = c64::new(self.rv[1][kk], self.rv[2][kk]) + nu * m_rq;
                self.rhs[kk] = value.re;
                self.im[kk] = value.im;
            }
            if let Some((d, _)) = self.system.damping() {
                d.mul_vec(rq_re, &mut self.scratch);
                axpy(1.0, &self.scratch, &mut self.rhs);
                d.mul_vec(rq_im, &mut self.im_scratch);
                axpy(1.0, &self.im_scratch, &mut self.im);
            }
            self.complex.solve(&mut self.rhs, &mut self.im)?;
            report.linear_solves += 1;
            // Updates: W += ΔW (dv = ν dq − r_q for the pair), then Z = T W.
            for kk in 0..n {
                let dq = c64::new(self.rhs[kk], self.im[kk]);
                let dv = nu * dq - c64::new(self.rq[1][kk], self.rq[2][kk]);
                self.wq[0][kk] += self.dq_real[kk];
                self.wv[0][kk] += self.dv_real[kk];
                self.wq[1][kk] += dq.re;
                self.wq[2][kk] += dq.im;
                self.wv[1][kk] += dv.re;
                self.wv[2][kk] += dv.im;
            }
            let mut change = 0.0f64;
            let mut size = 0.0f64;
            for i in 0..3 {
                for kk in 0..n {
                    let zq: f64 = (0..3).map(|j| k.t[(i, j)] * self.wq[j][kk]).sum();
                    let zv: f64 = (0..3).map(|j| k.t[(i, j)] * self.wv[j][kk]).sum();
                    change = change.max((zq - self.zq[i][kk]).abs());
                    size = size.max(zq.abs());
                    self.zq[i][kk] = zq;
                    self.zv[i][kk] = zv;
                }
            }
            if !change.is_finite() {
                return Err(StepError::NonFinite {
                    what: "position",
                    index: 0,
                });
            }
            if iterations > 1 {
                theta = change / previous;
                if theta >= 1.0 {
                    return Err(StepError::NewtonFailed {
                        iterations,
                        reason: format!(
                            "Radau IIA's simplified Newton diverges (contraction {theta:.3})"
                        ),
                    });
                }
            }
            previous = change;
            let eta = if iterations > 1 {
                theta / (1.0 - theta)
            } else {
                1.0
            };
            if eta * change <= self.newton.tolerance * size
                || change <= 8.0 * f64::EPSILON * q_scale
            {
                converged = true;
                break;
            }
        }
        report.newton_iterations += iterations;
        if !converged {
            report.newton_unconverged += 1;
            if self.newton.require_convergence {
                return Err(StepError::NewtonFailed {
                    iterations,
                    reason: "Radau IIA's simplified Newton did not meet the tolerance".into(),
                });
            }
        }
        let StageOutput { q, v, error } = out;
        for kk in 0..n {
            q[kk] = start.q[kk] + self.zq[2][kk];
            v[kk] = start.v[kk] + self.zv[2][kk];
        }
        if let Some(err) = error {
            // cont = F(y) + (γ/h) Σ e_j Z_j; err = (μ I − J)⁻¹ cont.
            model.set_time(start.t);
            Self::force_at(
                model,
                &start.q,
                &start.v,
                &mut self.scratch,
                &mut self.rv[0],
            )?;
            self.rq[0].copy_from_slice(&start.v);
            self.yv.fill(0.0);
            for j in 0..3 {
                axpy(mu * k.e[j], &self.zq[j], &mut self.rq[0]);
                axpy(mu * k.e[j], &self.zv[j], &mut self.yv);
            }
            model.mass().mul_vec(&self.yv, &mut self.scratch);
            axpy(1.0, &self.scratch, &mut self.rv[0]);
            let (eq, ev) = err.split_at_mut(n);
            Self::solve_real(
                &mut self.system,
                model,
                &start.q,
                mu,
                &self.rq[0],
                &self.rv[0],
                &mut self.scratch,
                eq,
                ev,
                report,
            )?;
        }
        Ok(())
    }
}

impl EmbeddedPair for RadauIIA {
    fn name(&self) -> &'static str {
        "radau-iia"
    }

    fn order(&self) -> u32 {
        5
    }

    fn embedded_order(&self) -> u32 {
        3
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
        self.step(model, start, h, out, report)
    }
}
