//! Incremental potential contact (IPC; Li et al. 2020, as in ipc-toolkit and PolyFEM):
//! intersection-free, tunnelling-free contact for every method whose unknown is the
//! end-of-step position (backward Euler, BDF-k, the Newmark family, static).
//!
//! # The objective and its scaling with dt
//!
//! The one Newton loop minimizes, per step,
//!
//! ```text
//! E(x) = ½ (x − x̂)ᵀ M (x − x̂) + β ( Ψ(x) + κ Σ_k b(d_k(x)²; d̂²) + Σ_k D_k(x) )
//! ```
//!
//! with the scheme's `x̂` and `β` (`β = dt²` for backward Euler), `Ψ` the elastic and
//! gravity potential, `b` the barrier ([`barrier`]) of the squared distance of every contact
//! pair closer than d̂ ([`contacts`]), and `D_k` lagged friction ([`friction`]). The barrier
//! and friction sit inside `β` like every potential, so `κ` is an energy (J) and `κ ∇B` a
//! force (N) whatever the step: a given κ means the same contact stiffness at any dt. IPC
//! writes the barrier outside `h²` (`κ_IPC = β κ`); the adaptive rule below is IPC's rule
//! translated through that factor.
//!
//! # Barrier stiffness
//!
//! `kappa = "auto"` (default): `κ_min = 10¹¹ m̄ / (dt² · 4 s₀ b''(s₀))` with `m̄` the mean
//! vertex mass and `s₀ = (10⁻⁸ · bbox diagonal)²` (ipc-toolkit's `initial_barrier_stiffness`),
//! `κ_max = 100 κ_min`. At the first solve that starts with contacts, κ balances the barrier
//! gradient against the rest: `κ = clamp(−∇Ψ·∇B / |∇B|², κ_min, κ_max)`; after each step it
//! doubles (up to κ_max) when the smallest distance was below `10⁻⁹ · bbox diagonal` after two
//! steps in a row and shrinking (IPC's update, applied per step rather than per Newton
//! iteration). A number fixes κ (J).
//!
//! # Continuous collision detection
//!
//! Every Newton step is capped by additive CCD ([`ccd`]; Li, Kaufman, Jiang 2021) over the
//! candidate pairs of the swept primitives ([`broad_phase`]) and by conservative advancement
//! against the analytic obstacles (their distances are 1-Lipschitz), so no iterate is ever
//! closer than the minimum separation; the solve starts from the start-of-step positions moved
//! toward the scheme's guess as far as CCD allows. The obstacles are evaluated where the
//! scheme evaluates them (the end of the step); an obstacle whose path carries it into the
//! body between steps is reported as an inadmissible start.
//!
//! # Friction
//!
//! With `mu > 0`, each contact at the start of a solve gets a friction stencil: its normal
//! force `λ = κ |∂b/∂d|`, tangent basis and closest-point weights, fixed for the solve;
//! `friction_iterations > 1` re-lags them at the solution and solves again.

pub mod barrier;
pub mod ccd;
mod collision_mesh;
pub mod contacts;
pub mod distance;
pub mod friction;
mod probe;
mod settings;

pub use crate::contact::mesh_obstacle::MeshObstacle;
pub use barrier::BarrierKind;
pub use collision_mesh::CollisionMesh;
pub use probe::{CollisionMeshArrays, IpcProbe};
pub use settings::{IpcConfig, Stiffness};

use super::obstacle::Obstacles;
use crate::contact::broad_phase::{Aabb, BroadPhase};
use crate::fem::project_to_psd;
use crate::integrate::newton::StepFilter;
use crate::integrate::{Integrator, State, StepError, StepReport};
use crate::model::{ContactPotential, DofMap, Model};
use contacts::{Contact, Scratch, Search};
use friction::{FrictionParameters, FrictionStencil};
use nalgebra::{Matrix3, Vector3};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// What a solve lags: the stiffness and the friction stencils with their start positions.
#[derive(Debug, Default)]
struct Lagged {
    kappa: f64,
    kappa_min: f64,
    kappa_max: f64,
    /// Whether κ has been set from the gradient balance (adaptive κ).
    balanced: bool,
    friction: Vec<FrictionStencil>,
    x_start: Vec<Vector3<f64>>,
    /// Scratch: every vertex's position at a solution being re-lagged.
    positions: Vec<Vector3<f64>>,
    /// Friction solves left in this step.
    relags_left: u32,
    /// The smallest squared distance after the previous step (adaptive κ).
    previous_min_s: f64,
    /// The end time of the last converged solve or step (where moving obstacles were), and a
    /// start carried along by moving obstacles for the current solve (stacked free DOFs).
    last_end: Option<f64>,
    carried: Option<Vec<f64>>,
}

/// Incremental potential contact of one body: its collision mesh, the analytic obstacles,
/// the settings and the state shared by the potential (in the model), the step filter (in
/// the Newton loop) and the integrator wrapper that reports.
#[derive(Debug)]
pub struct Ipc {
    mesh: CollisionMesh,
    obstacles: Arc<Obstacles>,
    config: IpcConfig,
    dofs: DofMap,
    rest: Vec<Vector3<f64>>,
    bbox_diagonal: f64,
    /// The run's step (s): the scale of κ_min and of friction's ε_u.
    dt: f64,
    lagged: Mutex<Lagged>,
    scratch: Mutex<Scratch>,
    ccd_queries: AtomicU64,
}

/// The smallest squared distance of `contacts` (`s_hat` when there are none).
fn min_distance_squared(contacts: &[Contact], s_hat: f64) -> f64 {
    contacts
        .iter()
        .map(Contact::distance_squared)
        .fold(s_hat, f64::min)
}

impl Ipc {
    /// IPC for `model` (whose body's boundary triangles are `surface`) against the analytic
    /// `obstacles` and the static `meshes`, with steps of `dt` (the adaptive κ's scale).
    pub fn new(
        model: &Model,
        surface: &[[usize; 3]],
        obstacles: Arc<Obstacles>,
        meshes: &[MeshObstacle],
        config: IpcConfig,
        dt: f64,
    ) -> Self {
        let rest = model.rest_positions().to_vec();
        let mesh = CollisionMesh::new(&rest, surface, meshes);
        let bbox = Aabb::from_points(&rest);
        let bbox_diagonal = (bbox.max - bbox.min).norm().max(f64::MIN_POSITIVE);
        let masses = model.vertex_masses();
        let mean_mass = masses.iter().sum::<f64>() / masses.len().max(1) as f64;
        let s_hat = config.dhat * config.dhat;
        let s0 = (1e-8 * bbox_diagonal).powi(2).min(0.5 * s_hat);
        let kappa_min =
            1e11 * mean_mass / (dt * dt * 4.0 * s0 * config.barrier.second_derivative(s0, s_hat));
        let (kappa, kappa_min, kappa_max) = match config.kappa {
            Stiffness::Auto => (kappa_min, kappa_min, 100.0 * kappa_min),
            Stiffness::Fixed(k) => (k, k, k),
        };
        Self {
            mesh,
            obstacles,
            config,
            dofs: model.dofs().clone(),
            rest,
            bbox_diagonal,
            dt,
            lagged: Mutex::new(Lagged {
                kappa,
                kappa_min,
                kappa_max,
                previous_min_s: f64::INFINITY,
                ..Lagged::default()
            }),
            scratch: Mutex::new(Scratch::default()),
            ccd_queries: AtomicU64::new(0),
        }
    }

    /// The current barrier stiffness κ (J).
    pub fn kappa(&self) -> f64 {
        self.lagged.lock().expect("not poisoned").kappa
    }

    /// CCD queries so far.
    pub fn ccd_queries(&self) -> u64 {
        self.ccd_queries.load(Ordering::Relaxed)
    }

    fn search(&self) -> Search<'_> {
        Search {
            mesh: &self.mesh,
            obstacles: &self.obstacles,
            dhat: self.config.dhat,
            self_contact: self.config.self_contact,
        }
    }

    /// Every vertex's position for stacked free positions `q` (fixed vertices at rest).
    fn full_positions(&self, q: &[f64], out: &mut Vec<Vector3<f64>>) {
        out.clone_from(&self.rest);
        self.dofs.scatter(q, out);
    }

    /// The contacts at full positions `x` and time `t`: their count, the smallest distance
    /// (d̂ when none) and whether the configuration is admissible.
    pub fn contact_stats(&self, x: &[Vector3<f64>], t: f64) -> (usize, f64, bool) {
        let mut scratch = self.scratch.lock().expect("not poisoned");
        let admissible = contacts::find(&self.search(), x, t, &mut scratch);
        let s_hat = self.config.dhat * self.config.dhat;
        let s = min_distance_squared(&scratch.contacts, s_hat);
        (scratch.contacts.len(), s.max(0.0).sqrt(), admissible)
    }

    /// The barrier's value (κ = 1) at `x`, its gradient added into `g` (full, per vertex)
    /// when given.
    fn unit_barrier(&self, x: &[Vector3<f64>], t: f64, mut g: Option<&mut [Vector3<f64>]>) -> f64 {
        let mut scratch = self.scratch.lock().expect("not poisoned");
        if !contacts::find(&self.search(), x, t, &mut scratch) {
            return f64::INFINITY;
        }
        let s_hat = self.config.dhat * self.config.dhat;
        let order = u8::from(g.is_some());
        let mut total = 0.0;
        for c in &scratch.contacts {
            let l = contacts::local(c, &self.mesh, x, self.config.barrier, s_hat, order);
            total += l.value;
            if let Some(g) = g.as_deref_mut() {
                for (k, &v) in l.vertices[..l.count].iter().enumerate() {
                    if !self.mesh.is_obstacle(v) {
                        g[v as usize] += l.gradient.fixed_rows::<3>(3 * k).into_owned();
                    }
                }
            }
        }
        total
    }

    /// Friction stencils of the contacts at `x` (with `x_start` the step's start), normal
    /// forces from stiffness `kappa`.
    fn friction_stencils(
        &self,
        x: &[Vector3<f64>],
        t: f64,
        dt: f64,
        kappa: f64,
        out: &mut Vec<FrictionStencil>,
    ) {
        out.clear();
        if self.config.mu <= 0.0 {
            return;
        }
        let mut scratch = self.scratch.lock().expect("not poisoned");
        contacts::find(&self.search(), x, t, &mut scratch);
        let s_hat = self.config.dhat * self.config.dhat;
        let barrier = self.config.barrier;
        let p = |v: u32| self.mesh.position(x, v);
        for c in &scratch.contacts {
            let s = c.distance_squared();
            if s <= 0.0 {
                continue;
            }
            // λ = κ |db/dd| = κ |b'(s)| 2 d.
            let normal_force = kappa * barrier.first_derivative(s, s_hat).abs() * 2.0 * s.sqrt();
            let (ids, weights, count, offset, normal) = match *c {
                Contact::PointTriangle(v, _) => {
                    let (w, n) =
                        friction::point_triangle_weights(&p(v[0]), &p(v[1]), &p(v[2]), &p(v[3]));
                    (v, w, 4, Vector3::zeros(), n)
                }
                Contact::EdgeEdge(v, _, _) => {
                    let (w, n) =
                        friction::edge_edge_weights(&p(v[0]), &p(v[1]), &p(v[2]), &p(v[3]));
                    (v, w, 4, Vector3::zeros(), n)
                }
                Contact::PointObstacle(v, sample) => (
                    [v, 0, 0, 0],
                    [1.0, 0.0, 0.0, 0.0],
                    1,
                    sample.velocity * dt,
                    sample.sdf.gradient,
                ),
            };
            // Obstacle vertices never move: they drop out of the relative displacement.
            let mut stencil = FrictionStencil {
                vertices: [0; 4],
                count: 0,
                weights: [0.0; 4],
                basis: FrictionStencil::basis_for_normal(&normal),
                normal_force,
                obstacle_offset: offset,
            };
            for k in 0..count {
                if !self.mesh.is_obstacle(ids[k]) {
                    stencil.vertices[stencil.count] = ids[k] as usize;
                    stencil.weights[stencil.count] = weights[k];
                    stencil.count += 1;
                }
            }
            if stencil.count > 0 && normal_force > 0.0 {
                out.push(stencil);
            }
        }
    }

    /// The friction parameters (`ε_u = ε_v · dt` with the run's step).
    fn friction_parameters(&self) -> FrictionParameters {
        FrictionParameters {
            mu: self.config.mu,
            epsilon_v: self.config.epsilon_v,
            dt: self.dt,
        }
    }

    /// A solve of the step ending at `t` starts from stacked free positions `q`: lag κ and
    /// friction there.
    fn begin_solve(&self, model: &mut Model, q: &[f64], t: f64) -> Result<(), StepError> {
        let dt = self.dt;
        // The step's start positions (friction's x^t), in the lagged buffer.
        let (mut x_start, mut stencils, from) = {
            let mut lagged = self.lagged.lock().expect("not poisoned");
            lagged.relags_left = self.config.friction_iterations.saturating_sub(1);
            lagged.carried = None;
            let from = lagged.last_end.unwrap_or(t - dt).min(t);
            (
                std::mem::take(&mut lagged.x_start),
                std::mem::take(&mut lagged.friction),
                from,
            )
        };
        self.full_positions(q, &mut x_start);
        let (mut count, _, mut admissible) = self.contact_stats(&x_start, t);
        // Moving obstacles may have come onto the body since `from`: start the solve with the
        // surface vertices near each one carried along by its displacement (they keep their
        // place relative to it), if that start is admissible; κ and friction are lagged there.
        let mut carried = None;
        if !admissible && let Some(y) = self.carry(&x_start, from, t) {
            (count, _, admissible) = self.contact_stats(&y, t);
            if admissible {
                let mut start = q.to_vec();
                self.dofs.gather(&y, &mut start);
                self.lagged.lock().expect("not poisoned").carried = Some(start);
                carried = Some(y);
            }
        }
        let result = if admissible {
            let x = carried.as_deref().unwrap_or(&x_start);
            self.lag_at(model, q, x, t, count, &mut stencils)
        } else {
            stencils.clear();
            Err(StepError::NewtonFailed {
                iterations: 0,
                reason: "incremental potential contact: the step starts with touching or \
                         intersecting primitives (or an obstacle moved into the body)"
                    .into(),
            })
        };
        let mut lagged = self.lagged.lock().expect("not poisoned");
        lagged.x_start = x_start;
        lagged.friction = stencils;
        result
    }

    /// Lag κ (the gradient balance at the first solve with contacts) and the friction
    /// stencils at full positions `x` (stacked free positions `q`), with `count` contacts.
    fn lag_at(
        &self,
        model: &mut Model,
        q: &[f64],
        x: &[Vector3<f64>],
        t: f64,
        count: usize,
        stencils: &mut Vec<FrictionStencil>,
    ) -> Result<(), StepError> {
        let needs_balance = {
            let lagged = self.lagged.lock().expect("not poisoned");
            count > 0 && !lagged.balanced && self.config.kappa == Stiffness::Auto
        };
        if needs_balance {
            // κ = −∇Ψ·∇B / |∇B|² over free vertices, ∇Ψ without the contact potential.
            let mut g = vec![0.0; q.len()];
            model.gradient(q, &mut g).map_err(StepError::from)?;
            let mut gb = vec![Vector3::zeros(); x.len()];
            self.unit_barrier(x, t, Some(&mut gb));
            let kappa_now = self.kappa();
            let (mut dot, mut norm2) = (0.0, 0.0);
            for (f, &v) in self.dofs.free_vertices().iter().enumerate() {
                let gpsi = Vector3::new(g[3 * f], g[3 * f + 1], g[3 * f + 2]) - gb[v] * kappa_now;
                dot += gpsi.dot(&gb[v]);
                norm2 += gb[v].norm_squared();
            }
            let mut lagged = self.lagged.lock().expect("not poisoned");
            if norm2 > 0.0 {
                lagged.kappa = (-dot / norm2).clamp(lagged.kappa_min, lagged.kappa_max);
                lagged.balanced = true;
            }
        }
        self.friction_stencils(x, t, self.dt, self.kappa(), stencils);
        Ok(())
    }

    /// The positions `x` with every free surface vertex that a moving analytic obstacle could
    /// reach over `[from, to]` (closer at `to` than its displacement plus d̂) moved by that
    /// displacement; `None` when no obstacle moved or one has members with paths of their
    /// own (a displacement that is not one translation).
    fn carry(&self, x: &[Vector3<f64>], from: f64, to: f64) -> Option<Vec<Vector3<f64>>> {
        let mut y = x.to_vec();
        let mut moved = false;
        for o in self.obstacles.iter() {
            let Some(path) = &o.path else { continue };
            if !o.is_static_apart_from_its_path() {
                return None;
            }
            let shift = path.offset(to) - path.offset(from);
            if shift == Vector3::zeros() {
                continue;
            }
            let reach = shift.norm() + self.config.dhat;
            for &v in self
                .mesh
                .vertices
                .iter()
                .filter(|&&v| !self.mesh.is_obstacle(v))
            {
                let v = v as usize;
                if !self.dofs.is_fixed(v)
                    && y[v] == x[v]
                    && o.sample(&x[v], to).sdf.distance < reach
                {
                    y[v] += shift;
                    moved = true;
                }
            }
        }
        moved.then_some(y)
    }

    /// A carried start for the current solve, if [`Self::begin_solve`] made one.
    fn start_point(&self, start: &mut [f64]) -> bool {
        match &self.lagged.lock().expect("not poisoned").carried {
            Some(c) => {
                start.copy_from_slice(c);
                true
            }
            None => false,
        }
    }

    /// After a converged solve at `q`: re-lag friction there if iterations are left.
    fn relag(&self, q: &[f64], t: f64) -> bool {
        let dt = self.dt;
        let mut lagged = self.lagged.lock().expect("not poisoned");
        // A converged solve: the obstacles are at its end time (a halved step's second half
        // starts there).
        lagged.last_end = Some(t);
        if lagged.relags_left == 0 || self.config.mu <= 0.0 {
            return false;
        }
        lagged.relags_left -= 1;
        let kappa = lagged.kappa;
        let mut x = std::mem::take(&mut lagged.positions);
        let mut stencils = std::mem::take(&mut lagged.friction);
        drop(lagged);
        self.full_positions(q, &mut x);
        self.friction_stencils(&x, t, dt, kappa, &mut stencils);
        let mut lagged = self.lagged.lock().expect("not poisoned");
        lagged.positions = x;
        lagged.friction = stencils;
        true
    }

    /// After a step ending with smallest distance `d`: IPC's κ update.
    fn after_step(&self, d: f64) {
        let mut lagged = self.lagged.lock().expect("not poisoned");
        let s = d * d;
        let eps = (1e-9 * self.bbox_diagonal).powi(2);
        if self.config.kappa == Stiffness::Auto
            && lagged.previous_min_s < eps
            && s < eps
            && s < lagged.previous_min_s
        {
            lagged.kappa = (2.0 * lagged.kappa).min(lagged.kappa_max);
        }
        lagged.previous_min_s = s;
    }

    /// The largest fraction of the step from stacked free positions `q` by `dq` that keeps
    /// every pair apart (CCD), at time `t`.
    fn max_step(&self, q: &[f64], dq: &[f64], t: f64, buffers: &mut FilterBuffers) -> f64 {
        let (mut x, mut dx) = (
            std::mem::take(&mut buffers.x),
            std::mem::take(&mut buffers.dx),
        );
        self.full_positions(q, &mut x);
        dx.clear();
        dx.resize(self.rest.len(), Vector3::zeros());
        self.dofs.scatter(dq, &mut dx);
        let alpha = self.max_step_of(&x, &dx, t, buffers);
        (buffers.x, buffers.dx) = (x, dx);
        alpha
    }

    /// [`Self::max_step`] for every vertex's positions `x` and displacement `dx`.
    fn max_step_of(
        &self,
        x: &[Vector3<f64>],
        dx: &[Vector3<f64>],
        t: f64,
        buffers: &mut FilterBuffers,
    ) -> f64 {
        let settings = ccd::CcdSettings {
            min_separation: self.config.min_separation,
            ..ccd::CcdSettings::default()
        };
        let mesh = &self.mesh;
        let p = |v: u32| mesh.position(x, v);
        let d = |v: u32| {
            if mesh.is_obstacle(v) {
                Vector3::zeros()
            } else {
                dx[v as usize]
            }
        };
        mesh.swept_boxes(
            x,
            dx,
            self.config.min_separation,
            &mut buffers.vertex_boxes,
            &mut buffers.edge_boxes,
            &mut buffers.face_boxes,
        );
        let mut alpha: f64 = 1.0;
        let mut queries = 0u64;
        buffers.broad.pairs(
            &buffers.vertex_boxes,
            &buffers.face_boxes,
            &mut buffers.pairs,
        );
        for &(i, f) in &buffers.pairs {
            let v = mesh.vertices[i as usize];
            let face = mesh.faces[f as usize];
            if !mesh.pair_counts(&[v], &face, self.config.self_contact) {
                continue;
            }
            queries += 1;
            let toi = ccd::point_triangle_ccd(
                &p(v),
                &p(face[0]),
                &p(face[1]),
                &p(face[2]),
                &d(v),
                &d(face[0]),
                &d(face[1]),
                &d(face[2]),
                alpha,
                &settings,
            );
            alpha = alpha.min(toi.t);
        }
        buffers
            .broad
            .self_pairs(&buffers.edge_boxes, &mut buffers.pairs);
        for &(i, j) in &buffers.pairs {
            let (ea, eb) = (mesh.edges[i as usize], mesh.edges[j as usize]);
            if !mesh.pair_counts(&ea, &eb, self.config.self_contact) {
                continue;
            }
            queries += 1;
            let toi = ccd::edge_edge_ccd(
                &p(ea[0]),
                &p(ea[1]),
                &p(eb[0]),
                &p(eb[1]),
                &d(ea[0]),
                &d(ea[1]),
                &d(eb[0]),
                &d(eb[1]),
                alpha,
                &settings,
            );
            alpha = alpha.min(toi.t);
        }
        for &v in mesh.vertices.iter().filter(|&&v| !mesh.is_obstacle(v)) {
            let (start, step) = (x[v as usize], dx[v as usize]);
            if step == Vector3::zeros() {
                continue;
            }
            for o in self.obstacles.iter() {
                let reach = step.norm() * alpha + self.config.min_separation;
                if o.sample(&start, t).sdf.distance > reach {
                    continue;
                }
                queries += 1;
                let toi = ccd::point_sdf_ccd(
                    &start,
                    &step,
                    &mut |y| o.sample(y, t).sdf.distance,
                    alpha,
                    &settings,
                );
                alpha = alpha.min(toi.t);
            }
        }
        self.ccd_queries.fetch_add(queries, Ordering::Relaxed);
        alpha
    }
}

/// The contact potential in the model: barrier plus lagged friction.
#[derive(Debug)]
pub struct IpcPotential(pub Arc<Ipc>);

impl ContactPotential for IpcPotential {
    fn name(&self) -> &str {
        "ipc"
    }

    fn energy(&self, t: f64, x: &[Vector3<f64>]) -> f64 {
        let ipc = &self.0;
        let barrier = ipc.unit_barrier(x, t, None);
        let lagged = ipc.lagged.lock().expect("not poisoned");
        if !barrier.is_finite() {
            return f64::INFINITY;
        }
        let mut e = lagged.kappa * barrier;
        if !lagged.friction.is_empty() {
            let fp = ipc.friction_parameters();
            e += lagged
                .friction
                .iter()
                .map(|s| s.energy(&fp, x, &lagged.x_start))
                .sum::<f64>();
        }
        e
    }

    fn driven_power(&self, t: f64, x: &[Vector3<f64>]) -> f64 {
        let ipc = &self.0;
        let kappa = ipc.kappa();
        let s_hat = ipc.config.dhat * ipc.config.dhat;
        let mut scratch = ipc.scratch.lock().expect("not poisoned");
        contacts::find(&ipc.search(), x, t, &mut scratch);
        scratch
            .contacts
            .iter()
            .map(|c| match *c {
                Contact::PointObstacle(_, sample) if sample.velocity != Vector3::zeros() => {
                    let d = sample.sdf.distance;
                    // The force on the vertex, −κ b'(s) 2d n, times the obstacle's velocity.
                    let b1 = ipc.config.barrier.first_derivative(d * d, s_hat);
                    -kappa * b1 * 2.0 * d * sample.sdf.gradient.dot(&sample.velocity)
                }
                _ => 0.0,
            })
            .sum()
    }

    fn stored_energy(&self, t: f64, x: &[Vector3<f64>]) -> f64 {
        self.0.kappa() * self.0.unit_barrier(x, t, None)
    }

    fn gradient(&self, t: f64, x: &[Vector3<f64>], add: &mut dyn FnMut(usize, Vector3<f64>)) {
        let ipc = &self.0;
        let kappa = ipc.kappa();
        let mut scratch = ipc.scratch.lock().expect("not poisoned");
        contacts::find(&ipc.search(), x, t, &mut scratch);
        let s_hat = ipc.config.dhat * ipc.config.dhat;
        for c in &scratch.contacts {
            let l = contacts::local(c, &ipc.mesh, x, ipc.config.barrier, s_hat, 1);
            for (k, &v) in l.vertices[..l.count].iter().enumerate() {
                if !ipc.mesh.is_obstacle(v) {
                    add(v as usize, l.gradient.fixed_rows::<3>(3 * k) * kappa);
                }
            }
        }
        drop(scratch);
        let lagged = ipc.lagged.lock().expect("not poisoned");
        if !lagged.friction.is_empty() {
            let fp = ipc.friction_parameters();
            for s in &lagged.friction {
                s.gradient(&fp, x, &lagged.x_start, add);
            }
        }
    }

    fn hessian(
        &self,
        t: f64,
        x: &[Vector3<f64>],
        project: bool,
        add: &mut dyn FnMut(usize, usize, &Matrix3<f64>),
    ) {
        let ipc = &self.0;
        let kappa = ipc.kappa();
        let mut scratch = ipc.scratch.lock().expect("not poisoned");
        contacts::find(&ipc.search(), x, t, &mut scratch);
        let s_hat = ipc.config.dhat * ipc.config.dhat;
        for c in &scratch.contacts {
            let mut l = contacts::local(c, &ipc.mesh, x, ipc.config.barrier, s_hat, 2);
            l.hessian *= kappa;
            if project {
                if l.count == 1 {
                    let mut h: Matrix3<f64> = l.hessian.fixed_view::<3, 3>(0, 0).into_owned();
                    project_to_psd(&mut h);
                    l.hessian.fixed_view_mut::<3, 3>(0, 0).copy_from(&h);
                } else {
                    project_to_psd(&mut l.hessian);
                }
            }
            for (a, &va) in l.vertices[..l.count].iter().enumerate() {
                if ipc.mesh.is_obstacle(va) {
                    continue;
                }
                for (b, &vb) in l.vertices[..l.count].iter().enumerate() {
                    if ipc.mesh.is_obstacle(vb) {
                        continue;
                    }
                    let block: Matrix3<f64> =
                        l.hessian.fixed_view::<3, 3>(3 * a, 3 * b).into_owned();
                    add(va as usize, vb as usize, &block);
                }
            }
        }
        drop(scratch);
        let lagged = ipc.lagged.lock().expect("not poisoned");
        if !lagged.friction.is_empty() {
            let fp = ipc.friction_parameters();
            for s in &lagged.friction {
                s.hessian(&fp, x, &lagged.x_start, project, add);
            }
        }
    }
}

/// Scratch of the step filter.
#[derive(Debug, Default)]
struct FilterBuffers {
    x: Vec<Vector3<f64>>,
    dx: Vec<Vector3<f64>>,
    broad: BroadPhase,
    vertex_boxes: Vec<Aabb>,
    edge_boxes: Vec<Aabb>,
    face_boxes: Vec<Aabb>,
    pairs: Vec<(u32, u32)>,
}

/// IPC's step filter in the Newton loop: CCD caps each step; solves lag κ and friction.
#[derive(Debug)]
pub struct IpcFilter {
    ipc: Arc<Ipc>,
    buffers: FilterBuffers,
}

impl IpcFilter {
    /// The filter of `ipc`.
    pub fn new(ipc: Arc<Ipc>) -> Self {
        Self {
            ipc,
            buffers: FilterBuffers::default(),
        }
    }
}

impl StepFilter for IpcFilter {
    fn max_step(&mut self, x: &[f64], dx: &[f64], t: f64) -> f64 {
        self.ipc.max_step(x, dx, t, &mut self.buffers)
    }

    fn begin_solve(&mut self, model: &mut Model, x_ref: &[f64], t: f64) -> Result<(), StepError> {
        self.ipc.begin_solve(model, x_ref, t)
    }

    fn relag(&mut self, x: &[f64], t: f64) -> bool {
        self.ipc.relag(x, t)
    }

    fn start_point(&mut self, start: &mut [f64]) -> bool {
        self.ipc.start_point(start)
    }
}

/// The scene's integrator with IPC in its Newton loop, reporting contacts, the smallest
/// distance, κ and CCD queries after each step.
pub struct WithIpc {
    inner: Box<dyn Integrator>,
    ipc: Arc<Ipc>,
    check: Arc<super::frame_check::FrameCheck>,
    x: Vec<Vector3<f64>>,
}

impl WithIpc {
    /// `inner` (built with [`IpcFilter`] in its Newton loop) reporting for `ipc`, sampled
    /// frames checked by `check`.
    pub fn new(
        inner: Box<dyn Integrator>,
        ipc: Arc<Ipc>,
        check: Arc<super::frame_check::FrameCheck>,
    ) -> Self {
        Self {
            inner,
            ipc,
            check,
            x: Vec::new(),
        }
    }
}

impl Integrator for WithIpc {
    fn name(&self) -> &'static str {
        self.inner.name()
    }

    fn order(&self) -> u32 {
        self.inner.order()
    }

    fn is_explicit(&self) -> bool {
        self.inner.is_explicit()
    }

    fn check_model(&self, model: &Model) -> Result<(), StepError> {
        self.inner.check_model(model)
    }

    fn internal_steps(&self) -> &[f64] {
        self.inner.internal_steps()
    }

    fn drain_iteration_log(&mut self, out: &mut Vec<crate::integrate::newton::IterationRecord>) {
        self.inner.drain_iteration_log(out);
    }

    fn intersection_free(&self, model: &Model, state: &State) -> Option<bool> {
        Some(
            self.check
                .intersection_free(&model.full_positions(&state.q), state.t),
        )
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        let queries = self.ipc.ccd_queries();
        self.inner.advance(model, state, dt, report)?;
        self.ipc.lagged.lock().expect("not poisoned").last_end = Some(state.t + dt);
        self.ipc.full_positions(&state.q, &mut self.x);
        let (count, distance, _) = self.ipc.contact_stats(&self.x, state.t + dt);
        self.ipc.after_step(distance);
        report.contacts = u32::try_from(count).unwrap_or(u32::MAX);
        report.min_distance = Some(distance);
        report.barrier_stiffness = self.ipc.kappa();
        report.ccd_queries += self.ipc.ccd_queries() - queries;
        Ok(())
    }

    fn reset(&mut self) {
        self.inner.reset();
    }
}

/// Incremental potential contact for a scene (`response = "ipc"`): the body's boundary
/// triangles against the analytic obstacles (mesh tables skipped; still boxes as triangle
/// meshes) and the mesh obstacles, with steps of `dt`; adds the contact potential to `model`.
/// Built even without obstacles (self-contact).
pub(super) fn build(setup: &super::ContactSetup<'_>, model: &mut Model) -> super::Contact {
    let set: Obstacles = setup
        .obstacles
        .iter()
        .filter(|o| !o.is_mesh())
        .map(super::ObstacleConfig::obstacle)
        .collect();
    // Still boxes take part as triangle meshes (their edges and corners then meet the body's
    // edges and faces, not only its vertices); the rest stay signed distances.
    let mut contact_meshes = setup.meshes.to_vec();
    let mut distances = Vec::new();
    for o in set.iter() {
        if o.is_static() {
            o.box_meshes(0.0, &mut contact_meshes);
            distances.extend(o.without_boxes());
        } else {
            distances.push(o.clone());
        }
    }
    let set = Arc::new(set);
    let shared = Arc::new(Ipc::new(
        model,
        setup.surface,
        Arc::new(Obstacles::new(distances)),
        &contact_meshes,
        setup.config.ipc,
        setup.dt,
    ));
    model.set_contact_potential(Box::new(IpcPotential(shared.clone())));
    let check = super::frame_check::FrameCheck::new(
        setup.surface.to_vec(),
        setup.meshes.to_vec(),
        set.clone(),
    );
    super::Contact {
        obstacles: set,
        config: *setup.config,
        ipc: Some(shared),
        check: Arc::new(check),
    }
}

/// The scene's method with the barrier's step filter inside its Newton loop, wrapped to report
/// contacts and check frames.
pub(super) fn integrator(
    contact: &super::Contact,
    settings: &crate::integrate::IntegratorSettings,
) -> Box<dyn Integrator> {
    let shared = contact.ipc.clone().expect("built by ipc::build");
    let filter = IpcFilter::new(shared.clone());
    let inner = settings
        .build_constrained(crate::integrate::newton::NewtonContact::Barrier(Box::new(
            filter,
        )))
        .expect("scene validation admits ipc only for methods on the Newton loop");
    Box::new(WithIpc::new(inner, shared, contact.check.clone()))
}
