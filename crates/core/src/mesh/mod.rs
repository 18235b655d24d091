//! Tetrahedral meshes: one [`TetMesh`] type that every reader and generator produces, the
//! triangle [`SurfaceMesh`] used for display meshes, surface extraction and a quality report.
//!
//! - Readers, one module per format: [`medit`] (MEDIT `.mesh`, 1-based), [`plain`] (Brown
//!   `v`/`t` `.mesh`, 0-based), [`tetgen`] (`.node` + `.ele`, base from the first id), [`obj`]
//!   (OBJ surfaces, 1-based), [`gmsh`] (`.msh` 2.2 and 4.1, ASCII and binary), [`vtk::xml`]
//!   (`.vtu` XML, every data mode and compressor VTK writes) and [`vtk::legacy`] (legacy
//!   `.vtk`, ASCII and binary) unstructured grids. [`formats`] is the table of them (name,
//!   extensions, content sniffer, reader, description; adding a format is one file plus one
//!   line there); [`read_mesh`], [`read_tet_mesh`] and [`read_surface_mesh`] pick one from it
//!   by content and extension. In memory every index is 0-based.
//! - [`surface`]: boundary faces, edge topology, closed-manifold check.
//! - [`generate`]: box, beam and ball meshes.
//! - [`quality`]: the [`MeshReport`].
//! - [`skinning`]: barycentric binding of a display mesh to a tet mesh ([`Skinning`]), built
//!   with the point-query grid [`tet_grid::TetGrid`].
//!
//! Orientation convention: a tet `[a, b, c, d]` is positively oriented when
//! `(b - a) · ((c - a) × (d - a)) > 0` (the convention of every reference mesh). A surface
//! triangle is wound counter-clockwise seen from outside (normals out by the right-hand rule).

mod bytes;
mod error;
pub mod formats;
pub mod generate;
pub mod gmsh;
pub mod medit;
pub mod obj;
pub mod plain;
pub mod quality;
mod read;
pub mod skinning;
pub mod surface;
pub mod tet_grid;
pub mod tetgen;
mod text;
pub mod vtk;

pub use error::MeshError;
pub use formats::{MESH_FORMATS, MeshFormat};
pub use generate::{ball, beam, box_mesh};
pub use quality::{BoundingBox, MeshReport};
pub use read::{read_mesh, read_surface_mesh, read_tet_mesh};
pub use skinning::{OutsideVertex, Skinning, SkinningError};

use nalgebra::Vector3;

/// A tetrahedral mesh: vertex positions and 0-based, 4-vertex tets.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TetMesh {
    /// Vertex positions (units as given by the file or generator).
    pub positions: Vec<Vector3<f64>>,
    /// Tets as 0-based vertex indices, every index `< positions.len()`.
    pub tets: Vec<[usize; 4]>,
}

/// A mesh of either kind, as read from a file whose kind was not known beforehand.
#[derive(Clone, Debug, PartialEq)]
pub enum AnyMesh {
    /// A tetrahedral mesh.
    Tet(TetMesh),
    /// A triangle surface.
    Surface(SurfaceMesh),
}

/// A triangle surface: vertex positions and 0-based triangles (outward normals by the
/// right-hand rule when the surface is closed and correctly wound).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfaceMesh {
    /// Vertex positions.
    pub positions: Vec<Vector3<f64>>,
    /// Triangles as 0-based vertex indices.
    pub triangles: Vec<[usize; 3]>,
}

impl TetMesh {
    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of tets.
    pub fn num_tets(&self) -> usize {
        self.tets.len()
    }

    /// Six times the signed volume of tet `t`: positive for a positively oriented tet.
    pub fn signed_volume6(&self, t: usize) -> f64 {
        let [a, b, c, d] = self.tets[t];
        let p = &self.positions;
        (p[b] - p[a]).dot(&(p[c] - p[a]).cross(&(p[d] - p[a])))
    }

    /// Signed volume of tet `t`.
    pub fn signed_volume(&self, t: usize) -> f64 {
        self.signed_volume6(t) / 6.0
    }

    /// Sum of signed tet volumes.
    pub fn total_volume(&self) -> f64 {
        (0..self.num_tets()).map(|t| self.signed_volume(t)).sum()
    }

    /// Axis-aligned bounding box `(min, max)`; `None` for a mesh without vertices.
    pub fn bounding_box(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        bounding_box(&self.positions)
    }
}

impl SurfaceMesh {
    /// Axis-aligned bounding box `(min, max)`; `None` for a mesh without vertices.
    pub fn bounding_box(&self) -> Option<(Vector3<f64>, Vector3<f64>)> {
        bounding_box(&self.positions)
    }
}

/// Axis-aligned bounding box of a point set.
pub fn bounding_box(points: &[Vector3<f64>]) -> Option<(Vector3<f64>, Vector3<f64>)> {
    let first = *points.first()?;
    Some(
        points
            .iter()
            .fold((first, first), |(lo, hi), p| (lo.inf(p), hi.sup(p))),
    )
}
