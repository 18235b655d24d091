//! No silent acceptance of meaningless set-ups (issue 30, part 4): each is bad input (exit
//! code 2, a message naming the file and key and what is valid, nothing written) or a stated
//! warning (printed, and kept in meta.json and report.md). And the size of a run says how much
//! of the body is fixed.

mod common;

use common::{TempDir, run_study, run_study_ok, simulate, softbench};
use softbench::data::DataPaths;

/// A 2 × 1 × 1-cell box (12 vertices) clamped at x = 0 (4 vertices): 24 free DOFs, 12 fixed.
const BEAM: &str = r#"
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

/// The stability table every stability study here uses.
const STABILITY: &str = "[stability]\ndt_min = 1e-4\ndt_max = 0.005\nhorizon = 0.1\n";

/// The work-precision table every work-precision study here uses.
const WORK_PRECISION: &str = "[work-precision]\nhorizon = 0.04\nsamples = 2\n";

fn stderr(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exit code 2 and every one of `expect` on stderr.
#[track_caller]
fn assert_bad_input(o: &std::process::Output, expect: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    for e in expect {
        assert!(err.contains(e), "expected `{e}` in: {err}");
    }
}

/// `study` (the lines after `name`, `study` and `scenes = ["beam.toml"]`, with the kind
/// `kind`) next to the beam: refused with exit code 2, `expect` on stderr, nothing written.
#[track_caller]
fn assert_study_refused(kind: &str, body: &str, expect: &[&str]) {
    let tmp = TempDir::new("silent-study");
    tmp.write("beam.toml", BEAM);
    let path = tmp.write(
        "study.toml",
        &format!("name = \"s\"\nstudy = \"{kind}\"\nscenes = [\"beam.toml\"]\n{body}"),
    );
    let out = tmp.path().join("results");
    let o = run_study(&path, &out, &[]);
    assert_bad_input(&o, expect);
    assert!(!out.exists(), "something was written for a refused study");
}

// 1. A body with every vertex fixed has nothing to integrate.

#[test]
fn a_scene_that_fixes_every_vertex_is_bad_input_naming_the_key_that_fixed_them() {
    let tmp = TempDir::new("all-fixed");
    let cases = [
        // The rule alone: its tolerance reaches the far end.
        (
            BEAM.replace("tolerance = 1e-6", "tolerance = 10.0"),
            vec![
                "fixed.rule:",
                "fixes all 12 vertices",
                "fixed.rule fixes 12",
                "0 free DOFs",
            ],
        ),
        // A box around the whole body (the rule's 4 vertices are inside it too).
        (
            BEAM.replace(
                "[fixed]\n",
                "[fixed]\nbox = { min = [-1.0, -1.0, -1.0], max = [2.0, 2.0, 2.0] }\n",
            ),
            vec!["fixed.box:", "fixed.rule fixes 4, fixed.box fixes 12"],
        ),
        // Every index.
        (
            BEAM.replace(
                "[fixed]\n",
                "[fixed]\nindices = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]\n",
            ),
            vec!["fixed.indices:", "fixed.indices fixes 12"],
        ),
        // No part alone, the union: the key is the table, each part is counted.
        (
            BEAM.replace(
                "[fixed]\n",
                "[fixed]\nbox = { min = [0.4, -1.0, -1.0], max = [2.0, 2.0, 2.0] }\n",
            ),
            vec![
                "fixed:",
                "fixes all 12 vertices",
                "fixed.rule fixes 4, fixed.box fixes 8",
            ],
        ),
    ];
    for (i, (scene, expect)) in cases.iter().enumerate() {
        let file = tmp.write(&format!("scene{i}.toml"), scene);
        let out = tmp.path().join(format!("out{i}"));
        let o = simulate(&file, &out, &[]);
        assert_bad_input(&o, expect);
        assert!(
            stderr(&o).contains(&format!("scene{i}.toml")),
            "{}",
            stderr(&o)
        );
        assert!(!out.exists(), "case {i}: nothing may be written");
    }
    // The same through --set, and in a study, where it is found at load.
    let file = tmp.write("beam.toml", BEAM);
    let out = tmp.path().join("out-set");
    let o = simulate(&file, &out, &["--set", "fixed.rule.tolerance=10"]);
    assert_bad_input(&o, &["fixed.rule:", "0 free DOFs"]);
    assert!(!out.exists());
    assert_study_refused(
        "trajectory",
        "[set]\n\"fixed.rule.tolerance\" = 10.0\n[grid]\n\"integrator.method\" = [\"rk4\"]\n",
        &["study.toml", "beam", "fixed.rule:", "0 free DOFs"],
    );
}

// 2. The size of a run: free and fixed DOFs and vertices.

#[test]
fn summary_json_and_runs_csv_count_the_free_and_fixed_dofs() {
    let tmp = TempDir::new("dof-counts");
    let file = tmp.write("beam.toml", BEAM);
    let out = tmp.path().join("out");
    let o = simulate(&file, &out, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(
        summary["dofs"],
        serde_json::json!({
            "vertices": 12, "fixed_vertices": 4, "free_dofs": 24, "fixed_dofs": 12
        })
    );
    // The sentence simulate's last line can carry.
    let counts: softbench::model::DofCounts =
        serde_json::from_value(summary["dofs"].clone()).unwrap();
    assert_eq!(
        counts.to_string(),
        "24 free and 12 fixed DOFs (4 of 12 vertices fixed)"
    );

    let study = tmp.write(
        "study.toml",
        "name = \"sizes\"\nstudy = \"trajectory\"\nscenes = [\"beam.toml\"]\n\
         [grid]\n\"integrator.method\" = [\"backward-euler\"]\n",
    );
    let results = tmp.path().join("results");
    run_study_ok(&study, &results, &[]);
    let runs = softbench::study::table::Table::read(&results.join("sizes/runs.csv"))
        .unwrap()
        .unwrap();
    let row = &runs.rows[0];
    assert_eq!(runs.get(row, "free_dofs"), Some("24"));
    assert_eq!(runs.get(row, "fixed_dofs"), Some("12"));
}

// 3. A grid over a key the study kind sets itself only repeats one run.

#[test]
fn a_grid_over_a_key_the_kind_sets_itself_is_refused_naming_the_key() {
    // The case of the issue: a stability study's dt grid ran duplicates of one search.
    assert_study_refused(
        "stability",
        &format!(
            "[grid]\n\"integrator.method\" = [\"rk4\"]\n\"run.dt\" = [0.01, 0.005]\n{STABILITY}"
        ),
        &[
            "study.toml:6",
            "grid.\"run.dt\"",
            "a stability study sets run.dt itself",
            "the search chooses each trial's step",
            "repeat the same run",
        ],
    );
    // In a [[methods]] entry, a sub-key of the kind's key too.
    assert_study_refused(
        "stability",
        &format!("[[methods]]\nmethod = \"rk4\"\n\"run.steps\" = [10, 20]\n{STABILITY}"),
        &["methods[0].\"run.steps\"", "horizon / dt steps"],
    );
    assert_study_refused(
        "work-precision",
        &format!(
            "[grid]\n\"integrator.method\" = [\"rk4\"]\n\"run.dt\" = [0.01]\n\
             \"run.sample_every\" = [1, 2]\n{WORK_PRECISION}"
        ),
        &["grid.\"run.sample_every\"", "a work-precision study sets"],
    );
    // A solver study uses only the scene's run.dt.
    assert_study_refused(
        "solver",
        "[grid]\n\"integrator.method\" = [\"backward-euler\"]\n\"run.steps\" = [5, 10]\n\
         [solver]\nsteps = [1]\n",
        &["grid.\"run.steps\"", "last of [solver] steps"],
    );
    // A sweep of stability runs over run.dt is the same mistake.
    assert_study_refused(
        "sweep",
        &format!(
            "[grid]\n\"integrator.method\" = [\"rk4\"]\n\"run.dt\" = [0.01, 0.005]\n\
             [sweep]\nkind = \"stability\"\nparameter = \"run.dt\"\n{STABILITY}"
        ),
        &["grid.\"run.dt\"", "a stability study sets run.dt itself"],
    );
}

// 4. A study's own `[set]` of a key its kind replaces is an error; a scene file's horizon the
// kind replaces is a stated warning.

#[test]
fn set_of_a_key_the_kind_replaces_is_refused() {
    assert_study_refused(
        "work-precision",
        &format!(
            "[set]\n\"run.steps\" = 10\n[grid]\n\"integrator.method\" = [\"rk4\"]\n\
             \"run.dt\" = [0.01]\n{WORK_PRECISION}"
        ),
        &[
            "study.toml:5",
            "set.\"run.steps\"",
            "a work-precision study sets run.steps itself",
            "would be replaced in every run",
        ],
    );
    assert_study_refused(
        "stability",
        &format!(
            "[grid]\n\"integrator.method\" = [\"rk4\"]\n{STABILITY}\
             [quick]\nset = {{ \"run.energy_limit\" = 10.0 }}\n"
        ),
        &["quick.set.\"run.energy_limit\"", "energy_factor"],
    );
    // A solver study leaves run.steps unused, and a scene needs one: [set] may give it.
    let tmp = TempDir::new("solver-set");
    tmp.write("beam.toml", BEAM);
    let path = tmp.write(
        "study.toml",
        "name = \"s\"\nstudy = \"solver\"\nscenes = [\"beam.toml\"]\n[set]\n\"run.steps\" = 2\n\
         [grid]\n\"integrator.method\" = [\"backward-euler\"]\n[solver]\nsteps = [1]\n",
    );
    let study = softbench::study::load(&path, false, &DataPaths::new(None)).unwrap();
    assert!(study.warnings.is_empty(), "{:?}", study.warnings);
}

#[test]
fn a_scene_horizon_a_work_precision_study_replaces_is_a_stated_warning() {
    let tmp = TempDir::new("wp-horizon");
    tmp.write("beam.toml", BEAM);
    let path = tmp.write(
        "study.toml",
        &format!(
            "name = \"wp\"\nstudy = \"work-precision\"\nscenes = [\"beam.toml\"]\n\
             [grid]\n\"integrator.method\" = [\"backward-euler\"]\n\"run.dt\" = [0.01]\n\
             {WORK_PRECISION}reference = {{ method = \"rk4\" }}\n"
        ),
    );
    let expected = "scene `beam`: run.steps = 5 of the scene (a horizon of 0.05 s at its \
                    run.dt = 0.01 s) is replaced by horizon / dt steps of each run.dt of the dt \
                    ladder, for [work-precision] horizon = 0.04 s";
    let results = tmp.path().join("results");
    let o = run_study_ok(&path, &results, &[]);
    assert!(
        stderr(&o).contains(&format!("warning: wp: {expected}")),
        "{}",
        stderr(&o)
    );
    let meta: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(results.join("wp/meta.json")).unwrap())
            .unwrap();
    assert_eq!(meta["study"]["warnings"], serde_json::json!([expected]));
    let report = std::fs::read_to_string(results.join("wp/report.md")).unwrap();
    assert!(report.contains(&format!("- {expected}")), "{report}");

    // A scene whose horizon is the study's loses nothing: no warning.
    tmp.write("beam.toml", &BEAM.replace("steps = 5", "steps = 4"));
    let study = softbench::study::load(&path, false, &DataPaths::new(None)).unwrap();
    assert!(study.warnings.is_empty(), "{:?}", study.warnings);
}

// 5. A folder where a file is expected is called a folder, not "not found".

#[test]
fn a_folder_given_as_a_file_is_called_a_folder() {
    let tmp = TempDir::new("folder-as-file");
    std::fs::create_dir_all(tmp.path().join("meshes")).unwrap();
    let scene = tmp.write(
        "scene.toml",
        &BEAM.replace(
            "generate = { box = [2, 1, 1], size = [1.0, 0.5, 0.5] }",
            "file = \"meshes\"",
        ),
    );
    let out = tmp.path().join("out");
    let o = simulate(&scene, &out, &[]);
    assert_bad_input(
        &o,
        &[
            "scene.toml",
            "mesh.file",
            "`meshes` is a folder (directory), not a data file",
        ],
    );
    assert!(!stderr(&o).contains("not found"), "{}", stderr(&o));
    assert!(!out.exists());

    let folder = tmp.path().join("meshes");
    let o = softbench(&["mesh-info", folder.to_str().unwrap()]);
    assert_bad_input(&o, &["is a folder (directory)"]);
    let e = softbench::mesh::read_tet_mesh(&folder)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("is a folder (directory), not a mesh file"),
        "{e}"
    );

    // A folder as the scene or study file.
    let o = simulate(&folder, &out, &[]);
    assert_bad_input(
        &o,
        &["meshes", "folder (directory), not a scene or study file"],
    );
    let o = run_study(&folder, &out, &[]);
    assert_bad_input(
        &o,
        &["meshes", "folder (directory), not a scene or study file"],
    );
    assert!(!out.exists());
}

// 6. Grids that say less than they seem to.

#[test]
fn repeated_values_a_key_in_set_and_grid_and_one_value_or_stray_sweeps_are_refused() {
    assert_study_refused(
        "trajectory",
        "[grid]\n\"integrator.method\" = [\"rk4\", \"backward-euler\", \"rk4\"]\n",
        &[
            "study.toml:5",
            "grid.\"integrator.method\"",
            "lists \"rk4\" more than once",
        ],
    );
    assert_study_refused(
        "trajectory",
        "[[methods]]\nmethod = \"rk4\"\n\"run.dt\" = [0.01, 0.01]\n",
        &["\"run.dt\"", "lists 0.01 more than once"],
    );
    assert_study_refused(
        "trajectory",
        "[set]\n\"run.dt\" = 0.01\n[grid]\n\"integrator.method\" = [\"rk4\"]\n\
         \"run.dt\" = [0.01, 0.005]\n",
        &[
            "study.toml:8",
            "grid.\"run.dt\"",
            "[set] gives \"run.dt\" too",
        ],
    );
    assert_study_refused(
        "sweep",
        "[grid]\n\"integrator.method\" = [\"rk4\"]\n\"material.youngs_modulus\" = [1e4]\n\
         [sweep]\nkind = \"trajectory\"\nparameter = \"material.youngs_modulus\"\n",
        &["sweep.parameter", "has 1 value", "at least two"],
    );
    // Only a sweep reads [sweep].
    assert_study_refused(
        "trajectory",
        "[grid]\n\"integrator.method\" = [\"rk4\"]\n\"run.dt\" = [0.01, 0.005]\n\
         [sweep]\nkind = \"trajectory\"\nparameter = \"run.dt\"\n",
        &["study.toml:7", "sweep:", "read only by study = \"sweep\""],
    );
}
