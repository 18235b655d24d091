//! The independent check of a sampled frame: is it free of intersections? Exact predicates
//! ([`super::intersection`]) on the body's boundary triangles — against each other (self-
//! intersection), against static mesh obstacles and against the triangulated boxes among the
//! analytic obstacles — and a signed-distance test of every vertex against every analytic
//! obstacle. It shares no code with any contact response, so a response cannot certify itself.

use super::intersection::{intersections_between, self_intersections};
use super::mesh_obstacle::MeshObstacle;
use super::obstacle::Obstacles;
use nalgebra::Vector3;
use std::sync::Arc;

/// What a frame is checked against.
#[derive(Clone, Debug)]
pub struct FrameCheck {
    surface: Vec<[usize; 3]>,
    meshes: Vec<MeshObstacle>,
    obstacles: Arc<Obstacles>,
}

impl FrameCheck {
    /// A check of the body's boundary triangles `surface` against `meshes` and `obstacles`.
    pub fn new(
        surface: Vec<[usize; 3]>,
        meshes: Vec<MeshObstacle>,
        obstacles: Arc<Obstacles>,
    ) -> Self {
        Self {
            surface,
            meshes,
            obstacles,
        }
    }

    /// Whether the body at every-vertex positions `x` and time `t` is free of intersections
    /// (non-finite positions are not).
    pub fn intersection_free(&self, x: &[Vector3<f64>], t: f64) -> bool {
        if !x.iter().all(|p| p.iter().all(|c| c.is_finite())) {
            return false;
        }
        if self_intersections(x, &self.surface).intersecting_pairs > 0 {
            return false;
        }
        let mut boxes = Vec::new();
        for o in self.obstacles.iter() {
            o.box_meshes(t, &mut boxes);
        }
        for m in self.meshes.iter().chain(&boxes) {
            if intersections_between(x, &self.surface, &m.positions, &m.triangles)
                .intersecting_pairs
                > 0
            {
                return false;
            }
        }
        self.obstacles.is_empty() || x.iter().all(|p| self.obstacles.distance(p, t) >= 0.0)
    }
}
