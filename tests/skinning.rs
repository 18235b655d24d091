//! Skinning a display mesh onto a tet mesh: exact at rest and for affine deformations; vertices
//! outside the tet mesh bind to the closest point of the nearest tet.

mod common;

use common::reference_mesh;
use nalgebra::{Matrix3, Vector3};
use softbench::mesh::{
    Skinning, SkinningError, TetMesh, box_mesh, read_surface_mesh, read_tet_mesh,
};
use softbench::rng::Rng;

/// A random, well-conditioned affine map `x -> A x + b`.
fn random_affine(seed: u64) -> (Matrix3<f64>, Vector3<f64>) {
    let mut rng = Rng::new(seed);
    let a = Matrix3::identity() + Matrix3::from_fn(|_, _| rng.range(-0.4, 0.4));
    let b = Vector3::from_fn(|_, _| rng.range(-2.0, 2.0));
    (a, b)
}

fn diagonal(points: &[Vector3<f64>]) -> f64 {
    let (lo, hi) = softbench::mesh::bounding_box(points).unwrap();
    (hi - lo).norm()
}

fn max_error(a: &[Vector3<f64>], b: &[Vector3<f64>]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(p, q)| (p - q).norm())
        .fold(0.0, f64::max)
}

/// Distance from `p` to the tet mesh by brute force: 0 inside a tet, else the smallest
/// distance to a boundary-or-interior face (sampled densely enough is not needed: faces are
/// triangles, so use the closest point of each triangle by projection and clamping).
fn brute_force_distance(mesh: &TetMesh, p: &Vector3<f64>) -> f64 {
    let mut best = f64::INFINITY;
    for tet in &mesh.tets {
        let x = tet.map(|v| mesh.positions[v]);
        for face in softbench::mesh::surface::TET_FACES {
            best = best.min(point_triangle_distance(
                p, x[face[0]], x[face[1]], x[face[2]],
            ));
        }
    }
    best
}

/// Point-triangle distance by minimizing over a fine parameter grid plus the exact plane
/// projection when it falls inside: independent of the library's Voronoi-region code.
fn point_triangle_distance(
    p: &Vector3<f64>,
    a: Vector3<f64>,
    b: Vector3<f64>,
    c: Vector3<f64>,
) -> f64 {
    let n = (b - a).cross(&(c - a));
    let mut best = f64::INFINITY;
    // Projection onto the plane, if inside the triangle.
    if n.norm() > 0.0 {
        let q = p - n * (n.dot(&(p - a)) / n.norm_squared());
        let inside = [(a, b), (b, c), (c, a)]
            .iter()
            .all(|(u, v)| (v - u).cross(&(q - u)).dot(&n) >= 0.0);
        if inside {
            best = (p - q).norm();
        }
    }
    // The three edges, each minimized exactly.
    for (u, v) in [(a, b), (b, c), (c, a)] {
        let e = v - u;
        let t = if e.norm_squared() > 0.0 {
            ((p - u).dot(&e) / e.norm_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        best = best.min((p - (u + e * t)).norm());
    }
    best
}

#[test]
fn skinning_reproduces_the_armadillo_display_mesh_at_rest() {
    let Some(tet_path) = reference_mesh("arma_6.node") else {
        return;
    };
    let Some(obj_path) = reference_mesh("armadillo.obj") else {
        return;
    };
    let mesh = read_tet_mesh(tet_path).unwrap();
    let display = read_surface_mesh(obj_path).unwrap();
    assert_eq!(display.num_vertices(), 26_002);
    let skin = Skinning::new(&mesh, &display.positions).unwrap();
    assert_eq!(skin.num_display_vertices(), 26_002);
    assert_eq!(
        skin.outside(),
        &[],
        "every armadillo.obj vertex lies inside arma_6"
    );
    let error = max_error(&skin.apply(&mesh.positions), &display.positions);
    let scale = diagonal(&display.positions);
    assert!(
        error <= 1e-12 * scale,
        "max error {error:e} (scale {scale})"
    );
    for i in 0..skin.num_display_vertices() {
        let w = skin.weights(i);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        assert!(w.iter().all(|&x| x >= -1e-10), "vertex {i}: {w:?}");
    }
}

#[test]
fn skinning_is_exact_for_affine_deformations() {
    let Some(tet_path) = reference_mesh("arma_6.node") else {
        return;
    };
    let Some(obj_path) = reference_mesh("armadillo.obj") else {
        return;
    };
    let mesh = read_tet_mesh(tet_path).unwrap();
    let display = read_surface_mesh(obj_path).unwrap();
    let skin = Skinning::new(&mesh, &display.positions).unwrap();
    let mut out = vec![Vector3::zeros(); skin.num_display_vertices()];
    for seed in 1..=3 {
        let (a, b) = random_affine(seed);
        let x: Vec<_> = mesh.positions.iter().map(|p| a * p + b).collect();
        skin.apply_into(&x, &mut out);
        let expected: Vec<_> = display.positions.iter().map(|p| a * p + b).collect();
        let error = max_error(&out, &expected);
        let scale = diagonal(&expected);
        assert!(error <= 1e-12 * scale, "seed {seed}: max error {error:e}");
    }
}

#[test]
fn outside_vertices_of_the_coarser_bunny_bind_to_the_closest_point_of_the_nearest_tet() {
    let Some(tet_path) = reference_mesh("coarser_bunny.mesh") else {
        return;
    };
    let Some(obj_path) = reference_mesh("coarser_bunny.obj") else {
        return;
    };
    let mesh = read_tet_mesh(tet_path).unwrap();
    let display = read_surface_mesh(obj_path).unwrap();
    let skin = Skinning::new(&mesh, &display.positions).unwrap();
    let outside = skin.outside();
    eprintln!(
        "coarser_bunny.obj on coarser_bunny.mesh: {} of {} vertices outside, largest distance {:.4}",
        outside.len(),
        display.num_vertices(),
        skin.max_outside_distance()
    );
    assert_eq!(outside.len(), 33, "the data README counts 33 outside");
    let at_rest = skin.apply(&mesh.positions);
    let scale = diagonal(&mesh.positions);
    let mut is_outside = vec![false; display.num_vertices()];
    for o in outside {
        is_outside[o.vertex] = true;
        let p = display.positions[o.vertex];
        let w = skin.weights(o.vertex);
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{w:?}");
        assert!(w.iter().all(|&x| (0.0..=1.0).contains(&x)), "{w:?}");
        assert!(o.distance > 0.0);
        // At rest the vertex lands on the closest point: it moves by the reported distance,
        // which is the true distance to the tet mesh.
        let moved = (at_rest[o.vertex] - p).norm();
        assert!(
            (moved - o.distance).abs() <= 1e-12 * scale,
            "{o:?}: moved {moved}"
        );
        let truth = brute_force_distance(&mesh, &p);
        assert!(
            (truth - o.distance).abs() <= 1e-12 * scale,
            "{o:?}: brute force {truth}"
        );
    }
    // Inside vertices are reproduced exactly.
    for (i, p) in display.positions.iter().enumerate() {
        if !is_outside[i] {
            assert!((at_rest[i] - p).norm() <= 1e-12 * scale, "vertex {i}");
        }
    }
    assert!(skin.max_outside_distance() < 0.05 * scale);
}

#[test]
fn a_box_surface_and_points_around_it_skin_onto_a_generated_box() {
    let mesh = box_mesh([3, 2, 4], [1.0, 1.0, 1.0]);
    let mut points = mesh.boundary_surface().positions;
    let mut rng = Rng::new(11);
    for _ in 0..200 {
        points.push(Vector3::from_fn(|_, _| rng.range(0.0, 1.0)));
    }
    // Points outside: the nearest point of the box is the coordinate-wise clamp.
    let outside = [
        Vector3::new(1.5, 0.5, 0.5),
        Vector3::new(-0.25, 0.3, 1.1),
        Vector3::new(2.0, 2.0, 2.0),
        Vector3::new(0.7, -3.0, 0.2),
    ];
    let first_outside = points.len();
    points.extend(outside);
    let skin = Skinning::new(&mesh, &points).unwrap();
    let found: Vec<usize> = skin.outside().iter().map(|o| o.vertex).collect();
    assert_eq!(found, (first_outside..points.len()).collect::<Vec<_>>());
    let at_rest = skin.apply(&mesh.positions);
    for (i, p) in points.iter().enumerate() {
        let clamped = p.map(|c| c.clamp(0.0, 1.0));
        assert!(
            (at_rest[i] - clamped).norm() < 1e-14,
            "point {i}: {:?}",
            at_rest[i]
        );
    }
    for o in skin.outside() {
        let p = points[o.vertex];
        let d = (p - p.map(|c| c.clamp(0.0, 1.0))).norm();
        assert!((o.distance - d).abs() < 1e-14, "{o:?}, expected {d}");
    }
    assert!((skin.max_outside_distance() - 3.0).abs() < 1e-14);
    // Inside points follow an affine map exactly.
    let (a, b) = random_affine(5);
    let x: Vec<_> = mesh.positions.iter().map(|p| a * p + b).collect();
    let moved = skin.apply(&x);
    for i in 0..first_outside {
        assert!((moved[i] - (a * points[i] + b)).norm() < 1e-13, "point {i}");
    }
}

#[test]
fn skinning_without_tets_is_an_error() {
    let mesh = TetMesh {
        positions: vec![Vector3::zeros()],
        tets: Vec::new(),
    };
    assert_eq!(
        Skinning::new(&mesh, &[Vector3::zeros()]),
        Err(SkinningError::NoTets)
    );
}
