//! The shipped cow (`experiments/scenes/cow.mesh`, public domain) and the Brown write-up's
//! demo: it reads as the mesh its provenance describes, and the scene and the contact study
//! run with no downloaded data.

mod common;

use common::TempDir;
use std::path::Path;

fn experiments() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/experiments"))
}

#[test]
fn the_shipped_cow_is_the_mesh_its_provenance_describes() {
    let mesh = softbench::mesh::read_tet_mesh(experiments().join("scenes/cow.mesh")).unwrap();
    assert_eq!((mesh.num_vertices(), mesh.num_tets()), (549, 1571));
    assert!((mesh.total_volume() - 0.689342).abs() < 1e-6);
    let (lo, hi) = mesh.bounding_box().unwrap();
    assert!((lo.y + 0.7235).abs() < 1e-4 && (hi.z - 1.0108).abs() < 1e-4);
    let provenance = std::fs::read_to_string(experiments().join("scenes/cow.md")).unwrap();
    assert!(provenance.contains("CC0") && provenance.contains("public domain"));
}

#[test]
fn the_cow_drop_study_runs_without_downloaded_data() {
    let tmp = TempDir::new("cow-drop");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_softbench"))
        .args(["run", experiments().join("cow_drop.toml").to_str().unwrap()])
        .args(["--out", tmp.path().to_str().unwrap(), "--quick"])
        .env_remove("SOFTBENCH_DATA")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let runs = std::fs::read_to_string(tmp.path().join("cow_drop/runs.csv")).unwrap();
    assert_eq!(runs.lines().count(), 4, "{runs}");
    assert!(
        runs.lines().skip(1).all(|l| l.contains(",completed,")),
        "{runs}"
    );
    assert!(runs.contains("cow-rk4,cow,rk4"));
}
