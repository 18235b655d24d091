//! The run pipeline as a library call: `Simulation` writes what `softbench simulate` writes,
//! frames and pictures share the one display mesh read and skinned when the run is prepared,
//! and a study's pictures show the display mesh as `simulate --render` does.

mod common;

use common::{TempDir, simulate};
use nalgebra::Vector3;
use softbench::data::DataPaths;
use softbench::export::{ExportFormat, write_obj};
use softbench::mesh::generate::box_mesh;
use softbench::mesh::read_surface_mesh;
use softbench::parallel::Parallelism;
use softbench::pipeline::{FRAMES_DIR, RUN_SNAPSHOTS, SimulateOptions, Simulation, SummaryFile};
use softbench::render::Snapshots;
use softbench::scene;
use std::path::Path;

use common::{csv_without_timings, is_timing};

/// A JSON document without its timing fields.
fn json_without_timings(value: serde_json::Value) -> serde_json::Value {
    match value {
        serde_json::Value::Object(map) => map
            .into_iter()
            .filter(|(k, _)| !is_timing(k))
            .map(|(k, v)| (k, json_without_timings(v)))
            .collect(),
        serde_json::Value::Array(items) => items.into_iter().map(json_without_timings).collect(),
        other => other,
    }
}

fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

const NO_OUTPUTS: SimulateOptions = SimulateOptions {
    export: None,
    every: 1,
    pictures: false,
    progress: false,
    threads: None,
};

#[test]
fn a_scene_run_through_the_library_writes_what_simulate_writes() {
    let dir = TempDir::new("pipeline-same-as-cli");
    let scene_file = common::scene("cantilever.toml");
    let overrides = ["run.steps=12".to_owned(), "run.sample_every=3".to_owned()];

    let cli = dir.path().join("cli");
    let output = simulate(
        &scene_file,
        &cli,
        &["--set", &overrides[0], "--set", &overrides[1]],
    );
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );

    let lib = dir.path().join("lib");
    std::fs::create_dir_all(&lib).unwrap();
    let loaded = scene::load(&scene_file, &overrides).unwrap();
    let done = Simulation::prepare(
        loaded,
        &DataPaths::new(None),
        Parallelism::Rayon,
        NO_OUTPUTS,
    )
    .unwrap()
    .run(&lib)
    .unwrap();
    assert!(done.summary.outcome.is_completed());
    assert_eq!(done.summary.steps_completed, 12);
    // Rows at steps 0, 3, 6, 9 and 12.
    assert_eq!(done.rows, 5);

    assert_eq!(
        csv_without_timings(&cli.join("trajectory.csv")),
        csv_without_timings(&done.trajectory)
    );
    assert_eq!(
        std::fs::read(cli.join("final_positions.csv")).unwrap(),
        std::fs::read(&done.final_positions).unwrap()
    );
    assert_eq!(
        json_without_timings(read_json(&cli.join("summary.json"))),
        json_without_timings(read_json(&done.summary_file))
    );
    // The file is the typed document, byte for byte.
    let config = scene::load(&scene_file, &overrides).unwrap().config;
    let mut typed = Vec::new();
    SummaryFile {
        softbench_version: env!("CARGO_PKG_VERSION"),
        scene: &done.name,
        scene_file: &scene_file,
        linear_solver: Some("cholesky".into()),
        dofs: done.dofs,
        springs: &done.spring_counts,
        summary: &done.summary,
        config: &config,
    }
    .write(&mut typed)
    .unwrap();
    assert_eq!(
        String::from_utf8(typed).unwrap(),
        std::fs::read_to_string(&done.summary_file).unwrap()
    );
}

/// A small clamped box under gravity whose `[display]` mesh is its boundary surface shrunk
/// towards the centre (so every display vertex lies inside a tet); returns the scene file and
/// the display mesh's vertex count.
fn box_with_display(dir: &TempDir) -> (std::path::PathBuf, usize) {
    let cells = [4, 2, 2];
    let size = [1.0, 0.5, 0.5];
    let mut display = box_mesh(cells, size).boundary_surface();
    let centre = Vector3::new(0.5, 0.25, 0.25);
    for p in &mut display.positions {
        *p = centre + (*p - centre) * 0.9;
    }
    let mut obj = Vec::new();
    write_obj(
        &mut obj,
        "shrunk box",
        &display.positions,
        &display.triangles,
    )
    .unwrap();
    std::fs::write(dir.path().join("skin.obj"), obj).unwrap();
    let scene = dir.write(
        "skinned_box.toml",
        r#"
[mesh]
generate = { box = [4, 2, 2], size = [1.0, 0.5, 0.5] }

[material]
model = "stable-neo-hookean"
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0

[fixed]
rule = { axis = "x", side = "min", tolerance = 1e-6 }

[forces]
gravity = [0.0, -9.81, 0.0]

[integrator]
method = "backward-euler"

[display]
file = "skin.obj"

[run]
dt = 0.01
steps = 6
"#,
    );
    (scene, display.num_vertices())
}

#[test]
fn obj_frames_and_pictures_share_the_display_mesh_read_once_when_prepared() {
    let dir = TempDir::new("pipeline-display-once");
    let (scene_file, display_vertices) = box_with_display(&dir);
    let options = SimulateOptions {
        export: Some(ExportFormat::Obj),
        every: 3,
        pictures: true,
        progress: false,
        threads: None,
    };
    let loaded = scene::load(&scene_file, &[]).unwrap();
    let simulation = Simulation::prepare(
        loaded,
        &DataPaths::new(None),
        Parallelism::Sequential,
        options,
    )
    .unwrap();
    let display = simulation
        .display()
        .expect("the scene names a display mesh");
    assert_eq!(display.skinning.num_display_vertices(), display_vertices);
    // Everything the run shows comes from what `prepare` read: without the file, the frames
    // and the pictures are still the display mesh's.
    std::fs::remove_file(dir.path().join("skin.obj")).unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    let done = simulation.run(&out).unwrap();
    assert!(done.summary.outcome.is_completed());
    assert_eq!(done.frames, 3, "steps 0, 3 and 6");
    let frame = read_surface_mesh(out.join(FRAMES_DIR).join("frame_00006.obj")).unwrap();
    assert_eq!(frame.num_vertices(), display_vertices);
    let snapshots = Snapshots::read(&out.join(RUN_SNAPSHOTS)).unwrap();
    assert_eq!(snapshots.num_vertices(), display_vertices);
    assert!(out.join("filmstrip.png").is_file() && out.join("animation.gif").is_file());
}

#[test]
fn vtu_frames_alone_do_not_read_the_display_mesh() {
    let dir = TempDir::new("pipeline-vtu-no-display");
    let (scene_file, _) = box_with_display(&dir);
    // A display mesh that cannot be read is no error when nothing shows it.
    std::fs::remove_file(dir.path().join("skin.obj")).unwrap();
    let loaded = scene::load(&scene_file, &[]).unwrap();
    let options = SimulateOptions {
        export: Some(ExportFormat::Vtu),
        ..NO_OUTPUTS
    };
    let simulation = Simulation::prepare(
        loaded,
        &DataPaths::new(None),
        Parallelism::Sequential,
        options,
    )
    .unwrap();
    assert!(simulation.display().is_none());
}

/// A trajectory study of one run of `scene_file` (in the same folder).
fn one_run_study(dir: &TempDir, scene_file: &Path) -> std::path::PathBuf {
    dir.write(
        "skinned.toml",
        &format!(
            r#"name = "skinned"
study = "trajectory"
scenes = [{:?}]

[grid]
"integrator.method" = ["backward-euler"]
"#,
            scene_file.file_name().unwrap().to_str().unwrap()
        ),
    )
}

#[test]
fn a_study_draws_the_display_mesh_as_simulate_render_does() {
    let dir = TempDir::new("pipeline-study-display");
    let (scene_file, display_vertices) = box_with_display(&dir);
    let study_file = one_run_study(&dir, &scene_file);
    let study = softbench::study::load(&study_file, false, &DataPaths::new(None)).unwrap();
    let options = softbench::study::RunOptions {
        force: true,
        ..softbench::study::RunOptions::new(dir.path().join("results"))
    };
    let done = softbench::study::run(&study, &options).unwrap();
    assert_eq!(done.ran, 1);
    let id = &study.runs[0].id;
    let snapshots =
        Snapshots::read(&done.dir.join("series").join(format!("{id}.snapshots"))).unwrap();
    assert_eq!(snapshots.num_vertices(), display_vertices);
}

#[test]
fn a_study_whose_display_mesh_is_missing_fails_at_load() {
    let dir = TempDir::new("pipeline-study-no-display");
    let (scene_file, _) = box_with_display(&dir);
    std::fs::remove_file(dir.path().join("skin.obj")).unwrap();
    let study_file = one_run_study(&dir, &scene_file);
    let error = softbench::study::load(&study_file, false, &DataPaths::new(None))
        .expect_err("a missing display mesh is bad input");
    let message = error.to_string();
    assert!(
        message.contains("display.file") && message.contains("skin.obj"),
        "{message}"
    );
}
