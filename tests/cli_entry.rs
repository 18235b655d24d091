//! `softbench::cli`: a program that registers its own method gets the whole command line with
//! it (`run` with `--shard`, `--only` and `--quick`, `merge`, `list`); the dependency route the
//! README gives keeps softbench's lock file; and command-line mistakes are bad input (exit 2)
//! with a message that points the right way.

mod common;

use common::{TempDir, softbench};
use softbench::integrate::methods::explicit;
use softbench::integrate::runge_kutta::{ExplicitRungeKutta, Tableau};
use softbench::integrate::{Method, register_method};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Once;

/// Heun's third-order method, as the README's example registers it.
const HEUN3: Tableau = Tableau {
    name: "heun3",
    order: 3,
    a: &[&[], &[1.0 / 3.0], &[0.0, 2.0 / 3.0]],
    b: &[0.25, 0.0, 0.75],
    b_embedded: None,
};

fn register_heun3() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let heun3 = explicit(
            "heun3",
            3,
            "Heun's third-order Runge-Kutta method",
            |_, _| Box::new(ExplicitRungeKutta::new(HEUN3)),
        );
        register_method(heun3).unwrap();
    });
}

fn cli(args: &[&str]) -> ExitCode {
    softbench::cli::run(std::iter::once("softbench").chain(args.iter().copied()))
}

fn manifest_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn a_program_that_registers_a_method_runs_studies_of_it_in_shards_and_merges() {
    register_heun3();
    assert_eq!(Method::from_name("heun3").unwrap().order(), 3);
    let dir = TempDir::new("cli-entry");
    let scene = manifest_dir().join("experiments/scenes/soft_beam.toml");
    let study = dir.write(
        "own.toml",
        &format!(
            r#"name = "own"
study = "trajectory"
scenes = [{scene:?}]

[grid]
"integrator.method" = ["heun3", "rk4", "midpoint"]

[set]
"run.dt" = 0.002
"run.steps" = 40

[quick]
steps = 10
"#
        ),
    );
    let study = study.to_str().unwrap();
    let out = dir.path().join("results");
    let out = out.to_str().unwrap();
    for shard in ["0/2", "1/2"] {
        let code = cli(&["run", study, "--out", out, "--quick", "--shard", shard]);
        assert_eq!(code, ExitCode::SUCCESS, "shard {shard}");
    }
    let runs_csv = dir.path().join("results/own/runs.csv");
    let runs = std::fs::read_to_string(&runs_csv).unwrap();
    assert_eq!(runs.lines().count(), 4, "{runs}");
    let heun = runs
        .lines()
        .find(|l| l.contains("heun3"))
        .expect("heun3 ran");
    assert!(heun.contains("completed"), "{heun}");
    // The merge of a finished sharded study gives the same table again.
    let code = cli(&["merge", dir.path().join("results/own").to_str().unwrap()]);
    assert_eq!(code, ExitCode::SUCCESS);
    assert_eq!(std::fs::read_to_string(&runs_csv).unwrap(), runs);
    // --only by the new name, in a fresh folder: one run.
    let only = dir.path().join("only");
    let code = cli(&[
        "run",
        study,
        "--out",
        only.to_str().unwrap(),
        "--quick",
        "--only",
        "heun3",
    ]);
    assert_eq!(code, ExitCode::SUCCESS);
    let runs = std::fs::read_to_string(only.join("own/runs.csv")).unwrap();
    assert_eq!(runs.lines().count(), 2, "{runs}");
}

/// A crate that depends on softbench and starts from softbench's Cargo.lock (the README's
/// route) resolves every package softbench uses at softbench's locked version.
#[test]
fn a_dependent_crate_started_from_the_lock_file_keeps_its_versions() {
    let dir = TempDir::new("cli-entry-dependent");
    std::fs::create_dir_all(dir.path().join("src")).unwrap();
    dir.write(
        "Cargo.toml",
        &format!(
            "[package]\nname = \"mine\"\nversion = \"0.1.0\"\nedition = \"2024\"\n\n\
             [dependencies]\nsoftbench = {{ path = {:?} }}\n",
            manifest_dir()
        ),
    );
    dir.write(
        "src/main.rs",
        "fn main() -> std::process::ExitCode { softbench::cli::main() }\n",
    );
    let ours = std::fs::read_to_string(manifest_dir().join("Cargo.lock")).unwrap();
    std::fs::write(dir.path().join("Cargo.lock"), &ours).unwrap();
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    // Resolved for this machine only (`host-tuple`): over every platform, cargo metadata
    // wants the packages of the others too (Windows-only crates a Linux build never
    // downloads), so `--offline` failed on a fresh machine whose cache held only what the
    // build had fetched. The lock file it writes is the same either way.
    let status = std::process::Command::new(cargo)
        .args([
            "metadata",
            "--offline",
            "--format-version",
            "1",
            "--filter-platform",
            "host-tuple",
        ])
        .current_dir(dir.path())
        .stdout(std::process::Stdio::null())
        .status()
        .unwrap();
    assert!(status.success(), "cargo metadata failed");
    let theirs = std::fs::read_to_string(dir.path().join("Cargo.lock")).unwrap();
    let versions = |lock: &str| -> std::collections::BTreeSet<(String, String)> {
        let value: toml::Table = toml::from_str(lock).expect("Cargo.lock is TOML");
        value["package"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| {
                let s = |k: &str| p[k].as_str().unwrap().to_owned();
                (s("name"), s("version"))
            })
            .collect()
    };
    let (ours, theirs) = (versions(&ours), versions(&theirs));
    let moved: Vec<_> = theirs
        .iter()
        .filter(|(name, _)| name != "mine")
        .filter(|p| !ours.contains(*p))
        .collect();
    assert!(
        moved.is_empty(),
        "re-locked away from softbench's lock: {moved:?}"
    );
    assert!(theirs.len() > 200, "{} packages", theirs.len());
}

#[test]
fn run_set_is_refused_with_a_pointer_to_the_study_file() {
    let out = softbench(&["run", "any.toml", "--set", "run.dt=0.1"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("run has no --set"), "{err}");
    assert!(err.contains("[grid]") && err.contains("simulate"), "{err}");
    assert!(!err.contains("tip:"), "{err}");
}

#[test]
fn an_out_that_is_a_file_is_bad_input_and_nothing_is_written() {
    let dir = TempDir::new("cli-entry-out");
    let file = dir.write("taken", "keep me");
    let scene = manifest_dir().join("experiments/scenes/soft_beam.toml");
    let study = manifest_dir().join("experiments/quickstart.toml");
    let below = file.join("below");
    for out in [&file, &below] {
        for args in [
            vec!["simulate", scene.to_str().unwrap()],
            vec!["run", study.to_str().unwrap()],
            vec!["slurm", study.to_str().unwrap()],
        ] {
            let mut args = args.clone();
            args.extend(["--out", out.to_str().unwrap()]);
            let run = softbench(&args);
            let err = String::from_utf8_lossy(&run.stderr);
            assert_eq!(run.status.code(), Some(2), "{args:?}: {err}");
            assert!(err.contains("not a folder"), "{err}");
        }
    }
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "keep me");
}

#[test]
fn simulate_says_how_many_dofs_are_free_and_fixed() {
    let dir = TempDir::new("cli-entry-dofs");
    let scene = manifest_dir().join("experiments/scenes/soft_beam.toml");
    let run = softbench(&[
        "simulate",
        scene.to_str().unwrap(),
        "--out",
        dir.path().to_str().unwrap(),
        "--set",
        "run.steps=2",
    ]);
    assert!(run.status.success());
    let out = String::from_utf8_lossy(&run.stdout);
    assert!(
        out.contains("270 free and 27 fixed DOFs (9 of 99 vertices fixed)"),
        "{out}"
    );
}
