//! Mass-spring bodies: particles joined by springs, with lumped particle masses and no tet
//! elasticity. One generator per file:
//! - [`jello_cube`]: an n × n × n lattice with structural, shear and bending springs;
//! - [`jello_sphere`]: particles on rings of latitude, a centre particle, antipodal springs;
//! - [`tet_edges()`]: a spring along every edge of a tet mesh (the course's mass-spring bunny).
//!
//! A generator returns a [`SpringBody`]: rest positions, springs (rest lengths from the rest
//! positions) and the [`SpringKind`] of each spring, so stiffness and damping can be set per
//! kind and counted. [`SpringBody::into_model_spec`] turns it into a [`ModelSpec`] with
//! `material: None`, `density: None` and the particle masses as point masses.

pub mod jello_cube;
pub mod jello_sphere;
pub mod tet_edges;

pub use jello_cube::JelloCube;
pub use jello_sphere::JelloSphere;
pub use tet_edges::tet_edges;

use crate::mesh::TetMesh;
use crate::model::{FixedSelection, InvertedTets, MassKind, ModelSpec, Spring};
use crate::parallel::Parallelism;
use nalgebra::Vector3;

/// What a spring of a generated body is for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SpringKind {
    /// Between direct neighbours: lattice axis neighbours, or neighbours along a ring of
    /// latitude or a meridian of the sphere.
    Structural,
    /// Between diagonal neighbours: face and space diagonals of a lattice cell, or the
    /// diagonals of a cell of the sphere grid.
    Shear,
    /// Between every-other neighbours (skip one) along the axes or the sphere grid lines.
    Bending,
    /// From the sphere's centre particle to every other particle.
    Radial,
    /// Between a sphere particle and the particle diametrically opposite.
    Antipodal,
    /// Along an edge of a tet mesh.
    Edge,
}

impl SpringKind {
    /// Every kind, in a fixed order.
    pub const ALL: [SpringKind; 6] = [
        Self::Structural,
        Self::Shear,
        Self::Bending,
        Self::Radial,
        Self::Antipodal,
        Self::Edge,
    ];

    /// The name scene files use (`structural`, `shear`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Self::Structural => "structural",
            Self::Shear => "shear",
            Self::Bending => "bending",
            Self::Radial => "radial",
            Self::Antipodal => "antipodal",
            Self::Edge => "edge",
        }
    }
}

impl std::fmt::Display for SpringKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Stiffness (N/m) and damping coefficient (N s/m) of a spring.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpringCoefficients {
    pub stiffness: f64,
    pub damping: f64,
}

impl SpringCoefficients {
    /// Stiffness `k` without damping.
    pub fn stiffness(k: f64) -> Self {
        Self {
            stiffness: k,
            damping: 0.0,
        }
    }
}

/// How particle masses are given: the same mass for each particle, or a total split evenly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ParticleMass {
    /// Mass of each particle (kg).
    Each(f64),
    /// Total mass (kg), split evenly over the particles.
    Total(f64),
}

/// A generated mass-spring body.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SpringBody {
    /// Rest positions of the particles (m).
    pub positions: Vec<Vector3<f64>>,
    /// Tets over the particles where the generator has them (the cube lattice, a tet mesh),
    /// for surfaces and display only: a [`Model`](crate::model::Model) built with
    /// `material: None, density: None` does not use them.
    pub tets: Vec<[usize; 4]>,
    /// The springs, each pair of particles at most once.
    pub springs: Vec<Spring>,
    /// The kind of each spring (same length as `springs`).
    pub kinds: Vec<SpringKind>,
}

impl SpringBody {
    /// Number of particles.
    pub fn num_particles(&self) -> usize {
        self.positions.len()
    }

    /// Number of springs of `kind`.
    pub fn count(&self, kind: SpringKind) -> usize {
        self.kinds.iter().filter(|&&k| k == kind).count()
    }

    /// Add a spring from `i` to `j` of `kind`, with its rest length from the rest positions.
    fn push(&mut self, i: usize, j: usize, kind: SpringKind, c: SpringCoefficients) {
        let rest_length = (self.positions[i] - self.positions[j]).norm();
        self.springs.push(Spring {
            i,
            j,
            rest_length,
            stiffness: c.stiffness,
            damping: c.damping,
        });
        self.kinds.push(kind);
    }

    /// The mass of every particle (kg).
    pub fn point_masses(&self, mass: ParticleMass) -> Vec<f64> {
        let n = self.num_particles();
        let each = match mass {
            ParticleMass::Each(m) => m,
            ParticleMass::Total(m) => m / n as f64,
        };
        vec![each; n]
    }

    /// The tet mesh view of the body: its positions and (display-only) tets.
    pub fn mesh(&self) -> TetMesh {
        TetMesh {
            positions: self.positions.clone(),
            tets: self.tets.clone(),
        }
    }

    /// A model spec for this body: no tet material or density, the particle masses as point
    /// masses (lumped, so explicit methods need no mass solve), the springs; no gravity,
    /// nothing fixed (set those on the returned spec).
    pub fn into_model_spec(self, mass: ParticleMass) -> ModelSpec {
        let point_masses = self.point_masses(mass);
        ModelSpec {
            mesh: TetMesh {
                positions: self.positions,
                tets: self.tets,
            },
            material: None,
            density: None,
            mass_kind: MassKind::Lumped,
            point_masses: Some(point_masses),
            springs: self.springs,
            gravity: None,
            fixed: FixedSelection::none(),
            inverted_tets: InvertedTets::Refuse,
            parallelism: Parallelism::Rayon,
            damping: crate::model::Damping::default(),
        }
    }
}
