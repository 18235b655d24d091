//! A study split into shards (`run --shard K/N`) and merged (`merge`) gives the results of a
//! local run (all columns but timings); the assignment is a partition balanced by cost and
//! the same for every shard; shared work (references) is computed once; a merge says which
//! runs are missing, is idempotent, and a shard run again resumes.

mod common;

use common::results::assert_same_study;
use common::{TempDir, run_study, run_study_ok, softbench};
use softbench::data::DataPaths;
use softbench::study::shard::{assign, estimated_cost, runs_of};
use softbench::study::{Shard, table::Table};
use std::path::{Path, PathBuf};

fn study(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("experiments")
        .join(name)
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Run shards `ks` of `n` at the same time (separate processes), each asserted to succeed;
/// their stderr, by shard.
fn run_shards(file: &Path, out: &Path, ks: &[usize], n: usize, extra: &[&str]) -> Vec<String> {
    let children: Vec<_> = ks
        .iter()
        .map(|k| {
            let mut args = vec![
                "run".to_owned(),
                file.display().to_string(),
                "--out".into(),
                out.display().to_string(),
                "--shard".into(),
                format!("{k}/{n}"),
            ];
            args.extend(extra.iter().map(|s| (*s).to_owned()));
            std::process::Command::new(env!("CARGO_BIN_EXE_softbench"))
                .args(&args)
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    children
        .into_iter()
        .map(|c| {
            let o = c.wait_with_output().unwrap();
            assert!(o.status.success(), "a shard failed: {}", text(&o.stderr));
            text(&o.stderr) + &text(&o.stdout)
        })
        .collect()
}

fn meta(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("meta.json")).unwrap()).unwrap()
}

#[test]
fn the_assignment_is_a_partition_balanced_by_cost_and_the_same_for_every_shard() {
    let s =
        softbench::study::load(&study("quickstart.toml"), false, &DataPaths::from_env()).unwrap();
    for n in [1, 2, 3, 5, s.runs.len()] {
        let shard_of = assign(&s, n);
        assert_eq!(shard_of, assign(&s, n), "the assignment is deterministic");
        // Every run in exactly one shard: the shards' own lists partition the grid.
        let mut seen = vec![0; s.runs.len()];
        let mut loads = Vec::new();
        for k in 0..n {
            let (runs, cost) = runs_of(&s, Shard { index: k, count: n });
            for r in &runs {
                let i = s.runs.iter().position(|x| x.id == r.id).unwrap();
                seen[i] += 1;
                assert_eq!(shard_of[i], k);
            }
            loads.push(cost);
        }
        assert!(seen.iter().all(|&c| c == 1), "{n} shards: {seen:?}");
        // Longest-processing-time-first: no shard exceeds another by more than one run.
        let largest = s
            .runs
            .iter()
            .map(|r| estimated_cost(&s, r))
            .fold(0.0, f64::max);
        let (lo, hi) = loads
            .iter()
            .fold((f64::MAX, 0.0f64), |(lo, hi), &c| (lo.min(c), hi.max(c)));
        assert!(hi - lo <= largest, "{n} shards: loads {loads:?}");
    }
    // Balanced by cost, not by count: an implicit run on the beam (10 per DOF-step) weighs
    // more than an explicit one (its order per DOF-step).
    let cost = |id: &str| estimated_cost(&s, s.runs.iter().find(|r| r.id == id).unwrap());
    assert_eq!(
        cost("soft_beam-backward-euler-cholesky"),
        2.5 * cost("soft_beam-rk4")
    );
}

#[test]
fn quickstart_as_three_shards_and_merge_equals_a_local_run() {
    let tmp = TempDir::new("shards-quickstart");
    let file = study("quickstart.toml");
    let local = tmp.path().join("local");
    run_study_ok(&file, &local, &["--quick"]);
    let sharded = tmp.path().join("sharded");
    let logs = run_shards(&file, &sharded, &[0, 1, 2], 3, &["--quick"]);
    // The last shard to finish merged.
    assert!(
        logs.iter()
            .any(|l| l.contains("every run of the study is done")),
        "{logs:?}"
    );
    let (l, s) = (local.join("quickstart"), sharded.join("quickstart"));
    assert_same_study(&l, &s);
    for plot in ["energy-soft_beam.png", "phases-jello_cube.svg"] {
        assert!(s.join(plot).is_file(), "no {plot}");
    }
    let m = meta(&s);
    let shards = m["shards"].as_array().unwrap();
    assert_eq!(shards.len(), 3);
    for (k, r) in shards.iter().enumerate() {
        assert_eq!(r["shard"], k);
        assert_eq!(r["of"], 3);
        assert_eq!(r["status"], "finished");
        assert!(r["host"].is_string() && r["machine"]["cpu"].is_string());
        assert!(r["started"].is_string() && r["finished"].is_string());
        assert!(r["wall_seconds"].as_f64().unwrap() >= 0.0);
    }
    assert!(m["missing"].is_null(), "nothing is missing");
    let report = std::fs::read_to_string(s.join("report.md")).unwrap();
    assert!(report.contains("| 2/3 |") && !report.contains("Missing runs"));

    // Merging again rewrites the same files.
    let before: Vec<Vec<u8>> = ["runs.csv", "report.md"]
        .iter()
        .map(|f| std::fs::read(s.join(f)).unwrap())
        .collect();
    let mut meta_before = m.clone();
    let o = softbench(&["merge", s.to_str().unwrap()]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stdout).contains("merged 12 of 12 runs from 3 shard(s)"));
    for (f, b) in ["runs.csv", "report.md"].iter().zip(&before) {
        assert_eq!(&std::fs::read(s.join(f)).unwrap(), b, "{f} changed");
    }
    let mut meta_after = meta(&s);
    for m in [&mut meta_before, &mut meta_after] {
        m.as_object_mut().unwrap().remove("command");
    }
    assert_eq!(meta_before, meta_after);
}

#[test]
fn a_merge_says_which_runs_are_missing_and_a_shard_run_again_resumes() {
    let tmp = TempDir::new("shards-missing");
    let file = study("quickstart.toml");
    let out = tmp.path();
    let dir = out.join("quickstart");
    run_shards(&file, out, &[0, 1], 3, &["--quick"]);
    let s = softbench::study::load(&file, true, &DataPaths::from_env()).unwrap();
    let (third, _) = runs_of(&s, Shard { index: 2, count: 3 });
    let expected: Vec<String> = third.iter().map(|r| r.id.clone()).collect();

    let o = softbench(&["merge", dir.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stderr));
    let err = text(&o.stderr);
    assert!(err.contains(&format!("{} of 12 runs are missing", expected.len())));
    for id in &expected {
        assert!(err.contains(id.as_str()), "{id} not named: {err}");
    }
    let missing: Vec<String> = meta(&dir)["missing"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap().to_owned())
        .collect();
    assert_eq!(missing, expected);
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(report.contains("Incomplete") && report.contains("## Missing runs"));
    let runs = Table::read(&dir.join("runs.csv")).unwrap().unwrap();
    assert_eq!(runs.rows.len(), 12 - expected.len());

    // A shard run again reuses its finished runs, like a local run.
    let o = run_study_ok(&file, out, &["--quick", "--shard", "1/3"]);
    assert!(
        text(&o.stdout).contains("(0 run now, 4 reused)"),
        "{}",
        text(&o.stdout)
    );
    // The last shard completes the study and merges.
    let o = run_study_ok(&file, out, &["--quick", "--shard", "2/3"]);
    assert!(
        text(&o.stdout).contains("merged 12 runs"),
        "{}",
        text(&o.stdout)
    );
    assert!(meta(&dir)["missing"].is_null());
    // A local run of the same study now reuses every run the shards did.
    let o = run_study_ok(&file, out, &["--quick"]);
    assert!(
        text(&o.stdout).contains("(0 run now, 12 reused)"),
        "{}",
        text(&o.stdout)
    );
}

#[test]
fn bad_shard_merge_and_slurm_options_are_refused_before_anything_is_written() {
    let tmp = TempDir::new("shards-bad");
    let file = study("quickstart.toml");
    let o = run_study(&file, tmp.path(), &["--shard", "3/3"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("0 <= K < N"),
        "{}",
        text(&o.stderr)
    );
    let o = softbench(&["merge", tmp.path().to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(text(&o.stderr).contains("not a study folder"));
    let out = tmp.path().to_str().unwrap();
    let f = file.to_str().unwrap();
    for (args, says) in [
        (vec!["--time", "1h"], "HH:MM:SS"),
        (vec!["--shards", "13"], "only 12 runs"),
        (vec!["--shards", "0"], "at least 1"),
        (vec!["--partition", "a b"], "partition"),
        (vec!["--cpus-per-task", "0"], "at least 1"),
    ] {
        let mut all = vec!["slurm", f, "--out", out];
        all.extend(&args);
        let o = softbench(&all);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o.stderr));
        assert!(
            text(&o.stderr).contains(says),
            "{args:?}: {}",
            text(&o.stderr)
        );
    }
    assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 0);
}

#[test]
fn slurm_writes_an_array_of_shards_and_a_merge_after_it() {
    let tmp = TempDir::new("shards-slurm-scripts");
    let file = study("quickstart.toml");
    let o = softbench(&[
        "slurm",
        file.to_str().unwrap(),
        "--out",
        tmp.path().to_str().unwrap(),
        "--shards",
        "3",
        "--cpus-per-task",
        "2",
        "--time",
        "10",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let dir = tmp.path().join("quickstart/slurm");
    let array = std::fs::read_to_string(dir.join("shards.sbatch")).unwrap();
    assert!(array.contains("#SBATCH --array=0-2\n"));
    assert!(array.contains("#SBATCH --time=10\n"));
    assert!(array.contains("--shard \"$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT\" --jobs 2"));
    let merge = std::fs::read_to_string(dir.join("merge.sbatch")).unwrap();
    assert!(merge.contains(" merge ") && merge.contains("--wait"));
    let submit = std::fs::read_to_string(dir.join("submit.sh")).unwrap();
    assert!(submit.contains("--dependency=afterok:"));
    // The script is valid shell.
    let o = std::process::Command::new("bash")
        .args(["-n", dir.join("shards.sbatch").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", text(&o.stderr));
}

#[test]
fn work_precision_as_three_shards_and_merge_equals_a_local_run() {
    if common::reference_mesh("coarser_bunny.mesh").is_none() {
        return;
    }
    let tmp = TempDir::new("shards-work-precision");
    let file = study("work_precision.toml");
    let local = tmp.path().join("local");
    run_study_ok(&file, &local, &["--quick"]);
    let sharded = tmp.path().join("sharded");
    let logs = run_shards(&file, &sharded, &[0, 1, 2], 3, &["--quick"]);
    let (l, s) = (local.join("work_precision"), sharded.join("work_precision"));
    assert_same_study(&l, &s);
    // Each scene's reference was computed by one shard and read by the others.
    for scene in ["cantilever", "bunny"] {
        let line = format!("reference for {scene}: ");
        let here = logs
            .iter()
            .filter(|l| {
                l.lines()
                    .any(|x| x.starts_with(&line) && x.contains("computed here"))
            })
            .count();
        assert_eq!(here, 1, "{scene}: {logs:?}");
    }
    let report = std::fs::read_to_string(s.join("report.md")).unwrap();
    // Each reference line names its scene and material.
    assert!(
        report.contains("- bunny (neo-hookean): rk4")
            || report.contains("- bunny (neo-hookean): implicit-midpoint"),
        "{report}"
    );
}

/// Regression: a reference was computed from the first *pending* run of its scene, so a
/// study resumed after `--only '*cg*'` (or a shard holding only CG runs) scored its runs
/// against an implicit-midpoint reference solved with CG instead of Cholesky, and its errors
/// differed from a fresh run's in the 9th digit. Now every invocation uses the first run of
/// the study.
#[test]
fn a_reference_comes_from_the_studys_first_run_whatever_is_pending() {
    let tmp = TempDir::new("shards-template");
    tmp.write(
        "beam.toml",
        r#"
[mesh]
generate = { box = [4, 1, 1], size = [1.0, 0.25, 0.25] }
[material]
model = "stable-neo-hookean"
youngs_modulus = 2e4
poisson_ratio = 0.3
density = 1000.0
[fixed]
rule = { axis = "x", side = "min", tolerance = 1e-6 }
[forces]
gravity = [0.0, -9.81, 0.0]
[run]
dt = 0.01
steps = 1
"#,
    );
    let file = tmp.write(
        "study.toml",
        r#"name = "template"
study = "work-precision"
scenes = ["beam.toml"]
[set]
"integrator.newton.tolerance" = 1e-12
[grid]
"integrator.method" = ["backward-euler"]
"integrator.linear_solver" = ["cholesky", "cg"]
"run.dt" = [0.008, 0.004]
[work-precision]
horizon = 0.08
samples = 2
reference = { method = "implicit-midpoint", dt_factor = 8 }
"#,
    );
    let fresh = tmp.path().join("fresh");
    run_study_ok(&file, &fresh, &[]);
    let resumed = tmp.path().join("resumed");
    run_study_ok(&file, &resumed, &["--only", "cg"]);
    run_study_ok(&file, &resumed, &[]);
    let sharded = tmp.path().join("sharded");
    // Shard 1 of 4 holds one CG run only.
    let s = softbench::study::load(&file, false, &DataPaths::from_env()).unwrap();
    let (one, _) = runs_of(&s, Shard { index: 1, count: 4 });
    assert!(
        one.iter().all(|r| r.id.contains("-cg-")),
        "{:?}",
        one.iter().map(|r| &r.id).collect::<Vec<_>>()
    );
    run_shards(&file, &sharded, &[1], 4, &[]);
    run_shards(&file, &sharded, &[0, 2, 3], 4, &[]);
    for other in [&resumed, &sharded] {
        assert_same_study(&fresh.join("template"), &other.join("template"));
    }
}

/// Regression (CI, 2026-11-28): a shard merged as soon as every run was in some shard's
/// table, while another shard had written its table but not yet its end record, so the
/// merged `meta.json` listed that shard as `running`. A shard now merges only when every
/// shard of its N has recorded its end; here shard 1's record is set back to `running` as
/// if it were still writing it (or had been killed).
#[test]
fn a_shard_that_has_not_recorded_its_end_is_waited_for_not_merged_as_running() {
    let tmp = TempDir::new("shards-unended");
    let file = study("quickstart.toml");
    let out = tmp.path();
    let dir = out.join("quickstart");
    run_shards(&file, out, &[0], 2, &["--quick"]);
    run_shards(&file, out, &[1], 2, &["--quick"]);
    assert!(meta(&dir)["shards"].as_array().unwrap().len() == 2);
    let record = dir.join("shards/1-of-2/shard.json");
    let mut r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&record).unwrap()).unwrap();
    r["status"] = "running".into();
    std::fs::write(&record, serde_json::to_string_pretty(&r).unwrap()).unwrap();
    std::fs::remove_file(dir.join("meta.json")).unwrap();

    let o = run_study_ok(&file, out, &["--quick", "--shard", "0/2"]);
    let said = text(&o.stdout);
    assert!(
        said.contains("every run of the study is done, but shard 1/2 has not recorded its end"),
        "{said}"
    );
    assert!(!said.contains("merged"), "{said}");
    assert!(
        !dir.join("meta.json").exists(),
        "no merge while shard 1 is unended"
    );

    // Shard 1 ends (run again: it reuses its runs) and merges; every record says finished.
    let o = run_study_ok(&file, out, &["--quick", "--shard", "1/2"]);
    assert!(
        text(&o.stdout).contains("merged 12 runs"),
        "{}",
        text(&o.stdout)
    );
    for r in meta(&dir)["shards"].as_array().unwrap() {
        assert_eq!(r["status"], "finished", "{r}");
    }
}
