//! The [`Model`]: a conservative system over the free DOFs of a mesh. It sums potentials —
//! elastic (tet FEM), springs, gravity — and answers their value, gradient and sparse Hessian.
//!
//! The Hessian's sparsity pattern and the gather lists that assemble into it are built once;
//! each evaluation computes element quantities into preallocated buffers (in parallel when
//! asked) and gathers them in a fixed order, so results are bitwise identical run to run and
//! across thread counts. Every evaluation is counted in [`EvalCounters`].
//!
//! [`highest_mode`] finds the highest natural frequency of the linearized model (the explicit
//! stability limit `2 / omega_max`).

mod damping;
mod dofs;
mod drag;
mod elastic;
mod error;
mod local;
mod mass;
mod measures;
mod pattern;
mod spectrum;
mod springs;
mod vertex_potential;

pub use damping::Damping;
pub use dofs::{AxisRule, DofMap, FIXED, FixedSelection, Side};
pub use drag::{Drag, DragPath, Waypoint};
pub use error::ModelError;
pub use local::ElasticElements;
pub(crate) use mass::MassInverse;
pub use mass::{MassKind, MassMatrix};
pub use pattern::BlockPattern;
pub use spectrum::{HighestMode, SpectrumError, SpectrumSettings, highest_mode};
pub use springs::Spring;
pub use vertex_potential::VertexPotential;

use crate::fem::{TetRest, consistent_mass_matrix, lumped_vertex_mass};
use crate::material::MaterialModel;
use crate::mesh::TetMesh;
use crate::parallel::Parallelism;
use crate::sparse::{SparsityPattern, SymmetricMatrix};
use elastic::{ElasticBody, ElementFailure};
use nalgebra::Vector3;
use pattern::{ElementGather, gather_matrix, gather_vector};
use std::sync::Arc;

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
}

impl PotentialParts {
    /// Sum of all parts.
    pub fn total(&self) -> f64 {
        self.elastic + self.springs + self.gravity + self.vertex
    }
}

/// Options of a Hessian evaluation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HessianOptions {
    /// Project every element Hessian to positive semi-definite (eigenvalue clamp).
    pub project_elements: bool,
}

/// Scratch space reused by every evaluation (element matrices allocated on first use, so
/// methods that never ask for a Hessian never pay for it).
#[derive(Debug, Default)]
struct Buffers {
    partial: Vec<f64>,
    tet_vectors: Vec<f64>,
    tet_matrices: Vec<f64>,
    spring_vectors: Vec<f64>,
    spring_matrices: Vec<f64>,
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
    gravity: Option<Vector3<f64>>,
    parallelism: Parallelism,
    counters: EvalCounters,
    buffers: Buffers,
}

fn invalid(field: &str, value: impl std::fmt::Display, expected: &str) -> ModelError {
    ModelError::InvalidParameter {
        field: field.into(),
        value: value.to_string(),
        expected: expected.into(),
    }
}

/// Check tet indices and orientation; reorient if asked. Returns the rest data per tet.
fn prepare_tets(mesh: &mut TetMesh, policy: InvertedTets) -> Result<Vec<TetRest>, ModelError> {
    let n = mesh.num_vertices();
    for (t, tet) in mesh.tets.iter().enumerate() {
        if let Some(&v) = tet.iter().find(|&&v| v >= n) {
            return Err(ModelError::TetIndexOutOfRange {
                tet: t,
                vertex: v,
                vertices: n,
            });
        }
    }
    let inverted: Vec<usize> = (0..mesh.num_tets())
        .filter(|&t| mesh.signed_volume6(t) < 0.0)
        .collect();
    if !inverted.is_empty() {
        match policy {
            InvertedTets::Refuse => {
                return Err(ModelError::InvertedTets {
                    count: inverted.len(),
                    first: inverted.iter().copied().take(10).collect(),
                });
            }
            InvertedTets::Reorient => {
                for &t in &inverted {
                    mesh.tets[t].swap(2, 3);
                }
            }
        }
    }
    let mut degenerate = Vec::new();
    let rest: Vec<TetRest> = mesh
        .tets
        .iter()
        .enumerate()
        .filter_map(|(t, tet)| {
            let x = tet.map(|v| mesh.positions[v]);
            TetRest::new(&x).map_err(|_| degenerate.push(t)).ok()
        })
        .collect();
    if !degenerate.is_empty() {
        return Err(ModelError::DegenerateTets {
            count: degenerate.len(),
            first: degenerate.into_iter().take(10).collect(),
        });
    }
    Ok(rest)
}

impl Model {
    /// Build a model: validate the input, eliminate fixed vertices, build the Hessian pattern,
    /// the gather lists and the mass matrix.
    pub fn new(spec: ModelSpec) -> Result<Self, ModelError> {
        let ModelSpec {
            mut mesh,
            material,
            density,
            mass_kind,
            point_masses,
            springs,
            gravity,
            fixed,
            inverted_tets,
            parallelism,
            damping,
        } = spec;
        let n = mesh.num_vertices();
        if let Some(rho) = density
            && !(rho.is_finite() && rho > 0.0)
        {
            return Err(invalid(
                "material.density",
                rho,
                "a positive density in kg/m^3",
            ));
        }
        if let Some(g) = gravity
            && !g.iter().all(|c| c.is_finite())
        {
            return Err(invalid(
                "forces.gravity",
                format!("{g:?}"),
                "three finite numbers (m/s^2)",
            ));
        }
        for (s, sp) in springs.iter().enumerate() {
            if sp.i >= n || sp.j >= n || sp.i == sp.j {
                return Err(ModelError::InvalidSpring {
                    spring: s,
                    i: sp.i,
                    j: sp.j,
                    vertices: n,
                });
            }
            let non_negative = |x: f64| x.is_finite() && x >= 0.0;
            if !non_negative(sp.stiffness)
                || !non_negative(sp.rest_length)
                || !non_negative(sp.damping)
            {
                return Err(invalid(
                    &format!("springs[{s}]"),
                    format!(
                        "stiffness {} rest length {} damping {}",
                        sp.stiffness, sp.rest_length, sp.damping
                    ),
                    "finite, non-negative stiffness, rest length and damping",
                ));
            }
        }
        let non_negative = |x: f64| x.is_finite() && x >= 0.0;
        if let Some((alpha, beta)) = damping.rayleigh
            && !(non_negative(alpha) && non_negative(beta))
        {
            return Err(invalid(
                "damping.rayleigh",
                format!("alpha {alpha}, beta {beta}"),
                "alpha >= 0 and beta >= 0",
            ));
        }
        if let Some((phi, psi)) = damping.strain_rate
            && !(non_negative(phi) && non_negative(psi))
        {
            return Err(invalid(
                "damping.strain_rate",
                format!("phi {phi}, psi {psi}"),
                "phi >= 0 and psi >= 0",
            ));
        }
        if damping.strain_rate.is_some() && material.is_none() {
            return Err(invalid(
                "damping.strain_rate",
                "set",
                "a [material] for the tets it acts on",
            ));
        }
        let uses_tets = material.is_some() || density.is_some();
        let rest = if uses_tets {
            prepare_tets(&mut mesh, inverted_tets)?
        } else {
            Vec::new()
        };
        let tets = if uses_tets {
            std::mem::take(&mut mesh.tets)
        } else {
            Vec::new()
        };

        // Lumped vertex masses (also the row sums of the consistent matrix).
        let mut vertex_mass = vec![0.0; n];
        if let Some(rho) = density {
            for (tet, r) in tets.iter().zip(&rest) {
                let m = lumped_vertex_mass(rho, r.volume);
                for &v in tet {
                    vertex_mass[v] += m;
                }
            }
        }
        if let Some(pm) = &point_masses {
            if pm.len() != n {
                return Err(invalid(
                    "point_masses",
                    pm.len(),
                    &format!("one mass per vertex ({n})"),
                ));
            }
            for (v, &m) in pm.iter().enumerate() {
                if !(m.is_finite() && m >= 0.0) {
                    return Err(invalid(
                        &format!("point_masses[{v}]"),
                        m,
                        "a finite, non-negative mass",
                    ));
                }
                vertex_mass[v] += m;
            }
        }

        let dofs = DofMap::new(&fixed.resolve(&mesh)?);
        if let Some(v) = dofs
            .free_vertices()
            .iter()
            .copied()
            .find(|&v| vertex_mass[v] <= 0.0)
        {
            return Err(ModelError::MasslessVertex { vertex: v });
        }
        let free = |v: usize| dofs.free_index(v);
        let tet_free: Vec<[u32; 4]> = tets.iter().map(|t| t.map(free)).collect();
        let spring_free: Vec<[u32; 2]> = springs.iter().map(|s| [free(s.i), free(s.j)]).collect();
        let all_elements = tet_free
            .iter()
            .map(|t| t.as_slice())
            .chain(spring_free.iter().map(|s| s.as_slice()));
        let pattern = BlockPattern::new(dofs.num_free(), all_elements);
        let tet_gather = ElementGather::new(&pattern, 4, tet_free.iter().map(|t| t.as_slice()));
        let spring_gather =
            ElementGather::new(&pattern, 2, spring_free.iter().map(|s| s.as_slice()));

        let mass = match mass_kind {
            MassKind::Consistent => {
                let mut buf = vec![0.0; 144 * tets.len()];
                if let Some(rho) = density {
                    for (r, out) in rest.iter().zip(buf.chunks_exact_mut(144)) {
                        consistent_mass_matrix(rho, r.volume, out);
                    }
                }
                let mut m = SymmetricMatrix::zeros(pattern.scalar().clone());
                gather_matrix(
                    parallelism,
                    &pattern,
                    &[(&tet_gather, &buf)],
                    m.values_mut(),
                );
                // Point masses are lumped onto the diagonal.
                if let Some(pm) = &point_masses {
                    for (f, &v) in dofs.free_vertices().iter().enumerate() {
                        for i in 0..3 {
                            let slot = pattern
                                .scalar()
                                .find(3 * f + i, 3 * f + i)
                                .expect("diagonal");
                            m.values_mut()[slot] += pm[v];
                        }
                    }
                }
                MassMatrix::Consistent(m)
            }
            MassKind::Lumped => {
                let diagonal = dofs
                    .free_vertices()
                    .iter()
                    .flat_map(|&v| [vertex_mass[v]; 3])
                    .collect();
                let diagonal_slots = (0..dofs.num_dofs())
                    .map(|i| pattern.scalar().find(i, i).expect("diagonal"))
                    .collect();
                MassMatrix::Lumped {
                    diagonal,
                    diagonal_slots,
                }
            }
        };

        // Tets used only for mass take no further part in assembly.
        let tet_gather = if material.is_some() {
            tet_gather
        } else {
            ElementGather::default()
        };
        let diagonal_slots = (0..dofs.num_free())
            .map(|f| {
                std::array::from_fn(|k| {
                    let (i, j) = (k % 3, k / 3);
                    pattern
                        .scalar()
                        .find(3 * f + i, 3 * f + j)
                        .expect("diagonal blocks are in the pattern")
                })
            })
            .collect();
        // Elastic energy is a difference of O(stiffness) terms (e.g. J^(-2/3) I1 - 3) and a
        // spring's is (l - L)^2 with l - L a difference of O(L) numbers: their round-off is set
        // by these magnitudes, not by the (possibly tiny) energy itself.
        let stiffness_scale = material
            .as_ref()
            .and_then(|m| {
                m.first_piola_derivative(&nalgebra::Matrix3::identity())
                    .ok()
            })
            .map_or(0.0, |d| d.norm());
        let energy_roundoff_scale = stiffness_scale * rest.iter().map(|r| r.volume).sum::<f64>()
            + springs
                .iter()
                .map(|s| s.stiffness * s.rest_length * s.rest_length)
                .sum::<f64>();
        let elastic = material.map(|material| ElasticBody {
            material,
            tets,
            rest,
        });
        Ok(Self {
            dofs,
            rest_positions: mesh.positions.clone(),
            positions: mesh.positions,
            elastic,
            springs,
            vertex_potentials: Vec::new(),
            diagonal_slots,
            time: 0.0,
            damping,
            energy_roundoff_scale,
            velocities: vec![Vector3::zeros(); n],
            stiffness_scratch: None,
            pattern,
            tet_gather,
            spring_gather,
            vertex_mass,
            mass,
            gravity,
            parallelism,
            counters: EvalCounters::default(),
            buffers: Buffers::default(),
        })
    }

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

    /// Change how element loops run (results do not change).
    pub fn set_parallelism(&mut self, par: Parallelism) {
        self.parallelism = par;
    }

    /// Evaluation counts since construction or the last reset.
    pub fn counters(&self) -> EvalCounters {
        self.counters
    }

    /// Reset the evaluation counters.
    pub fn reset_counters(&mut self) {
        self.counters = EvalCounters::default();
    }

    fn load_state(&mut self, q: &[f64]) -> Result<(), ModelError> {
        if q.len() != self.num_dofs() {
            return Err(ModelError::StateLength {
                got: q.len(),
                expected: self.num_dofs(),
            });
        }
        self.dofs.scatter(q, &mut self.positions);
        Ok(())
    }

    /// Sum the element vectors in the buffers (tets, springs) into `out` over free DOFs.
    fn gather_element_vectors(&self, out: &mut [f64]) {
        let b = &self.buffers;
        let families = [
            (&self.tet_gather, b.tet_vectors.as_slice()),
            (&self.spring_gather, b.spring_vectors.as_slice()),
        ];
        gather_vector(self.parallelism, &families, out);
    }

    /// Sum the element matrices in the buffers (tets, springs) into `values` over the pattern.
    fn gather_element_matrices(&self, values: &mut [f64]) {
        let b = &self.buffers;
        let families = [
            (&self.tet_gather, b.tet_matrices.as_slice()),
            (&self.spring_gather, b.spring_matrices.as_slice()),
        ];
        gather_matrix(self.parallelism, &self.pattern, &families, values);
    }

    fn element_error(&self, f: ElementFailure) -> ModelError {
        let material = self.material().map_or("material", |m| m.name());
        ModelError::InvertedElement {
            tet: f.tet,
            det_f: f.det_f,
            material,
        }
    }

    /// The potential at `q`, split by source.
    pub fn potential_parts(&mut self, q: &[f64]) -> Result<PotentialParts, ModelError> {
        self.load_state(q)?;
        self.counters.potential += 1;
        let x = &self.positions;
        let elastic = match &self.elastic {
            Some(body) => {
                self.buffers.partial.resize(body.num_chunks(), 0.0);
                body.energy(self.parallelism, x, &mut self.buffers.partial)
                    .map_err(|f| self.element_error(f))?
            }
            None => 0.0,
        };
        let springs = self
            .springs
            .iter()
            .map(|s| s.energy(&x[s.i], &x[s.j]))
            .sum();
        let gravity = self.gravity.map_or(0.0, |g| {
            -x.iter()
                .zip(&self.vertex_mass)
                .map(|(p, m)| m * g.dot(p))
                .sum::<f64>()
        });
        let vertex = self
            .vertex_potentials
            .iter()
            .map(|p| p.energy(self.time, x))
            .sum();
        Ok(PotentialParts {
            elastic,
            springs,
            gravity,
            vertex,
        })
    }

    /// The total potential at `q` (J).
    pub fn potential(&mut self, q: &[f64]) -> Result<f64, ModelError> {
        Ok(self.potential_parts(q)?.total())
    }

    /// The gradient of the potential at `q`, written to `g` (length [`Self::num_dofs`]).
    pub fn gradient(&mut self, q: &[f64], g: &mut [f64]) -> Result<(), ModelError> {
        self.load_state(q)?;
        assert_eq!(
            g.len(),
            self.num_dofs(),
            "gradient output has the wrong length"
        );
        self.counters.gradient += 1;
        let par = self.parallelism;
        let b = &mut self.buffers;
        if let Some(body) = &self.elastic {
            b.tet_vectors.resize(12 * body.tets.len(), 0.0);
            let res = body.gradients(par, &self.positions, &mut b.tet_vectors);
            if let Err(f) = res {
                return Err(self.element_error(f));
            }
        }
        b.spring_vectors.resize(6 * self.springs.len(), 0.0);
        for (s, out) in self
            .springs
            .iter()
            .zip(b.spring_vectors.chunks_exact_mut(6))
        {
            s.gradient(&self.positions[s.i], &self.positions[s.j], out);
        }
        self.gather_element_vectors(g);
        if let Some(gr) = self.gravity {
            for (f, &v) in self.dofs.free_vertices().iter().enumerate() {
                for i in 0..3 {
                    g[3 * f + i] -= self.vertex_mass[v] * gr[i];
                }
            }
        }
        let dofs = &self.dofs;
        for p in &self.vertex_potentials {
            p.gradient(self.time, &self.positions, &mut |v, gv| {
                let f = dofs.free_index(v);
                if f != FIXED {
                    let f = f as usize;
                    for i in 0..3 {
                        g[3 * f + i] += gv[i];
                    }
                }
            });
        }
        Ok(())
    }

    /// The Hessian of the potential at `q`, written into `h` (which must be over
    /// [`Self::hessian_pattern`]; see [`Self::new_hessian`]).
    pub fn hessian(
        &mut self,
        q: &[f64],
        h: &mut SymmetricMatrix,
        options: HessianOptions,
    ) -> Result<(), ModelError> {
        self.load_state(q)?;
        assert!(
            Arc::ptr_eq(h.pattern(), self.pattern.scalar()),
            "the Hessian must be created by Model::new_hessian"
        );
        self.counters.hessian += 1;
        let par = self.parallelism;
        let b = &mut self.buffers;
        if let Some(body) = &self.elastic {
            b.tet_matrices.resize(144 * body.tets.len(), 0.0);
            let res = body.hessians(
                par,
                &self.positions,
                options.project_elements,
                &mut b.tet_matrices,
            );
            if let Err(f) = res {
                return Err(self.element_error(f));
            }
        }
        b.spring_matrices.resize(36 * self.springs.len(), 0.0);
        for (s, out) in self
            .springs
            .iter()
            .zip(b.spring_matrices.chunks_exact_mut(36))
        {
            s.hessian(
                &self.positions[s.i],
                &self.positions[s.j],
                options.project_elements,
                out,
            );
        }
        self.gather_element_matrices(h.values_mut());
        let values = h.values_mut();
        let (dofs, slots) = (&self.dofs, &self.diagonal_slots);
        for p in &self.vertex_potentials {
            p.hessian(
                self.time,
                &self.positions,
                options.project_elements,
                &mut |v, block| {
                    let f = dofs.free_index(v);
                    if f != FIXED {
                        for (slot, value) in slots[f as usize].iter().zip(block.iter()) {
                            values[*slot] += value;
                        }
                    }
                },
            );
        }
        Ok(())
    }
}
