//! A bad study file: exit code 2, a message naming the file, line and key, nothing written.

mod common;

use common::{TempDir, run_study, run_study_ok};

/// A scene that needs no data, next to the study.
const SCENE: &str = r#"
[mesh]
generate = { box = [2, 1, 1], size = [1.0, 0.5, 0.5] }
[material]
model = "stable-neo-hookean"
youngs_modulus = 1e4
poisson_ratio = 0.3
density = 100.0
[fixed]
rule = { axis = "x", side = "min", tolerance = 1e-6 }
[run]
dt = 0.01
steps = 5
"#;

const GOOD: &str = r#"name = "bad"
study = "trajectory"
scenes = ["beam.toml"]

[grid]
"integrator.method" = ["rk4", "backward-euler"]
"#;

/// Run `study` (written next to the beam scene) and check exit code 2, that stderr contains
/// every one of `expect`, and that no results folder was created.
fn assert_rejected(study: &str, expect: &[&str]) {
    let tmp = TempDir::new("study-bad");
    tmp.write("beam.toml", SCENE);
    let path = tmp.write("study.toml", study);
    let out = tmp.path().join("results");
    let o = run_study(&path, &out, &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    for e in expect {
        assert!(err.contains(e), "expected `{e}` in: {err}");
    }
    assert!(!out.exists(), "something was written for a bad study");
}

#[test]
fn the_good_study_runs() {
    let tmp = TempDir::new("study-good");
    tmp.write("beam.toml", SCENE);
    let path = tmp.write("study.toml", GOOD);
    let out = tmp.path().join("results");
    run_study_ok(&path, &out, &[]);
    assert!(out.join("bad/runs.csv").is_file());
}

#[test]
fn inline_scenes_and_per_method_options_run() {
    let tmp = TempDir::new("study-inline");
    // The same beam, inline, with a name; one method with its own option ladder.
    let inline: String = SCENE
        .replace("[mesh]", "[scenes.mesh]")
        .replace("[material]", "[scenes.material]")
        .replace("[fixed]", "[scenes.fixed]")
        .replace("[run]", "[scenes.run]");
    let study = format!(
        "name = \"inline\"\nstudy = \"trajectory\"\n\n\
         [[methods]]\nmethod = \"adaptive-rk4\"\n\"integrator.adaptive.tolerance\" = [1e-3, 1e-5]\n\n\
         [[methods]]\nmethod = \"backward-euler\"\n\n\
         [[scenes]]\nname = \"inline_beam\"\n{inline}"
    );
    let path = tmp.write("study.toml", &study);
    let out = tmp.path().join("results");
    run_study_ok(&path, &out, &[]);
    let runs = softbench::study::table::Table::read(&out.join("inline/runs.csv"))
        .unwrap()
        .unwrap();
    let ids: Vec<&str> = runs.rows.iter().map(|r| r[0].as_str()).collect();
    assert_eq!(
        ids,
        [
            "inline_beam-adaptive-rk4-tolerance=0.001",
            "inline_beam-adaptive-rk4-tolerance=1e-5",
            "inline_beam-backward-euler-cholesky",
        ]
    );
    let tolerance: Vec<&str> = runs
        .rows
        .iter()
        .map(|r| runs.get(r, "integrator.adaptive.tolerance").unwrap())
        .collect();
    assert_eq!(tolerance, ["0.001", "1e-5", ""]);
}

/// Two entries of one method that differ only by a key one of them sets (with one value) are
/// two runs with their own ids; an entry repeated is one run. (A key with one value in one
/// entry was left out of the ids, so the second run was silently dropped.)
#[test]
fn entries_told_apart_by_a_single_valued_key_are_both_run() {
    let tmp = TempDir::new("study-entries");
    tmp.write("beam.toml", SCENE);
    let study = "name = \"entries\"\nstudy = \"trajectory\"\nscenes = [\"beam.toml\"]\n\n\
                 [[methods]]\nmethod = \"backward-euler\"\n\n\
                 [[methods]]\nmethod = \"backward-euler\"\n\"integrator.newton.refactor_every\" = 5\n\n\
                 [[methods]]\nmethod = \"backward-euler\"\n";
    let path = tmp.write("study.toml", study);
    let out = tmp.path().join("results");
    run_study_ok(&path, &out, &[]);
    let runs = softbench::study::table::Table::read(&out.join("entries/runs.csv"))
        .unwrap()
        .unwrap();
    let ids: Vec<&str> = runs.rows.iter().map(|r| r[0].as_str()).collect();
    assert_eq!(
        ids,
        [
            "beam-backward-euler-cholesky",
            "beam-backward-euler-cholesky-refactor_every=5",
        ]
    );
}

#[test]
fn unknown_key() {
    let s = GOOD.replace(
        "study = \"trajectory\"",
        "study = \"trajectory\"\nhorizon = 3",
    );
    assert_rejected(&s, &["study.toml:3", "unknown field `horizon`", "quick"]);
}

#[test]
fn wrong_type() {
    let s = GOOD.replace("scenes = [\"beam.toml\"]", "scenes = \"beam.toml\"");
    assert_rejected(&s, &["study.toml", "line 3", "scenes"]);
}

#[test]
fn unknown_study_kind() {
    let s = GOOD.replace("\"trajectory\"", "\"trajectories\"");
    assert_rejected(
        &s,
        &[
            "study.toml:2",
            "trajectories",
            "did you mean `trajectory`?",
            "sweep",
        ],
    );
}

#[test]
fn unknown_method_suggests_the_closest() {
    let s = GOOD.replace("\"rk4\", ", "\"rk5\", ");
    assert_rejected(
        &s,
        &[
            "study.toml:6",
            "integrator.method",
            "rk5",
            "did you mean `rk4`?",
        ],
    );
}

#[test]
fn unknown_grid_key() {
    let s = format!("{GOOD}\"material.youngs_modulu\" = [1e4, 1e5]\n");
    assert_rejected(
        &s,
        &["study.toml:7", "material.youngs_modulu", "youngs_modulus"],
    );
}

#[test]
fn empty_grid_list_and_empty_grid() {
    let s = format!("{GOOD}\"run.steps\" = []\n");
    assert_rejected(&s, &["study.toml:7", "run.steps", "empty"]);
    let s = GOOD.replace(
        "\"integrator.method\" = [\"rk4\", \"backward-euler\"]\n",
        "",
    );
    assert_rejected(&s, &["study.toml", "grid", "empty"]);
}

#[test]
fn non_positive_dt() {
    let s = format!("{GOOD}\"run.dt\" = [0.01, -0.001]\n");
    assert_rejected(&s, &["study.toml:7", "run.dt", "positive"]);
    let s = GOOD.replace("[grid]", "[set]\n\"run.dt\" = 0.0\n\n[grid]");
    assert_rejected(&s, &["study.toml:6", "run.dt", "positive"]);
}

#[test]
fn missing_mesh_file() {
    let s = GOOD.replace("beam.toml", "missing_mesh.toml");
    let tmp = TempDir::new("study-bad-mesh");
    tmp.write(
        "missing_mesh.toml",
        &SCENE.replace(
            "generate = { box = [2, 1, 1], size = [1.0, 0.5, 0.5] }",
            "file = \"no_such.mesh\"",
        ),
    );
    let path = tmp.write("study.toml", &s);
    let out = tmp.path().join("results");
    let o = run_study(&path, &out, &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for e in ["study.toml:3", "missing_mesh.toml", "no_such.mesh"] {
        assert!(err.contains(e), "expected `{e}` in: {err}");
    }
    assert!(!out.exists());
}

#[test]
fn missing_scene_file() {
    let s = GOOD.replace("beam.toml", "nowhere.toml");
    assert_rejected(&s, &["study.toml:3", "nowhere.toml", "cannot read"]);
}

#[test]
fn stability_without_settings_and_bad_bracket() {
    let s = GOOD.replace("\"trajectory\"", "\"stability\"");
    assert_rejected(&s, &["study.toml", "stability", "dt_min"]);
    let s = format!(
        "{}\n[stability]\ndt_min = 0.1\ndt_max = 0.01\nhorizon = 1.0\n",
        GOOD.replace("\"trajectory\"", "\"stability\"")
    );
    assert_rejected(&s, &["study.toml:10", "stability.dt_max", "dt_min"]);
}

#[test]
fn stability_scan_and_kept_energy_settings_are_checked_and_probes_are_gone() {
    let base = format!(
        "{}\n[stability]\ndt_min = 1e-3\ndt_max = 0.01\nhorizon = 1.0\n",
        GOOD.replace("\"trajectory\"", "\"stability\"")
    );
    assert_rejected(
        &format!("{base}probes = 2\n"),
        &["stability.probes", "no longer a setting", "scan_per_decade"],
    );
    assert_rejected(
        &format!("{base}scan_per_decade = 0.5\n"),
        &["stability.scan_per_decade", "[1, 100]", "0.5"],
    );
    assert_rejected(
        &format!("{base}invented_energy_limit = -1\n"),
        &["stability.invented_energy_limit", "> 0"],
    );
    assert_rejected(
        &format!("{base}\n[quick]\nscan_per_decade = 1000\n"),
        &["quick.scan_per_decade", "[1, 100]"],
    );
}

#[test]
fn work_precision_dt_must_divide_the_sample_interval() {
    let s = format!(
        "{}\"run.dt\" = [0.01, 0.003]\n\n[work-precision]\nhorizon = 0.04\nsamples = 2\n",
        GOOD.replace("\"trajectory\"", "\"work-precision\"")
    );
    assert_rejected(&s, &["study.toml:7", "run.dt", "0.003", "divide"]);
}

#[test]
fn work_precision_repeats_must_be_between_1_and_100() {
    for repeats in ["0", "101"] {
        let s = format!(
            "{}\"run.dt\" = [0.01]\n\n[work-precision]\nhorizon = 0.04\nsamples = 2\nrepeats = {repeats}\n",
            GOOD.replace("\"trajectory\"", "\"work-precision\"")
        );
        assert_rejected(&s, &["work-precision.repeats", "1 to 100", repeats]);
    }
}

#[test]
fn only_pattern_matching_nothing() {
    let tmp = TempDir::new("study-only");
    tmp.write("beam.toml", SCENE);
    let path = tmp.write("study.toml", GOOD);
    let out = tmp.path().join("results");
    let o = run_study(&path, &out, &["--only", "dopri"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("beam-rk4"));
    assert!(!out.exists());
}

#[test]
fn stability_step_bounds_that_leave_nothing_to_judge() {
    let stability = "name = \"bad\"\nstudy = \"stability\"\nscenes = [\"beam.toml\"]\n\
                     [grid]\n\"integrator.method\" = [\"rk4\"]\n[stability]\n\
                     dt_min = 1e-4\ndt_max = 0.01\nhorizon = 1.0\n";
    // horizon / max_steps above the ceiling: no step can be judged.
    assert_rejected(
        &format!("{stability}max_steps = 10\nmin_steps = 5\ndt_ceiling = 0.01\n"),
        &["study.toml", "stability.max_steps", "no step can be judged"],
    );
    assert_rejected(
        &format!("{stability}max_steps = 100\nmin_steps = 200\n"),
        &["stability.min_steps", "[1, max_steps = 100]"],
    );
    assert_rejected(
        &format!("{stability}energy_factor = 0\n"),
        &["stability.energy_factor", "must be > 0"],
    );
    // A quick horizon would make quick verdicts differ from the full study's.
    assert_rejected(
        &format!("{stability}[quick]\nhorizon = 0.1\n"),
        &["quick.horizon", "keeps its horizon"],
    );
}

#[test]
fn an_unknown_quick_key_is_refused_with_the_keys_the_kinds_read() {
    let s = format!("{GOOD}\n[quick]\nstpes = 5\n");
    assert_rejected(
        &s,
        &["study.toml:9", "quick.stpes", "steps", "max_steps", "dts"],
    );
}

#[test]
fn a_quick_key_of_the_wrong_type_names_its_line() {
    let s = format!("{GOOD}\n[quick]\nsteps = \"many\"\n");
    assert_rejected(&s, &["study.toml", "line 9", "steps", "expected usize"]);
}

/// A stability trial must cover its horizon: a scene's cost budget would decide the verdict,
/// so it is refused, not ignored.
#[test]
fn a_cost_budget_in_a_stability_study_is_refused() {
    let study = r#"name = "bad"
study = "stability"
scenes = ["beam.toml"]
[set]
"run.budget.evaluations" = 100.0
[grid]
"integrator.method" = ["rk4"]
[stability]
dt_min = 1e-4
dt_max = 0.01
horizon = 0.1
"#;
    assert_rejected(
        study,
        &["sets run.budget", "stability trial must cover its horizon"],
    );
}

/// A folder named in `scenes` stands for its scene files; an empty one is refused.
#[test]
fn a_scene_folder_runs_its_files_and_an_empty_one_is_refused() {
    let tmp = TempDir::new("study-folder");
    std::fs::create_dir_all(tmp.path().join("scenes")).unwrap();
    tmp.write("scenes/a.toml", SCENE);
    tmp.write("scenes/b.toml", SCENE);
    tmp.write("scenes/notes.txt", "not a scene");
    let path = tmp.write(
        "study.toml",
        &GOOD.replace("[\"beam.toml\"]", "[\"scenes\"]"),
    );
    let out = tmp.path().join("results");
    run_study_ok(&path, &out, &[]);
    let runs = std::fs::read_to_string(out.join("bad/runs.csv")).unwrap();
    assert_eq!(runs.lines().count(), 1 + 2 * 2, "{runs}");
    std::fs::create_dir_all(tmp.path().join("empty")).unwrap();
    let path = tmp.write(
        "empty.toml",
        &GOOD.replace("[\"beam.toml\"]", "[\"empty\"]"),
    );
    let o = run_study(&path, &tmp.path().join("none"), &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("holds no .toml scene file"), "{err}");
}
