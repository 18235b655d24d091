//! Springs along every edge of a tet mesh, each edge once: the course's mass-spring bunny
//! (CSC417 A2: `coarse_bunny.mesh`, every tet edge a spring of stiffness 1e5, unit particle
//! masses).

use super::{SpringBody, SpringCoefficients, SpringKind};
use crate::mesh::TetMesh;

/// A body with one [`SpringKind::Edge`] spring per unique edge of `mesh`'s tets, rest lengths
/// from the mesh positions, in increasing `(i, j)` order with `i < j`. The body keeps the
/// mesh's positions and tets (the tets for display).
///
/// # Panics
/// If a tet refers to a vertex that does not exist.
pub fn tet_edges(mesh: &TetMesh, coefficients: SpringCoefficients) -> SpringBody {
    let n = mesh.num_vertices();
    let mut edges: Vec<(usize, usize)> = Vec::with_capacity(6 * mesh.num_tets());
    for tet in &mesh.tets {
        assert!(
            tet.iter().all(|&v| v < n),
            "tet_edges: tet {tet:?} refers to a vertex beyond the {n} vertices"
        );
        for a in 0..4 {
            for b in a + 1..4 {
                let (i, j) = (tet[a].min(tet[b]), tet[a].max(tet[b]));
                if i != j {
                    edges.push((i, j));
                }
            }
        }
    }
    edges.sort_unstable();
    edges.dedup();
    let mut body = SpringBody {
        positions: mesh.positions.clone(),
        tets: mesh.tets.clone(),
        springs: Vec::with_capacity(edges.len()),
        kinds: Vec::with_capacity(edges.len()),
    };
    for (i, j) in edges {
        body.push(i, j, SpringKind::Edge, coefficients);
    }
    body
}
