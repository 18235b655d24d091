//! No silent acceptance of meaningless set-ups (issue 30, part 4): each is bad input (exit
//! code 2, a message naming the file and key and what is valid, nothing written) or a stated
//! warning (printed, and kept in meta.json and report.md). And the size of a run says how much
//! of the body is fixed.

mod common;

use common::{TempDir, run_study, run_study_ok, simulate, softbench};

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
fn repeated_values_a_key_in_set_and_grid_and_a_one_value_sweep_are_refused() {
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
}
