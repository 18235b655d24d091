//! Vertex block descent (Chen, Macklin, Yuksel et al. 2024, "Vertex Block Descent"):
//! Gauss–Seidel over vertices on the backward Euler incremental potential
//!
//! `E(x) = 1/2 (x − x̂)ᵀ M (x − x̂) + dt² V(x) + dt/2 (x − q)ᵀ D (x − q)`, `x̂ = q + dt v`,
//!
//! the same `E` that `backward-euler` minimizes by Newton (damping `D` taken at `x̂`, as there),
//! so for any material VBD converges to the backward Euler step as its iterations grow.
//! Each vertex takes one 3×3 Newton step `x_i −= H_i⁻¹ g_i` with every other vertex held:
//! `g_i` is the exact partial gradient of `E` and `H_i = M_ii + dt² P(Σ_e H_e,ii) + dt D_ii`,
//! where the summed elastic (and spring, vertex-potential) 3×3 block is projected to positive
//! semi-definite (eigenvalue clamp, only when it is not already positive definite) so that
//! every local step descends. Consistent mass is used exactly (its row couples neighbours,
//! which the colouring keeps in other colours), so no lumping is assumed.
//!
//! Vertices of one colour ([`super::colouring`]) share no element, so each colour is updated
//! in parallel: the steps are computed from positions no thread writes, then applied; the
//! result is that of a sequential sweep in colour order for any thread count. Per-vertex tet
//! and spring lists are built once; a step allocates nothing.
//!
//! Options: the initial guess ([`VbdInitialization`]), the sweep ([`VbdSweep`]: the
//! paper's colour-by-colour Gauss–Seidel, or a damped block Jacobi whose steps all read the
//! same positions, in parallel over every vertex) and an acceleration of the sweeps as a
//! fixed-point map ([`super::acceleration`]: Chebyshev, Anderson). Velocity is
//! `v = (x − q)/dt`, as for backward Euler.

use super::acceleration::energy::PotentialScratch;
use super::acceleration::{Accelerate, Acceleration, AccelerationSettings, IncrementalPotential};
use super::{Integrator, State, StepError, StepReport};
use crate::colouring::Colouring;
use crate::fem::{ProjectToPsd, TetRest};
use crate::material::{Corotated, Material, MaterialModel};
use crate::model::{ElasticElements, MassMatrix, Model, Spring};
use crate::parallel::{Parallelism, for_each_chunk};
use crate::sparse::SymmetricMatrix;
use nalgebra::{Matrix3, Vector3};

/// The first iterate of a step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VbdInitialization {
    /// `x = q`.
    Previous,
    /// `x = q + dt v`.
    Inertia,
    /// The paper's adaptive guess `x = q + dt v + dt² ã ĝ`, with `ã` the previous step's
    /// acceleration along gravity clamped to `[0, |g|]` (full gravity on a first step;
    /// `inertia` without gravity).
    #[default]
    Adaptive,
}

crate::named_enum! {
    /// How a VBD sweep visits the vertices (`sweep` in `[integrator.vbd]`).
    pub enum VbdSweep: "vbd sweep", UnknownVbdSweep {
        /// Colour by colour, each vertex seeing the colours before it (the paper's).
        GaussSeidel = "gauss-seidel",
            "colour by colour: each colour sees the ones updated before it (the paper's)",
        /// Every vertex's step from the same positions, scaled by `jacobi_damping`.
        Jacobi = "jacobi",
            "damped block Jacobi: every vertex's 3x3 step from the same positions, times jacobi_damping",
    }
}

// named_enum! fixes the derive list, so the default is written out.
#[allow(clippy::derivable_impls)]
impl Default for VbdSweep {
    fn default() -> Self {
        Self::GaussSeidel
    }
}

/// Settings of `vbd`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct VbdSettings {
    /// Sweeps over all vertices per step. Default 20.
    pub iterations: u32,
    /// The first iterate. Default `adaptive`.
    pub initialization: VbdInitialization,
    /// Gauss–Seidel (colour by colour) or damped block Jacobi. Default `gauss-seidel`.
    pub sweep: VbdSweep,
    /// The factor α of the Jacobi sweep, `x_i += α Δx_i`, in (0, 1]. Default 0.5: with `A`
    /// the Hessian of `E` (a sum of positive semi-definite 4-vertex tet terms, 2-vertex
    /// springs, and the mass) and `D` its 3×3 block diagonal, `A ≼ 4 D` (a PSD matrix of k
    /// blocks is at most k times its block diagonal), so `D⁻¹A` has its spectrum in (0, 4]
    /// and the linearized iteration `I − α D⁻¹A` contracts for α < 1/2 and does not grow at
    /// 1/2; undamped (α = 1) it can diverge on a stiff body, where neighbours' steps overshoot
    /// together.
    pub jacobi_damping: f64,
    /// Acceleration of the sweeps: `none`, `chebyshev` or `anderson`. Default `none`.
    pub acceleration: Acceleration,
    /// Chebyshev's spectral radius ρ in [0, 1); 0 = estimate it each step. Default 0.
    pub chebyshev_rho: f64,
    /// Anderson's history m. Default 5.
    pub anderson_history: u32,
}

impl Default for VbdSettings {
    fn default() -> Self {
        Self {
            iterations: 20,
            initialization: VbdInitialization::Adaptive,
            sweep: VbdSweep::GaussSeidel,
            jacobi_damping: 0.5,
            acceleration: Acceleration::None,
            chebyshev_rho: 0.0,
            anderson_history: DEFAULT_ANDERSON_HISTORY,
        }
    }
}

/// Default `anderson_history` of both local solvers.
pub const DEFAULT_ANDERSON_HISTORY: u32 = 5;

impl VbdSettings {
    /// Check every field's range.
    pub fn validate(&self) -> Result<(), String> {
        if self.iterations == 0 {
            return Err("vbd.iterations must be >= 1".into());
        }
        if !(self.jacobi_damping > 0.0 && self.jacobi_damping <= 1.0) {
            return Err(format!(
                "vbd.jacobi_damping must be in (0, 1], got {}",
                self.jacobi_damping
            ));
        }
        self.acceleration_settings().validate("vbd")
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

/// Vertices per parallel task.
const CHUNK: usize = 16;

/// What is built once per model: the colouring and per-vertex element lists.
#[derive(Debug)]
struct Setup {
    num_dofs: usize,
    colouring: Colouring,
    /// Per free vertex f: `tet_corner[tet_ptr[f]..tet_ptr[f + 1]]` = `4 tet + corner`.
    tet_ptr: Vec<usize>,
    tet_corner: Vec<u32>,
    /// Per free vertex f: `spring_side[...]` = `2 spring + side`.
    spring_ptr: Vec<usize>,
    spring_side: Vec<u32>,
}

/// CSR lists: for each free vertex, the codes `arity * element + corner` of the elements that
/// hold it.
pub(super) fn incidence<const N: usize>(
    model: &Model,
    elements: impl Iterator<Item = [usize; N]> + Clone,
) -> (Vec<usize>, Vec<u32>) {
    let dofs = model.dofs();
    let nf = dofs.num_free();
    let mut ptr = vec![0usize; nf + 1];
    for el in elements.clone() {
        for v in el {
            if !dofs.is_fixed(v) {
                ptr[dofs.free_index(v) as usize + 1] += 1;
            }
        }
    }
    for f in 0..nf {
        ptr[f + 1] += ptr[f];
    }
    let mut fill = ptr.clone();
    let mut codes = vec![0u32; ptr[nf]];
    for (e, el) in elements.enumerate() {
        for (a, v) in el.into_iter().enumerate() {
            if !dofs.is_fixed(v) {
                let f = dofs.free_index(v) as usize;
                codes[fill[f]] = u32::try_from(N * e + a).expect("element index exceeds u32");
                fill[f] += 1;
            }
        }
    }
    (ptr, codes)
}

impl Setup {
    fn new(model: &Model) -> Self {
        let pattern = model.hessian_pattern().clone();
        let (cp, ri) = (pattern.col_ptr(), pattern.row_idx());
        // Block column f's first scalar column lists 3 rows per coupled vertex.
        let colouring = Colouring::greedy(model.dofs().num_free(), |f, visit| {
            for &r in ri[cp[3 * f]..cp[3 * f + 1]].iter().step_by(3) {
                visit(r / 3);
            }
        });
        let tets = model.elastic_elements().map_or(&[][..], |e| e.tets);
        let (tet_ptr, tet_corner) = incidence(model, tets.iter().copied());
        let springs = model.springs();
        let (spring_ptr, spring_side) = incidence(model, springs.iter().map(|s| [s.i, s.j]));
        Self {
            num_dofs: model.num_dofs(),
            colouring,
            tet_ptr,
            tet_corner,
            spring_ptr,
            spring_side,
        }
    }
}

/// The vertex block descent integrator.
#[derive(Debug, Default)]
pub struct Vbd {
    settings: VbdSettings,
    setup: Option<Setup>,
    /// Every vertex's current position (fixed ones at their prescribed positions).
    x: Vec<Vector3<f64>>,
    /// The acceleration (`None`: plain sweeps), the free DOFs it works on and its energy
    /// scratch.
    accelerator: Option<Box<dyn Accelerate>>,
    flat: Vec<f64>,
    energy_scratch: PotentialScratch,
    x_hat: Vec<f64>,
    dx: Vec<f64>,
    damping: Option<SymmetricMatrix>,
    /// Vertex potentials' gradient and Hessian block per vertex, refreshed per colour.
    vp_grad: Vec<Vector3<f64>>,
    vp_hess: Vec<Matrix3<f64>>,
    /// The velocity at the start of the previous step and the time this step must start at
    /// for it to be used (adaptive initialization).
    previous_v: Vec<f64>,
    previous_for: Option<f64>,
}

impl Vbd {
    /// A new integrator with `settings`.
    pub fn new(settings: VbdSettings) -> Self {
        Self {
            settings,
            accelerator: settings.acceleration_settings().build(),
            ..Self::default()
        }
    }

    /// The colouring of the free vertices used by the last step (`None` before a step).
    pub fn colouring(&self) -> Option<&Colouring> {
        self.setup.as_ref().map(|s| &s.colouring)
    }

    fn initialize(&mut self, model: &Model, state: &State, dt: f64) {
        let g = model.gravity().filter(|g| g.norm() > 0.0);
        let previous = self
            .previous_for
            .filter(|&t| t == state.t)
            .map(|_| &self.previous_v);
        for (f, &v) in model.dofs().free_vertices().iter().enumerate() {
            let q = Vector3::from_column_slice(&state.q[3 * f..3 * f + 3]);
            let vel = Vector3::from_column_slice(&state.v[3 * f..3 * f + 3]);
            self.x[v] = match self.settings.initialization {
                VbdInitialization::Previous => q,
                VbdInitialization::Inertia => q + vel * dt,
                VbdInitialization::Adaptive => {
                    let mut x = q + vel * dt;
                    if let Some(g) = g {
                        let (gn, dir) = (g.norm(), g / g.norm());
                        let a = match previous {
                            Some(pv) => {
                                let pv = Vector3::from_column_slice(&pv[3 * f..3 * f + 3]);
                                ((vel - pv) / dt).dot(&dir).clamp(0.0, gn)
                            }
                            None => gn,
                        };
                        x += dir * (dt * dt * a);
                    }
                    x
                }
            };
        }
    }
}

/// The vertex potentials' gradient and Hessian block of every vertex.
type VertexTerms<'a> = (&'a [Vector3<f64>], &'a [Matrix3<f64>]);

/// Everything one vertex's local step reads.
struct Local<'a, M> {
    material: M,
    material_name: &'static str,
    tets: &'a [[usize; 4]],
    rest: &'a [TetRest],
    setup: &'a Setup,
    springs: &'a [Spring],
    free_vertices: &'a [usize],
    mass: &'a MassMatrix,
    vertex_mass: &'a [f64],
    gravity: Option<Vector3<f64>>,
    damping: Option<&'a SymmetricMatrix>,
    vertex_terms: Option<VertexTerms<'a>>,
    x_hat: &'a [f64],
    q: &'a [f64],
    dt: f64,
}

/// `(A (x − anchor))` restricted to free vertex f's three rows, and A's diagonal block there.
#[inline]
fn row_block(
    a: &SymmetricMatrix,
    f: usize,
    x: &[Vector3<f64>],
    free_vertices: &[usize],
    anchor: &[f64],
) -> (Vector3<f64>, Matrix3<f64>) {
    let pattern = a.pattern();
    let (cp, ri, val) = (pattern.col_ptr(), pattern.row_idx(), a.values());
    let mut g = Vector3::zeros();
    let mut h = Matrix3::zeros();
    for k in 0..3 {
        let c = 3 * f + k;
        for p in cp[c]..cp[c + 1] {
            let r = ri[p];
            let y = x[free_vertices[r / 3]][r % 3] - anchor[r];
            g[k] += val[p] * y;
            if r / 3 == f {
                h[(r % 3, k)] += val[p];
            }
        }
    }
    (g, h)
}

impl<M: Material> Local<'_, M> {
    /// The local Newton step of free vertex `f` at positions `x`.
    fn step(&self, f: usize, x: &[Vector3<f64>]) -> Result<Vector3<f64>, StepError> {
        let s = self.setup;
        let v = self.free_vertices[f];
        // Potential part: dt² (elastic + springs + gravity + vertex potentials).
        let mut gp = Vector3::zeros();
        let mut hp = Matrix3::zeros();
        for &code in &s.tet_corner[s.tet_ptr[f]..s.tet_ptr[f + 1]] {
            let (e, a) = (code as usize / 4, code as usize % 4);
            let t = &self.tets[e];
            let rest = &self.rest[e];
            let fm = rest.deformation_gradient(&[x[t[0]], x[t[1]], x[t[2]], x[t[3]]]);
            let fail = |err: crate::material::InvalidDeformation| StepError::InvertedElement {
                tet: e,
                det_f: err.det_f,
                material: self.material_name,
            };
            let n = rest.shape_gradient(a);
            let (pn, block) = self.material.vertex_terms(&fm, &n).map_err(fail)?;
            gp += pn * rest.volume;
            hp += block * rest.volume;
        }
        let mut buf6 = [0.0; 6];
        let mut buf36 = [0.0; 36];
        for &code in &s.spring_side[s.spring_ptr[f]..s.spring_ptr[f + 1]] {
            let (k, side) = (code as usize / 2, code as usize % 2);
            let sp = &self.springs[k];
            sp.gradient(&x[sp.i], &x[sp.j], &mut buf6);
            sp.hessian(&x[sp.i], &x[sp.j], true, &mut buf36);
            gp += Vector3::from_column_slice(&buf6[3 * side..3 * side + 3]);
            let o = crate::fem::block_offset(2, side, side);
            hp += Matrix3::from_column_slice(&buf36[o..o + 9]);
        }
        if let Some(g) = self.gravity {
            gp -= g * self.vertex_mass[v];
        }
        if let Some((vg, vh)) = self.vertex_terms {
            gp += vg[v];
            hp += vh[v];
        }
        hp = (hp + hp.transpose()) * 0.5;
        if hp.cholesky().is_none() {
            hp.project_to_psd();
        }
        let dt = self.dt;
        let mut g = gp * (dt * dt);
        let mut h = hp * (dt * dt);
        // Inertia.
        match self.mass {
            MassMatrix::Consistent(m) => {
                let (mg, mh) = row_block(m, f, x, self.free_vertices, self.x_hat);
                g += mg;
                h += mh;
            }
            MassMatrix::Lumped { diagonal, .. } => {
                for k in 0..3 {
                    let i = 3 * f + k;
                    g[k] += diagonal[i] * (x[v][k] - self.x_hat[i]);
                    h[(k, k)] += diagonal[i];
                }
            }
        }
        // Damping dt/2 (x − q)ᵀ D (x − q).
        if let Some(d) = self.damping {
            let (dg, dh) = row_block(d, f, x, self.free_vertices, self.q);
            g += dg * dt;
            h += dh * dt;
        }
        Ok(h.cholesky().map_or_else(Vector3::zeros, |c| -c.solve(&g)))
    }
}

impl Integrator for Vbd {
    fn name(&self) -> &'static str {
        "vbd"
    }

    fn order(&self) -> u32 {
        1
    }

    fn is_explicit(&self) -> bool {
        false
    }

    fn reset(&mut self) {
        self.previous_for = None;
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let n = model.num_dofs();
        if self.setup.as_ref().map(|s| s.num_dofs) != Some(n) || self.x.is_empty() {
            self.setup = Some(Setup::new(model));
            self.x = model.full_positions(&state.q);
            self.x_hat = vec![0.0; n];
            self.flat = vec![0.0; n];
            let largest = self
                .setup
                .as_ref()
                .map_or(0, |s| s.colouring.largest_group());
            self.dx = match self.settings.sweep {
                VbdSweep::GaussSeidel => vec![0.0; 3 * largest],
                VbdSweep::Jacobi => vec![0.0; n],
            };
            self.previous_v = vec![0.0; n];
            self.previous_for = None;
            if !model.vertex_potentials().is_empty() {
                self.vp_grad = vec![Vector3::zeros(); self.x.len()];
                self.vp_hess = vec![Matrix3::zeros(); self.x.len()];
            }
        }
        for (i, (q, v)) in state.q.iter().zip(&state.v).enumerate() {
            self.x_hat[i] = q + dt * v;
        }
        model.set_time(state.t + dt);
        if model.has_damping() {
            let d = self.damping.get_or_insert_with(|| model.new_hessian());
            model.damping_matrix(&self.x_hat, d)?;
        }
        self.initialize(model, state, dt);
        match model.elastic_elements() {
            Some(ElasticElements {
                material,
                tets,
                rest,
            }) => match *material {
                MaterialModel::NeoHookean(m) => {
                    self.solve(m, material.name(), tets, rest, model, state, dt)
                }
                MaterialModel::StableNeoHookean(m) => {
                    self.solve(m, material.name(), tets, rest, model, state, dt)
                }
                MaterialModel::StVenantKirchhoff(m) => {
                    self.solve(m, material.name(), tets, rest, model, state, dt)
                }
                MaterialModel::Corotated(m) => {
                    self.solve(m, material.name(), tets, rest, model, state, dt)
                }
                MaterialModel::ConstraintNeoHookean(m) => {
                    self.solve(m, material.name(), tets, rest, model, state, dt)
                }
            },
            None => {
                let none = Corotated {
                    mu: 0.0,
                    lambda: 0.0,
                };
                self.solve(none, "none", &[], &[], model, state, dt)
            }
        }?;
        self.previous_v.copy_from_slice(&state.v);
        self.previous_for = Some(state.t + dt);
        for (f, &v) in model.dofs().free_vertices().iter().enumerate() {
            for k in 0..3 {
                let i = 3 * f + k;
                state.v[i] = (self.x[v][k] - state.q[i]) / dt;
                state.q[i] = self.x[v][k];
            }
        }
        report.substeps = 1;
        report.local_iterations = self.settings.iterations;
        // Each sweep computes every vertex's force and 3x3 Hessian block from its elements.
        let sweeps = u64::from(self.settings.iterations);
        model.count_local_passes(sweeps, sweeps);
        if let Some(acc) = &self.accelerator {
            acc.report(report);
        }
        Ok(())
    }
}

impl Vbd {
    #[allow(clippy::too_many_arguments)]
    fn solve<M: Material>(
        &mut self,
        material: M,
        material_name: &'static str,
        tets: &[[usize; 4]],
        rest: &[TetRest],
        model: &Model,
        state: &State,
        dt: f64,
    ) -> Result<(), StepError> {
        let setup = self.setup.as_ref().expect("set up before solving");
        let par: Parallelism = model.parallelism();
        let free_vertices = model.dofs().free_vertices();
        let potentials = model.vertex_potentials();
        if let Some(acc) = self.accelerator.as_mut() {
            model.dofs().gather(&self.x, &mut self.flat);
            acc.start(&self.flat);
        }
        let damping = self.damping.as_ref().filter(|_| model.has_damping());
        for _ in 0..self.settings.iterations {
            StepError::stop_if_requested()?;
            let groups = match self.settings.sweep {
                VbdSweep::GaussSeidel => setup.colouring.num_colours(),
                VbdSweep::Jacobi => 1,
            };
            for c in 0..groups {
                let group = match self.settings.sweep {
                    VbdSweep::GaussSeidel => Some(setup.colouring.group(c)),
                    VbdSweep::Jacobi => None,
                };
                if !potentials.is_empty() {
                    self.vp_grad.fill(Vector3::zeros());
                    self.vp_hess.fill(Matrix3::zeros());
                    let (vg, vh) = (&mut self.vp_grad, &mut self.vp_hess);
                    for p in potentials {
                        p.gradient(model.time(), &self.x, &mut |v, g| vg[v] += g);
                        p.hessian(model.time(), &self.x, true, &mut |v, h| vh[v] += h);
                    }
                }
                let local = Local {
                    material,
                    material_name,
                    tets,
                    rest,
                    setup,
                    springs: model.springs(),
                    free_vertices,
                    mass: model.mass(),
                    vertex_mass: model.vertex_masses(),
                    gravity: model.gravity(),
                    damping,
                    vertex_terms: (!potentials.is_empty())
                        .then_some((self.vp_grad.as_slice(), self.vp_hess.as_slice())),
                    x_hat: &self.x_hat,
                    q: &state.q,
                    dt,
                };
                let x = &self.x;
                let len = group.map_or(free_vertices.len(), <[usize]>::len);
                let out = &mut self.dx[..3 * len];
                for_each_chunk(par, out, 3 * CHUNK, |ci, out| {
                    for (k, o) in out.chunks_exact_mut(3).enumerate() {
                        let i = ci * CHUNK + k;
                        let f = group.map_or(i, |g| g[i]);
                        let d = local.step(f, x)?;
                        o.copy_from_slice(d.as_slice());
                    }
                    Ok::<(), StepError>(())
                })?;
                let scale = match self.settings.sweep {
                    VbdSweep::GaussSeidel => 1.0,
                    VbdSweep::Jacobi => self.settings.jacobi_damping,
                };
                for k in 0..len {
                    let f = group.map_or(k, |g| g[k]);
                    let v = free_vertices[f];
                    self.x[v] += Vector3::from_column_slice(&self.dx[3 * k..3 * k + 3]) * scale;
                }
            }
            if let Some(acc) = self.accelerator.as_mut() {
                let dofs = model.dofs();
                dofs.gather(&self.x, &mut self.flat);
                let potential = IncrementalPotential {
                    model,
                    x_hat: &self.x_hat,
                    q: &state.q,
                    damping,
                    dt,
                };
                let scratch = &mut self.energy_scratch;
                acc.update(&mut self.flat, &mut |y| potential.value(y, scratch))?;
                dofs.scatter(&self.flat, &mut self.x);
            }
        }
        Ok(())
    }
}
