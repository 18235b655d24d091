//! Surface extraction and the closed-manifold check.

mod common;

use std::collections::BTreeSet;

use common::{assert_close, reference_mesh};
use nalgebra::Vector3;
use softbench::mesh::surface::{
    TET_FACES, boundary_faces, check_edges, classify_faces, is_closed_manifold,
};
use softbench::mesh::{TetMesh, box_mesh, read_surface_mesh, read_tet_mesh};
use softbench::rng::Rng;

/// A triangle rotated so its smallest index comes first; keeps the winding, so two triangles
/// are the same oriented face exactly when their canonical forms are equal.
fn canonical([a, b, c]: [usize; 3]) -> [usize; 3] {
    if a < b && a < c {
        [a, b, c]
    } else if b < c {
        [b, c, a]
    } else {
        [c, a, b]
    }
}

fn oriented_set(triangles: &[[usize; 3]]) -> BTreeSet<[usize; 3]> {
    triangles.iter().copied().map(canonical).collect()
}

#[test]
fn surface_of_coarser_bunny_matches_armadillo2_obj() {
    let Some(tet_path) = reference_mesh("coarser_bunny.mesh") else {
        return;
    };
    let Some(obj_path) = reference_mesh("armadillo2.obj") else {
        return;
    };
    let tets = read_tet_mesh(tet_path).unwrap();
    let obj = read_surface_mesh(obj_path).unwrap();
    // armadillo2.obj lists the tet mesh's vertices in the same order, so indices compare.
    assert_eq!(tets.positions, obj.positions);
    let ours = tets.boundary_surface();
    assert_eq!(ours.triangles.len(), 834);
    let unoriented = |t: &[[usize; 3]]| -> BTreeSet<[usize; 3]> {
        t.iter()
            .map(|f| {
                let mut f = *f;
                f.sort();
                f
            })
            .collect()
    };
    assert_eq!(unoriented(&ours.triangles), unoriented(&obj.triangles));
    assert_eq!(oriented_set(&ours.triangles), oriented_set(&obj.triangles));
    assert_close(ours.enclosed_volume(), tets.total_volume(), 1e-9);
}

/// A random tet, reordered if needed to be positively oriented.
fn random_positive_tet(rng: &mut Rng) -> TetMesh {
    let mut positions: Vec<Vector3<f64>> = (0..4)
        .map(|_| {
            Vector3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
        })
        .collect();
    let mut mesh = TetMesh {
        positions: positions.clone(),
        tets: vec![[0, 1, 2, 3]],
    };
    if mesh.signed_volume(0) < 0.0 {
        positions.swap(2, 3);
        mesh.positions = positions;
    }
    mesh
}

#[test]
fn tet_faces_point_away_from_the_opposite_vertex() {
    let mut rng = Rng::new(7);
    for _ in 0..100 {
        let mesh = random_positive_tet(&mut rng);
        let p = &mesh.positions;
        for (opposite, face) in TET_FACES.iter().enumerate() {
            assert!(!face.contains(&opposite));
            let [a, b, c] = face.map(|i| p[i]);
            let normal = (b - a).cross(&(c - a));
            assert!(
                normal.dot(&(a - p[opposite])) > 0.0,
                "face {face:?} points inward"
            );
        }
        let surface = mesh.boundary_surface();
        assert_eq!(surface.triangles.len(), 4);
        assert!(surface.is_closed_manifold());
        assert_close(surface.enclosed_volume(), mesh.signed_volume(0), 1e-9);
    }
}

#[test]
fn two_tets_sharing_a_face_have_six_boundary_faces() {
    // Tets [0,1,2,3] and [1,0,2,4] share face {0,1,2} and are both positive for this geometry.
    let mesh = TetMesh {
        positions: vec![
            Vector3::new(0.0, 0.0, 0.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, 1.0, 0.0),
            Vector3::new(0.0, 0.0, 1.0),
            Vector3::new(0.0, 0.0, -1.0),
        ],
        tets: vec![[0, 1, 2, 3], [1, 0, 2, 4]],
    };
    assert!(mesh.signed_volume(0) > 0.0 && mesh.signed_volume(1) > 0.0);
    let faces = classify_faces(&mesh.tets);
    assert_eq!(
        (faces.interior, faces.misoriented, faces.overshared),
        (1, 0, 0)
    );
    assert_eq!(faces.boundary.len(), 6);
    assert!(faces.boundary.iter().all(|f| {
        let mut s = *f;
        s.sort();
        s != [0, 1, 2]
    }));
    assert!(is_closed_manifold(&faces.boundary));
    assert_close(
        mesh.boundary_surface().enclosed_volume(),
        mesh.total_volume(),
        1e-12,
    );
}

#[test]
fn face_shared_by_equally_oriented_tets_is_reported_misoriented() {
    // The second tet repeats the first's orientation of the shared face: one tet is inverted.
    let tets = [[0, 1, 2, 3], [0, 1, 2, 4]];
    let faces = classify_faces(&tets);
    assert_eq!((faces.interior, faces.misoriented), (1, 1));
    assert!(!is_closed_manifold(&faces.boundary));
}

#[test]
fn face_shared_by_three_tets_is_overshared() {
    let tets = [[0, 1, 2, 3], [1, 0, 2, 4], [1, 0, 2, 5]];
    let faces = classify_faces(&tets);
    assert_eq!(faces.overshared, 1);
    assert_eq!(faces.interior, 0);
}

#[test]
fn boundary_of_a_box_is_closed_and_encloses_its_volume() {
    let mesh = box_mesh([3, 4, 5], [1.5, 2.0, 0.5]);
    let surface = mesh.boundary_surface();
    assert_eq!(surface.triangles.len(), 4 * (3 * 4 + 4 * 5 + 5 * 3));
    assert!(surface.is_closed_manifold());
    assert_close(surface.enclosed_volume(), 1.5, 1e-12);
}

#[test]
fn closed_manifold_check_rejects_open_nonmanifold_and_misoriented_surfaces() {
    let tet = boundary_faces(&[[0, 1, 2, 3]]);
    assert!(is_closed_manifold(&tet));

    let open = &tet[..3];
    let e = check_edges(open);
    assert_eq!((e.edges, e.open), (6, 3));
    assert!(!is_closed_manifold(open));

    let mut flipped = tet.clone();
    flipped[0].swap(1, 2);
    let e = check_edges(&flipped);
    assert_eq!(e.misoriented, 3);
    assert!(!is_closed_manifold(&flipped));

    // Two tets glued along an edge only (edge {0,1} has four faces around it).
    let mut bowtie = tet.clone();
    bowtie.extend(boundary_faces(&[[0, 1, 4, 5]]));
    let e = check_edges(&bowtie);
    assert_eq!(e.nonmanifold, 1);
    assert!(!is_closed_manifold(&bowtie));

    let degenerate = vec![[0, 0, 1]];
    assert_eq!(check_edges(&degenerate).degenerate_triangles, 1);
    assert!(!is_closed_manifold(&degenerate));
    assert!(!is_closed_manifold(&[]));
}

#[test]
fn boundary_winding_follows_index_order_for_an_inverted_tet() {
    // Swapping two vertices inverts the tet and reverses every boundary face.
    let faces = boundary_faces(&[[0, 1, 3, 2]]);
    let reference = boundary_faces(&[[0, 1, 2, 3]]);
    let reversed: BTreeSet<_> = reference
        .iter()
        .map(|&[a, b, c]| canonical([a, c, b]))
        .collect();
    assert_eq!(oriented_set(&faces), reversed);
}
