//! Scenes with mass-spring bodies and drags: the shipped scenes parse and run through
//! `softbench simulate`, and bad `[springs]`, `[jello]` and `[[drag]]` values are errors naming
//! the key.

mod common;

use common::{scene, simulate};

use common::TempDir;
use softbench::scene::{self, SceneError};
use std::path::Path;

/// Run a shipped scene for `steps` steps with `extra` overrides; return the exit code, the
/// summary and stderr.
fn run_scene(
    name: &str,
    steps: usize,
    extra: &[&str],
    dir: &TempDir,
) -> (i32, serde_json::Value, String) {
    let out = dir.path().join(format!("{name}-{}", extra.join("-")));
    let steps = format!("run.steps={steps}");
    let mut args = vec!["--set", steps.as_str()];
    for e in extra {
        args.extend(["--set", e]);
    }
    let result = simulate(&scene(name), &out, &args);
    let stderr = String::from_utf8_lossy(&result.stderr).into_owned();
    let code = result.status.code().expect("killed by a signal");
    let summary = std::fs::read_to_string(out.join("summary.json"))
        .map(|s| serde_json::from_str(&s).unwrap())
        .unwrap_or(serde_json::Value::Null);
    (code, summary, stderr)
}

#[test]
fn the_jello_scenes_run_a_few_steps_and_fall() {
    let dir = TempDir::new("springs-jello");
    for name in ["jello_cube.toml", "jello_sphere.toml"] {
        for method in [
            "backward-euler",
            "linearly-implicit-euler",
            "implicit-midpoint",
        ] {
            let set = format!("integrator.method={method}");
            let (code, summary, stderr) = run_scene(name, 5, &[&set], &dir);
            assert_eq!(code, 0, "{name} {method}: {stderr}");
            let s = &summary["summary"];
            assert_eq!(s["steps_completed"], 5, "{name} {method}");
            let e = &s["final_energy"];
            assert!(
                e["kinetic"].as_f64().unwrap() > 0.0,
                "{name} {method}: falls"
            );
        }
    }
}

/// `simulate` reports a jello body's springs per kind, in summary.json and on its last line:
/// for the shipped cube (n = 6 particles per side) 3 n² (n − 1) structural, 6 n (n − 1)² face
/// plus 4 (n − 1)³ space diagonals, 3 n² (n − 2) bending; a FEM body has none.
#[test]
fn simulate_reports_the_spring_counts_per_kind() {
    let dir = TempDir::new("springs-counts");
    let out = dir.path().join("cube");
    let result = simulate(&scene("jello_cube.toml"), &out, &["--set", "run.steps=1"]);
    assert!(result.status.success());
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let n = 6;
    let m = n - 1;
    assert_eq!(
        summary["springs"],
        serde_json::json!({
            "structural": 3 * n * n * m,
            "shear": 6 * n * m * m + 4 * m * m * m,
            "bending": 3 * n * n * (n - 2),
        })
    );
    let stdout = String::from_utf8_lossy(&result.stdout);
    assert!(
        stdout.contains("springs: structural 540, shear 1400, bending 432"),
        "{stdout}"
    );
    let beam = dir.path().join("beam");
    let result = simulate(&scene("cantilever.toml"), &beam, &["--set", "run.steps=1"]);
    assert!(result.status.success());
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(beam.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["springs"], serde_json::json!({}));
}

fn build(name: &str) -> scene::Scene {
    let loaded = scene::load(&scene(name), &[]).unwrap();
    scene::build(
        &loaded,
        &softbench::data::DataPaths::from_env(),
        softbench::parallel::Parallelism::Sequential,
    )
    .unwrap()
}

#[test]
fn the_jello_scenes_have_the_particles_and_springs_their_comments_count() {
    let cube = build("jello_cube.toml");
    // 6^3 particles; 3 n^2 (n-1) + 6 n (n-1)^2 + 4 (n-1)^3 + 3 n^2 (n-2) springs.
    assert_eq!(cube.model.vertex_masses().len(), 216);
    assert_eq!(cube.model.springs().len(), 540 + 900 + 500 + 432);
    let total: f64 = cube.model.vertex_masses().iter().sum();
    assert!((total - 1.0).abs() < 1e-12);

    let sphere = build("jello_sphere.toml");
    // 8 rings x 12 segments + 2 poles + centre; radial, structural, shear, bending, antipodal.
    assert_eq!(sphere.model.vertex_masses().len(), 99);
    assert_eq!(sphere.model.springs().len(), 98 + 204 + 168 + 192 + 49);
}

#[test]
fn the_spring_bunny_runs_with_the_course_parameters() {
    if common::reference_mesh("coarse_bunny.mesh").is_none() {
        return;
    }
    let dir = TempDir::new("springs-bunny");
    let (code, summary, stderr) = run_scene("spring_bunny.toml", 5, &[], &dir);
    assert_eq!(code, 0, "{stderr}");
    let s = &summary["summary"];
    assert_eq!(s["method"], "linearly-implicit-euler");
    assert_eq!(s["dt"], 0.005);
    assert_eq!(s["steps_completed"], 5);
    let built = build("spring_bunny.toml");
    assert_eq!(built.model.springs().len(), 3521);
    assert!(built.model.springs().iter().all(|s| s.stiffness == 1e5));
    assert!(built.model.vertex_masses().iter().all(|&m| m == 1.0));
}

#[test]
fn the_dragged_armadillo_runs_with_backward_euler_and_linearly_implicit_euler_explodes() {
    if common::reference_mesh("arma_6.node").is_none() {
        return;
    }
    let dir = TempDir::new("springs-armadillo");
    let (code, summary, stderr) = run_scene("armadillo_drag.toml", 5, &[], &dir);
    assert_eq!(code, 0, "{stderr}");
    let e = &summary["summary"]["final_energy"];
    assert!(
        e["elastic"].as_f64().unwrap() > 100.0,
        "the hand is pulled: {e}"
    );
    assert!(
        e["external"].as_f64().unwrap() > 0.0,
        "the drag springs are stretched: {e}"
    );
    // The scene's comment says so: the one-step yank inverts a tet at step 2.
    let (code, summary, stderr) = run_scene(
        "armadillo_drag.toml",
        5,
        &["integrator.method=linearly-implicit-euler"],
        &dir,
    );
    assert_eq!(code, 1, "{stderr}");
    let outcome = &summary["summary"]["outcome"];
    assert_eq!(outcome["cause"], "inverted element", "{outcome}");
    assert_eq!(outcome["step"], 2, "{outcome}");
}

fn invalid_key(text: &str) -> String {
    match scene::parse(text, Path::new("scene.toml"), &[]) {
        Err(SceneError::Invalid { key, .. }) => key,
        Err(other) => panic!("expected an invalid value, got: {other}"),
        Ok(_) => panic!("expected an error for:\n{text}"),
    }
}

const RUN: &str = "[run]\ndt = 0.01\nsteps = 10\n";

fn cube(extra: &str) -> String {
    format!(
        "[jello]\nshape = \"cube\"\nn = 3\nsize = 1.0\nstiffness = {{ structural = 1.0, shear = 1.0, bending = 1.0 }}\ntotal_mass = 1.0\n{extra}\n{RUN}"
    )
}

#[test]
fn bad_jello_values_are_errors_naming_the_key() {
    let ok = cube("");
    assert!(scene::parse(&ok, Path::new("scene.toml"), &[]).is_ok());
    let cases = [
        (ok.replace("n = 3", "n = 1"), "jello.n"),
        (ok.replace("size = 1.0", "size = 0.0"), "jello.size"),
        (
            ok.replace("shear = 1.0", "shear = -1.0"),
            "jello.stiffness.shear",
        ),
        (ok.replace(", bending = 1.0", ""), "jello.stiffness.bending"),
        (
            ok.replace("total_mass = 1.0", "particle_mass = 1.0\ntotal_mass = 1.0"),
            "jello",
        ),
        (
            ok.replace("total_mass = 1.0", "total_mass = 0.0"),
            "jello.total_mass",
        ),
        (ok.replace("n = 3", "n = 3\nrings = 4"), "jello.rings"),
        (
            ok.replace("bending = 1.0 }", "bending = 1.0, radial = 1.0 }"),
            "jello.stiffness.radial",
        ),
        (
            format!("{ok}\n[material]\nyoungs_modulus = 1e5\npoisson_ratio = 0.3\ndensity = 1.0\n"),
            "material",
        ),
        (
            format!("[mesh]\ngenerate = {{ box = [1, 1, 1], size = [1.0, 1.0, 1.0] }}\n{ok}"),
            "jello",
        ),
        (RUN.to_owned(), "mesh"),
    ];
    for (text, key) in &cases {
        assert_eq!(&invalid_key(text), key, "{text}");
    }
    let sphere = |rings: usize, segments: usize, radius: f64| {
        format!(
            "[jello]\nshape = \"sphere\"\nrings = {rings}\nsegments = {segments}\nradius = {radius}\nstiffness = {{ structural = 1.0, shear = 1.0, bending = 1.0, radial = 1.0, antipodal = 1.0 }}\nparticle_mass = 0.1\n{RUN}"
        )
    };
    assert!(scene::parse(&sphere(4, 8, 1.0), Path::new("s.toml"), &[]).is_ok());
    assert_eq!(invalid_key(&sphere(1, 8, 1.0)), "jello.rings");
    assert_eq!(invalid_key(&sphere(4, 7, 1.0)), "jello.segments");
    assert_eq!(invalid_key(&sphere(4, 4, 1.0)), "jello.segments");
    assert_eq!(invalid_key(&sphere(4, 8, 0.0)), "jello.radius");
    assert_eq!(
        invalid_key(&sphere(4, 8, 1.0).replace(", antipodal = 1.0", "")),
        "jello.stiffness.antipodal"
    );
}

#[test]
fn bad_springs_and_drag_values_are_errors_naming_the_key() {
    let mesh = "[mesh]\ngenerate = { box = [1, 1, 1], size = [1.0, 1.0, 1.0] }\n";
    let springs =
        format!("{mesh}[springs]\nfrom_tets = true\nstiffness = 10.0\nparticle_mass = 1.0\n{RUN}");
    assert!(scene::parse(&springs, Path::new("s.toml"), &[]).is_ok());
    assert_eq!(
        invalid_key(&springs.replace("stiffness = 10.0", "stiffness = -10.0")),
        "springs.stiffness"
    );
    assert_eq!(
        invalid_key(&springs.replace("from_tets = true", "from_tets = false")),
        "springs.from_tets"
    );
    assert_eq!(
        invalid_key(&springs.replace("particle_mass = 1.0\n", "")),
        "springs"
    );
    assert_eq!(
        invalid_key(&cube(
            "[springs]\nfrom_tets = true\nstiffness = 1.0\nparticle_mass = 1.0\n"
        )),
        "springs"
    );

    let drag = |body: &str| {
        format!(
            "{springs}\n[[drag]]\npoint = [1.0, 1.0, 1.0]\nradius = 0.1\nstiffness = 100.0\n{body}\n"
        )
    };
    let ok = drag(
        "path = [{ t = 0.0, offset = [0, 0, 0] }, { t = 0.5, offset = [0.2, 0, 0] }]\nrelease = 1.0",
    );
    assert!(scene::parse(&ok, Path::new("s.toml"), &[]).is_ok());
    assert_eq!(
        invalid_key(&ok.replace("t = 0.5", "t = 0.0")),
        "drag[0].path[1].t"
    );
    assert_eq!(
        invalid_key(&ok.replace("stiffness = 100.0", "stiffness = -1.0")),
        "drag[0].stiffness"
    );
    assert_eq!(
        invalid_key(&ok.replace("radius = 0.1", "radius = -0.1")),
        "drag[0].radius"
    );
    assert_eq!(invalid_key(&drag("path = []")), "drag[0].path");
    assert_eq!(
        invalid_key(&ok.replace("release = 1.0", "release = -1.0")),
        "drag[0].release"
    );
}

#[test]
fn a_drag_on_fixed_vertices_only_is_an_error_at_build() {
    let dir = TempDir::new("springs-drag-fixed");
    let file = dir.write(
        "scene.toml",
        &format!(
            "[mesh]\ngenerate = {{ box = [1, 1, 1], size = [1.0, 1.0, 1.0] }}\n[springs]\nfrom_tets = true\nstiffness = 10.0\nparticle_mass = 1.0\n[fixed]\nindices = [0]\n[[drag]]\npoint = [0.0, 0.0, 0.0]\nstiffness = 1.0\npath = [{{ t = 0.0, offset = [0, 0, 0] }}]\n{RUN}"
        ),
    );
    let out = dir.path().join("out");
    let result = simulate(&file, &out, &[]);
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("drag[0].point") && stderr.contains("fixed"),
        "{stderr}"
    );
    assert!(!out.exists());
}
