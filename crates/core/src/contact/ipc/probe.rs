//! What an independent implementation of incremental potential contact is compared against
//! (`python/tests/test_ipctk.py` asks ipc-toolkit the same questions): at given positions, the
//! unit-stiffness barrier and its gradient, the contacts and their smallest distance, and the
//! collision-free fraction of a given displacement; and the collision mesh they are computed
//! on, by vertex index.

use super::{FilterBuffers, Ipc, min_distance_squared};
use crate::contact::ipc::contacts;
use nalgebra::Vector3;

/// The answers of softbench's IPC at one configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct IpcProbe {
    /// The barrier summed over the contacts with κ = 1 (∞ if the configuration intersects).
    pub barrier: f64,
    /// Its gradient with respect to every body vertex (zero off the surface).
    pub gradient: Vec<Vector3<f64>>,
    /// Contacts within d̂.
    pub contacts: usize,
    /// The smallest distance over them (m; d̂ when there are none).
    pub min_distance: f64,
    /// The largest fraction in [0, 1] of the displacement that keeps every pair apart (CCD),
    /// if a displacement was given.
    pub step: Option<f64>,
}

/// The collision mesh by vertex index: the body's vertices come first (`num_body`), then the
/// mesh obstacles' (whose positions are given); edges and faces over both.
#[derive(Clone, Debug, PartialEq)]
pub struct CollisionMeshArrays {
    pub num_body: usize,
    pub obstacle_positions: Vec<Vector3<f64>>,
    pub vertices: Vec<u32>,
    pub edges: Vec<[u32; 2]>,
    pub faces: Vec<[u32; 3]>,
}

impl Ipc {
    /// The answers at every body vertex's positions `x` and time `t` (and, with a
    /// displacement `dx` of every body vertex, its collision-free fraction). Counts no CCD
    /// query and changes no lagged state.
    pub fn probe(&self, x: &[Vector3<f64>], t: f64, dx: Option<&[Vector3<f64>]>) -> IpcProbe {
        let mut gradient = vec![Vector3::zeros(); x.len()];
        let barrier = self.unit_barrier(x, t, Some(&mut gradient));
        let (contacts, min_distance) = {
            let mut scratch = self.scratch.lock().expect("not poisoned");
            contacts::find(&self.search(), x, t, &mut scratch);
            let s_hat = self.config.dhat * self.config.dhat;
            let s = min_distance_squared(&scratch.contacts, s_hat);
            (scratch.contacts.len(), s.max(0.0).sqrt())
        };
        let queries = self.ccd_queries();
        let step = dx.map(|dx| self.max_step_of(x, dx, t, &mut FilterBuffers::default()));
        self.ccd_queries
            .store(queries, std::sync::atomic::Ordering::Relaxed);
        IpcProbe {
            barrier,
            gradient,
            contacts,
            min_distance,
            step,
        }
    }

    /// The collision mesh its contacts are computed on.
    pub fn collision_mesh_arrays(&self) -> CollisionMeshArrays {
        let mesh = &self.mesh;
        CollisionMeshArrays {
            num_body: self.rest.len(),
            obstacle_positions: mesh.obstacle_positions().to_vec(),
            vertices: mesh.vertices.clone(),
            edges: mesh.edges.clone(),
            faces: mesh.faces.clone(),
        }
    }

    /// d̂ (m) and whether the body's own surfaces collide.
    pub fn dhat_and_self_contact(&self) -> (f64, bool) {
        (self.config.dhat, self.config.self_contact)
    }
}
