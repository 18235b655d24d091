//! The active contacts of a configuration and the barrier's value and derivatives on each.
//!
//! A contact is a vertex–triangle or edge–edge pair of collision primitives closer than d̂,
//! or a body surface vertex closer than d̂ to a convex piece of an analytic obstacle. Every
//! such pair contributes `κ b(d²)` (edge–edge pairs times IPC's mollifier, which vanishes
//! smoothly as the edges become parallel): the pairs are not deduplicated across shared
//! features, as in the original IPC formulation. Candidates come from the broad phase
//! (near-linear in the surface size), distances from [`super::distance`].

use super::barrier::BarrierKind;
use super::collision_mesh::CollisionMesh;
use super::distance::{
    Mat12, Vec12, edge_edge_distance_derivatives, edge_edge_distance_squared, edge_edge_mollifier,
    point_triangle_distance_derivatives, point_triangle_distance_squared,
};
use crate::contact::broad_phase::{Aabb, BroadPhase};
use crate::contact::obstacle::{ObstacleSample, Obstacles};
use nalgebra::{Matrix3, Vector3};

/// One pair closer than d̂.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Contact {
    /// A vertex and a triangle: `[p, t0, t1, t2]` (collision vertex ids).
    PointTriangle([u32; 4], f64),
    /// Two edges `[a0, a1, b0, b1]` with the mollifier threshold ε_x.
    EdgeEdge([u32; 4], f64, f64),
    /// A body vertex near a convex piece of an analytic obstacle (the sample at the vertex).
    PointObstacle(u32, ObstacleSample),
}

impl Contact {
    /// The squared distance of the pair (as found).
    pub fn distance_squared(&self) -> f64 {
        match *self {
            Self::PointTriangle(_, s) | Self::EdgeEdge(_, _, s) => s,
            Self::PointObstacle(_, o) => o.sdf.distance * o.sdf.distance,
        }
    }
}

/// A contact's barrier term on its stencil: the vertices (the first `count` of `vertices`),
/// value, gradient and Hessian over their stacked coordinates.
pub struct Local {
    pub vertices: [u32; 4],
    pub count: usize,
    pub value: f64,
    pub gradient: Vec12,
    pub hessian: Mat12,
}

/// Reusable buffers of the contact search.
#[derive(Debug, Default)]
pub struct Scratch {
    broad: BroadPhase,
    vertex_boxes: Vec<Aabb>,
    edge_boxes: Vec<Aabb>,
    face_boxes: Vec<Aabb>,
    pairs: Vec<(u32, u32)>,
    /// The contacts of the last [`find`].
    pub contacts: Vec<Contact>,
}

/// What the search needs to know besides positions.
pub struct Search<'a> {
    pub mesh: &'a CollisionMesh,
    pub obstacles: &'a Obstacles,
    pub dhat: f64,
    pub self_contact: bool,
}

/// Find every contact at body positions `x` and time `t` into `scratch.contacts`. Returns
/// `false` if some pair touches or crosses (distance 0 or a vertex inside an obstacle): the
/// configuration is not admissible.
pub fn find(search: &Search<'_>, x: &[Vector3<f64>], t: f64, scratch: &mut Scratch) -> bool {
    let Search {
        mesh,
        obstacles,
        dhat,
        self_contact,
    } = *search;
    let s_hat = dhat * dhat;
    let mut admissible = true;
    scratch.contacts.clear();
    mesh.boxes(
        x,
        dhat,
        &mut scratch.vertex_boxes,
        &mut scratch.edge_boxes,
        &mut scratch.face_boxes,
    );
    let p = |v: u32| mesh.position(x, v);
    scratch.broad.pairs(
        &scratch.vertex_boxes,
        &scratch.face_boxes,
        &mut scratch.pairs,
    );
    for &(i, f) in &scratch.pairs {
        let v = mesh.vertices[i as usize];
        let face = mesh.faces[f as usize];
        if !mesh.pair_counts(&[v], &face, self_contact) {
            continue;
        }
        let s = point_triangle_distance_squared(&p(v), &p(face[0]), &p(face[1]), &p(face[2]));
        if s < s_hat {
            admissible &= s > 0.0;
            scratch
                .contacts
                .push(Contact::PointTriangle([v, face[0], face[1], face[2]], s));
        }
    }
    scratch
        .broad
        .self_pairs(&scratch.edge_boxes, &mut scratch.pairs);
    for &(i, j) in &scratch.pairs {
        let (ea, eb) = (mesh.edges[i as usize], mesh.edges[j as usize]);
        if !mesh.pair_counts(&ea, &eb, self_contact) {
            continue;
        }
        let s = edge_edge_distance_squared(&p(ea[0]), &p(ea[1]), &p(eb[0]), &p(eb[1]));
        if s < s_hat {
            admissible &= s > 0.0;
            let eps_x =
                1e-3 * mesh.edge_rest_length2[i as usize] * mesh.edge_rest_length2[j as usize];
            scratch
                .contacts
                .push(Contact::EdgeEdge([ea[0], ea[1], eb[0], eb[1]], eps_x, s));
        }
    }
    if !obstacles.is_empty() {
        for &v in mesh.vertices.iter().filter(|&&v| !mesh.is_obstacle(v)) {
            let at = x[v as usize];
            for o in obstacles.iter() {
                o.for_each_piece(&at, t, &mut |_, sample| {
                    if sample.sdf.distance < dhat {
                        admissible &= sample.sdf.distance > 0.0;
                        scratch.contacts.push(Contact::PointObstacle(v, sample));
                    }
                });
            }
        }
    }
    admissible
}

/// The barrier term `b` (κ = 1) of `contact` at body positions `x`, with its derivatives
/// when `order >= 1` (gradient) and `2` (Hessian).
pub fn local(
    contact: &Contact,
    mesh: &CollisionMesh,
    x: &[Vector3<f64>],
    barrier: BarrierKind,
    s_hat: f64,
    order: u8,
) -> Local {
    let p = |v: u32| mesh.position(x, v);
    let mut out = Local {
        vertices: [0; 4],
        count: 4,
        value: 0.0,
        gradient: Vec12::zeros(),
        hessian: Mat12::zeros(),
    };
    match *contact {
        Contact::PointTriangle(v, _) => {
            out.vertices = v;
            let (s, g, h) =
                point_triangle_distance_derivatives(&p(v[0]), &p(v[1]), &p(v[2]), &p(v[3]));
            chain(&mut out, barrier, s, s_hat, &g, &h, order);
        }
        Contact::EdgeEdge(v, eps_x, _) => {
            out.vertices = v;
            let (a0, a1, b0, b1) = (p(v[0]), p(v[1]), p(v[2]), p(v[3]));
            let (s, g, h) = edge_edge_distance_derivatives(&a0, &a1, &b0, &b1);
            let (m, gm, hm) = edge_edge_mollifier(&a0, &a1, &b0, &b1, eps_x);
            chain(&mut out, barrier, s, s_hat, &g, &h, order);
            if m < 1.0 {
                // (m b)'' = m b'' + b m'' + b' m'^T + m' b'^T
                let (b, gb) = (out.value, out.gradient);
                if order >= 2 {
                    out.hessian =
                        out.hessian * m + hm * b + gb * gm.transpose() + gm * gb.transpose();
                }
                out.gradient = gb * m + gm * b;
                out.value = m * b;
            }
        }
        Contact::PointObstacle(v, sample) => {
            out.vertices[0] = v;
            out.count = 1;
            let d = sample.sdf.distance;
            let n = sample.sdf.gradient;
            let s = d * d;
            out.value = barrier.value(s, s_hat);
            if order >= 1 {
                let b1 = barrier.first_derivative(s, s_hat);
                let gs = n * (2.0 * d);
                out.gradient.fixed_rows_mut::<3>(0).copy_from(&(gs * b1));
                if order >= 2 {
                    let b2 = barrier.second_derivative(s, s_hat);
                    let hs: Matrix3<f64> = (n * n.transpose() + sample.sdf.hessian * d) * 2.0;
                    let h = gs * gs.transpose() * b2 + hs * b1;
                    out.hessian.fixed_view_mut::<3, 3>(0, 0).copy_from(&h);
                }
            }
        }
    }
    out
}

/// `b(s)` and its derivatives through `s`'s gradient `g` and Hessian `h`.
fn chain(
    out: &mut Local,
    barrier: BarrierKind,
    s: f64,
    s_hat: f64,
    g: &Vec12,
    h: &Mat12,
    order: u8,
) {
    out.value = barrier.value(s, s_hat);
    if order >= 1 {
        let b1 = barrier.first_derivative(s, s_hat);
        out.gradient = g * b1;
        if order >= 2 {
            let b2 = barrier.second_derivative(s, s_hat);
            out.hessian = g * g.transpose() * b2 + h * b1;
        }
    }
}
