//! `softbench simulate --export vtu|obj --every K`: numbered frames at step 0, every K steps
//! and the last step; bad export options are bad input (exit 2, nothing written).

mod common;

use common::{scene, simulate, softbench};

use common::TempDir;
use std::path::Path;

/// The file names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    names
}

/// The `t` column of `trajectory.csv` by step.
fn times(out: &Path) -> Vec<(usize, f64)> {
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    csv.lines()
        .skip(1)
        .map(|l| {
            let mut f = l.split(',');
            (
                f.next().unwrap().parse().unwrap(),
                f.next().unwrap().parse().unwrap(),
            )
        })
        .collect()
}

#[test]
fn export_vtu_every_5_writes_frames_0_5_10_and_the_last_step_12() {
    let dir = TempDir::new("cli-export-vtu");
    let out = dir.path().join("out");
    let result = simulate(
        &scene("cantilever.toml"),
        &out,
        &["--set", "run.steps=12", "--export", "vtu", "--every", "5"],
    );
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(0), "{stderr}");
    let frames = out.join("frames");
    assert_eq!(
        listing(&frames),
        [
            "frame_00000.vtu",
            "frame_00005.vtu",
            "frame_00010.vtu",
            "frame_00012.vtu",
            "series.pvd"
        ]
    );
    // The collection lists each frame with the time the trajectory gives its step.
    let pvd = std::fs::read_to_string(frames.join("series.pvd")).unwrap();
    let t = times(&out);
    let listed: Vec<&str> = pvd.lines().filter(|l| l.contains("<DataSet")).collect();
    assert_eq!(listed.len(), 4);
    for (line, step) in listed.iter().zip([0usize, 5, 10, 12]) {
        assert!(
            line.contains(&format!("file=\"frame_{step:05}.vtu\"")),
            "{line}"
        );
        let time = t.iter().find(|(s, _)| *s == step).unwrap().1;
        assert!(
            line.contains(&format!("timestep=\"{time:?}\"")),
            "{line} vs t = {time}"
        );
    }
    // Each frame is a complete VTU of the 1080-tet beam.
    for name in ["frame_00000.vtu", "frame_00012.vtu"] {
        let text = std::fs::read_to_string(frames.join(name)).unwrap();
        assert!(text.contains(r#"NumberOfPoints="336" NumberOfCells="1080""#));
        for array in ["velocity", "displacement", "J", "energy", "energy_density"] {
            assert!(
                text.contains(&format!("Name=\"{array}\"")),
                "{name}: {array}"
            );
        }
        assert!(text.trim_end().ends_with("</VTKFile>"));
    }
}

#[test]
fn export_obj_writes_the_boundary_surface_at_step_0_and_the_last_step() {
    let dir = TempDir::new("cli-export-obj");
    let out = dir.path().join("out");
    let result = simulate(
        &scene("cantilever.toml"),
        &out,
        &["--set", "run.steps=3", "--export", "obj", "--every", "10"],
    );
    assert_eq!(result.status.code(), Some(0));
    let frames = out.join("frames");
    assert_eq!(listing(&frames), ["frame_00000.obj", "frame_00003.obj"]);
    let surface = softbench::mesh::read_surface_mesh(frames.join("frame_00003.obj")).unwrap();
    // A 20 × 3 × 3-cell box: 21·4·4 − 19·2·2 boundary vertices, 2 triangles per cell face.
    assert_eq!(surface.num_vertices(), 21 * 4 * 4 - 19 * 2 * 2);
    assert_eq!(surface.num_triangles(), 2 * 2 * (20 * 3 + 20 * 3 + 3 * 3));
    assert!(surface.is_closed_manifold());
}

#[test]
fn export_obj_with_a_display_section_writes_the_skinned_armadillo() {
    let Some(_) = common::reference_mesh("arma_6.node") else {
        return;
    };
    let Some(display) = common::reference_mesh("armadillo.obj") else {
        return;
    };
    let dir = TempDir::new("cli-export-display");
    let scene_file = scene("armadillo.toml");
    let text = std::fs::read_to_string(&scene_file).unwrap();
    assert!(
        text.contains("[display]"),
        "the shipped scene names its display mesh"
    );
    let out = dir.path().join("out");
    let result = simulate(
        &scene_file,
        &out,
        &["--set", "run.steps=4", "--export", "obj", "--every", "2"],
    );
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(0), "{stderr}");
    let frames = out.join("frames");
    assert_eq!(
        listing(&frames),
        ["frame_00000.obj", "frame_00002.obj", "frame_00004.obj"]
    );
    let original = softbench::mesh::read_surface_mesh(display).unwrap();
    let first = softbench::mesh::read_surface_mesh(frames.join("frame_00000.obj")).unwrap();
    let last = softbench::mesh::read_surface_mesh(frames.join("frame_00004.obj")).unwrap();
    assert_eq!(first.num_vertices(), 26_002);
    assert_eq!(first.triangles, original.triangles);
    assert_eq!(last.triangles, original.triangles);
    let error = first
        .positions
        .iter()
        .zip(&original.positions)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(
        error < 1e-12,
        "the rest frame reproduces the display mesh: {error:e}"
    );
    assert!(first.positions != last.positions, "the display mesh moves");
}

#[test]
fn a_bad_export_format_is_bad_input_and_nothing_is_written() {
    let dir = TempDir::new("cli-export-bad");
    let out = dir.path().join("out");
    let result = simulate(&scene("cantilever.toml"), &out, &["--export", "vtk"]);
    assert_eq!(result.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        stderr.contains("unknown export format `vtk`; did you mean `vtu`?")
            && stderr.contains("obj"),
        "{stderr}"
    );
    assert!(!out.exists(), "nothing may be written for bad input");
}

#[test]
fn every_0_or_every_without_export_is_bad_input_and_nothing_is_written() {
    let dir = TempDir::new("cli-export-every");
    let out = dir.path().join("out");
    let cantilever = scene("cantilever.toml");
    let base = [
        "simulate",
        cantilever.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    for extra in [&["--export", "vtu", "--every", "0"][..], &["--every", "3"]] {
        let args: Vec<&str> = base.iter().chain(extra).copied().collect();
        let result = softbench(&args);
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{extra:?}: {stderr}");
        assert!(stderr.contains("--every"), "{extra:?}: {stderr}");
        assert!(
            !out.exists(),
            "{extra:?}: nothing may be written for bad input"
        );
    }
}

#[test]
fn a_missing_display_mesh_is_bad_input_when_exporting_obj() {
    let dir = TempDir::new("cli-export-no-display");
    let text = std::fs::read_to_string(scene("cantilever.toml")).unwrap();
    let scene_file = dir.write(
        "beam.toml",
        &format!("{text}\n[display]\nfile = \"no-such-display.obj\"\n"),
    );
    let out = dir.path().join("out");
    let result = simulate(&scene_file, &out, &["--export", "obj"]);
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("display.file") && stderr.contains("no-such-display.obj"),
        "{stderr}"
    );
    assert!(!out.exists());
}
