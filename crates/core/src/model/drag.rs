//! Scripted drag: the course handout's mouse drag as a script. The vertices nearest a point
//! are picked once, and each is pulled by a zero-rest-length spring towards a target that
//! moves along a path, until the drag is released.
//!
//! The target of picked vertex `v` at time `t` is its *rest* position plus the path's offset,
//! `X_v + o(t)`, so a picked patch keeps its shape while it is dragged (targets at one common
//! point would pull the patch together). The energy is `sum_v k/2 |x_v − X_v − o(t)|²` while
//! `t < release` and 0 from `release` on; gradient `k (x_v − X_v − o(t))`, Hessian `k I` per
//! picked vertex, so implicit methods see the drag. It lives in `model/` beside the
//! [`VertexPotential`] trait because it acts on any body — FEM or mass-spring — like gravity.
//!
//! The course's drag differs in one way: there the target is recomputed each step from the
//! vertex's *current* position plus the mouse offset, so the pull never settles. A script
//! needs a target fixed in space to be reproducible.

use super::{ModelError, VertexPotential};
use nalgebra::{Matrix3, Vector3};

fn invalid(field: &str, value: impl std::fmt::Display, expected: &str) -> ModelError {
    ModelError::InvalidParameter {
        field: field.into(),
        value: value.to_string(),
        expected: expected.into(),
    }
}

/// A point of a drag path: at time `t` (s) the target is offset by `offset` (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Waypoint {
    pub t: f64,
    pub offset: Vector3<f64>,
}

/// A piecewise-linear offset over time through waypoints with increasing times. Before the
/// first waypoint the offset is the first one's, after the last it stays at the last one's.
#[derive(Clone, Debug, PartialEq)]
pub struct DragPath {
    waypoints: Vec<Waypoint>,
}

impl DragPath {
    /// A path through `waypoints`: at least one, finite, times strictly increasing.
    pub fn new(waypoints: Vec<Waypoint>) -> Result<Self, ModelError> {
        if waypoints.is_empty() {
            return Err(invalid("drag.path", "[]", "at least one waypoint"));
        }
        for (i, w) in waypoints.iter().enumerate() {
            if !(w.t.is_finite() && w.offset.iter().all(|c| c.is_finite())) {
                return Err(invalid(
                    &format!("drag.path[{i}]"),
                    format!("t = {}, offset = {:?}", w.t, w.offset.as_slice()),
                    "a finite time and offset",
                ));
            }
            if i > 0 && w.t <= waypoints[i - 1].t {
                return Err(invalid(
                    &format!("drag.path[{i}].t"),
                    w.t,
                    &format!("times increasing (after {})", waypoints[i - 1].t),
                ));
            }
        }
        Ok(Self { waypoints })
    }

    /// The waypoints.
    pub fn waypoints(&self) -> &[Waypoint] {
        &self.waypoints
    }

    /// The offset at time `t`.
    pub fn offset(&self, t: f64) -> Vector3<f64> {
        let w = &self.waypoints;
        let next = w.partition_point(|p| p.t <= t);
        if next == 0 {
            return w[0].offset;
        }
        if next == w.len() {
            return w[w.len() - 1].offset;
        }
        let (a, b) = (&w[next - 1], &w[next]);
        let s = (t - a.t) / (b.t - a.t);
        a.offset + (b.offset - a.offset) * s
    }
}

/// Picked vertices pulled towards moving targets (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Drag {
    vertices: Vec<usize>,
    anchors: Vec<Vector3<f64>>,
    stiffness: f64,
    path: DragPath,
    release: f64,
}

impl Drag {
    /// The vertices within `radius` of `point` (by `positions`), in increasing index order;
    /// if none is, the single nearest vertex (the lowest index among equally near ones).
    /// Empty only when `positions` is.
    pub fn pick(positions: &[Vector3<f64>], point: &Vector3<f64>, radius: f64) -> Vec<usize> {
        let within: Vec<usize> = positions
            .iter()
            .enumerate()
            .filter(|(_, p)| (*p - point).norm() <= radius)
            .map(|(v, _)| v)
            .collect();
        if !within.is_empty() {
            return within;
        }
        positions
            .iter()
            .map(|p| (p - point).norm_squared())
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(v, _)| vec![v])
            .unwrap_or_default()
    }

    /// A drag of `vertices` (anchored at their `rest_positions`) with spring stiffness
    /// `stiffness` (N/m, >= 0) along `path`, released at time `release` (`None`: never).
    pub fn new(
        rest_positions: &[Vector3<f64>],
        vertices: Vec<usize>,
        stiffness: f64,
        path: DragPath,
        release: Option<f64>,
    ) -> Result<Self, ModelError> {
        if vertices.is_empty() {
            return Err(invalid("drag.vertices", "[]", "at least one vertex"));
        }
        if let Some(&v) = vertices.iter().find(|&&v| v >= rest_positions.len()) {
            return Err(invalid(
                "drag.vertices",
                v,
                &format!("vertex indices below {}", rest_positions.len()),
            ));
        }
        if !(stiffness.is_finite() && stiffness >= 0.0) {
            return Err(invalid(
                "drag.stiffness",
                stiffness,
                "a finite stiffness >= 0 (N/m)",
            ));
        }
        let release = release.unwrap_or(f64::INFINITY);
        if release.is_nan() {
            return Err(invalid("drag.release", release, "a time in seconds"));
        }
        let anchors = vertices.iter().map(|&v| rest_positions[v]).collect();
        Ok(Self {
            vertices,
            anchors,
            stiffness,
            path,
            release,
        })
    }

    /// The picked vertices.
    pub fn vertices(&self) -> &[usize] {
        &self.vertices
    }

    /// The spring stiffness (N/m).
    pub fn stiffness(&self) -> f64 {
        self.stiffness
    }

    /// The path of the offset.
    pub fn path(&self) -> &DragPath {
        &self.path
    }

    /// The release time (s); infinite if never released.
    pub fn release(&self) -> f64 {
        self.release
    }

    /// Whether the springs pull at time `t` (`t < release`).
    pub fn is_active(&self, t: f64) -> bool {
        t < self.release
    }

    /// The target of the `k`-th picked vertex at time `t`: its rest position plus the offset.
    pub fn target(&self, k: usize, t: f64) -> Vector3<f64> {
        self.anchors[k] + self.path.offset(t)
    }
}

impl VertexPotential for Drag {
    fn name(&self) -> &str {
        "drag"
    }

    fn energy(&self, t: f64, x: &[Vector3<f64>]) -> f64 {
        if !self.is_active(t) {
            return 0.0;
        }
        let offset = self.path.offset(t);
        self.vertices
            .iter()
            .zip(&self.anchors)
            .map(|(&v, a)| 0.5 * self.stiffness * (x[v] - a - offset).norm_squared())
            .sum()
    }

    fn gradient(&self, t: f64, x: &[Vector3<f64>], add: &mut dyn FnMut(usize, Vector3<f64>)) {
        if !self.is_active(t) {
            return;
        }
        let offset = self.path.offset(t);
        for (&v, a) in self.vertices.iter().zip(&self.anchors) {
            add(v, (x[v] - a - offset) * self.stiffness);
        }
    }

    fn hessian(
        &self,
        t: f64,
        _x: &[Vector3<f64>],
        _project: bool,
        add: &mut dyn FnMut(usize, Matrix3<f64>),
    ) {
        if !self.is_active(t) {
            return;
        }
        for &v in &self.vertices {
            add(v, Matrix3::identity() * self.stiffness);
        }
    }

    fn anchors(&self, t: f64, add: &mut dyn FnMut(usize, f64, Vector3<f64>)) -> bool {
        if self.is_active(t) {
            let offset = self.path.offset(t);
            for (&v, a) in self.vertices.iter().zip(&self.anchors) {
                add(v, self.stiffness, a + offset);
            }
        }
        true
    }
}
