//! The primitives contact is computed between: the body's boundary surface (its vertices,
//! edges and triangles, by model vertex index) and static triangle-mesh obstacles, whose
//! vertices are numbered after the body's (`num_body + k`) and never move.

use crate::contact::broad_phase::Aabb;
use nalgebra::Vector3;

use crate::contact::mesh_obstacle::MeshObstacle;

/// Surface vertices, edges and triangles of the body and of the mesh obstacles.
#[derive(Clone, Debug, Default)]
pub struct CollisionMesh {
    /// Vertices of the body (the model's); indices at or above are obstacle vertices.
    num_body: usize,
    /// Positions of the obstacle vertices (index `num_body + k`).
    obstacle_positions: Vec<Vector3<f64>>,
    /// Collision vertices: the body's surface vertices, then every obstacle vertex.
    pub vertices: Vec<u32>,
    /// Unique edges of every triangle.
    pub edges: Vec<[u32; 2]>,
    /// Squared rest length of each edge (the edge–edge mollifier's scale).
    pub edge_rest_length2: Vec<f64>,
    /// The body's boundary triangles, then the obstacles'.
    pub faces: Vec<[u32; 3]>,
}

impl CollisionMesh {
    /// From the body's boundary triangles over `rest` (its vertex positions) and the mesh
    /// obstacles.
    pub fn new(rest: &[Vector3<f64>], surface: &[[usize; 3]], obstacles: &[MeshObstacle]) -> Self {
        let num_body = rest.len();
        let mut faces: Vec<[u32; 3]> = surface
            .iter()
            .map(|f| f.map(|v| u32::try_from(v).expect("vertex index fits u32")))
            .collect();
        let mut obstacle_positions = Vec::new();
        for o in obstacles {
            let offset = num_body + obstacle_positions.len();
            faces.extend(o.triangles.iter().map(|f| f.map(|v| (offset + v) as u32)));
            obstacle_positions.extend_from_slice(&o.positions);
        }
        let mut edges: Vec<[u32; 2]> = faces
            .iter()
            .flat_map(|f| [[f[0], f[1]], [f[1], f[2]], [f[2], f[0]]])
            .map(|[a, b]| [a.min(b), a.max(b)])
            .collect();
        edges.sort_unstable();
        edges.dedup();
        let mut vertices: Vec<u32> = faces.iter().flatten().copied().collect();
        vertices.sort_unstable();
        vertices.dedup();
        let mut mesh = Self {
            num_body,
            obstacle_positions,
            vertices,
            edges,
            edge_rest_length2: Vec::new(),
            faces,
        };
        mesh.edge_rest_length2 = mesh
            .edges
            .iter()
            .map(|&[a, b]| (mesh.position(rest, a) - mesh.position(rest, b)).norm_squared())
            .collect();
        mesh
    }

    /// Positions of the obstacle vertices (collision vertex `num_body + k` is the `k`-th).
    pub fn obstacle_positions(&self) -> &[Vector3<f64>] {
        &self.obstacle_positions
    }

    /// Whether collision vertex `v` belongs to an obstacle (never moves, has no DOF).
    #[inline]
    pub fn is_obstacle(&self, v: u32) -> bool {
        v as usize >= self.num_body
    }

    /// The position of collision vertex `v` given the body's positions `x`.
    #[inline]
    pub fn position(&self, x: &[Vector3<f64>], v: u32) -> Vector3<f64> {
        match x.get(v as usize) {
            Some(p) if (v as usize) < self.num_body => *p,
            _ => self.obstacle_positions[v as usize - self.num_body],
        }
    }

    /// Bounding boxes of vertices, edges and faces at `x`, vertices inflated by `r`, edges
    /// by `r / 2`, faces not at all (a vertex–face or edge–edge pair within `r` overlaps).
    pub fn boxes(
        &self,
        x: &[Vector3<f64>],
        r: f64,
        vertices: &mut Vec<Aabb>,
        edges: &mut Vec<Aabb>,
        faces: &mut Vec<Aabb>,
    ) {
        let p = |v: u32| self.position(x, v);
        vertices.clear();
        vertices.extend(self.vertices.iter().map(|&v| Aabb::point(p(v)).inflate(r)));
        edges.clear();
        edges.extend(
            self.edges
                .iter()
                .map(|&[a, b]| Aabb::point(p(a)).union(Aabb::point(p(b))).inflate(0.5 * r)),
        );
        faces.clear();
        faces.extend(self.faces.iter().map(|f| {
            Aabb::point(p(f[0]))
                .union(Aabb::point(p(f[1])))
                .union(Aabb::point(p(f[2])))
        }));
    }

    /// Swept boxes of the motion from `x` by `dx` (obstacle vertices do not move), each
    /// inflated by `r`.
    pub fn swept_boxes(
        &self,
        x: &[Vector3<f64>],
        dx: &[Vector3<f64>],
        r: f64,
        vertices: &mut Vec<Aabb>,
        edges: &mut Vec<Aabb>,
        faces: &mut Vec<Aabb>,
    ) {
        let swept = |v: u32| {
            let d = if self.is_obstacle(v) {
                Vector3::zeros()
            } else {
                dx[v as usize]
            };
            Aabb::swept(self.position(x, v), d)
        };
        vertices.clear();
        vertices.extend(self.vertices.iter().map(|&v| swept(v).inflate(r)));
        edges.clear();
        edges.extend(
            self.edges
                .iter()
                .map(|&[a, b]| swept(a).union(swept(b)).inflate(r)),
        );
        faces.clear();
        faces.extend(
            self.faces
                .iter()
                .map(|f| swept(f[0]).union(swept(f[1])).union(swept(f[2])).inflate(r)),
        );
    }

    /// Whether a vertex–face or edge–edge pair between these vertex sets is one contact is
    /// computed for: no shared vertex, not both on obstacles, and body–body only with
    /// self-contact.
    pub fn pair_counts(&self, a: &[u32], b: &[u32], self_contact: bool) -> bool {
        if a.iter().any(|v| b.contains(v)) {
            return false;
        }
        let obstacle_a = a.iter().all(|&v| self.is_obstacle(v));
        let obstacle_b = b.iter().all(|&v| self.is_obstacle(v));
        let body_a = a.iter().all(|&v| !self.is_obstacle(v));
        let body_b = b.iter().all(|&v| !self.is_obstacle(v));
        if obstacle_a && obstacle_b {
            return false;
        }
        self_contact || !(body_a && body_b)
    }
}
