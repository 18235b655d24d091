//! `softbench simulate`: every shipped scene runs with every method; a method that blows up
//! ends with the step, time and cause and exit code 1, never a panic or a truncated CSV; bad
//! input is exit code 2 with nothing written.

mod common;

use common::{scene, simulate, softbench};

use common::TempDir;
use std::path::Path;

const TRAJECTORY_HEADER: &str = "step,t,dt,kinetic,elastic,gravity,total,momentum_x,momentum_y,momentum_z,newton_iterations,linear_iterations,wall_seconds";

fn methods() -> Vec<String> {
    softbench::integrate::Method::all()
        .iter()
        .map(|m| m.name().to_owned())
        .collect()
}

/// Run `scene` with `method` for `steps` steps and check the outputs are complete and honest.
/// Adaptive methods cover a short interval: on the stiff course meshes they need thousands
/// of internal steps per 0.01 s (which is what they are for, but not what this test checks).
fn check_run(scene_file: &Path, method: &str, steps: usize, dir: &TempDir) {
    let out = dir.path().join(method);
    let out_str = out.to_str().unwrap();
    let steps_set = format!("run.steps={steps}");
    let method_set = format!("integrator.method={method}");
    let mut args = vec![
        "simulate",
        scene_file.to_str().unwrap(),
        "--out",
        out_str,
        "--set",
        &method_set,
        "--set",
        &steps_set,
    ];
    let entry = softbench::integrate::Method::from_name(method).unwrap();
    if entry.is_adaptive() {
        args.extend(["--set", "run.dt=1e-4"]);
    }
    // An implicit method's velocity estimate carries Newton's residual divided by the stage's
    // step: at the default atol (1e-9 m/s) a resting 165-unit bunny needs internal steps
    // below 1e-9 s, each with a factorization. An atol at the scene's scale is what a user
    // sets (docs/integrators.md).
    if entry.is_adaptive() && !entry.is_explicit() {
        args.extend(["--set", "integrator.adaptive.absolute_tolerance=1e-4"]);
    }
    // Projective dynamics has one energy, corotated elasticity, and refuses other materials.
    if method == "projective-dynamics" {
        args.extend(["--set", "material.model=corotated"]);
    }
    // XPBD likewise converges to the energy of its constraints only, with lumped mass.
    if method == "xpbd" {
        args.extend(["--set", "material.model=xpbd-neo-hookean"]);
        args.extend(["--set", "material.mass=lumped"]);
    }
    let result = softbench(&args);
    let code = result.status.code();
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        matches!(code, Some(0) | Some(1)),
        "{method}: exit {code:?} (a panic is 101): {stderr}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let outcome = &summary["summary"]["outcome"];
    let completed = summary["summary"]["steps_completed"].as_u64().unwrap() as usize;
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let mut lines = csv.lines();
    assert!(
        lines.next().unwrap().starts_with(TRAJECTORY_HEADER),
        "{method}: header"
    );
    let rows: Vec<&str> = lines.collect();
    assert!(!out.join("trajectory.csv.partial").exists());
    match code {
        Some(0) => {
            assert_eq!(outcome["status"], "completed", "{method}");
            assert_eq!(
                rows.len(),
                steps + 1,
                "{method}: one row per step plus step 0"
            );
            let positions = std::fs::read_to_string(out.join("final_positions.csv")).unwrap();
            assert!(positions.starts_with("vertex,x,y,z\n"));
        }
        _ => {
            let status = outcome["status"].as_str().unwrap();
            assert!(
                ["unstable", "left-material-domain", "solver-failed"].contains(&status),
                "{method}: outcome {status}"
            );
            let cause = outcome["cause"].as_str().unwrap();
            let allowed = [
                "non-finite state",
                "inverted element",
                "energy growth",
                "newton failure",
                "solver failure",
                "step too small",
                "too many substeps",
            ];
            assert!(allowed.contains(&cause), "{method}: cause {cause}");
            assert!(
                stderr.contains(&format!("ended {status} at step")) && stderr.contains(cause),
                "{method}: {stderr}"
            );
            // Every row is a valid state: step 0 through the last completed (and sampled) step.
            let last: usize = rows
                .last()
                .unwrap()
                .split(',')
                .next()
                .unwrap()
                .parse()
                .unwrap();
            assert!(
                last <= completed && !rows.is_empty(),
                "{method}: rows end at {last}, completed {completed}"
            );
            assert!(rows.iter().all(|r| {
                r.split(',')
                    .all(|f| f.parse::<f64>().map_or(true, f64::is_finite))
            }));
        }
    }
}

#[test]
fn the_cantilever_runs_with_every_method() {
    let dir = TempDir::new("simulate-cantilever");
    for method in methods() {
        check_run(&scene("cantilever.toml"), &method, 4, &dir);
    }
}

#[test]
fn the_course_armadillo_and_bunny_run_with_every_method() {
    for (name, mesh) in [
        ("armadillo.toml", "arma_6.node"),
        ("bunny.toml", "coarser_bunny.mesh"),
    ] {
        if common::reference_mesh(mesh).is_none() {
            return;
        }
        let dir = TempDir::new("simulate-course");
        for method in methods() {
            check_run(&scene(name), &method, 3, &dir);
        }
    }
}

#[test]
fn explicit_methods_blow_up_on_the_armadillo_at_the_course_step_and_say_why() {
    if common::reference_mesh("arma_6.node").is_none() {
        return;
    }
    let dir = TempDir::new("simulate-blowup");
    let out = dir.path().join("out");
    let result = simulate(
        &scene("armadillo.toml"),
        &out,
        &[
            "--set",
            "integrator.method=symplectic-euler",
            "--set",
            "run.steps=50",
        ],
    );
    assert_eq!(result.status.code(), Some(1));
    // Its first step gains far more than the body holds; a blow-up is growth, which one step
    // cannot show, and the second step inverts an element (det F of order -1e10).
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        stderr.contains("ended unstable at step")
            || stderr.contains("ended left-material-domain at step 2"),
        "{stderr}"
    );
}

#[test]
fn unknown_method_is_bad_input_with_a_suggestion_and_nothing_is_written() {
    let dir = TempDir::new("simulate-bad-method");
    let out = dir.path().join("out");
    let result = simulate(
        &scene("cantilever.toml"),
        &out,
        &["--set", "integrator.method=rk5"],
    );
    assert_eq!(result.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        stderr.contains("did you mean `rk4`?") && stderr.contains("backward-euler"),
        "{stderr}"
    );
    assert!(!out.exists(), "nothing may be written for bad input");
}

#[test]
fn unknown_key_names_the_file_and_line_and_the_valid_keys() {
    let dir = TempDir::new("simulate-bad-key");
    let file = dir.write(
        "scene.toml",
        "[mesh]\ngenerate = { box = [1, 1, 1], size = [1.0, 1.0, 1.0] }\n\n[run]\ndt = 0.01\nstep = 10\n",
    );
    let out = dir.path().join("out");
    let result = simulate(&file, &out, &[]);
    assert_eq!(result.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        stderr.contains("scene.toml") && stderr.contains("line 6") && stderr.contains("`steps`"),
        "{stderr}"
    );
    assert!(!out.exists());
}

#[test]
fn invalid_values_and_missing_meshes_are_bad_input() {
    let dir = TempDir::new("simulate-bad-values");
    let cases = [
        (
            "[mesh]\ngenerate = { box = [1, 1, 1], size = [1.0, 1.0, 1.0] }\n[run]\ndt = -0.01\nsteps = 10\n",
            "run.dt",
        ),
        (
            "[mesh]\nfile = \"no-such-mesh.mesh\"\n[run]\ndt = 0.01\nsteps = 10\n",
            "no-such-mesh.mesh",
        ),
        (
            "[mesh]\ngenerate = { box = [1, 1, 1], size = [1.0, 1.0, 1.0] }\n[material]\nyoungs_modulus = 1e5\npoisson_ratio = 0.5\ndensity = 1.0\n[run]\ndt = 0.01\nsteps = 10\n",
            "poisson_ratio",
        ),
        (
            "[mesh]\ngenerate = { box = [1, 1, 1], size = [1.0, 1.0, 1.0] }\n[material]\nyoungs_modulus = 1e5\npoisson_ratio = 0.3\ndensity = -1.0\n[run]\ndt = 0.01\nsteps = 10\n",
            "density",
        ),
    ];
    for (i, (text, needle)) in cases.iter().enumerate() {
        let file = dir.write(&format!("scene{i}.toml"), text);
        let out = dir.path().join(format!("out{i}"));
        let result = simulate(&file, &out, &[]);
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "case {i}: {stderr}");
        assert!(
            stderr.contains(needle),
            "case {i}: expected `{needle}` in: {stderr}"
        );
        assert!(!out.exists(), "case {i}: nothing may be written");
    }
}

#[test]
fn set_overrides_reach_the_run() {
    let dir = TempDir::new("simulate-set");
    let out = dir.path().join("out");
    let result = simulate(
        &scene("cantilever.toml"),
        &out,
        &[
            "--set",
            "integrator.method=implicit-midpoint",
            "--set",
            "run.dt=5e-3",
            "--set",
            "run.steps=4",
            "--set",
            "run.sample_every=2",
        ],
    );
    assert_eq!(
        result.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["summary"]["method"], "implicit-midpoint");
    assert_eq!(summary["summary"]["dt"], 5e-3);
    let rows = std::fs::read_to_string(out.join("trajectory.csv"))
        .unwrap()
        .lines()
        .count();
    assert_eq!(rows, 1 + 3, "header plus steps 0, 2, 4");
}

#[test]
fn damping_from_the_scene_file_removes_energy() {
    let dir = TempDir::new("simulate-damping");
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "simulate",
            scene_path_str(),
            "--out",
            out.to_str().unwrap(),
            "--set",
            "integrator.method=implicit-midpoint",
            "--set",
            "run.steps=60",
        ];
        args.extend_from_slice(extra);
        let result = softbench(&args);
        assert_eq!(
            result.status.code(),
            Some(0),
            "{}",
            String::from_utf8_lossy(&result.stderr)
        );
        let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
        let total = |line: &str| line.split(',').nth(6).unwrap().parse::<f64>().unwrap();
        let lines: Vec<&str> = csv.lines().skip(1).collect();
        total(lines[0]) - total(lines[lines.len() - 1])
    };
    let undamped_loss = run("undamped", &[]);
    let damped_loss = run(
        "damped",
        &[
            "--set",
            "damping.strain_rate={ phi = 2000.0, psi = 2000.0 }",
        ],
    );
    assert!(
        damped_loss > 10.0 * undamped_loss.abs(),
        "damped loss {damped_loss:.3e} vs undamped {undamped_loss:.3e}"
    );
}

fn scene_path_str() -> &'static str {
    static PATH: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    PATH.get_or_init(|| scene("cantilever.toml").to_str().unwrap().to_owned())
}

#[test]
fn every_shipped_scene_runs_a_few_steps() {
    let dir = TempDir::new("simulate-every-scene");
    let mut scenes: Vec<_> = std::fs::read_dir(scene(""))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    scenes.sort();
    assert!(
        scenes.len() >= 10,
        "expected the shipped scenes, found {scenes:?}"
    );
    let data_set = std::env::var_os("SOFTBENCH_DATA").is_some();
    for path in scenes {
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        let out = dir.path().join(&name);
        let result = simulate(&path, &out, &["--set", "run.steps=3"]);
        let stderr = String::from_utf8_lossy(&result.stderr);
        if !data_set && result.status.code() == Some(2) && stderr.contains("SOFTBENCH_DATA") {
            use std::io::Write;
            let _ = writeln!(
                std::io::stderr(),
                "skipped: {name}: needs a reference mesh and SOFTBENCH_DATA is not set"
            );
            continue;
        }
        assert_eq!(result.status.code(), Some(0), "{name}: {stderr}");
    }
}

#[test]
fn constrained_contact_with_damping_runs_and_reports_no_penetration() {
    // The constraints live in the one Newton loop, whose objective carries the damping term:
    // the combination the first version had to refuse now runs.
    let dir = TempDir::new("simulate-constrained-damping");
    let out = dir.path().join("out");
    let result = simulate(
        &scene("ball-drop.toml"),
        &out,
        &[
            "--set",
            "contact.response=constrained",
            "--set",
            "damping.strain_rate={ phi = 1.0, psi = 1.0 }",
            "--set",
            "run.steps=20",
            "--set",
            "run.sample_every=1",
        ],
    );
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(0), "{stderr}");
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (penetration, qp) = (column("max_penetration"), column("qp_solves"));
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| {
            l.split(',')
                .map(|x| {
                    if x.is_empty() {
                        f64::NAN
                    } else {
                        x.parse().unwrap()
                    }
                })
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 21, "every step sampled");
    assert!(
        rows.iter().all(|r| r[penetration] <= 1e-8),
        "no penetration"
    );
    assert!(
        rows.iter().any(|r| r[qp] > 0.0),
        "the drop reaches the ground"
    );
}
