//! No silent acceptance of meaningless set-ups (issue 30, part 4): each is bad input (exit
//! code 2, a message naming the file and key and what is valid, nothing written) or a stated
//! warning (printed, and kept in meta.json and report.md). And the size of a run says how much
//! of the body is fixed.

mod common;

use common::{TempDir, run_study_ok, simulate};

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
