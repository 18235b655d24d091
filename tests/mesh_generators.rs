//! The box, beam and ball generators: counts, exact volumes, orientation, conformity.

mod common;

use std::f64::consts::PI;

use common::assert_close;
use nalgebra::Vector3;
use softbench::mesh::surface::classify_faces;
use softbench::mesh::{MeshReport, TetMesh, ball, beam, box_mesh};

/// Every face is shared by at most two tets, and the two wind it oppositely; the boundary is a
/// closed 2-manifold; no tet is inverted or degenerate.
#[track_caller]
fn assert_conforming_and_positive(mesh: &TetMesh) {
    let faces = classify_faces(&mesh.tets);
    assert_eq!(faces.overshared, 0, "faces shared by more than two tets");
    assert_eq!(
        faces.misoriented, 0,
        "interior faces wound the same way by both tets"
    );
    assert_eq!(
        4 * mesh.num_tets(),
        faces.boundary.len() + 2 * faces.interior
    );
    for t in 0..mesh.num_tets() {
        assert!(
            mesh.signed_volume(t) > 0.0,
            "tet {t} is not positively oriented"
        );
    }
    let report = MeshReport::for_tet_mesh(mesh);
    assert!(report.closed_manifold);
    assert_eq!((report.inverted, report.degenerate), (0, 0));
}

#[test]
fn box_mesh_has_six_tets_per_cell_and_a_vertex_lattice() {
    let (nx, ny, nz) = (3, 4, 5);
    let mesh = box_mesh([nx, ny, nz], [1.0, 2.0, 3.0]);
    assert_eq!(mesh.num_tets(), 6 * nx * ny * nz);
    assert_eq!(mesh.num_vertices(), (nx + 1) * (ny + 1) * (nz + 1));
    // x runs fastest: vertex (i, j, k) sits at (i/nx, 2 j/ny, 3 k/nz).
    let index = |i: usize, j: usize, k: usize| i + (nx + 1) * (j + (ny + 1) * k);
    let p = mesh.positions[index(2, 1, 3)];
    assert_close(p.x, 2.0 / 3.0, 1e-15);
    assert_close(p.y, 0.5, 1e-15);
    assert_close(p.z, 1.8, 1e-15);
}

#[test]
fn box_mesh_spans_zero_to_size_with_exact_volume() {
    let size = [1.5, 0.7, 2.25];
    let mesh = box_mesh([5, 3, 4], size);
    let (lo, hi) = mesh.bounding_box().unwrap();
    assert_eq!(lo, Vector3::zeros());
    assert_eq!(hi, Vector3::from(size));
    let cell = size[0] / 5.0 * size[1] / 3.0 * size[2] / 4.0;
    for t in 0..mesh.num_tets() {
        assert_close(mesh.signed_volume(t), cell / 6.0, 1e-12);
    }
    assert_close(mesh.total_volume(), size.iter().product(), 1e-12);
}

#[test]
fn box_mesh_is_conforming_with_a_closed_surface() {
    for cells in [[1, 1, 1], [2, 1, 1], [3, 4, 5], [6, 2, 3]] {
        let mesh = box_mesh(cells, [1.0, 1.0, 1.0]);
        assert_conforming_and_positive(&mesh);
        let [nx, ny, nz] = cells;
        let report = MeshReport::for_tet_mesh(&mesh);
        assert_eq!(report.surface_triangles, 4 * (nx * ny + ny * nz + nz * nx));
    }
}

#[test]
fn single_cell_box_has_the_kuhn_split_quality() {
    // Every Kuhn tet of a cube is congruent: edges 1, 1, 1, √2, √2, √3.
    let report = MeshReport::for_tet_mesh(&box_mesh([1, 1, 1], [1.0, 1.0, 1.0]));
    assert_eq!(report.edges, 19);
    assert!(report.min_quality.unwrap() > 0.5);
}

#[test]
fn beam_cells_are_close_to_cubes() {
    let mesh = beam(4.0, 1.0, 3);
    assert_eq!(mesh.num_tets(), 6 * 12 * 3 * 3);
    let (lo, hi) = mesh.bounding_box().unwrap();
    assert_eq!((lo, hi), (Vector3::zeros(), Vector3::new(4.0, 1.0, 1.0)));
    assert_close(mesh.total_volume(), 4.0, 1e-12);
    assert_conforming_and_positive(&mesh);
}

#[test]
fn million_tet_box_has_the_expected_counts() {
    let mesh = box_mesh([100, 100, 17], [1.0, 1.0, 0.17]);
    assert_eq!(mesh.num_tets(), 1_020_000);
    assert_eq!(mesh.num_vertices(), 101 * 101 * 18);
}

#[test]
fn ball_has_48_n_cubed_tets_and_is_conforming_and_positive() {
    for n in 1..=8 {
        let mesh = ball(2.0, n);
        assert_eq!(mesh.num_tets(), 48 * n * n * n);
        assert_eq!(mesh.num_vertices(), (2 * n + 1).pow(3));
        assert_conforming_and_positive(&mesh);
    }
}

#[test]
fn ball_volume_approaches_four_thirds_pi_r_cubed() {
    let r: f64 = 0.5;
    let exact = 4.0 / 3.0 * PI * r.powi(3);
    let mut previous_error = f64::INFINITY;
    for n in [2, 4, 8] {
        let volume = ball(r, n).total_volume();
        let error = (exact - volume) / exact;
        assert!(
            error > 0.0,
            "an inscribed polyhedron is smaller than the ball"
        );
        assert!(
            error < previous_error / 3.0,
            "error {error} does not shrink like 1/n²"
        );
        previous_error = error;
    }
    assert!(previous_error < 0.01);
    let error_at_4 = (exact - ball(r, 4).total_volume()) / exact;
    assert!(error_at_4 < 0.02, "resolution 4 is {error_at_4} off");
}

#[test]
fn ball_surface_vertices_lie_on_the_sphere_and_quality_is_reasonable() {
    let radius = 3.0;
    let mesh = ball(radius, 6);
    let surface = mesh.boundary_surface();
    for &i in surface.triangles.iter().flatten() {
        assert_close(mesh.positions[i].norm(), radius, 1e-12);
    }
    let (lo, hi) = mesh.bounding_box().unwrap();
    assert_close(hi.x, radius, 1e-12);
    assert_close(lo.y, -radius, 1e-12);
    let quality = MeshReport::for_tet_mesh(&mesh).min_quality.unwrap();
    assert!(quality > 0.5, "min quality {quality}");
}
