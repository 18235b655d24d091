//! `softbench mesh-info`, run as the built binary.

mod common;

use std::process::{Command, Output};

use common::{TempDir, reference_mesh};
use softbench::mesh::{MeshFormat, box_mesh};

fn softbench(args: &[&str], cwd: &std::path::Path, data: Option<&std::path::Path>) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_softbench"));
    cmd.args(args).current_dir(cwd);
    match data {
        Some(dir) => cmd.env("SOFTBENCH_DATA", dir),
        None => cmd.env_remove("SOFTBENCH_DATA"),
    };
    cmd.output().expect("cannot run softbench")
}

fn json(output: &Output) -> serde_json::Value {
    assert!(
        output.status.success(),
        "softbench failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    serde_json::from_slice(&output.stdout).expect("stdout is not one JSON object")
}

const KEYS: [&str; 15] = [
    "file",
    "format",
    "vertices",
    "tets",
    "surface_triangles",
    "bbox",
    "volume",
    "min_tet_volume",
    "max_tet_volume",
    "min_quality",
    "inverted",
    "degenerate",
    "boundary_vertices",
    "edges",
    "closed_manifold",
];

/// A generated 2×1×1 box written as a plain .mesh.
fn write_box(dir: &TempDir) {
    let mesh = box_mesh([2, 1, 1], [2.0, 1.0, 1.0]);
    let mut text = String::new();
    for p in &mesh.positions {
        text += &format!("v {} {} {}\n", p.x, p.y, p.z);
    }
    for t in &mesh.tets {
        text += &format!("t {} {} {} {}\n", t[0], t[1], t[2], t[3]);
    }
    dir.write("box.mesh", &text);
}

#[test]
fn mesh_info_json_reports_a_generated_box() {
    let dir = TempDir::new("cli-box");
    write_box(&dir);
    let v = json(&softbench(
        &["mesh-info", "box.mesh", "--json"],
        dir.path(),
        None,
    ));
    for key in KEYS {
        assert!(v.get(key).is_some(), "missing key `{key}` in {v}");
    }
    assert_eq!(v["format"], "plain");
    assert_eq!(v["vertices"], 12);
    assert_eq!(v["tets"], 12);
    assert_eq!(v["surface_triangles"], 20);
    assert_eq!(v["inverted"], 0);
    assert_eq!(v["degenerate"], 0);
    assert_eq!(v["closed_manifold"], true);
    assert!((v["volume"].as_f64().unwrap() - 2.0).abs() < 1e-12);
    assert_eq!(v["bbox"]["max"], serde_json::json!([2.0, 1.0, 1.0]));
}

#[test]
fn mesh_info_finds_the_file_through_softbench_data() {
    let data = TempDir::new("cli-data");
    let elsewhere = TempDir::new("cli-cwd");
    write_box(&data);
    let v = json(&softbench(
        &["mesh-info", "box.mesh", "--json"],
        elsewhere.path(),
        Some(data.path()),
    ));
    assert_eq!(
        v["file"],
        data.path().join("box.mesh").display().to_string()
    );
}

#[test]
fn mesh_info_text_output_is_a_readable_report() {
    let dir = TempDir::new("cli-text");
    write_box(&dir);
    let output = softbench(&["mesh-info", "box.mesh"], dir.path(), None);
    assert!(output.status.success());
    let text = String::from_utf8(output.stdout).unwrap();
    for needle in [
        "plain v/t .mesh",
        "tets                12",
        "closed 2-manifold   yes",
    ] {
        assert!(text.contains(needle), "`{needle}` not in:\n{text}");
    }
}

#[test]
fn mesh_info_json_on_the_coarser_bunny() {
    let Some(path) = reference_mesh("coarser_bunny.mesh") else {
        return;
    };
    let data = path.parent().unwrap();
    let cwd = TempDir::new("cli-bunny");
    let v = json(&softbench(
        &["mesh-info", "coarser_bunny.mesh", "--json"],
        cwd.path(),
        Some(data),
    ));
    for key in KEYS {
        assert!(v.get(key).is_some(), "missing key `{key}` in {v}");
    }
    assert_eq!(v["format"], "medit");
    assert_eq!(v["vertices"], 500);
    assert_eq!(v["tets"], 1518);
    assert_eq!(v["surface_triangles"], 834);
    assert_eq!(v["boundary_vertices"], 419);
    assert_eq!(v["edges"], 2434);
    assert_eq!(v["closed_manifold"], true);
}

#[test]
fn mesh_info_json_on_an_obj_reports_the_surface() {
    let Some(path) = reference_mesh("armadillo2.obj") else {
        return;
    };
    let v = json(&softbench(
        &["mesh-info", path.to_str().unwrap(), "--json"],
        path.parent().unwrap(),
        None,
    ));
    assert_eq!(v["format"], "obj");
    assert_eq!(v["tets"], 0);
    assert_eq!(v["surface_triangles"], 834);
    assert_eq!(v["closed_manifold"], true);
    assert!(v["min_tet_volume"].is_null());
}

#[test]
fn malformed_file_exits_with_code_2_and_names_file_and_line() {
    let dir = TempDir::new("cli-bad");
    dir.write(
        "bad.mesh",
        "v 0 0 0\nv 1 0 0\nv 0 1 oops\nv 0 0 1\nt 0 1 2 3\n",
    );
    let output = softbench(&["mesh-info", "bad.mesh", "--json"], dir.path(), None);
    assert_eq!(output.status.code(), Some(2));
    assert!(output.stdout.is_empty());
    let stderr = String::from_utf8(output.stderr).unwrap();
    assert!(stderr.contains("bad.mesh:3:"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn missing_ele_is_reported_once_with_exit_code_2() {
    let dir = TempDir::new("cli-no-ele");
    dir.write(
        "lonely.node",
        "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n",
    );
    let output = softbench(&["mesh-info", "lonely.node"], dir.path(), None);
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8(output.stderr).unwrap();
    assert!(stderr.contains("lonely.ele"), "{stderr}");
    // The io error is part of the message; it must not be repeated as a cause.
    assert_eq!(stderr.matches("os error").count(), 1, "{stderr}");
}

#[test]
fn missing_file_exits_with_code_2_and_explains_softbench_data() {
    let dir = TempDir::new("cli-missing");
    let output = softbench(&["mesh-info", "nowhere.mesh"], dir.path(), None);
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8(output.stderr).unwrap();
    assert!(stderr.contains("nowhere.mesh (current folder)"), "{stderr}");
    assert!(stderr.contains("SOFTBENCH_DATA is not set"), "{stderr}");
}

#[test]
fn help_and_list_name_every_format_of_the_table() {
    let dir = TempDir::new("cli-help");
    let help = softbench(&["mesh-info", "--help"], dir.path(), None);
    assert!(help.status.success());
    let help = String::from_utf8(help.stdout).unwrap();
    let list = softbench(&["list"], dir.path(), None);
    assert!(list.status.success());
    let list = String::from_utf8(list.stdout).unwrap();
    let listed = list.split_once("mesh formats").map_or("", |(_, rest)| rest);
    for format in MeshFormat::all() {
        let e = format.entry();
        let line = format!("{:6} {}", e.name, e.title);
        assert!(help.contains(&line), "`{line}` not in:\n{help}");
        assert!(help.contains(e.description), "{} not in:\n{help}", e.name);
        assert!(listed.contains(e.description), "{} not in:\n{list}", e.name);
    }
}
