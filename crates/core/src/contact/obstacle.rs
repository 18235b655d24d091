//! Obstacles: a shape placed by a rigid transform, optionally moving along a [`Path`]; groups
//! of obstacles (their union: the minimum distance); and [`Obstacles`], a scene's set.

use super::mesh_obstacle::MeshObstacle;
use super::path::Path;
use super::sdf::{Sdf, SdfValue};
use super::{Capsule, Cuboid, HalfSpace, Sphere};
use crate::parallel::{ThreadCount, add_to_thread_count, thread_count};
use nalgebra::{Isometry3, Point3, Translation3, Vector3};

/// How many obstacle queries the current thread has made (each [`Obstacle::sample`] and
/// [`Obstacle::for_each_piece`] call counts one). Contact code runs in the step of the thread
/// that steps the integrator (or on the pool thread it moved to, whose count is added back:
/// [`crate::parallel::counted_on_pool`]), so this tells whether a run touched any contact code.
pub fn query_count() -> u64 {
    thread_count(ThreadCount::ObstacleQueries)
}

fn count_query() {
    add_to_thread_count(ThreadCount::ObstacleQueries, 1);
}

/// What an obstacle is made of. One variant per shape file, plus groups.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    HalfSpace(HalfSpace),
    Sphere(Sphere),
    Cuboid(Cuboid),
    Capsule(Capsule),
    /// The union of the member obstacles (each with its own transform and path, relative to
    /// the group's frame): the minimum of their distances.
    Group(Vec<Obstacle>),
}

/// An obstacle at a point and time, in world coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObstacleSample {
    /// Signed distance with gradient (the outward normal) and Hessian.
    pub sdf: SdfValue,
    /// Velocity of the obstacle's material at the point (m/s), from its path.
    pub velocity: Vector3<f64>,
}

/// A shape placed in the world by `transform` and then translated along `path`:
/// `x_world = path.offset(t) + transform * x_shape`.
#[derive(Clone, Debug, PartialEq)]
pub struct Obstacle {
    pub shape: Shape,
    pub transform: Isometry3<f64>,
    pub path: Option<Path>,
}

impl Obstacle {
    /// A still obstacle with its shape in world coordinates.
    pub fn new(shape: Shape) -> Self {
        Self {
            shape,
            transform: Isometry3::identity(),
            path: None,
        }
    }

    /// The same obstacle placed by `transform`.
    pub fn with_transform(mut self, transform: Isometry3<f64>) -> Self {
        self.transform = transform;
        self
    }

    /// The same obstacle moving along `path`.
    pub fn with_path(mut self, path: Path) -> Self {
        self.path = Some(path);
        self
    }

    /// The rigid motion from the shape's frame to its parent's at time `t`, and the frame's
    /// velocity in the parent.
    fn pose(&self, t: f64) -> (Isometry3<f64>, Vector3<f64>) {
        match &self.path {
            Some(path) => (
                Translation3::from(path.offset(t)) * self.transform,
                path.velocity(t),
            ),
            None => (self.transform, Vector3::zeros()),
        }
    }

    /// Whether no member of the obstacle has a path of its own (its own path may move it
    /// as one translation).
    pub fn is_static_apart_from_its_path(&self) -> bool {
        match &self.shape {
            Shape::Group(members) => members.iter().all(Obstacle::is_static),
            _ => true,
        }
    }

    /// Whether the obstacle and every member of it stand still (no path anywhere).
    pub fn is_static(&self) -> bool {
        self.path.is_none()
            && match &self.shape {
                Shape::Group(members) => members.iter().all(Obstacle::is_static),
                _ => true,
            }
    }

    /// The boxes of this obstacle (members of groups included) at time `t` as closed
    /// triangle meshes (12 triangles each, wound outward), appended to `out`.
    pub fn box_meshes(&self, t: f64, out: &mut Vec<MeshObstacle>) {
        self.box_meshes_in(t, &Isometry3::identity(), out);
    }

    fn box_meshes_in(&self, t: f64, parent: &Isometry3<f64>, out: &mut Vec<MeshObstacle>) {
        let pose = parent * self.pose(t).0;
        match &self.shape {
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
                    m.box_meshes_in(t, &pose, out);
                }
            }
            _ => {}
        }
    }

    /// The obstacle without its boxes (`None` if nothing else is left): what remains a
    /// signed distance once the boxes are triangle meshes.
    pub fn without_boxes(&self) -> Option<Obstacle> {
        match &self.shape {
            Shape::Cuboid(_) => None,
            Shape::Group(members) => {
                let rest: Vec<Obstacle> =
                    members.iter().filter_map(Obstacle::without_boxes).collect();
                (!rest.is_empty()).then(|| Obstacle {
                    shape: Shape::Group(rest),
                    transform: self.transform,
                    path: self.path.clone(),
                })
            }
            _ => Some(self.clone()),
        }
    }

    /// The signed distance to this obstacle (a group: the nearest member) at `p`, time `t`.
    pub fn sample(&self, p: &Vector3<f64>, t: f64) -> ObstacleSample {
        count_query();
        let mut nearest: Option<ObstacleSample> = None;
        self.visit(p, t, &mut |_, s| {
            if nearest.is_none_or(|n| s.sdf.distance < n.sdf.distance) {
                nearest = Some(s);
            }
        });
        nearest.unwrap_or(ObstacleSample {
            sdf: SdfValue::flat(f64::INFINITY, Vector3::y()),
            velocity: Vector3::zeros(),
        })
    }

    /// Call `f(piece, sample)` for each convex piece (each shape that is not a group, numbered
    /// depth-first from 0) at `p`, time `t`. A point is outside the obstacle exactly when it
    /// is outside every piece; each piece's distance is convex in `p`.
    pub fn for_each_piece(
        &self,
        p: &Vector3<f64>,
        t: f64,
        f: &mut dyn FnMut(usize, ObstacleSample),
    ) {
        count_query();
        self.visit(p, t, f);
    }

    fn visit(&self, p: &Vector3<f64>, t: f64, f: &mut dyn FnMut(usize, ObstacleSample)) {
        let mut next = 0;
        self.visit_from(p, t, &mut next, f);
    }

    fn visit_from(
        &self,
        p: &Vector3<f64>,
        t: f64,
        next: &mut usize,
        f: &mut dyn FnMut(usize, ObstacleSample),
    ) {
        let (pose, velocity) = self.pose(t);
        let local = pose.inverse_transform_point(&Point3::from(*p)).coords;
        let r = pose.rotation.to_rotation_matrix().into_inner();
        let mut emit = |sdf: SdfValue| {
            let s = ObstacleSample {
                sdf: sdf.rotated(&r),
                velocity,
            };
            f(*next, s);
            *next += 1;
        };
        match &self.shape {
            Shape::HalfSpace(s) => emit(s.eval(&local)),
            Shape::Sphere(s) => emit(s.eval(&local)),
            Shape::Cuboid(s) => emit(s.eval(&local)),
            Shape::Capsule(s) => emit(s.eval(&local)),
            Shape::Group(members) => {
                for m in members {
                    m.visit_from(&local, t, next, &mut |piece, s| {
                        f(
                            piece,
                            ObstacleSample {
                                sdf: s.sdf.rotated(&r),
                                velocity: velocity + r * s.velocity,
                            },
                        );
                    });
                }
            }
        }
    }
}

/// A box's corners (bit k of the index: the sign along axis k) in the order its 12
/// triangles, wound outward, index them.
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

/// The obstacles of a scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Obstacles {
    list: Vec<Obstacle>,
}

/// Contacts of a configuration.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ContactStats {
    /// (vertex, obstacle) pairs closer than the contact margin (or inside).
    pub contacts: u32,
    /// The deepest penetration, `max(0, -min sdf)` (m).
    pub max_penetration: f64,
}

impl Obstacles {
    pub fn new(list: Vec<Obstacle>) -> Self {
        Self { list }
    }

    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    pub fn len(&self) -> usize {
        self.list.len()
    }

    pub fn iter(&self) -> std::slice::Iter<'_, Obstacle> {
        self.list.iter()
    }

    /// The signed distance to the nearest obstacle (+inf with no obstacles).
    pub fn distance(&self, p: &Vector3<f64>, t: f64) -> f64 {
        self.list
            .iter()
            .map(|o| o.sample(p, t).sdf.distance)
            .fold(f64::INFINITY, f64::min)
    }

    /// Contacts of the free vertices at stacked positions `q` (see [`crate::model::DofMap`])
    /// at time `t`: pairs within `margin`, and the deepest penetration.
    pub fn stats(&self, q: &[f64], t: f64, margin: f64) -> ContactStats {
        let mut stats = ContactStats::default();
        for x in q.chunks_exact(3) {
            let p = Vector3::new(x[0], x[1], x[2]);
            for o in &self.list {
                let d = o.sample(&p, t).sdf.distance;
                if d <= margin {
                    stats.contacts += 1;
                }
                stats.max_penetration = stats.max_penetration.max(-d);
            }
        }
        stats
    }
}

impl FromIterator<Obstacle> for Obstacles {
    fn from_iter<I: IntoIterator<Item = Obstacle>>(iter: I) -> Self {
        Self::new(iter.into_iter().collect())
    }
}
