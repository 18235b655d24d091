//! Projective dynamics (Bouaziz, Martin, Liu, Kavan, Pauly 2014): local/global iterations on
//! the backward Euler step of a *projective* energy, a sum of weighted squared distances
//! `w/2 ‖A x − p‖²` to constraint sets, with `p` the closest point of the set.
//!
//! The energy it converges to is corotated elasticity, `psi = mu ‖F − R‖² + lambda/2
//! (tr S − 3)²` (material `corotated`, F = R S), which is exactly projective per tet:
//! - as-rigid-as-possible: `(2 mu)/2 dist²(F, SO(3))`, projection `R` (polar rotation, through
//!   the rotation-variant SVD, so inverted tets project to a rotation too);
//! - volume: `(3 lambda)/2 dist²(F, {tr S = 3})`, projection `F − t R` with
//!   `t = (tr S − 3)/3` (the singular values moved onto the plane `Σσ = 3`).
//!
//! Springs are projective too (`k/2 dist²(x_i − x_j, sphere of radius L)`), and so is a drag
//! (`k/2 |x − target(t)|²`, a projection onto a point: it adds `dt² k` to the matrix's
//! diagonal while it pulls). So the converged reference is `backward-euler` on the same scene
//! with material `corotated`. Damping enters as backward Euler's quadratic term
//! `dt/2 (x − q)ᵀ D (x − q)` (D at x̂), which adds `dt D` to the global matrix: with damping the
//! matrix is refactored every step. A scene with another material or a per-vertex potential
//! that is not a set of anchors (penalty contact) is refused when the scene is built: their
//! energies have no projective form here (obstacles take the `projection` or `velocity-flip`
//! response instead).
//!
//! Global step: `(M + dt² Σ w Gᵀ G + dt² K) x = M x̂ + dt² (m g + Σ w Gᵀ p + K t) − (fixed-vertex
//! terms)`, the matrix factored once per dt and drag state (symbolic once) by the scene's
//! linear solver. Local step:
//! the projections of every tet, in parallel into a per-tet buffer, gathered per vertex in a
//! fixed order, so results are identical for any thread count. Velocity `v = (x − q)/dt`.
//!
//! The iterations can be accelerated ([`super::acceleration`]: Chebyshev, Anderson) as a
//! fixed-point map of the free DOFs; Anderson's safeguard evaluates the backward Euler
//! incremental potential of the model (corotated, springs, gravity, drags, damping), the
//! energy local/global iterations decrease.

use super::acceleration::energy::PotentialScratch;
use super::acceleration::{Accelerate, Acceleration, AccelerationSettings, IncrementalPotential};
use super::vbd::{DEFAULT_ANDERSON_HISTORY, incidence};
use super::{Integrator, State, StepError, StepReport};
use crate::fem::TetRest;
use crate::material::{MaterialModel, RotationVariantSvd};
use crate::model::{Anchors, Model, ModelError};
use crate::parallel::{Parallelism, for_each_chunk};
use crate::solve::LinearSolver;
use crate::sparse::SymmetricMatrix;
use nalgebra::{Matrix3, Vector3};

/// Settings of `projective-dynamics`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProjectiveDynamicsSettings {
    /// Local/global iterations per step. Default 10.
    pub iterations: u32,
    /// Acceleration of the iterations: `none`, `chebyshev` or `anderson`. Default `none`.
    pub acceleration: Acceleration,
    /// Chebyshev's spectral radius ρ in [0, 1); 0 = estimate it each step. Default 0.
    pub chebyshev_rho: f64,
    /// Anderson's history m. Default 5.
    pub anderson_history: u32,
}

impl Default for ProjectiveDynamicsSettings {
    fn default() -> Self {
        Self {
            iterations: 10,
            acceleration: Acceleration::None,
            chebyshev_rho: 0.0,
            anderson_history: DEFAULT_ANDERSON_HISTORY,
        }
    }
}

impl ProjectiveDynamicsSettings {
    /// Check every field's range.
    pub fn validate(&self) -> Result<(), String> {
        if self.iterations == 0 {
            return Err("projective_dynamics.iterations must be >= 1".into());
        }
        self.acceleration_settings().validate("projective_dynamics")
    }

    /// The acceleration part.
    pub fn acceleration_settings(&self) -> AccelerationSettings {
        AccelerationSettings {
            acceleration: self.acceleration,
            chebyshev_rho: self.chebyshev_rho,
            anderson_history: self.anderson_history,
        }
    }
}

/// Tets per parallel task of the local step.
const CHUNK: usize = 256;

fn unsupported(field: &str, value: impl ToString, expected: &str) -> StepError {
    StepError::Model(ModelError::InvalidParameter {
        field: field.into(),
        value: value.to_string(),
        expected: expected.into(),
    })
}

/// The projective-dynamics integrator.
pub struct ProjectiveDynamics {
    settings: ProjectiveDynamicsSettings,
    solver: Box<dyn LinearSolver>,
    /// The acceleration (`None`: plain iterations) and its energy scratch.
    accelerator: Option<Box<dyn Accelerate>>,
    energy_scratch: PotentialScratch,
    /// The dt the matrices belong to and the number of DOFs they were built for.
    factored: Option<(f64, usize)>,
    /// `M + dt² Σ w Gᵀ G`; the system matrix (plus `dt² K` and `dt D`), and `D(x̂)`.
    base: Option<SymmetricMatrix>,
    system: Option<SymmetricMatrix>,
    damping: Option<SymmetricMatrix>,
    /// The anchors at the step's end, and the stiffness per vertex the factorization holds
    /// (`None`: nothing factored yet).
    anchors: Anchors,
    factored_anchors: Option<Vec<f64>>,
    /// The diagonal slots of the free DOFs in the Hessian pattern.
    diagonal: Vec<usize>,
    damping_q: Vec<f64>,
    /// Per free vertex: `4 tet + corner` of its tets; `2 spring + side` of its springs.
    tet_ptr: Vec<usize>,
    tet_corner: Vec<u32>,
    spring_ptr: Vec<usize>,
    spring_side: Vec<u32>,
    /// `(Σ w Gᵀ G)` applied to the fixed vertices' positions, restricted to free DOFs.
    fixed_coupling: Vec<f64>,
    /// Per tet: `V (w_a p_a + w_v p_v)` (column-major 3×3); per spring: `k p`.
    tet_targets: Vec<f64>,
    spring_targets: Vec<f64>,
    x: Vec<Vector3<f64>>,
    x_hat: Vec<f64>,
    rhs: Vec<f64>,
    inertia: Vec<f64>,
}

impl ProjectiveDynamics {
    /// A new integrator solving its global systems with `solver`.
    pub fn new(settings: ProjectiveDynamicsSettings, solver: Box<dyn LinearSolver>) -> Self {
        Self {
            settings,
            solver,
            accelerator: settings.acceleration_settings().build(),
            energy_scratch: PotentialScratch::default(),
            factored: None,
            base: None,
            system: None,
            damping: None,
            anchors: Anchors::default(),
            factored_anchors: None,
            diagonal: Vec::new(),
            damping_q: Vec::new(),
            tet_ptr: Vec::new(),
            tet_corner: Vec::new(),
            spring_ptr: Vec::new(),
            spring_side: Vec::new(),
            fixed_coupling: Vec::new(),
            tet_targets: Vec::new(),
            spring_targets: Vec::new(),
            x: Vec::new(),
            x_hat: Vec::new(),
            rhs: Vec::new(),
            inertia: Vec::new(),
        }
    }

    /// The corotated constants `(w_arap, w_volume) = (2 mu, 3 lambda)`, or the reason the
    /// model has no projective form here.
    fn weights(model: &Model) -> Result<(f64, f64), StepError> {
        if let Err(name) = Anchors::check(model.vertex_potentials()) {
            return Err(unsupported(
                "vertex potential",
                name,
                "projective-dynamics takes drags (anchors) but no other per-vertex potential; \
                 for obstacles use contact.response = \"projection\" or \"velocity-flip\"",
            ));
        }
        match model.elastic_elements().map(|e| *e.material) {
            None => Ok((0.0, 0.0)),
            Some(MaterialModel::Corotated(c)) => Ok((2.0 * c.mu, 3.0 * c.lambda)),
            Some(other) => Err(unsupported(
                "material.model",
                other.name(),
                "projective-dynamics converges to its projective energy, corotated elasticity: \
                 use material `corotated`",
            )),
        }
    }

    /// Build the incidence lists, the global matrix `M + dt² L` and its factorization.
    fn set_up(&mut self, model: &Model, dt: f64, w: f64) -> Result<(), StepError> {
        let n = model.num_dofs();
        let dofs = model.dofs();
        let empty: &[[usize; 4]] = &[];
        let (tets, rest): (&[[usize; 4]], &[TetRest]) = model
            .elastic_elements()
            .map_or((empty, &[]), |e| (e.tets, e.rest));
        (self.tet_ptr, self.tet_corner) = incidence(model, tets.iter().copied());
        let springs = model.springs();
        (self.spring_ptr, self.spring_side) = incidence(model, springs.iter().map(|s| [s.i, s.j]));
        let pattern = model.hessian_pattern();
        let mut a = model.new_hessian();
        model.mass().add_scaled_to(1.0, &mut a);
        self.fixed_coupling = vec![0.0; n];
        let x0 = model.full_positions(&model.rest_state());
        let mut add = |a: &mut SymmetricMatrix, vi: usize, vj: usize, c: f64| {
            let (fi, fj) = (dofs.free_index(vi), dofs.free_index(vj));
            if dofs.is_fixed(vi) {
                return;
            }
            let fi = fi as usize;
            if dofs.is_fixed(vj) {
                let coupling = &mut self.fixed_coupling[3 * fi..3 * fi + 3];
                for (out, xk) in coupling.iter_mut().zip(x0[vj].iter()) {
                    *out += c * xk;
                }
                return;
            }
            let fj = fj as usize;
            for k in 0..3 {
                let slot = pattern
                    .find(3 * fi + k, 3 * fj + k)
                    .expect("element couplings are in the Hessian pattern");
                a.values_mut()[slot] += dt * dt * c;
            }
        };
        for (t, r) in tets.iter().zip(rest) {
            let g = r.shape_gradients();
            for i in 0..4 {
                for j in 0..4 {
                    add(&mut a, t[i], t[j], w * r.volume * g[i].dot(&g[j]));
                }
            }
        }
        for s in springs {
            for (vi, vj, sign) in [
                (s.i, s.i, 1.0),
                (s.i, s.j, -1.0),
                (s.j, s.i, -1.0),
                (s.j, s.j, 1.0),
            ] {
                add(&mut a, vi, vj, sign * s.stiffness);
            }
        }
        self.solver.analyze(pattern)?;
        self.diagonal = (0..n)
            .map(|i| pattern.find(i, i).expect("the pattern holds the diagonal"))
            .collect();
        self.system = Some(a.clone());
        self.base = Some(a);
        self.factored_anchors = None;
        self.factored = Some((dt, n));
        self.tet_targets = vec![0.0; 9 * tets.len()];
        self.spring_targets = vec![0.0; 3 * springs.len()];
        self.x = x0;
        self.x_hat = vec![0.0; n];
        self.rhs = vec![0.0; n];
        self.inertia = vec![0.0; n];
        Ok(())
    }
}

/// The local step of one tet: `V (w_a R + w_v (F − t R))`, `t = (tr S − 3)/3`.
#[inline]
fn tet_target(
    r: &TetRest,
    t: &[usize; 4],
    x: &[Vector3<f64>],
    (wa, wv): (f64, f64),
) -> Matrix3<f64> {
    let f = r.deformation_gradient(&[x[t[0]], x[t[1]], x[t[2]], x[t[3]]]);
    let Some(svd) = RotationVariantSvd::new(&f) else {
        // A non-finite F: the projection is undefined; the state check reports it.
        return f * (r.volume * (wa + wv));
    };
    let rot = svd.rotation();
    let shift = (svd.sigma.sum() - 3.0) / 3.0;
    (rot * wa + (f - rot * shift) * wv) * r.volume
}

impl Integrator for ProjectiveDynamics {
    fn name(&self) -> &'static str {
        "projective-dynamics"
    }

    fn check_model(&self, model: &Model) -> Result<(), StepError> {
        Self::weights(model).map(|_| ())
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
        let (wa, wv) = Self::weights(model)?;
        let n = model.num_dofs();
        // Drags and the acceleration's energy are taken at the step's end.
        model.set_time(state.t + dt);
        if self.factored != Some((dt, n)) {
            self.set_up(model, dt, wa + wv)?;
            report.symbolic_analyses += 1;
        }
        let dofs = model.dofs();
        let free = dofs.free_vertices();
        for (i, (q, v)) in state.q.iter().zip(&state.v).enumerate() {
            self.x_hat[i] = q + dt * v;
        }
        // Drags pull towards their targets at the step's end, as in backward Euler.
        self.anchors
            .gather(model.vertex_potentials(), dofs.num_vertices(), state.t + dt)
            .map_err(|name| unsupported("vertex potential", name, "anchors"))?;
        // Constant part of the right-hand side: M x̂ + dt² (m g + K t) − dt² L_fixed x_fixed.
        model.mass().mul_vec(&self.x_hat, &mut self.inertia);
        let masses = model.vertex_masses();
        let g = model.gravity().unwrap_or_else(Vector3::zeros);
        for (f, &v) in free.iter().enumerate() {
            let pull = masses[v] * g + self.anchors.pull[v];
            for k in 0..3 {
                let i = 3 * f + k;
                self.inertia[i] += dt * dt * (pull[k] - self.fixed_coupling[i]);
            }
        }
        // The system matrix changes with damping (D at x̂) and when a drag starts or ends.
        let anchors = &self.anchors.stiffness;
        let unchanged = self.factored_anchors.as_ref().is_some_and(|k| {
            k.len() == free.len() && free.iter().zip(k).all(|(&v, k)| anchors[v] == *k)
        });
        if model.has_damping() || !unchanged {
            let factored = self.factored_anchors.get_or_insert_with(Vec::new);
            factored.clear();
            factored.extend(free.iter().map(|&v| anchors[v]));
            let base = self.base.as_ref().expect("set up");
            let a = self.system.as_mut().expect("set up");
            a.values_mut().copy_from_slice(base.values());
            for (f, k) in factored.iter().enumerate() {
                for j in 0..3 {
                    a.values_mut()[self.diagonal[3 * f + j]] += dt * dt * k;
                }
            }
            if model.has_damping() {
                let d = self.damping.get_or_insert_with(|| model.new_hessian());
                model.damping_matrix(&self.x_hat, d)?;
                a.axpby(1.0, dt, d);
            }
            if let Err(e) = self.solver.factor(a) {
                self.factored_anchors = None;
                return Err(e.into());
            }
            report.factorizations += 1;
        }
        if model.has_damping() {
            let d = self.damping.as_ref().expect("assembled above");
            self.damping_q.resize(n, 0.0);
            d.mul_vec(&state.q, &mut self.damping_q);
            for (r, dq) in self.inertia.iter_mut().zip(&self.damping_q) {
                *r += dt * dq;
            }
        }
        let dofs = model.dofs();
        let free = dofs.free_vertices();
        // The first iterate: x̂.
        dofs.scatter(&self.x_hat, &mut self.x);
        if let Some(acc) = self.accelerator.as_mut() {
            acc.start(&self.x_hat);
        }
        let damping = self.damping.as_ref().filter(|_| model.has_damping());
        let empty: &[[usize; 4]] = &[];
        let (tets, rest): (&[[usize; 4]], &[TetRest]) = model
            .elastic_elements()
            .map_or((empty, &[]), |e| (e.tets, e.rest));
        let springs = model.springs();
        let par: Parallelism = model.parallelism();
        for _ in 0..self.settings.iterations {
            StepError::stop_if_requested()?;
            // Local: every tet's projection, in parallel.
            let x = &self.x;
            for_each_chunk(par, &mut self.tet_targets, 9 * CHUNK, |ci, out| {
                for (k, o) in out.chunks_exact_mut(9).enumerate() {
                    let e = ci * CHUNK + k;
                    o.copy_from_slice(tet_target(&rest[e], &tets[e], x, (wa, wv)).as_slice());
                }
                Ok::<(), StepError>(())
            })?;
            for (s, o) in springs.iter().zip(self.spring_targets.chunks_exact_mut(3)) {
                let d = x[s.i] - x[s.j];
                let l = d.norm();
                let p = if l > 0.0 { d * (s.rest_length / l) } else { d };
                o.copy_from_slice((p * s.stiffness).as_slice());
            }
            // Gather per free vertex: rhs = inertia + dt² Σ Gᵀ (weighted targets).
            let (tp, tc, sp, ss) = (
                &self.tet_ptr,
                &self.tet_corner,
                &self.spring_ptr,
                &self.spring_side,
            );
            let (tt, st, inertia) = (&self.tet_targets, &self.spring_targets, &self.inertia);
            for_each_chunk(par, &mut self.rhs, 3 * CHUNK, |ci, out| {
                for (k, o) in out.chunks_exact_mut(3).enumerate() {
                    let f = ci * CHUNK + k;
                    let mut acc = Vector3::zeros();
                    for &code in &tc[tp[f]..tp[f + 1]] {
                        let (e, a) = (code as usize / 4, code as usize % 4);
                        let target = Matrix3::from_column_slice(&tt[9 * e..9 * e + 9]);
                        acc += target * rest[e].shape_gradient(a);
                    }
                    for &code in &ss[sp[f]..sp[f + 1]] {
                        let (s, side) = (code as usize / 2, code as usize % 2);
                        let p = Vector3::from_column_slice(&st[3 * s..3 * s + 3]);
                        acc += if side == 0 { p } else { -p };
                    }
                    for j in 0..3 {
                        o[j] = inertia[3 * f + j] + dt * dt * acc[j];
                    }
                }
                Ok::<(), StepError>(())
            })?;
            // Global: the prefactored solve.
            let solved = self.solver.solve(&mut self.rhs)?;
            report.linear_solves += 1;
            report.linear_iterations += solved.iterations as u64;
            report.max_relative_residual =
                report.max_relative_residual.max(solved.relative_residual);
            if let Some(acc) = self.accelerator.as_mut() {
                let potential = IncrementalPotential {
                    model,
                    x_hat: &self.x_hat,
                    q: &state.q,
                    damping,
                    dt,
                };
                let scratch = &mut self.energy_scratch;
                acc.update(&mut self.rhs, &mut |y| potential.value(y, scratch))?;
            }
            dofs.scatter(&self.rhs, &mut self.x);
        }
        for (i, (q, v)) in state.q.iter_mut().zip(state.v.iter_mut()).enumerate() {
            let x = self.x[free[i / 3]][i % 3];
            *v = (x - *q) / dt;
            *q = x;
        }
        report.substeps = 1;
        report.local_iterations = self.settings.iterations;
        // Each local step projects every element onto its constraint set.
        model.count_local_passes(u64::from(self.settings.iterations), 0);
        if let Some(acc) = &self.accelerator {
            acc.report(report);
        }
        Ok(())
    }
}
