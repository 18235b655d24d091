//! A mesh report: counts, extent, volumes, element quality and surface topology, for a tet mesh
//! or a triangle surface. This is what `softbench mesh-info` prints.
//!
//! Quality is the normalized radius ratio `3 r_in / r_circ` (insphere over circumsphere radius,
//! times 3): 1 for a regular tet, toward 0 for slivers, needles and caps, 0 for a flat tet. It
//! ignores orientation, so an inverted tet has the quality of its mirror image.
//!
//! Volume classes, with `tol = DEGENERATE_RELATIVE_VOLUME × mean |volume|`: a tet is
//! *degenerate* when `|volume| ≤ tol` (flat up to round-off) and *inverted* when
//! `volume < -tol`, so the two counts never overlap.

use std::fmt;

use nalgebra::Vector3;
use serde::Serialize;

use super::surface::{check_edges, classify_faces, count_tet_edges};
use super::{SurfaceMesh, TetMesh};

/// Relative tolerance (of the mean absolute tet volume) below which a tet counts as degenerate.
pub const DEGENERATE_RELATIVE_VOLUME: f64 = 1e-10;

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BoundingBox {
    /// Smallest x, y, z.
    pub min: [f64; 3],
    /// Largest x, y, z.
    pub max: [f64; 3],
}

impl BoundingBox {
    fn of(points: &[Vector3<f64>]) -> Option<Self> {
        super::bounding_box(points).map(|(lo, hi)| BoundingBox {
            min: lo.into(),
            max: hi.into(),
        })
    }
}

/// Summary of a mesh. For a surface the tet fields are 0 (counts) or `None` (extremes).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MeshReport {
    /// Number of vertices (including any that no element uses).
    pub vertices: usize,
    /// Number of tets (0 for a surface).
    pub tets: usize,
    /// Boundary triangles of a tet mesh, or all triangles of a surface.
    pub surface_triangles: usize,
    /// Bounding box of all vertices; `None` without vertices.
    pub bbox: Option<BoundingBox>,
    /// Sum of signed tet volumes, or the signed volume a surface encloses.
    pub volume: f64,
    /// Smallest signed tet volume.
    pub min_tet_volume: Option<f64>,
    /// Largest signed tet volume.
    pub max_tet_volume: Option<f64>,
    /// Smallest normalized radius ratio (1 = regular tet).
    pub min_quality: Option<f64>,
    /// Tets with volume below `-tol` (see the module docs).
    pub inverted: usize,
    /// Tets with `|volume| ≤ tol` (see the module docs).
    pub degenerate: usize,
    /// Vertices on the surface (used by a surface triangle).
    pub boundary_vertices: usize,
    /// Unique edges (of the tets, or of the surface triangles).
    pub edges: usize,
    /// Every surface edge is shared by exactly two triangles that run it in opposite directions.
    pub closed_manifold: bool,
}

/// The normalized radius ratio `3 r_in / r_circ` of a tet: 1 when regular, 0 when flat.
pub fn tet_quality(p: [Vector3<f64>; 4]) -> f64 {
    let (u, v, w) = (p[1] - p[0], p[2] - p[0], p[3] - p[0]);
    let volume6 = u.dot(&v.cross(&w)).abs();
    let area2: f64 = [(u, v), (v, w), (w, u), (p[2] - p[1], p[3] - p[1])]
        .iter()
        .map(|(a, b)| a.cross(b).norm())
        .sum();
    if volume6 == 0.0 || area2 == 0.0 {
        return 0.0;
    }
    // r_in = 3 V / A = volume6 / area2.
    let r_in = volume6 / area2;
    // Circumcentre relative to p[0].
    let centre = (v.cross(&w) * u.norm_squared()
        + w.cross(&u) * v.norm_squared()
        + u.cross(&v) * w.norm_squared())
        / (2.0 * volume6);
    3.0 * r_in / centre.norm()
}

/// The volume–edge ratio `6√2 |V| / l_rms³` (`l_rms` the root mean square edge length): also 1
/// when regular and 0 when flat, but gentler on needles than the radius ratio. It is the
/// "minimum quality" of the reference-mesh README; the report uses [`tet_quality`].
pub fn volume_edge_ratio(p: [Vector3<f64>; 4]) -> f64 {
    let (u, v, w) = (p[1] - p[0], p[2] - p[0], p[3] - p[0]);
    let volume = u.dot(&v.cross(&w)).abs() / 6.0;
    let sum_sq = u.norm_squared()
        + v.norm_squared()
        + w.norm_squared()
        + (p[2] - p[1]).norm_squared()
        + (p[3] - p[1]).norm_squared()
        + (p[3] - p[2]).norm_squared();
    if sum_sq == 0.0 {
        return 0.0;
    }
    let l_rms = (sum_sq / 6.0).sqrt();
    6.0 * std::f64::consts::SQRT_2 * volume / (l_rms * l_rms * l_rms)
}

impl MeshReport {
    /// Reports on a tet mesh.
    pub fn for_tet_mesh(mesh: &TetMesh) -> Self {
        let p = &mesh.positions;
        let volumes: Vec<f64> = (0..mesh.num_tets())
            .map(|t| mesh.signed_volume(t))
            .collect();
        let mean_abs = volumes.iter().map(|v| v.abs()).sum::<f64>() / volumes.len().max(1) as f64;
        let tol = DEGENERATE_RELATIVE_VOLUME * mean_abs;
        let min_quality = mesh
            .tets
            .iter()
            .map(|t| tet_quality(t.map(|i| p[i])))
            .reduce(f64::min);
        let faces = classify_faces(&mesh.tets);
        let edges = check_edges(&faces.boundary);
        MeshReport {
            vertices: mesh.num_vertices(),
            tets: mesh.num_tets(),
            surface_triangles: faces.boundary.len(),
            bbox: BoundingBox::of(p),
            volume: volumes.iter().sum(),
            min_tet_volume: volumes.iter().copied().reduce(f64::min),
            max_tet_volume: volumes.iter().copied().reduce(f64::max),
            min_quality,
            inverted: volumes.iter().filter(|&&v| v < -tol).count(),
            degenerate: volumes.iter().filter(|&&v| v.abs() <= tol).count(),
            boundary_vertices: count_used(p.len(), &faces.boundary),
            edges: count_tet_edges(&mesh.tets),
            closed_manifold: edges.is_closed_manifold(),
        }
    }

    /// Reports on a triangle surface.
    pub fn for_surface(mesh: &SurfaceMesh) -> Self {
        let edges = check_edges(&mesh.triangles);
        MeshReport {
            vertices: mesh.num_vertices(),
            tets: 0,
            surface_triangles: mesh.num_triangles(),
            bbox: BoundingBox::of(&mesh.positions),
            volume: mesh.enclosed_volume(),
            min_tet_volume: None,
            max_tet_volume: None,
            min_quality: None,
            inverted: 0,
            degenerate: 0,
            boundary_vertices: count_used(mesh.num_vertices(), &mesh.triangles),
            edges: edges.edges,
            closed_manifold: edges.is_closed_manifold(),
        }
    }
}

/// Number of distinct vertices the triangles use.
fn count_used(num_vertices: usize, triangles: &[[usize; 3]]) -> usize {
    let mut used = vec![false; num_vertices];
    for &i in triangles.iter().flatten() {
        if let Some(u) = used.get_mut(i) {
            *u = true;
        }
    }
    used.iter().filter(|&&u| u).count()
}

/// A number with about 6 significant digits, without exponent for ordinary magnitudes.
fn num(x: f64) -> String {
    let a = x.abs();
    if a == 0.0 || !x.is_finite() {
        format!("{x}")
    } else if !(1e-4..1e7).contains(&a) {
        format!("{x:.5e}")
    } else {
        let decimals = (5 - a.log10().floor() as i32).max(0) as usize;
        let s = format!("{x:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    }
}

impl fmt::Display for MeshReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let yes_no = |b: bool| if b { "yes" } else { "no" };
        let point = |p: [f64; 3]| format!("({}, {}, {})", num(p[0]), num(p[1]), num(p[2]));
        writeln!(f, "vertices            {}", self.vertices)?;
        if self.tets > 0 {
            writeln!(
                f,
                "tets                {} ({} inverted, {} degenerate)",
                self.tets, self.inverted, self.degenerate
            )?;
        }
        writeln!(f, "surface triangles   {}", self.surface_triangles)?;
        writeln!(f, "boundary vertices   {}", self.boundary_vertices)?;
        writeln!(f, "unique edges        {}", self.edges)?;
        writeln!(f, "closed 2-manifold   {}", yes_no(self.closed_manifold))?;
        if let Some(b) = self.bbox {
            writeln!(
                f,
                "bounding box        {} -> {}",
                point(b.min),
                point(b.max)
            )?;
        }
        let volume = if self.tets > 0 {
            "volume"
        } else {
            "enclosed volume"
        };
        writeln!(f, "{volume:<20}{}", num(self.volume))?;
        if let (Some(lo), Some(hi)) = (self.min_tet_volume, self.max_tet_volume) {
            writeln!(f, "tet volume          {} .. {}", num(lo), num(hi))?;
        }
        if let Some(q) = self.min_quality {
            writeln!(
                f,
                "min quality         {} (radius ratio 3 r_in / r_circ; 1 = regular)",
                num(q)
            )?;
        }
        Ok(())
    }
}
