//! Issue 25 (hardening II), the runs' side: budgets on every size a config can set, checked
//! at load; non-finite numbers never pass as a completed run; signals honoured inside long
//! work; a lock file that cannot be parsed reported at once; `--export` never following a
//! planted `frames` link; a file-size limit reported; a closed pipe ending quietly. Each test
//! is one reproducer of the issue.

mod common;

use common::{TempDir, run_study, simulate};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// A generated beam (no data needed) with `extra` appended to the scene.
fn beam(method: &str, dt: &str, steps: usize, extra: &str) -> String {
    format!(
        r#"
[mesh]
generate = {{ box = [4, 1, 1], size = [1.0, 0.25, 0.25] }}
[material]
model = "stable-neo-hookean"
youngs_modulus = 1e4
poisson_ratio = 0.3
density = 100.0
[integrator]
method = "{method}"
[run]
dt = {dt}
steps = {steps}
{extra}
"#
    )
}

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts exit code 2 with every one of `expect` in stderr, and that `out` holds nothing.
#[track_caller]
fn assert_refused(o: &std::process::Output, out: &Path, expect: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    for e in expect {
        assert!(err.contains(e), "expected `{e}` in: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
    let written: Vec<_> = std::fs::read_dir(out)
        .map(|d| d.flatten().map(|e| e.file_name()).collect())
        .unwrap_or_default();
    assert!(written.is_empty(), "{} holds {written:?}", out.display());
}

/// `summary.json`'s outcome status.
fn status(out: &Path) -> String {
    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    json["summary"]["outcome"]["status"]
        .as_str()
        .unwrap()
        .to_owned()
}

fn spawn(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_softbench"))
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot start softbench")
}

fn send(child: &Child, signal: i32) {
    // SAFETY: kill(2) on our own child's pid.
    let rc = unsafe { libc::kill(child.id() as libc::pid_t, signal) };
    assert_eq!(rc, 0, "cannot signal softbench");
}

/// Waits for `child` at most `limit`; kills it and panics past that.
fn wait_at_most(mut child: Child, limit: Duration) -> std::process::Output {
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("softbench did not exit within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

fn wp_study(dt: &str, extra: &str) -> String {
    format!(
        "name = \"wp\"\nstudy = \"work-precision\"\nscenes = [\"beam.toml\"]\n[grid]\n\
         \"integrator.method\" = [\"symplectic-euler\"]\n\"run.dt\" = [{dt}]\n\
         [work-precision]\nhorizon = 0.01\nsamples = 2\n{extra}"
    )
}

// 1. Budgets, checked at load.

#[test]
fn a_work_precision_study_at_dt_1e_300_is_refused_at_once() {
    let tmp = TempDir::new("wp-dt");
    tmp.write("beam.toml", &beam("symplectic-euler", "0.001", 10, ""));
    let study = tmp.write("study.toml", &wp_study("1e-300", ""));
    let out = tmp.path().join("results");
    let start = Instant::now();
    let o = run_study(&study, &out, &[]);
    assert_refused(
        &o,
        &out,
        &["grid.\"run.dt\"", "100000000", "SOFTBENCH_MAX_STEPS"],
    );
    assert!(start.elapsed() < Duration::from_secs(30));
}

#[test]
fn a_work_precision_reference_of_1e10_steps_is_refused_at_load() {
    let tmp = TempDir::new("wp-ref");
    tmp.write("beam.toml", &beam("symplectic-euler", "0.001", 10, ""));
    // The runs are small; the reference at 1e-12 s would take 2e10 steps.
    let study = tmp.write(
        "study.toml",
        &wp_study(
            "0.001",
            "[work-precision.reference]\nmethod = \"rk4\"\ndt = 1e-12\n",
        ),
    );
    let out = tmp.path().join("results");
    let o = run_study(&study, &out, &[]);
    assert_refused(
        &o,
        &out,
        &["work-precision.reference.dt", "SOFTBENCH_MAX_STEPS"],
    );
}

#[test]
fn stability_error_samples_1e12_is_refused_at_load() {
    let tmp = TempDir::new("stab-samples");
    tmp.write("beam.toml", &beam("rk4", "0.001", 10, ""));
    let study = tmp.write(
        "study.toml",
        "name = \"st\"\nstudy = \"stability\"\nscenes = [\"beam.toml\"]\n[grid]\n\
         \"integrator.method\" = [\"rk4\"]\n[stability]\ndt_min = 1e-4\ndt_max = 0.005\n\
         horizon = 0.1\nerror_samples = 1000000000000\n",
    );
    let out = tmp.path().join("results");
    let o = run_study(&study, &out, &[]);
    assert_refused(
        &o,
        &out,
        &["stability.error_samples", "10000", "SOFTBENCH_MAX_SAMPLES"],
    );
}

#[test]
fn stability_max_steps_beyond_the_step_budget_is_refused() {
    let tmp = TempDir::new("stab-steps");
    tmp.write("beam.toml", &beam("rk4", "0.001", 10, ""));
    let study = tmp.write(
        "study.toml",
        "name = \"st\"\nstudy = \"stability\"\nscenes = [\"beam.toml\"]\n[grid]\n\
         \"integrator.method\" = [\"rk4\"]\n[stability]\ndt_min = 1e-4\ndt_max = 0.005\n\
         horizon = 0.1\nerror_samples = 0\nmax_steps = 1000000000000\n",
    );
    let out = tmp.path().join("results");
    let o = run_study(&study, &out, &[]);
    assert_refused(&o, &out, &["stability.max_steps", "SOFTBENCH_MAX_STEPS"]);
}

#[test]
fn iteration_and_substep_counts_up_to_u32_max_are_refused() {
    for (method, table, key) in [
        (
            "vbd",
            "vbd = { iterations = 4294967295 }",
            "integrator.vbd.iterations",
        ),
        (
            "xpbd",
            "xpbd = { substeps = 4294967295 }",
            "integrator.xpbd.substeps",
        ),
        (
            "projective-dynamics",
            "projective_dynamics = { iterations = 4294967295 }",
            "integrator.projective_dynamics.iterations",
        ),
        (
            "backward-euler",
            "newton = { max_iterations = 4294967295 }",
            "integrator.newton.max_iterations",
        ),
    ] {
        let tmp = TempDir::new("iterations");
        let scene = beam(method, "0.001", 10, "").replace(
            &format!("method = \"{method}\""),
            &format!("method = \"{method}\"\n{table}"),
        );
        let scene = tmp.write("beam.toml", &scene);
        let out = tmp.path().join("out");
        let o = simulate(&scene, &out, &[]);
        assert_refused(&o, &out, &[key, "1000000", "SOFTBENCH_MAX_ITERATIONS"]);
    }
}

// 2. Non-finite is never success.

#[test]
fn a_speed_whose_kinetic_energy_overflows_is_an_input_error() {
    // The armadillo spun at 1e200 rad/s, on a generated beam: the kinetic energy is inf.
    let tmp = TempDir::new("spin");
    let scene = tmp.write(
        "spin.toml",
        &beam(
            "backward-euler",
            "0.001",
            10,
            "[initial]\nangular_velocity = [0.0, 0.0, 1e200]\n",
        ),
    );
    let out = tmp.path().join("out");
    let o = simulate(&scene, &out, &[]);
    assert_refused(&o, &out, &["initial.angular_velocity", "kinetic energy"]);
}

#[test]
fn a_drag_offset_of_1e308_is_refused() {
    let tmp = TempDir::new("drag");
    let scene = tmp.write(
        "drag.toml",
        &beam(
            "backward-euler",
            "0.001",
            10,
            "[[drag]]\npoint = [1.0, 0.25, 0.25]\nradius = 0.1\nstiffness = 1e5\npath = [\
             { t = 0.0, offset = [0.0, 0.0, 0.0] }, { t = 0.001, offset = [1e308, 0.0, 0.0] }]\n",
        ),
    );
    let out = tmp.path().join("out");
    let o = simulate(&scene, &out, &[]);
    assert_refused(&o, &out, &["drag", "1e50", "1e308"]);
}

#[test]
fn an_infinite_energy_is_unstable_even_with_the_blow_up_check_off() {
    // A drag whose energy overflows (stiffness 1e300 pulled 1e10 m) with energy_limit = 0:
    // this used to end `completed`, exit 0, with inf in trajectory.csv.
    let tmp = TempDir::new("inf-energy");
    let scene = tmp.write(
        "drag.toml",
        &beam(
            "backward-euler",
            "0.0001",
            20,
            "energy_limit = 0\n[[drag]]\npoint = [1.0, 0.25, 0.25]\nradius = 0.1\n\
             stiffness = 1e300\npath = [{ t = 0.0, offset = [0.0, 0.0, 0.0] }, \
             { t = 0.001, offset = [1e10, 0.0, 0.0] }]\n",
        ),
    );
    let out = tmp.path().join("out");
    let o = simulate(&scene, &out, &[]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(status(&out), "unstable");
    let err = stderr(&o);
    assert!(err.contains("at step 1") && err.contains("inf"), "{err}");
}

#[test]
fn a_time_step_of_1e300_is_refused_or_unstable_never_completed() {
    let tmp = TempDir::new("dt-1e300");
    // The time itself overflows (1e306 s x 1000 steps): refused at load.
    let scene = tmp.write("far.toml", &beam("symplectic-euler", "1e306", 1000, ""));
    let out = tmp.path().join("far");
    assert_refused(&simulate(&scene, &out, &[]), &out, &["run.dt", "overflows"]);
    // A finite horizon of absurd steps under gravity: the state overflows at step 1.
    let scene = tmp.write(
        "fall.toml",
        &beam(
            "symplectic-euler",
            "1e300",
            5,
            "[forces]\ngravity = [0.0, -9.81, 0.0]\n",
        ),
    );
    for limit in ["1e3", "0"] {
        let out = tmp.path().join(format!("fall-{limit}"));
        let o = simulate(
            &scene,
            &out,
            &["--set", &format!("run.energy_limit={limit}")],
        );
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert_eq!(status(&out), "unstable");
        assert!(stderr(&o).contains("at step 1"), "{}", stderr(&o));
    }
}

// 4. A robust lock.

#[test]
fn an_empty_or_garbage_lock_is_reported_at_once() {
    for content in [&b""[..], b"garbage\x01\xff"] {
        let tmp = TempDir::new("lock");
        let scene = tmp.write("beam.toml", &beam("symplectic-euler", "0.001", 5, ""));
        let out = tmp.path().join("out");
        std::fs::create_dir_all(&out).unwrap();
        std::fs::write(out.join(".softbench.lock"), content).unwrap();
        let start = Instant::now();
        let o = simulate(&scene, &out, &[]);
        assert!(start.elapsed() < Duration::from_secs(20));
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.contains("not a lock softbench can read") && err.contains("remove"),
            "{err}"
        );
        assert!(!out.join("trajectory.csv").exists());
    }
}

#[test]
fn with_wait_a_garbage_lock_says_what_it_waits_for_and_ends_once_removed() {
    let tmp = TempDir::new("lock-wait");
    let scene = tmp.write("beam.toml", &beam("symplectic-euler", "0.001", 5, ""));
    let out = tmp.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    let lock = out.join(".softbench.lock");
    std::fs::write(&lock, "garbage").unwrap();
    let child = spawn(&[
        "simulate",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--wait",
    ]);
    std::thread::sleep(Duration::from_secs(3));
    std::fs::remove_file(&lock).unwrap();
    let o = wait_at_most(child, Duration::from_secs(60));
    let err = stderr(&o);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("waiting for") && err.contains("not a lock softbench can read"),
        "{err}"
    );
    assert!(out.join("trajectory.csv").exists());
}

#[test]
fn the_step_budget_variable_also_bounds_study_runs() {
    // The same shape as the other budgets: the variable lowers the limit and is named.
    let tmp = TempDir::new("wp-budget");
    tmp.write("beam.toml", &beam("symplectic-euler", "0.001", 10, ""));
    let study = tmp.write("study.toml", &wp_study("0.0001", ""));
    let out = tmp.path().join("results");
    let o = Command::new(env!("CARGO_BIN_EXE_softbench"))
        .args([
            "run",
            study.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .env("SOFTBENCH_MAX_STEPS", "50")
        .output()
        .unwrap();
    assert_refused(&o, &out, &["grid.\"run.dt\"", "50", "SOFTBENCH_MAX_STEPS"]);
}

// 3. Signals inside long work.

/// A beam whose single VBD step takes minutes: a million iterations per step.
fn slow_vbd() -> String {
    beam(
        "vbd",
        "0.001",
        100,
        "[forces]\ngravity = [0.0, -9.81, 0.0]\n",
    )
    .replace("box = [4, 1, 1]", "box = [8, 4, 4]")
    .replace(
        "method = \"vbd\"",
        "method = \"vbd\"\nvbd = { iterations = 1000000 }",
    )
}

#[test]
fn sigterm_inside_a_step_of_a_million_vbd_iterations_stops_it_at_once() {
    for (signal, code) in [(libc::SIGTERM, 143), (libc::SIGINT, 130)] {
        let tmp = TempDir::new("sig-vbd");
        let scene = tmp.write("vbd.toml", &slow_vbd());
        let out = tmp.path().join("out");
        let child = spawn(&[
            "simulate",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        std::thread::sleep(Duration::from_millis(1500));
        send(&child, signal);
        let sent = Instant::now();
        let o = wait_at_most(child, Duration::from_secs(60));
        assert!(
            sent.elapsed() < Duration::from_secs(10),
            "{:?}",
            sent.elapsed()
        );
        assert_eq!(o.status.code(), Some(code), "{}", stderr(&o));
        assert_eq!(status(&out), "interrupted");
        assert!(stderr(&o).contains("during step 1"), "{}", stderr(&o));
    }
}

#[test]
fn a_second_signal_exits_at_once_with_a_message() {
    let tmp = TempDir::new("sig-twice");
    let scene = tmp.write("vbd.toml", &slow_vbd());
    let out = tmp.path().join("out");
    let child = spawn(&[
        "simulate",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    std::thread::sleep(Duration::from_millis(1500));
    send(&child, libc::SIGTERM);
    send(&child, libc::SIGINT);
    let o = wait_at_most(child, Duration::from_secs(60));
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("second stop signal"), "{err}");
}

#[test]
fn sigterm_during_a_studys_reference_stops_it_at_once() {
    let tmp = TempDir::new("sig-ref");
    tmp.write("beam.toml", &slow_vbd());
    // The runs are VBD; the reference (backward Euler at 1e-6 s, 2 x 10^4 steps) is long.
    let study = tmp.write(
        "study.toml",
        &wp_study(
            "0.001",
            "[work-precision.reference]\nmethod = \"backward-euler\"\ndt = 1e-6\n",
        ),
    );
    let out = tmp.path().join("results");
    let child = spawn(&[
        "run",
        study.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    std::thread::sleep(Duration::from_millis(2500));
    send(&child, libc::SIGTERM);
    let sent = Instant::now();
    let o = wait_at_most(child, Duration::from_secs(60));
    assert!(
        sent.elapsed() < Duration::from_secs(10),
        "{:?}",
        sent.elapsed()
    );
    assert_eq!(o.status.code(), Some(143), "{}", stderr(&o));
}

// 5. Smaller: a planted `frames` link, a file size limit, a closed pipe.

#[test]
fn a_planted_frames_symlink_is_refused_and_nothing_outside_is_deleted() {
    let tmp = TempDir::new("frames-link");
    let scene = tmp.write("beam.toml", &beam("symplectic-euler", "0.001", 5, ""));
    let outside = tmp.path().join("outside");
    std::fs::create_dir_all(&outside).unwrap();
    std::fs::write(outside.join("frame_00000.vtu"), "precious").unwrap();
    std::fs::write(outside.join("series.pvd"), "precious").unwrap();
    let out = tmp.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    std::os::unix::fs::symlink(&outside, out.join("frames")).unwrap();
    let o = simulate(&scene, &out, &["--export", "vtu"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("symbolic link") && err.contains("frames"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(outside.join("frame_00000.vtu")).unwrap(),
        "precious"
    );
    assert!(outside.join("series.pvd").exists());
    assert!(!out.join("trajectory.csv").exists());
}

#[test]
fn a_file_size_limit_is_reported_and_leaves_no_file_cut_short() {
    use std::os::unix::process::CommandExt;
    let tmp = TempDir::new("fsize");
    let scene = tmp.write("beam.toml", &beam("symplectic-euler", "0.0001", 20000, ""));
    let out = tmp.path().join("out");
    let mut command = Command::new(env!("CARGO_BIN_EXE_softbench"));
    command.args([
        "simulate",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--set",
        "run.sample_every=1",
    ]);
    // SAFETY: only setrlimit(2) between fork and exec.
    unsafe {
        command.pre_exec(|| {
            let limit = libc::rlimit {
                rlim_cur: 50 * 1024,
                rlim_max: 50 * 1024,
            };
            if libc::setrlimit(libc::RLIMIT_FSIZE, &limit) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let o = command.output().unwrap();
    let err = stderr(&o);
    // Not killed by SIGXFSZ: an exit code and a message.
    assert_eq!(o.status.code(), Some(1), "{err} {:?}", o.status);
    assert!(
        err.contains("File too large") && err.contains("ulimit -f"),
        "{err}"
    );
    assert!(!out.join("trajectory.csv").exists());
    let partials: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().ends_with(".partial"))
        .collect();
    assert!(partials.is_empty(), "{partials:?}");
}

#[test]
fn mesh_info_json_into_a_closed_pipe_ends_quietly() {
    let tmp = TempDir::new("mesh-info-pipe");
    let mesh = tmp.write(
        "tet.mesh",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nt 0 1 2 3\n",
    );
    for json in [true, false] {
        let mut args = vec!["mesh-info", mesh.to_str().unwrap()];
        if json {
            args.push("--json");
        }
        let mut child = Command::new(env!("CARGO_BIN_EXE_softbench"))
            .args(&args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Close our end before softbench writes: every write fails with EPIPE.
        drop(child.stdout.take());
        let o = child.wait_with_output().unwrap();
        assert_eq!(o.status.code(), Some(0), "json {json}: {}", stderr(&o));
        assert!(stderr(&o).is_empty(), "json {json}: {}", stderr(&o));
    }
}
