//! Obstacles as triangles at a time, for pictures: spheres and capsules as latitude-longitude
//! meshes, cuboids as boxes, a half-space as a square of its plane around the body.

use nalgebra::{Isometry3, Point3, Translation3, Vector3};

use super::snapshots::P3;
use softbench_core::contact::{Obstacle, Obstacles, Shape};

/// Segments around a sphere or capsule (and half as many from pole to pole).
const AROUND: usize = 24;

/// The obstacles at time `t` as triangles; a half-space becomes a square of side
/// `4 * size` centred under `center` (the body's box), so a ground shows without framing the
/// infinite plane.
pub fn tessellate(obstacles: &Obstacles, t: f64, center: Vector3<f64>, size: f64) -> Vec<[P3; 3]> {
    let mut out = Vec::new();
    for o in obstacles.iter() {
        add(o, &Isometry3::identity(), t, center, size, &mut out);
    }
    out
}

fn add(
    o: &Obstacle,
    parent: &Isometry3<f64>,
    t: f64,
    center: Vector3<f64>,
    size: f64,
    out: &mut Vec<[P3; 3]>,
) {
    let pose = match &o.path {
        Some(path) => parent * Translation3::from(path.offset(t)) * o.transform,
        None => parent * o.transform,
    };
    let mut push = |tri: [Vector3<f64>; 3]| {
        out.push(tri.map(|p| {
            let w = pose.transform_point(&Point3::from(p)).coords;
            [w.x as f32, w.y as f32, w.z as f32]
        }));
    };
    match &o.shape {
        Shape::HalfSpace(h) => {
            let n = h.normal();
            let local_center = pose.inverse_transform_point(&Point3::from(center)).coords;
            let foot = local_center - n * n.dot(&(local_center - h.point()));
            let seed = if n.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::z()
            };
            let u = n.cross(&seed).normalize() * 2.0 * size;
            let v = n.cross(&u);
            let c = [foot - u - v, foot + u - v, foot + u + v, foot - u + v];
            push([c[0], c[2], c[1]]);
            push([c[0], c[3], c[2]]);
        }
        Shape::Sphere(s) => {
            let (c, r) = s.center_radius();
            sphere_like(&mut push, |d| c + d * r);
        }
        Shape::Capsule(s) => {
            let (a, b, r) = s.axis_radius();
            let axis = b - a;
            let len = axis.norm();
            let z = if len > 0.0 { axis / len } else { Vector3::z() };
            let seed = if z.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            let x = z.cross(&seed).normalize();
            let y = z.cross(&x);
            sphere_like(&mut push, |d| {
                let end = if d.z >= 0.0 { b } else { a };
                end + (x * d.x + y * d.y + z * d.z) * r
            });
        }
        Shape::Cuboid(s) => {
            let (c, half, rot) = s.placement();
            let corner = |i: usize| {
                let l = Vector3::new(
                    if i & 1 == 0 { -half.x } else { half.x },
                    if i & 2 == 0 { -half.y } else { half.y },
                    if i & 4 == 0 { -half.z } else { half.z },
                );
                c + rot * l
            };
            const FACES: [[usize; 4]; 6] = [
                [0, 2, 3, 1],
                [4, 5, 7, 6],
                [0, 1, 5, 4],
                [2, 6, 7, 3],
                [0, 4, 6, 2],
                [1, 3, 7, 5],
            ];
            for f in FACES {
                push([corner(f[0]), corner(f[1]), corner(f[2])]);
                push([corner(f[0]), corner(f[2]), corner(f[3])]);
            }
        }
        Shape::Group(members) => {
            for m in members {
                add(m, &pose, t, center, size, out);
            }
        }
    }
}

/// A latitude-longitude sphere: `place` maps each unit direction to a point.
fn sphere_like(
    push: &mut impl FnMut([Vector3<f64>; 3]),
    place: impl Fn(Vector3<f64>) -> Vector3<f64>,
) {
    let rings = AROUND / 2;
    let dir = |i: usize, j: usize| {
        let theta = std::f64::consts::PI * i as f64 / rings as f64;
        let phi = 2.0 * std::f64::consts::PI * j as f64 / AROUND as f64;
        Vector3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    };
    for i in 0..rings {
        for j in 0..AROUND {
            let (a, b, c, d) = (dir(i, j), dir(i + 1, j), dir(i + 1, j + 1), dir(i, j + 1));
            if i > 0 {
                push([place(a), place(b), place(d)]);
            }
            if i + 1 < rings {
                push([place(b), place(c), place(d)]);
            }
        }
    }
}
