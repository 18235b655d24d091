//! Every file in the reference mesh folder (`SOFTBENCH_DATA`, normally `shared/meshes`) loads
//! and reports the counts, extents and volumes its README lists. Each test is skipped, with a
//! line on stderr, when `SOFTBENCH_DATA` is not set.

mod common;

use common::{assert_close, reference_mesh};
use softbench::mesh::quality::volume_edge_ratio;
use softbench::mesh::{MeshReport, TetMesh, read_surface_mesh, read_tet_mesh};

/// What the README says about a tet mesh. `None` where it does not say.
struct Expected {
    vertices: usize,
    tets: usize,
    boundary_faces: usize,
    boundary_vertices: Option<usize>,
    edges: Option<usize>,
    volume: f64,
    tet_volume_range: Option<(f64, f64)>,
    bbox: ([f64; 3], [f64; 3]),
    /// Half a unit in the last digit the README gives for the bbox.
    bbox_tolerance: f64,
}

/// Loads a reference tet mesh and checks it against the README; returns it for further checks.
fn check_tet_mesh(name: &str, e: Expected) -> Option<TetMesh> {
    let path = reference_mesh(name)?;
    let mesh = read_tet_mesh(&path).unwrap_or_else(|err| panic!("{err}"));
    let r = MeshReport::for_tet_mesh(&mesh);
    assert_eq!(r.vertices, e.vertices, "{name}: vertices");
    assert_eq!(r.tets, e.tets, "{name}: tets");
    assert_eq!(
        r.surface_triangles, e.boundary_faces,
        "{name}: boundary faces"
    );
    assert_eq!(
        (r.inverted, r.degenerate),
        (0, 0),
        "{name}: inverted, degenerate"
    );
    assert!(
        r.closed_manifold,
        "{name}: boundary is not a closed 2-manifold"
    );
    // Every reference mesh is a topological ball, so its boundary is a sphere (V - E + F = 2
    // with E = 3F/2) and the mesh has Euler characteristic V - E + F - T = 1. These give the
    // counts the README leaves out for the Brown meshes.
    let derived_boundary_vertices = e.boundary_faces / 2 + 2;
    let faces = (4 * e.tets + e.boundary_faces) / 2;
    let derived_edges = e.vertices + faces - e.tets - 1;
    assert_eq!(
        r.boundary_vertices,
        e.boundary_vertices.unwrap_or(derived_boundary_vertices),
        "{name}: boundary vertices"
    );
    assert_eq!(
        r.boundary_vertices, derived_boundary_vertices,
        "{name}: not a sphere"
    );
    assert_eq!(r.edges, e.edges.unwrap_or(derived_edges), "{name}: edges");
    assert_eq!(r.edges, derived_edges, "{name}: not a ball");
    assert_close(r.volume, e.volume, 5e-4);
    if let Some((lo, hi)) = e.tet_volume_range {
        assert_close(r.min_tet_volume.unwrap(), lo, 5e-3);
        assert_close(r.max_tet_volume.unwrap(), hi, 5e-3);
    }
    let bbox = r.bbox.unwrap();
    for axis in 0..3 {
        for (got, want) in [
            (bbox.min[axis], e.bbox.0[axis]),
            (bbox.max[axis], e.bbox.1[axis]),
        ] {
            assert!(
                (got - want).abs() <= e.bbox_tolerance,
                "{name}: bbox axis {axis}: {got} vs README {want}"
            );
        }
    }
    Some(mesh)
}

/// The README's "minimum quality" is the volume–edge ratio, not the radius ratio.
fn min_volume_edge_ratio(mesh: &TetMesh) -> f64 {
    let p = &mesh.positions;
    mesh.tets
        .iter()
        .map(|t| volume_edge_ratio(t.map(|i| p[i])))
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn coarser_bunny_mesh_matches_readme() {
    let Some(mesh) = check_tet_mesh(
        "coarser_bunny.mesh",
        Expected {
            vertices: 500,
            tets: 1518,
            boundary_faces: 834,
            boundary_vertices: Some(419),
            edges: Some(2434),
            volume: 920_754.67,
            tet_volume_range: Some((0.098, 4303.6)),
            bbox: ([-97.49, 27.58, -71.82], [64.65, 192.95, 62.12]),
            bbox_tolerance: 0.005,
        },
    ) else {
        return;
    };
    assert!((min_volume_edge_ratio(&mesh) - 0.22).abs() < 0.005);
}

#[test]
fn coarse_bunny_mesh_matches_readme() {
    let Some(mesh) = check_tet_mesh(
        "coarse_bunny.mesh",
        Expected {
            vertices: 699,
            tets: 2274,
            boundary_faces: 1098,
            boundary_vertices: Some(551),
            edges: Some(3521),
            volume: 837_150.68,
            tet_volume_range: Some((1.71, 2461.4)),
            bbox: ([-96.78, 29.09, -69.92], [62.95, 191.60, 59.69]),
            bbox_tolerance: 0.005,
        },
    ) else {
        return;
    };
    assert!((min_volume_edge_ratio(&mesh) - 0.23).abs() < 0.005);
}

#[test]
fn arma_6_tetgen_mesh_matches_readme() {
    let Some(mesh) = check_tet_mesh(
        "arma_6.node",
        Expected {
            vertices: 259,
            tets: 627,
            boundary_faces: 500,
            boundary_vertices: Some(252),
            edges: Some(1135),
            volume: 0.10028,
            tet_volume_range: Some((1.11e-5, 9.73e-4)),
            bbox: ([-0.0315, 0.0290, -0.0071], [0.8127, 1.0311, 0.7718]),
            bbox_tolerance: 0.00005,
        },
    ) else {
        return;
    };
    assert!((min_volume_edge_ratio(&mesh) - 0.127).abs() < 0.0005);
}

#[test]
fn arma_6_loads_the_same_from_its_ele_path() {
    let Some(node) = reference_mesh("arma_6.node") else {
        return;
    };
    let Some(ele) = reference_mesh("arma_6.ele") else {
        return;
    };
    assert_eq!(read_tet_mesh(node).unwrap(), read_tet_mesh(ele).unwrap());
}

#[test]
fn single_tet_mesh_matches_readme() {
    check_tet_mesh(
        "single-tet.mesh",
        Expected {
            vertices: 4,
            tets: 1,
            boundary_faces: 4,
            boundary_vertices: None,
            edges: None,
            volume: 0.123,
            tet_volume_range: None,
            bbox: ([-0.5, 0.0, -0.3], [0.5, 0.82, 0.6]),
            bbox_tolerance: 1e-12,
        },
    );
}

#[test]
fn cube_mesh_matches_readme() {
    check_tet_mesh(
        "cube.mesh",
        Expected {
            vertices: 8,
            tets: 5,
            boundary_faces: 12,
            boundary_vertices: None,
            edges: None,
            volume: 0.82f64.powi(3),
            tet_volume_range: None,
            bbox: ([-0.41; 3], [0.41; 3]),
            bbox_tolerance: 1e-12,
        },
    );
}

#[test]
fn sphere_mesh_matches_readme() {
    check_tet_mesh(
        "sphere.mesh",
        Expected {
            vertices: 61,
            tets: 116,
            boundary_faces: 116,
            boundary_vertices: None,
            edges: None,
            volume: 3.804,
            tet_volume_range: None,
            bbox: ([-0.990, -0.977, -0.981], [1.0, 0.978, 0.960]),
            bbox_tolerance: 0.0005,
        },
    );
}

#[test]
fn ellipsoid_mesh_matches_readme() {
    check_tet_mesh(
        "ellipsoid.mesh",
        Expected {
            vertices: 100,
            tets: 256,
            boundary_faces: 170,
            boundary_vertices: None,
            edges: None,
            volume: 7.671,
            tet_volume_range: None,
            bbox: ([-1.926, -0.997, -0.982], [2.0, 0.990, 0.993]),
            bbox_tolerance: 0.0005,
        },
    );
}

#[test]
fn cone_mesh_matches_readme() {
    check_tet_mesh(
        "cone.mesh",
        Expected {
            vertices: 237,
            tets: 575,
            boundary_faces: 444,
            boundary_vertices: None,
            edges: None,
            volume: 3.341,
            tet_volume_range: Some((1.46e-5, 0.0569)),
            bbox: ([0.0, -1.0, -1.0], [3.0, 1.0, 1.0]),
            bbox_tolerance: 0.00005,
        },
    );
}

/// Loads a reference OBJ and checks counts, closedness and a positive enclosed volume.
fn check_obj(name: &str, vertices: usize, triangles: usize) -> Option<MeshReport> {
    let path = reference_mesh(name)?;
    let mesh = read_surface_mesh(&path).unwrap_or_else(|err| panic!("{err}"));
    let r = MeshReport::for_surface(&mesh);
    assert_eq!(
        (r.vertices, r.surface_triangles),
        (vertices, triangles),
        "{name}"
    );
    assert!(r.closed_manifold, "{name}: not a closed 2-manifold");
    assert!(
        r.volume > 0.0,
        "{name}: enclosed volume {} is not positive",
        r.volume
    );
    assert_eq!(r.tets, 0);
    Some(r)
}

#[test]
fn armadillo_obj_matches_readme() {
    let Some(r) = check_obj("armadillo.obj", 26_002, 52_000) else {
        return;
    };
    assert_close(r.volume, 0.05536, 5e-4);
    let bbox = r.bbox.unwrap();
    let (lo, hi) = ([0.0113, 0.0728, 0.0433], [0.7926, 1.0035, 0.7533]);
    for axis in 0..3 {
        assert!((bbox.min[axis] - lo[axis]).abs() <= 5e-5);
        assert!((bbox.max[axis] - hi[axis]).abs() <= 5e-5);
    }
}

#[test]
fn coarser_bunny_obj_matches_readme() {
    check_obj("coarser_bunny.obj", 251, 498);
}

#[test]
fn coarse_bunny_obj_matches_readme() {
    check_obj("coarse_bunny.obj", 502, 1000);
}

#[test]
fn armadillo2_obj_matches_readme() {
    let Some(r) = check_obj("armadillo2.obj", 500, 834) else {
        return;
    };
    // 81 of its 500 vertices are not used by any face.
    assert_eq!(r.boundary_vertices, 500 - 81);
    assert_close(r.volume, 920_754.67, 5e-4);
}
