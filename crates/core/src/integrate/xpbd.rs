//! XPBD with Macklin & Müller's Neo-Hookean constraints (2021, "A Constraint-based
//! Formulation of Stable Neo-Hookean Materials"): per tet, the deviatoric constraint
//! `C_D = ‖F‖_F` with compliance `1/(mu V)` and the hydrostatic one `C_H = det F − (1 + mu/lambda)`
//! with compliance `1/(lambda V)`, solved one after the other in each tet.
//!
//! Its energy is `mu/2 ‖F‖² + lambda/2 (J − 1 − mu/lambda)²` per unit volume, material
//! `xpbd-neo-hookean` ([`crate::material::ConstraintNeoHookean`]): as substeps grow, XPBD
//! follows the dynamics of that energy (with lumped mass), so it matches `backward-euler` on
//! that material within backward Euler's discretization error. A drag is a compliant
//! zero-length constraint per picked vertex, `C = x − target(t)` with compliance `1/k` (its
//! potential `k/2 |x − target|²` exactly). Other materials, consistent mass, springs, damping
//! and other per-vertex potentials (penalty contact: use the `projection` or `velocity-flip`
//! response) are refused when the scene is built.
//!
//! Each substep `h = dt/substeps`: `v += h g`, `x += h v`, multipliers reset, `iterations`
//! Gauss–Seidel sweeps over the drag constraints (targets at the substep's end) and then the
//! tets, `v = (x − x_start)/h`. Tets of one colour share no free vertex
//! ([`super::colouring`]), so the tets of a colour are projected in place at once: each colour
//! is cut into chunks of `parallel_min_tets` tets, which the pool's threads claim in colour
//! order ([`crate::parallel::OrderedChunks`]), a colour starting once the one before it is
//! done. The result is that of a sequential sweep, whatever the thread count or split.

use super::{Integrator, State, StepError, StepReport};
use crate::colouring::Colouring;
use crate::fem::TetRest;
use crate::material::{ConstraintNeoHookean, MaterialModel, cofactor};
use crate::model::{Anchors, MassKind, Model, ModelError};
use crate::parallel::{DisjointSlice, OrderedChunks, Parallelism};
use nalgebra::{Matrix3, Vector3};

/// Settings of `xpbd`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct XpbdSettings {
    /// Substeps per step. Default 20.
    pub substeps: u32,
    /// Gauss–Seidel sweeps over the constraints per substep. Default 1.
    pub iterations: u32,
    /// Tets per parallel chunk of a colour; a sweep whose colours all fit in one chunk runs on
    /// the calling thread. Decides speed only, never results. Default
    /// [`PARALLEL_MIN_TETS`], measured by `cargo bench --bench thread_crossover`.
    pub parallel_min_tets: usize,
}

impl Default for XpbdSettings {
    fn default() -> Self {
        Self {
            substeps: 20,
            iterations: 1,
            parallel_min_tets: PARALLEL_MIN_TETS,
        }
    }
}

impl XpbdSettings {
    /// Check every field's range.
    pub fn validate(&self) -> Result<(), String> {
        if self.substeps == 0 || self.iterations == 0 {
            return Err("xpbd.substeps and xpbd.iterations must be >= 1".into());
        }
        Ok(())
    }
}

/// Default of [`XpbdSettings::parallel_min_tets`], tets per chunk (about 100 ns each):
/// `cargo bench --bench thread_crossover -- xpbd` measures the sweep against one thread. With
/// 64, two threads were 0.99–1.02x at 96 and 768 tets and 1.7x at 12k and 49k in four runs;
/// 32 was 0.84–1.03x at 768 tets, 128 0.88–0.98x at 2.6k.
pub const PARALLEL_MIN_TETS: usize = 64;

fn unsupported(field: &str, value: impl ToString, expected: &str) -> StepError {
    StepError::Model(ModelError::InvalidParameter {
        field: field.into(),
        value: value.to_string(),
        expected: expected.into(),
    })
}

/// The XPBD integrator.
#[derive(Debug, Default)]
pub struct Xpbd {
    settings: XpbdSettings,
    num_dofs: Option<usize>,
    colouring: Colouring,
    /// The sweep's chunks in colour order.
    schedule: OrderedChunks,
    /// The tets with their rest data in colour order (a colour's tets contiguous, so a sweep
    /// streams through memory; colour `c` starts at `colouring.group_start(c)`).
    sorted: Vec<([usize; 4], TetRest)>,
    /// Inverse lumped mass of every vertex (0 for fixed ones).
    inverse_mass: Vec<f64>,
    x: Vec<Vector3<f64>>,
    x_start: Vec<Vector3<f64>>,
    v: Vec<Vector3<f64>>,
    /// Multipliers (C_D, C_H) per tet, in colour order.
    lambda: Vec<[f64; 2]>,
    /// The drags at the current substep's end, and their multipliers per vertex.
    anchors: Anchors,
    anchor_lambda: Vec<Vector3<f64>>,
}

impl Xpbd {
    /// A new integrator with `settings`.
    pub fn new(settings: XpbdSettings) -> Self {
        Self {
            settings,
            ..Self::default()
        }
    }

    /// The colouring of the tets (`None` before a step).
    pub fn colouring(&self) -> Option<&Colouring> {
        self.num_dofs.map(|_| &self.colouring)
    }

    fn material(model: &Model) -> Result<Option<ConstraintNeoHookean>, StepError> {
        if model.has_damping() {
            return Err(unsupported("damping", "on", "xpbd has no damping"));
        }
        if !model.springs().is_empty() {
            return Err(unsupported(
                "springs",
                model.springs().len(),
                "xpbd has no springs",
            ));
        }
        if let Err(name) = Anchors::check(model.vertex_potentials()) {
            return Err(unsupported(
                "vertex potential",
                name,
                "xpbd takes drags (anchors) but no other per-vertex potential; for obstacles \
                 use contact.response = \"projection\" or \"velocity-flip\"",
            ));
        }
        let material = match model.elastic_elements().map(|e| *e.material) {
            None => None,
            Some(MaterialModel::ConstraintNeoHookean(m)) => Some(m),
            Some(other) => {
                return Err(unsupported(
                    "material.model",
                    other.name(),
                    "xpbd converges to the energy of its constraints: use material \
                     `xpbd-neo-hookean`",
                ));
            }
        };
        if model.mass().kind() != MassKind::Lumped {
            return Err(unsupported(
                "material.mass",
                "consistent",
                "xpbd moves vertices with their lumped masses; set material.mass = \"lumped\" \
                 so its converged reference has the same mass",
            ));
        }
        Ok(material)
    }

    fn set_up(&mut self, model: &Model, q: &[f64]) {
        let dofs = model.dofs();
        let empty: &[[usize; 4]] = &[];
        let (tets, rest): (&[[usize; 4]], &[TetRest]) = model
            .elastic_elements()
            .map_or((empty, &[]), |e| (e.tets, e.rest));
        let (ptr, codes) = super::vbd::incidence(model, tets.iter().copied());
        self.colouring = Colouring::greedy(tets.len(), |e, visit| {
            for &v in &tets[e] {
                if !dofs.is_fixed(v) {
                    let f = dofs.free_index(v) as usize;
                    for &code in &codes[ptr[f]..ptr[f + 1]] {
                        visit(code as usize / 4);
                    }
                }
            }
        });
        self.schedule = OrderedChunks::new(
            (0..self.colouring.num_colours()).map(|c| self.colouring.group(c).len()),
            self.settings.parallel_min_tets,
        );
        self.sorted = (0..self.colouring.num_colours())
            .flat_map(|c| self.colouring.group(c))
            .map(|&e| (tets[e], rest[e]))
            .collect();
        self.inverse_mass = (0..dofs.num_vertices())
            .map(|v| {
                if dofs.is_fixed(v) {
                    0.0
                } else {
                    1.0 / model.vertex_masses()[v]
                }
            })
            .collect();
        self.x = model.full_positions(q);
        self.x_start = self.x.clone();
        self.v = vec![Vector3::zeros(); self.x.len()];
        self.lambda = vec![[0.0; 2]; tets.len()];
        self.anchor_lambda = vec![Vector3::zeros(); self.x.len()];
        self.num_dofs = Some(model.num_dofs());
    }
}

impl Xpbd {
    /// One sweep over the drag constraints `C = x_v − t_v` (compliance `1/K_v`): each is
    /// linear, so its update is exact for the current multiplier.
    fn solve_anchors(&mut self, free: &[usize], h2: f64) {
        for &v in free {
            let k = self.anchors.stiffness[v];
            if k <= 0.0 {
                continue;
            }
            let alpha_tilde = 1.0 / (k * h2);
            let c = self.x[v] - self.anchors.pull[v] / k;
            let w = self.inverse_mass[v];
            let dl = (-c - self.anchor_lambda[v] * alpha_tilde) / (w + alpha_tilde);
            self.x[v] += dl * w;
            self.anchor_lambda[v] += dl;
        }
    }
}

/// One constraint projection on the tet's local positions `p`: returns the multiplier change.
/// `dm_inv`'s rows are the shape gradients of vertices 1–3.
#[inline(always)]
fn project(
    p: &mut [Vector3<f64>; 4],
    w: &[f64; 4],
    dm_inv: &Matrix3<f64>,
    c: f64,
    dc_df: &Matrix3<f64>,
    lambda: f64,
    alpha_tilde: f64,
) -> f64 {
    // dC/dx_a = (dC/dF) grad N_a: the columns of dC/dF Dm^{-T} for a = 1..3, and the four
    // shape gradients sum to zero.
    let g123 = dc_df * dm_inv.transpose();
    let g = [
        -(g123.column(0) + g123.column(1) + g123.column(2)),
        g123.column(0).into_owned(),
        g123.column(1).into_owned(),
        g123.column(2).into_owned(),
    ];
    let denominator = w[0] * g[0].norm_squared()
        + w[1] * g[1].norm_squared()
        + w[2] * g[2].norm_squared()
        + w[3] * g[3].norm_squared()
        + alpha_tilde;
    if denominator <= 0.0 {
        return 0.0;
    }
    let dl = (-c - alpha_tilde * lambda) / denominator;
    for a in 0..4 {
        p[a] += g[a] * (w[a] * dl);
    }
    dl
}

/// Both constraints of tet `e`, in place: its free vertices' positions in `x` and its
/// multipliers `lambda[e]`.
///
/// # Safety
/// No other task may touch `lambda[e]` or the positions of `tet`'s free vertices (those with
/// a nonzero inverse mass, the only ones written) while this runs; fixed vertices are only
/// read, and must not be written by anyone.
#[inline]
#[allow(clippy::too_many_arguments)]
unsafe fn solve_tet(
    m: &ConstraintNeoHookean,
    rest: &TetRest,
    tet: &[usize; 4],
    e: usize,
    x: &DisjointSlice<'_, Vector3<f64>>,
    lambda: &DisjointSlice<'_, [f64; 2]>,
    inverse_mass: &[f64],
    h2: f64,
) {
    // SAFETY (all reads and writes below): the caller's promise.
    let mut p = tet.map(|v| unsafe { x.read(v) });
    let mut l = unsafe { lambda.read(e) };
    let w = tet.map(|v| inverse_mass[v]);
    let dm_inv = &rest.dm_inv;
    // The compliances over h²: 1/(mu V h²) and 1/(lambda V h²), one division for both.
    let scale = 1.0 / (rest.volume * h2);
    let f = rest.deformation_gradient(&p);
    let norm = f.norm();
    if norm > 1e-12 && m.mu > 0.0 {
        let alpha = scale / m.mu;
        l[0] += project(&mut p, &w, dm_inv, norm, &(f * norm.recip()), l[0], alpha);
    }
    if m.lambda > 0.0 {
        let f = rest.deformation_gradient(&p);
        let alpha = scale / m.lambda;
        let c = f.determinant() - m.alpha;
        l[1] += project(&mut p, &w, dm_inv, c, &cofactor(&f), l[1], alpha);
    }
    for a in 0..4 {
        if w[a] > 0.0 {
            unsafe { x.write(tet[a], p[a]) };
        }
    }
    unsafe { lambda.write(e, l) };
}

impl Xpbd {
    /// The step's substeps on the calling thread (sweeps on the pool with `Rayon`).
    fn substeps(
        &mut self,
        model: &Model,
        state: &mut State,
        dt: f64,
        material: Option<ConstraintNeoHookean>,
    ) -> Result<(), StepError> {
        let par = model.parallelism();
        let dofs = model.dofs();
        let free = dofs.free_vertices();
        for (f, &v) in free.iter().enumerate() {
            self.x[v] = Vector3::from_column_slice(&state.q[3 * f..3 * f + 3]);
            self.v[v] = Vector3::from_column_slice(&state.v[3 * f..3 * f + 3]);
        }
        let g = model.gravity().unwrap_or_else(Vector3::zeros);
        let h = dt / f64::from(self.settings.substeps);
        let pulled = !model.vertex_potentials().is_empty();
        for s in 0..self.settings.substeps {
            StepError::stop_if_requested()?;
            for &v in free {
                self.x_start[v] = self.x[v];
                self.v[v] += g * h;
                self.x[v] += self.v[v] * h;
            }
            self.lambda.fill([0.0; 2]);
            if pulled {
                let t = state.t + h * f64::from(s + 1);
                self.anchors
                    .gather(model.vertex_potentials(), self.x.len(), t)
                    .map_err(|name| unsupported("vertex potential", name, "anchors"))?;
                self.anchor_lambda.fill(Vector3::zeros());
            }
            for _ in 0..self.settings.iterations {
                StepError::stop_if_requested()?;
                if pulled {
                    self.solve_anchors(free, h * h);
                }
                let Some(m) = material else {
                    continue;
                };
                let x = DisjointSlice::new(&mut self.x);
                let lambda = DisjointSlice::new(&mut self.lambda);
                let (sorted, inverse_mass) = (&self.sorted, &self.inverse_mass);
                let colouring = &self.colouring;
                self.schedule.run(par, &|c, range| {
                    let start = colouring.group_start(c);
                    let range = start + range.start..start + range.end;
                    for (k, (tet, rest)) in range.clone().zip(&sorted[range]) {
                        // SAFETY: tets of one colour share no free vertex (the colouring's
                        // edges) and each owns its multipliers; fixed vertices (inverse mass
                        // 0) are never written; the schedule runs colours one after another.
                        unsafe { solve_tet(&m, rest, tet, k, &x, &lambda, inverse_mass, h * h) };
                    }
                });
            }
            for &v in free {
                self.v[v] = (self.x[v] - self.x_start[v]) / h;
            }
        }
        for (f, &v) in free.iter().enumerate() {
            state.q[3 * f..3 * f + 3].copy_from_slice(self.x[v].as_slice());
            state.v[3 * f..3 * f + 3].copy_from_slice(self.v[v].as_slice());
        }
        Ok(())
    }
}

impl Integrator for Xpbd {
    fn name(&self) -> &'static str {
        "xpbd"
    }

    fn order(&self) -> u32 {
        1
    }

    fn is_explicit(&self) -> bool {
        false
    }

    fn check_model(&self, model: &Model) -> Result<(), StepError> {
        Self::material(model).map(|_| ())
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let material = Self::material(model)?;
        if self.num_dofs != Some(model.num_dofs()) {
            self.set_up(model, &state.q);
        }
        let par = model.parallelism();
        if par == Parallelism::Rayon && self.schedule.splits() {
            // One entry into rayon's pool per step rather than one per sweep (~20 µs each,
            // 50 sweeps per step by default): the step runs on a pool thread, whose sweeps
            // then start at the cost of a join.
            super::on_pool(|| self.substeps(model, state, dt, material))?;
        } else {
            self.substeps(model, state, dt, material)?;
        }
        report.substeps = self.settings.substeps;
        report.local_iterations = self.settings.substeps * self.settings.iterations;
        // Each sweep projects every constraint: its value and gradient, per element.
        model.count_local_passes(u64::from(report.local_iterations), 0);
        Ok(())
    }
}
