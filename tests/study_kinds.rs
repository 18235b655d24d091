//! Every registered study kind runs: a study of each kind, built from the kind's own example
//! tables, loads, runs in quick mode, writes its columns and report, and every run answers its
//! question. A kind added to the registry is covered here without editing this file.

mod common;

use common::TempDir;
use softbench::data::DataPaths;
use softbench::study::table::Table;
use softbench::study::{RunOptions, kinds, load, run};

/// A small beam that needs no data, next to the study.
const BEAM: &str = r#"
[mesh]
generate = { box = [4, 1, 1], size = [1.0, 0.2, 0.2] }
[material]
model = "stable-neo-hookean"
youngs_modulus = 2e5
poisson_ratio = 0.3
density = 1000.0
mass = "lumped"
[fixed]
rule = { axis = "x", side = "min", tolerance = 1e-6 }
[forces]
gravity = [0.0, -9.81, 0.0]
[integrator]
linear_solver = "cholesky"
[run]
dt = 0.002
steps = 20
"#;

#[test]
fn every_registered_study_kind_runs_from_its_example() {
    let registered = kinds();
    assert!(
        registered.len() >= 3,
        "trajectory, work-precision and stability are registered"
    );
    for kind in registered {
        let tmp = TempDir::new("study-kind");
        // A kind whose scenes need a table of their own (a suite's problems) gets it.
        tmp.write("beam.toml", &format!("{BEAM}\n{}", kind.scene_example));
        let text = format!(
            "name = \"kind\"\nstudy = \"{}\"\nscenes = [\"beam.toml\"]\n\n{}",
            kind.name, kind.example
        );
        let path = tmp.write("study.toml", &text);
        let study = load(&path, true, &DataPaths::new(None))
            .unwrap_or_else(|e| panic!("{}: its example does not load: {e}\n{text}", kind.name));
        assert!(!study.runs.is_empty(), "{}: no runs", kind.name);
        let dir = tmp.path().join("out");
        let done = run(&study, &RunOptions::new(dir.clone()))
            .unwrap_or_else(|e| panic!("{}: the study failed: {e}", kind.name));
        assert_eq!(done.ran, study.runs.len(), "{}", kind.name);
        // Every column the kind declares is written by some run: a kind's columns and what
        // its runs write cannot drift apart (a value for an undeclared column fails the run).
        assert!(
            done.unfilled_columns.is_empty(),
            "{}: declared columns no run filled: {:?}",
            kind.name,
            done.unfilled_columns
        );
        assert!(
            done.not_ok.is_empty(),
            "{}: runs that did not answer: {:?}",
            kind.name,
            done.not_ok
        );
        let runs = Table::read(&dir.join("runs.csv")).unwrap().unwrap();
        for column in kind.columns {
            assert!(
                runs.column(column).is_some(),
                "{}: runs.csv lacks its column {column}",
                kind.name
            );
        }
        assert_eq!(runs.rows.len(), study.runs.len(), "{}", kind.name);
        let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
        assert!(
            report.contains(kind.name),
            "{}: the report does not name its kind",
            kind.name
        );
    }
}

#[test]
fn every_registered_study_kind_is_listed() {
    let out = common::softbench(&["list"]);
    assert!(out.status.success());
    let listed = String::from_utf8_lossy(&out.stdout);
    for kind in kinds() {
        assert!(
            listed.contains(kind.name) && listed.contains(kind.description),
            "`softbench list` lacks the study kind {}:\n{listed}",
            kind.name
        );
    }
}

#[test]
fn a_study_kind_that_is_not_registered_is_refused_with_the_valid_ones() {
    let tmp = TempDir::new("study-kind-unknown");
    tmp.write("beam.toml", BEAM);
    let path = tmp.write(
        "study.toml",
        "name = \"kind\"\nstudy = \"stabilty\"\nscenes = [\"beam.toml\"]\n",
    );
    let e = load(&path, false, &DataPaths::new(None))
        .unwrap_err()
        .to_string();
    assert!(e.contains("study.toml"), "{e}");
    for kind in kinds() {
        assert!(e.contains(kind.name), "the error lists {}: {e}", kind.name);
    }
}
