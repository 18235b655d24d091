//! The [`Model`]: a conservative system over the free DOFs of a mesh. It sums potentials —
//! elastic (tet FEM), springs, gravity — and answers their value, gradient and sparse Hessian.
//!
//! The Hessian's sparsity pattern and the gather lists that assemble into it are built once;
//! each evaluation computes element quantities into preallocated buffers (in parallel when
//! asked) and gathers them in a fixed order, so results are bitwise identical run to run and
//! across thread counts. Every evaluation is counted in [`EvalCounters`].
//!
//! [`highest_mode`] finds the highest natural frequency of the linearized model (the explicit
//! stability limit `2 / omega_max`), [`lowest_modes`] its lowest modes (errors in the motion a
//! user sees).

mod build;
mod contact_potential;
mod damping;
mod discrete_gradient;
mod dofs;
mod drag;
mod elastic;
mod error;
mod evaluate;
mod local;
mod mass;
mod measures;
mod modes;
mod pattern;
mod spectrum;
mod springs;
mod vertex_potential;

pub use contact_potential::{ContactPotential, OffPatternBlock};
pub use damping::Damping;
pub use dofs::{AxisRule, DofCounts, DofMap, FIXED, FixedSelection, Side};
pub use drag::{Drag, DragPath, Waypoint};
pub use error::ModelError;
pub use local::ElasticElements;
pub(crate) use mass::MassInverse;
pub use mass::{MassKind, MassMatrix};
pub use modes::{Modes, lowest_modes};
pub use pattern::BlockPattern;
pub use spectrum::{HighestMode, SpectrumError, SpectrumSettings, highest_mode};
pub use springs::Spring;
pub use vertex_potential::{Anchors, VertexPotential};

use crate::fem::ElementFilter;
use crate::material::MaterialModel;
use crate::mesh::TetMesh;
use crate::parallel::Parallelism;
use crate::sparse::{SparsityPattern, SymmetricMatrix};
use elastic::ElasticBody;
use nalgebra::Vector3;
use pattern::ElementGather;
use std::sync::Arc;
use std::sync::atomic::AtomicBool;

/// What to do with tets of negative rest volume.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum InvertedTets {
    /// Refuse the mesh with the indices of the inverted tets.
    #[default]
    Refuse,
    /// Swap two vertices of each inverted tet so that it is positively oriented.
    Reorient,
}

/// Everything a [`Model`] is built from.
#[derive(Clone, Debug)]
pub struct ModelSpec {
    /// Rest positions and tets. Tets are used when there is an elastic material or a density.
    pub mesh: TetMesh,
    /// The elastic material of the tets, or `None` for a body without tet elasticity.
    pub material: Option<MaterialModel>,
    /// Mass density (kg/m^3) of the tets, or `None` when mass comes only from point masses.
    pub density: Option<f64>,
    /// Consistent or lumped tet mass.
    pub mass_kind: MassKind,
    /// Extra lumped mass per vertex (kg), e.g. the particles of a mass-spring body.
    pub point_masses: Option<Vec<f64>>,
    /// Springs between vertices.
    pub springs: Vec<Spring>,
    /// Gravitational acceleration (m/s^2), or `None`.
    pub gravity: Option<Vector3<f64>>,
    /// Which vertices are fixed (eliminated from the unknowns).
    pub fixed: FixedSelection,
    /// What to do with inverted rest tets.
    pub inverted_tets: InvertedTets,
    /// How element loops run.
    pub parallelism: Parallelism,
    /// Rayleigh and strain-rate damping (spring dashpots are per spring).
    pub damping: Damping,
}

impl ModelSpec {
    /// An elastic tet body with nothing fixed, no gravity, consistent mass.
    pub fn elastic(mesh: TetMesh, material: MaterialModel, density: f64) -> Self {
        Self {
            mesh,
            material: Some(material),
            density: Some(density),
            mass_kind: MassKind::Consistent,
            point_masses: None,
            springs: Vec::new(),
            gravity: None,
            fixed: FixedSelection::none(),
            inverted_tets: InvertedTets::Refuse,
            parallelism: Parallelism::Rayon,
            damping: Damping::default(),
        }
    }
}

/// How many times each kind of evaluation ran.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct EvalCounters {
    pub potential: u64,
    pub gradient: u64,
    pub hessian: u64,
}

/// The potential split by source (J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PotentialParts {
    pub elastic: f64,
    pub springs: f64,
    pub gravity: f64,
    /// Vertex potentials (contact penalties, drag springs).
    pub vertex: f64,
    /// The contact potential (barrier and friction; see [`ContactPotential`]).
    pub contact: f64,
}

impl PotentialParts {
    /// Sum of all parts.
    pub fn total(&self) -> f64 {
        self.elastic + self.springs + self.gravity + self.vertex + self.contact
    }
}

/// Options of a Hessian evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HessianOptions {
    /// The eigenvalue filter of every element matrix (tets and springs; vertex potentials
    /// are projected whenever a filter is given); `None` for the exact Hessian.
    pub filter: Option<ElementFilter>,
}

impl HessianOptions {
    /// Every element matrix projected to PSD (eigenvalues clamped at 0 on the 12×12).
    pub fn projected() -> Self {
        Self {
            filter: Some(ElementFilter::CLAMP),
        }
    }

    /// Through `filter`.
    pub fn filtered(filter: ElementFilter) -> Self {
        Self {
            filter: Some(filter),
        }
    }
}

/// Scratch space reused by every evaluation (element matrices allocated on first use, so
/// methods that never ask for a Hessian never pay for it).
#[derive(Debug, Default)]
struct Buffers {
    partial: Vec<f64>,
    /// All vertex positions at the start of a step, for two-state evaluations
    /// ([`Model::discrete_gradient`]).
    start_positions: Vec<Vector3<f64>>,
    tet_vectors: Vec<f64>,
    tet_matrices: Vec<f64>,
    spring_vectors: Vec<f64>,
    spring_matrices: Vec<f64>,
    /// The on-demand filter's memory: which tets and springs had a negative eigenvalue
    /// (see [`crate::fem::FilterScope`]).
    tet_flags: Vec<AtomicBool>,
    spring_flags: Vec<bool>,
    /// Element matrices the filter changed in the last Hessian evaluation.
    filtered: usize,
}

/// A conservative system over the free DOFs `q` (see the module docs).
#[derive(Debug)]
pub struct Model {
    dofs: DofMap,
    rest_positions: Vec<Vector3<f64>>,
    positions: Vec<Vector3<f64>>,
    elastic: Option<ElasticBody>,
    springs: Vec<Spring>,
    vertex_potentials: Vec<Box<dyn VertexPotential>>,
    /// The contact potential, if the scene has one (incremental potential contact).
    contact_potential: Option<Box<dyn ContactPotential>>,
    /// Its Hessian blocks the element pattern lacks, from the last [`Self::hessian`].
    off_pattern: Vec<OffPatternBlock>,
    /// Where each free vertex's 3×3 diagonal block sits in the Hessian values (column-major).
    diagonal_slots: Vec<[usize; 9]>,
    /// The time time-dependent potentials are evaluated at (s).
    time: f64,
    damping: Damping,
    /// The size of the terms that cancel in the potential (see [`Model::energy_roundoff_scale`]).
    energy_roundoff_scale: f64,
    /// Scratch: velocities of every vertex (fixed ones zero), and a damping matrix.
    velocities: Vec<Vector3<f64>>,
    stiffness_scratch: Option<SymmetricMatrix>,
    pattern: BlockPattern,
    tet_gather: ElementGather,
    spring_gather: ElementGather,
    vertex_mass: Vec<f64>,
    mass: MassMatrix,
    /// The tets' mass density (kg/m^3), if they have mass.
    density: Option<f64>,
    gravity: Option<Vector3<f64>>,
    parallelism: Parallelism,
    counters: EvalCounters,
    /// Wall time of potential, gradient and damping-force evaluations (s), for the "forces"
    /// phase of a step; Hessians are timed by their caller's assembly phase.
    force_seconds: f64,
    buffers: Buffers,
}

impl Model {
    /// Number of free DOFs (the length of `q`).
    pub fn num_dofs(&self) -> usize {
        self.dofs.num_dofs()
    }

    /// The vertex ↔ DOF map.
    pub fn dofs(&self) -> &DofMap {
        &self.dofs
    }

    /// Rest positions of all vertices.
    pub fn rest_positions(&self) -> &[Vector3<f64>] {
        &self.rest_positions
    }

    /// `q` at the rest configuration.
    pub fn rest_state(&self) -> Vec<f64> {
        let mut q = vec![0.0; self.num_dofs()];
        self.dofs.gather(&self.rest_positions, &mut q);
        q
    }

    /// Positions of all vertices for state `q` (fixed vertices at their prescribed positions).
    pub fn full_positions(&self, q: &[f64]) -> Vec<Vector3<f64>> {
        let mut x = self.positions.clone();
        self.dofs.scatter(q, &mut x);
        x
    }

    /// Lumped mass of every vertex (kg), fixed ones included.
    pub fn vertex_masses(&self) -> &[f64] {
        &self.vertex_mass
    }

    /// The mass matrix over free DOFs.
    pub fn mass(&self) -> &MassMatrix {
        &self.mass
    }

    /// The tets' mass density (kg/m^3), or `None` when mass comes only from point masses.
    pub fn density(&self) -> Option<f64> {
        self.density
    }

    /// Gravitational acceleration, if any.
    pub fn gravity(&self) -> Option<Vector3<f64>> {
        self.gravity
    }

    /// The elastic material, if any.
    pub fn material(&self) -> Option<&MaterialModel> {
        self.elastic.as_ref().map(|e| &e.material)
    }

    /// The springs.
    pub fn springs(&self) -> &[Spring] {
        &self.springs
    }

    /// Add a per-vertex potential (contact penalty, drag). Its Hessian blocks are diagonal,
    /// so the pattern does not change.
    pub fn add_vertex_potential(&mut self, potential: Box<dyn VertexPotential>) {
        self.vertex_potentials.push(potential);
    }

    /// Set the contact potential (replacing any). Its Hessian may couple vertices no element
    /// couples: see [`Self::off_pattern_blocks`].
    pub fn set_contact_potential(&mut self, potential: Box<dyn ContactPotential>) {
        self.contact_potential = Some(potential);
    }

    /// The contact potential, if any.
    pub fn contact_potential(&self) -> Option<&dyn ContactPotential> {
        self.contact_potential.as_deref()
    }

    /// The contact potential's Hessian blocks that the last [`Self::hessian`] could not store
    /// because the element pattern lacks them (empty without self-contact). A caller that
    /// factors the Hessian adds them on an extended pattern.
    pub fn off_pattern_blocks(&self) -> &[OffPatternBlock] {
        &self.off_pattern
    }

    /// The stored energy of the contact potential at positions `q` (0 without one; see
    /// [`ContactPotential::stored_energy`]).
    pub fn contact_stored_energy(&mut self, q: &[f64]) -> Result<f64, ModelError> {
        self.load_state(q)?;
        Ok(self
            .contact_potential
            .as_ref()
            .map_or(0.0, |p| p.stored_energy(self.time, &self.positions)))
    }

    /// The power moving obstacles put into the body through the contact potential at `q`,
    /// time `t` (W; 0 without one: see [`ContactPotential::driven_power`]).
    pub fn contact_driven_power(&mut self, q: &[f64], t: f64) -> Result<f64, ModelError> {
        self.load_state(q)?;
        Ok(self
            .contact_potential
            .as_ref()
            .map_or(0.0, |p| p.driven_power(t, &self.positions)))
    }

    /// The per-vertex potentials.
    pub fn vertex_potentials(&self) -> &[Box<dyn VertexPotential>] {
        &self.vertex_potentials
    }

    /// Set the time at which time-dependent potentials are evaluated (integrators call this
    /// before each evaluation at a new stage time).
    pub fn set_time(&mut self, t: f64) {
        self.time = t;
    }

    /// The current evaluation time (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// The energy of the per-vertex potentials at positions `q` and time `t` (not counted as
    /// a potential evaluation: it serves the work accounting of time-dependent potentials).
    pub fn vertex_energy_at(&mut self, q: &[f64], t: f64) -> Result<f64, ModelError> {
        self.load_state(q)?;
        Ok(self
            .vertex_potentials
            .iter()
            .map(|p| p.energy(t, &self.positions))
            .sum())
    }

    /// The Hessian's block pattern.
    pub fn block_pattern(&self) -> &BlockPattern {
        &self.pattern
    }

    /// The Hessian's scalar sparsity pattern (shared by all matrices this model fills).
    pub fn hessian_pattern(&self) -> &Arc<SparsityPattern> {
        self.pattern.scalar()
    }

    /// A zero matrix over the Hessian pattern, for [`Self::hessian`] to fill.
    pub fn new_hessian(&self) -> SymmetricMatrix {
        SymmetricMatrix::zeros(self.pattern.scalar().clone())
    }

    /// How element loops run.
    pub fn parallelism(&self) -> Parallelism {
        self.parallelism
    }

    /// Whether the elastic element loops a step calls run on rayon's pool: the Hessian loop's
    /// rule when the step assembles Hessians (`hessians`), else the gradient loop's. A step
    /// moves onto the pool only when this holds (`Integrator::step`), so a step too small for
    /// threads never pays the entry.
    pub fn element_loops_split(&self, hessians: bool) -> bool {
        let tets = self.elastic.as_ref().map_or(0, |e| e.tets.len());
        let min_chunks = if hessians {
            elastic::HESSIAN_MIN_CHUNKS
        } else {
            elastic::GRADIENT_MIN_CHUNKS
        };
        self.parallelism == Parallelism::Rayon && tets.div_ceil(elastic::CHUNK) >= min_chunks
    }

    /// Change how element loops run (results do not change).
    pub fn set_parallelism(&mut self, par: Parallelism) {
        self.parallelism = par;
    }

    /// Element matrices (tets and springs) the filter changed in the last Hessian
    /// evaluation; 0 without a filter.
    pub fn filtered_elements(&self) -> usize {
        self.buffers.filtered
    }

    /// Evaluation counts since construction or the last reset.
    pub fn counters(&self) -> EvalCounters {
        self.counters
    }

    /// Count a local solver's passes over every element as evaluations: a pass that computes
    /// each element's forces (its constraint or projection, its part of each vertex's force)
    /// is a gradient evaluation, one that also computes its Hessian blocks a Hessian
    /// evaluation, so costs in evaluations compare local solvers with Newton-type methods.
    pub fn count_local_passes(&mut self, gradient: u64, hessian: u64) {
        self.counters.gradient += gradient;
        self.counters.hessian += hessian;
    }

    /// Reset the evaluation counters (and the force-evaluation time).
    pub fn reset_counters(&mut self) {
        self.counters = EvalCounters::default();
        self.force_seconds = 0.0;
    }

    /// Wall time spent in potential, gradient and damping-force evaluations since
    /// construction or the last reset (s). Hessian and damping-matrix evaluations are not
    /// included: their callers time them as assembly.
    pub fn force_seconds(&self) -> f64 {
        self.force_seconds
    }

    /// Run `f` and add its wall time to [`Self::force_seconds`].
    pub(super) fn timed_force<T>(&mut self, f: impl FnOnce(&mut Self) -> T) -> T {
        let start = std::time::Instant::now();
        let out = f(self);
        self.force_seconds += start.elapsed().as_secs_f64();
        out
    }
}
