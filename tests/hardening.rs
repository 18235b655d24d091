//! Issue 13: a hostile or careless user. Each test is named after one reproducer of the issue
//! and checks it now gives a clear error (exit 2, nothing written), a clean stop, or correct
//! output.

mod common;

use common::{TempDir, run_study, scene, simulate, softbench};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The generated beam (no data needed), with `steps` steps.
fn beam(steps: usize) -> String {
    format!(
        r#"
[mesh]
generate = {{ box = [4, 1, 1], size = [1.0, 0.25, 0.25] }}
[material]
model = "stable-neo-hookean"
youngs_modulus = 1e4
poisson_ratio = 0.3
density = 100.0
[fixed]
rule = {{ axis = "x", side = "min", tolerance = 1e-6 }}
[forces]
gravity = [0.0, -9.81, 0.0]
[integrator]
method = "backward-euler"
[run]
dt = 0.001
steps = {steps}
"#
    )
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts exit code 2 with every one of `expect` in stderr.
#[track_caller]
fn assert_bad_input(o: &std::process::Output, expect: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    for e in expect {
        assert!(err.contains(e), "expected `{e}` in: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

fn spawn(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_softbench"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot start softbench")
}

/// Waits (generously) until `ready` holds; panics after two minutes.
fn wait_for(what: &str, mut ready: impl FnMut() -> bool) {
    let start = Instant::now();
    while !ready() {
        assert!(start.elapsed() < Duration::from_secs(120), "never: {what}");
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn send(child: &Child, signal: i32) {
    // SAFETY: kill(2) on our own child's pid.
    let rc = unsafe { libc::kill(child.id() as libc::pid_t, signal) };
    assert_eq!(rc, 0, "cannot signal softbench");
}

/// Every line of a CSV file has as many cells as its header, and it ends with a newline.
#[track_caller]
fn assert_whole_csv(path: &Path, rows: usize) {
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.ends_with('\n'), "{} is cut short", path.display());
    let mut lines = text.lines();
    let width = lines.next().unwrap().split(',').count();
    let mut n = 0;
    for line in lines {
        assert_eq!(
            line.split(',').count(),
            width,
            "ragged line in {}",
            path.display()
        );
        n += 1;
    }
    assert_eq!(n, rows, "{} rows in {}", n, path.display());
}

// 1. Two writers, one folder.

#[test]
fn two_simulates_into_one_folder_never_commit_a_ragged_file() {
    let tmp = TempDir::new("two-sim");
    let path = tmp.write("beam.toml", &beam(400));
    let out = tmp.path().join("out");
    let args = [
        "simulate",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    for _ in 0..3 {
        let (a, b) = (spawn(&args), spawn(&args));
        let pids = [a.id(), b.id()];
        let outputs = [a.wait_with_output().unwrap(), b.wait_with_output().unwrap()];
        for (i, o) in outputs.iter().enumerate() {
            if !o.status.success() {
                // The loser stops at once, naming the holder.
                let err = stderr(o);
                assert_eq!(o.status.code(), Some(1), "{err}");
                assert!(
                    err.contains(&format!("in use by softbench pid {}", pids[1 - i])),
                    "{err}"
                );
            }
        }
        assert!(outputs.iter().any(|o| o.status.success()));
        assert_whole_csv(&out.join("trajectory.csv"), 401);
        assert!(
            !out.join(".softbench.lock").exists(),
            "the lock was not released"
        );
    }
}

#[test]
fn two_studies_into_one_folder_wait_for_each_other_with_wait() {
    let tmp = TempDir::new("two-run");
    tmp.write("beam.toml", &beam(300));
    let study = tmp.write(
        "study.toml",
        r#"name = "both"
study = "trajectory"
scenes = ["beam.toml"]
[grid]
"integrator.method" = ["symplectic-euler", "rk4", "backward-euler", "implicit-midpoint", "bdf2", "midpoint"]
"#,
    );
    let out = tmp.path().join("results");
    let base = [
        "run",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--wait",
    ];
    let with = |only: &'static str| {
        let mut a = base.to_vec();
        a.extend(["--only", only]);
        a
    };
    let (a, b) = (spawn(&with("euler")), spawn(&with("mid")));
    for o in [a.wait_with_output().unwrap(), b.wait_with_output().unwrap()] {
        assert!(o.status.success(), "{}", stderr(&o));
    }
    // Both halves are in runs.csv: symplectic-euler, backward-euler (euler); implicit-midpoint,
    // midpoint (mid).
    assert_whole_csv(&out.join("both/runs.csv"), 4);
}

// 2. A study named `..` or `.`.

/// A one-run trajectory study of the beam named `name`, written into `tmp`.
fn study_named(tmp: &TempDir, name: &str) -> std::path::PathBuf {
    tmp.write("beam.toml", &beam(5));
    tmp.write(
        "study.toml",
        &format!(
            "name = \"{name}\"\nstudy = \"trajectory\"\nscenes = [\"beam.toml\"]\n[grid]\n\
             \"integrator.method\" = [\"rk4\"]\n"
        ),
    )
}

#[test]
fn a_study_named_dot_dot_or_dot_is_refused_and_writes_nothing() {
    for name in ["..", "."] {
        let tmp = TempDir::new("dotdot");
        let study = study_named(&tmp, name);
        let out = tmp.path().join("deep/results");
        let o = run_study(&study, &out, &[]);
        assert_bad_input(&o, &["name", "must not start with '.'"]);
        assert!(!tmp.path().join("deep").exists());
    }
}

// 3. A crafted TetGen header.

/// Four TetGen points, the corners of the unit tet.
const TETGEN_NODE: &str = "4 3 0 0\n0 0 0 0\n1 1 0 0\n2 0 1 0\n3 0 0 1\n";

#[test]
fn a_tetgen_attribute_count_that_wraps_is_an_error_not_a_panic() {
    let tmp = TempDir::new("tetgen-wrap");
    tmp.write("b.node", TETGEN_NODE);
    tmp.write("b.ele", "1 4 18446744073709551614\n0 0 1\n");
    let node = tmp.path().join("b.node");
    let o = softbench(&["mesh-info", node.to_str().unwrap()]);
    assert_bad_input(&o, &["b.ele:1", "attributes"]);
    let scene = tmp.write(
        "s.toml",
        "[mesh]\nfile = \"b.node\"\n[material]\nyoungs_modulus = 1e4\npoisson_ratio = 0.3\n\
         density = 1.0\n[run]\ndt = 0.01\nsteps = 1\n",
    );
    let o = simulate(&scene, &tmp.path().join("out"), &[]);
    assert_bad_input(&o, &["b.ele:1"]);
    assert!(!tmp.path().join("out").exists());
}

#[test]
fn a_tetgen_ele_header_with_a_fourth_field_is_refused() {
    let tmp = TempDir::new("tetgen-four");
    tmp.write("b.node", TETGEN_NODE);
    tmp.write("b.ele", "1 4 0 7\n0 0 1 2 3\n");
    let o = softbench(&["mesh-info", tmp.path().join("b.ele").to_str().unwrap()]);
    assert_bad_input(&o, &["b.ele:1", "found 4 fields"]);
}

// 4. Numbers that abort.

#[test]
fn absurd_sizes_are_errors_naming_the_number_the_limit_and_the_variable() {
    let cases = [
        ("run.steps=1000000000000", "SOFTBENCH_MAX_STEPS"),
        (
            "mesh.generate={box=[1000,1000,1000],size=[1,1,1]}",
            "SOFTBENCH_MAX_MESH",
        ),
        ("mesh.generate={ball=100000,radius=1}", "SOFTBENCH_MAX_MESH"),
        (
            "mesh.generate={box=[9223372036854775807,1,1],size=[1,1,1]}",
            "more than 2^64",
        ),
    ];
    let tmp = TempDir::new("sizes");
    let path = tmp.write("beam.toml", &beam(5));
    let out = tmp.path().join("out");
    for (set, expect) in cases {
        let o = simulate(&path, &out, &["--set", set]);
        assert_bad_input(&o, &[expect, "above the limit"]);
        assert!(!out.exists(), "{set}: something was written");
    }
    let o = simulate(&scene("jello_cube.toml"), &out, &["--set", "jello.n=3000"]);
    assert_bad_input(&o, &["jello.n", "27000000000", "SOFTBENCH_MAX_MESH"]);
}

#[test]
fn a_tiny_file_announcing_a_trillion_vertices_is_refused_before_allocating() {
    let tmp = TempDir::new("trillion");
    let medit = tmp.write(
        "big.mesh",
        "MeshVersionFormatted 1\nDimension 3\nVertices\n999999999999\n0 0 0 0\n",
    );
    let o = softbench(&["mesh-info", medit.to_str().unwrap()]);
    assert_bad_input(&o, &["big.mesh:4", "999999999999", "SOFTBENCH_MAX_MESH"]);
    tmp.write("t.node", "999999999999 3 0 0\n0 0 0 0\n");
    tmp.write("t.ele", "1 4 0\n0 0 1 2 3\n");
    let o = softbench(&["mesh-info", tmp.path().join("t.node").to_str().unwrap()]);
    assert_bad_input(&o, &["t.node:1", "SOFTBENCH_MAX_MESH"]);
}

#[test]
fn the_mesh_budget_can_be_raised_or_lowered_by_its_variable() {
    let tmp = TempDir::new("budget-var");
    let path = tmp.write("beam.toml", &beam(2));
    let o = Command::new(env!("CARGO_BIN_EXE_softbench"))
        .args(["simulate", path.to_str().unwrap(), "--out"])
        .arg(tmp.path().join("out"))
        .env("SOFTBENCH_MAX_MESH", "10")
        .output()
        .unwrap();
    assert_bad_input(&o, &["above the limit of 10"]);
}

// 5. relative_precision = 1e-300.

#[test]
fn a_stability_study_with_relative_precision_1e_300_is_refused() {
    let tmp = TempDir::new("precision");
    tmp.write("beam.toml", &beam(5));
    let study = tmp.write(
        "study.toml",
        r#"name = "prec"
study = "stability"
scenes = ["beam.toml"]
[grid]
"integrator.method" = ["rk4"]
[stability]
dt_min = 1e-5
dt_max = 0.1
horizon = 0.1
relative_precision = 1e-300
"#,
    );
    let o = run_study(&study, &tmp.path().join("results"), &[]);
    assert_bad_input(&o, &["stability.relative_precision", "1e-9"]);
}

// 6. Closed pipes.

#[test]
fn list_into_a_closed_pipe_ends_quietly() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_softbench"))
        .arg("list")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Close both ends we hold before softbench writes: every write fails with EPIPE.
    drop(child.stdout.take());
    drop(child.stderr.take());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(0), "{status:?}");
}

#[test]
fn a_study_whose_stderr_is_closed_still_finishes_and_writes_its_files() {
    let tmp = TempDir::new("closed-stderr");
    tmp.write("beam.toml", &beam(50));
    let study = tmp.write(
        "study.toml",
        r#"name = "pipe"
study = "trajectory"
scenes = ["beam.toml"]
[grid]
"integrator.method" = ["symplectic-euler", "rk4", "backward-euler"]
"#,
    );
    let out = tmp.path().join("results");
    let mut child = Command::new(env!("CARGO_BIN_EXE_softbench"))
        .args([
            "run",
            study.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    drop(child.stderr.take());
    let status = child.wait().unwrap();
    assert!(status.success(), "{status:?}");
    assert_whole_csv(&out.join("pipe/runs.csv"), 3);
    assert!(out.join("pipe/report.md").is_file());
}

// 7. Signals.

/// Starts a long simulate, waits until it is stepping, sends `signal`; returns the output.
fn simulate_and_signal(tmp: &TempDir, signal: i32) -> std::process::Output {
    let path = tmp.write("beam.toml", &beam(5_000_000));
    let out = tmp.path().join("out");
    let child = spawn(&[
        "simulate",
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    // Stepping once its temporary trajectory file exists and has grown past the first rows.
    wait_for("simulate writes rows", || {
        std::fs::read_dir(&out).is_ok_and(|entries| {
            entries.flatten().any(|e| {
                e.file_name()
                    .to_string_lossy()
                    .starts_with(".trajectory.csv.")
                    && e.metadata().is_ok_and(|m| m.len() > 20_000)
            })
        })
    });
    send(&child, signal);
    child.wait_with_output().unwrap()
}

#[test]
fn sigint_during_simulate_keeps_the_rows_and_reports_interrupted() {
    let tmp = TempDir::new("sigint");
    let o = simulate_and_signal(&tmp, libc::SIGINT);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(
        err.contains("stopped by SIGINT") && err.contains("run the same command"),
        "{err}"
    );
    let out = tmp.path().join("out");
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    assert!(summary.contains("\"status\": \"interrupted\""), "{summary}");
    let rows = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    assert!(rows.lines().count() > 10 && rows.ends_with('\n'));
    assert!(out.join("final_positions.csv").is_file());
    let left: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn sigterm_during_simulate_exits_143() {
    let tmp = TempDir::new("sigterm");
    let o = simulate_and_signal(&tmp, libc::SIGTERM);
    assert_eq!(o.status.code(), Some(143), "{}", stderr(&o));
    let summary = std::fs::read_to_string(tmp.path().join("out/summary.json")).unwrap();
    assert!(summary.contains("SIGTERM"));
}

#[test]
fn sigterm_during_a_study_keeps_finished_runs_and_the_next_run_resumes() {
    let tmp = TempDir::new("study-sigterm");
    tmp.write("beam.toml", &beam(20));
    tmp.write("long.toml", &beam(5_000_000));
    let study = tmp.write(
        "study.toml",
        r#"name = "stop"
study = "trajectory"
scenes = ["beam.toml", "long.toml"]
[grid]
"integrator.method" = ["rk4"]
"#,
    );
    let out = tmp.path().join("results");
    let child = spawn(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    // The short run is done once runs.csv exists; the long one then runs until the signal.
    wait_for("the first run is recorded", || {
        out.join("stop/runs.csv").is_file()
    });
    std::thread::sleep(Duration::from_millis(300));
    send(&child, libc::SIGTERM);
    let o = child.wait_with_output().unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(143), "{err}");
    assert!(
        err.contains("run the same command again to resume"),
        "{err}"
    );
    assert_whole_csv(&out.join("stop/runs.csv"), 1);
    assert!(!out.join("stop/.softbench.lock").exists());
    // Resume with the long run made short: the finished run is reused.
    tmp.write("long.toml", &beam(20));
    let o = run_study(&study, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("1 of 2 runs already complete"),
        "{}",
        stderr(&o)
    );
}

// 8. plot on a truncated runs.csv.

#[test]
fn plot_on_a_truncated_runs_csv_is_an_error_and_deletes_nothing() {
    let tmp = TempDir::new("plot-cut");
    tmp.write("beam.toml", &beam(20));
    let study = tmp.write(
        "study.toml",
        "name = \"cut\"\nstudy = \"trajectory\"\nscenes = [\"beam.toml\"]\n[grid]\n\
         \"integrator.method\" = [\"rk4\", \"backward-euler\"]\n",
    );
    let out = tmp.path().join("results");
    common::run_study_ok(&study, &out, &[]);
    let dir = out.join("cut");
    let pngs = |dir: &Path| {
        let mut v: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .filter(|n| n.to_string_lossy().ends_with(".png"))
            .collect();
        v.sort();
        v
    };
    let before = pngs(&dir);
    assert!(!before.is_empty());
    let runs = std::fs::read_to_string(dir.join("runs.csv")).unwrap();
    for cut in [20, runs.find('\n').unwrap() + 1, runs.len() - 3] {
        std::fs::write(dir.join("runs.csv"), &runs[..cut]).unwrap();
        let o = softbench(&["plot", dir.to_str().unwrap()]);
        assert_bad_input(&o, &["runs.csv"]);
        assert_eq!(pngs(&dir), before, "a plot was deleted (cut at {cut})");
    }
}

// 9. Smaller ones.

#[test]
fn density_or_gravity_near_1e160_is_refused() {
    let tmp = TempDir::new("huge-physics");
    let path = tmp.write("beam.toml", &beam(5));
    let out = tmp.path().join("out");
    let o = simulate(&path, &out, &["--set", "material.density=1e160"]);
    assert_bad_input(&o, &["material.density"]);
    let o = simulate(&path, &out, &["--set", "forces.gravity=[0.0,-1e160,0.0]"]);
    assert_bad_input(&o, &["forces.gravity"]);
    assert!(!out.exists());
}

#[test]
fn a_nan_fixed_box_is_refused() {
    let tmp = TempDir::new("nan-box");
    let path = tmp.write("beam.toml", &beam(5));
    let o = simulate(
        &path,
        &tmp.path().join("out"),
        &["--set", "fixed.box={min=[nan,0.0,0.0],max=[1.0,1.0,1.0]}"],
    );
    assert_bad_input(&o, &["fixed.box", "NaN"]);
}

/// A study over the beam with `extra` appended; asserts exit 2 mentioning `expect`.
fn assert_study_refused(extra: &str, expect: &[&str]) {
    let tmp = TempDir::new("small-study");
    tmp.write("beam.toml", &beam(5));
    let study = tmp.write(
        "study.toml",
        &format!("name = \"small\"\nstudy = \"trajectory\"\nscenes = [\"beam.toml\"]\n{extra}\n"),
    );
    let out = tmp.path().join("results");
    let o = run_study(&study, &out, &["--quick"]);
    assert_bad_input(&o, expect);
    assert!(!out.exists(), "something was written");
}

#[test]
fn quick_steps_0_is_refused() {
    assert_study_refused(
        "[grid]\n\"integrator.method\" = [\"rk4\"]\n[quick]\nsteps = 0",
        &["quick.steps"],
    );
}

#[test]
fn an_unknown_sweep_metric_is_refused() {
    let tmp = TempDir::new("sweep-metric");
    tmp.write("beam.toml", &beam(5));
    let study = tmp.write(
        "study.toml",
        r#"name = "sweep"
study = "sweep"
scenes = ["beam.toml"]
[grid]
"integrator.method" = ["rk4"]
"run.dt" = [0.01, 0.02]
[sweep]
kind = "trajectory"
parameter = "run.dt"
metrics = ["energy_drfit_max"]
"#,
    );
    let out = tmp.path().join("results");
    let o = run_study(&study, &out, &[]);
    assert_bad_input(&o, &["sweep.metrics", "did you mean `energy_drift_max`"]);
    assert!(!out.exists());
}

#[test]
fn coordinates_near_1e308_are_refused() {
    let tmp = TempDir::new("huge-coords");
    let path = tmp.write(
        "huge.mesh",
        "v 1e308 0 0\nv 0 1e308 0\nv 0 0 1e308\nv 0 0 0\nt 0 1 2 3\n",
    );
    let o = softbench(&["mesh-info", path.to_str().unwrap()]);
    assert_bad_input(&o, &["huge.mesh:1", "1e50"]);
}

#[test]
fn a_300_character_study_name_is_refused_before_anything_is_created() {
    let name = "a".repeat(300);
    let tmp = TempDir::new("long-name");
    let study = study_named(&tmp, &name);
    let out = tmp.path().join("results");
    let o = run_study(&study, &out, &[]);
    assert_bad_input(&o, &["name", "300 characters"]);
    assert!(!out.exists());
}

#[test]
fn a_million_run_grid_is_refused_at_once() {
    let tmp = TempDir::new("big-grid");
    tmp.write("beam.toml", &beam(5));
    let values: Vec<String> = (1..=1000).map(|i| format!("{}.0", i)).collect();
    let study = tmp.write(
        "study.toml",
        &format!(
            "name = \"grid\"\nstudy = \"trajectory\"\nscenes = [\"beam.toml\"]\n[grid]\n\
             \"integrator.method\" = [\"rk4\"]\n\"material.density\" = [{v}]\n\
             \"material.youngs_modulus\" = [{v}]\n",
            v = values.join(", ")
        ),
    );
    let o = run_study(&study, &tmp.path().join("results"), &[]);
    assert_bad_input(&o, &["1000000", "SOFTBENCH_MAX_RUNS"]);
}

#[test]
fn an_error_about_proc_self_environ_quotes_only_a_short_line() {
    let environ = Path::new("/proc/self/environ");
    if !environ.exists() {
        return;
    }
    let tmp = TempDir::new("environ");
    let o = Command::new(env!("CARGO_BIN_EXE_softbench"))
        .args(["simulate", "/proc/self/environ", "--out"])
        .arg(tmp.path().join("out"))
        .env("SOFTBENCH_SECRET_MARKER", "x".repeat(500))
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        !err.contains(&"x".repeat(100)),
        "the environment was echoed: {err}"
    );
    assert!(err.lines().all(|l| l.chars().count() <= 400), "{err}");
}
