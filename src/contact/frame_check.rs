//! The independent check of a sampled frame: is it free of intersections? Exact predicates
//! ([`super::intersection`]) on the body's boundary triangles — against each other (self-
//! intersection), against static mesh obstacles and against the triangulated boxes among the
//! analytic obstacles — and a signed-distance test of every vertex against every analytic
//! obstacle. It shares no code with any contact response, so a response cannot certify itself.

use super::intersection::{intersections_between, self_intersections};
use super::mesh_obstacle::MeshObstacle;
use super::obstacle::{Obstacle, Obstacles, Shape};
use nalgebra::{Point3, Vector3};
use std::sync::Arc;

/// What a frame is checked against.
#[derive(Clone, Debug)]
pub struct FrameCheck {
    surface: Vec<[usize; 3]>,
    meshes: Vec<MeshObstacle>,
    obstacles: Arc<Obstacles>,
}

/// A box's corners in the order its 12 triangles index them.
const BOX_TRIANGLES: [[usize; 3]; 12] = [
    [0, 2, 1],
    [1, 2, 3],
    [4, 5, 6],
    [5, 7, 6],
    [0, 1, 4],
    [1, 5, 4],
    [2, 6, 3],
    [3, 6, 7],
    [0, 4, 2],
    [2, 4, 6],
    [1, 3, 5],
    [3, 7, 5],
];

/// The triangulated surfaces of the boxes in `obstacle` (members of groups included) at
/// time `t`, appended to `out`.
fn box_meshes(
    obstacle: &Obstacle,
    t: f64,
    parent: &nalgebra::Isometry3<f64>,
    out: &mut Vec<MeshObstacle>,
) {
    let pose = parent * obstacle.pose_at(t);
    match &obstacle.shape {
        Shape::Cuboid(c) => {
            let (center, half, rotation) = c.placement();
            let positions = (0..8)
                .map(|k| {
                    let s = Vector3::new(
                        if k & 1 == 0 { -1.0 } else { 1.0 },
                        if k & 2 == 0 { -1.0 } else { 1.0 },
                        if k & 4 == 0 { -1.0 } else { 1.0 },
                    );
                    let local = center + rotation * half.component_mul(&s);
                    (pose * Point3::from(local)).coords
                })
                .collect();
            out.push(MeshObstacle {
                positions,
                triangles: BOX_TRIANGLES.to_vec(),
            });
        }
        Shape::Group(members) => {
            for m in members {
                box_meshes(m, t, &pose, out);
            }
        }
        _ => {}
    }
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
            box_meshes(o, t, &nalgebra::Isometry3::identity(), &mut boxes);
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
