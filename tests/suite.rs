//! The benchmark suite: problems state their protocol and are judged by it (solved, or failed
//! with a kind, a budget deciding only what it caps); methods that cannot run a problem,
//! problems whose data is missing and methods the suite omits are listed with the reason; a
//! private folder is a hidden tier reported apart; bad suites and problems are refused before
//! anything runs; and the shipped suite runs every registered method in quick mode.

mod common;

use common::{TempDir, run_study_ok};
use softbench::study::table::Table;
use std::path::Path;

/// A small clamped beam as a problem: `tolerance`, `budget` and `extra` vary.
fn problem(tolerance: f64, budget: &str, extra: &str) -> String {
    format!(
        r#"
[mesh]
generate = {{ box = [4, 1, 1], size = [0.4, 0.1, 0.1] }}
[material]
model = "stable-neo-hookean"
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0
mass = "lumped"
[fixed]
rule = {{ axis = "x", side = "min", tolerance = 1e-6 }}
[forces]
gravity = [0.0, -9.81, 0.0]
[run]
dt = 0.01
steps = 8
{budget}
[problem]
description = "a small beam sagging"
scenario = "hanging"
difficulty = "easy"
samples = 2
tolerance = {tolerance}
reference = {{ method = "rk4", dt = 1e-4, independent = {{ method = "radau-iia", dt = 0.001 }} }}
{extra}
"#
    )
}

const SUITE: &str = r#"name = "s"
study = "suite"
scenes = ["problems"]
[suite]
levels = ["loose", "tight"]
methods = "listed"
[[methods]]
method = "backward-euler"
"integrator.newton.tolerance" = [1e-3, 1e-9]
[[methods]]
method = "bdf2"
"integrator.newton.tolerance" = [1e-3, 1e-9]
[[methods]]
method = "projective-dynamics"
"integrator.projective_dynamics.iterations" = [5, 20]
[[methods]]
method = "rk4"
"#;

fn rows_of<'a>(runs: &'a Table, method: &str) -> Vec<&'a Vec<String>> {
    runs.rows
        .iter()
        .filter(|r| runs.get(r, "method") == Some(method))
        .collect()
}

#[test]
fn runs_are_judged_by_their_problem_and_what_cannot_run_is_listed() {
    let tmp = TempDir::new("suite-judge");
    std::fs::create_dir_all(tmp.path().join("problems")).unwrap();
    std::fs::create_dir_all(tmp.path().join("private")).unwrap();
    // BDF2 at dt 0.01 is accurate to a few percent here, backward Euler is not.
    tmp.write("problems/beam.toml", &problem(0.05, "", ""));
    // A problem on a mesh that is not there, marked optional: left out with its reason.
    tmp.write(
        "problems/course.toml",
        &problem(0.05, "", "optional = \"needs the course meshes\"").replace(
            "generate = { box = [4, 1, 1], size = [0.4, 0.1, 0.1] }",
            "file = \"nowhere.mesh\"",
        ),
    );
    // A private problem: the hidden tier.
    tmp.write("private/secret.toml", &problem(0.05, "", ""));
    let study = tmp.write(
        "suite.toml",
        &SUITE.replace(
            "methods = \"listed\"",
            "methods = \"listed\"\nhidden = [\"private\"]",
        ),
    );
    let out = tmp.path().join("out");
    run_study_ok(&study, &out, &["--jobs", "2"]);
    let dir = out.join("s");
    let runs = Table::read(&dir.join("runs.csv")).unwrap().unwrap();
    // Two problems run (the optional one is left out); projective dynamics cannot run Stable
    // Neo-Hookean: backward Euler and BDF2 at two levels, RK4 once, per problem.
    assert_eq!(runs.rows.len(), 2 * (2 + 2 + 1), "{:?}", runs.rows);
    for r in &runs.rows {
        let tier = if runs.get(r, "scene") == Some("secret") {
            "hidden"
        } else {
            "public"
        };
        assert_eq!(runs.get(r, "tier"), Some(tier));
        assert_eq!(runs.get(r, "tolerance"), Some("5e-2"));
        let solved = runs.get(r, "solved").unwrap();
        let failure = runs.get(r, "failure").unwrap();
        assert_eq!(solved == "yes", failure.is_empty(), "{r:?}");
    }
    for r in rows_of(&runs, "bdf2") {
        assert_eq!(runs.get(r, "solved"), Some("yes"), "{r:?}");
    }
    for r in rows_of(&runs, "backward-euler") {
        assert_eq!(runs.get(r, "failure"), Some("inaccurate"), "{r:?}");
        let level = runs.get(r, "level").unwrap();
        let cutoff = runs.get(r, "cutoff").unwrap();
        assert_eq!(
            cutoff,
            if level == "loose" {
                "integrator.newton.tolerance=0.001"
            } else {
                "integrator.newton.tolerance=1e-9"
            }
        );
    }
    // RK4 at dt 0.01 blows up: failed with its kind, at every level.
    for r in rows_of(&runs, "rk4") {
        assert_eq!(runs.get(r, "failure"), Some("unstable"));
        assert_eq!(runs.get(r, "level"), Some("-"));
    }
    let omissions = std::fs::read_to_string(dir.join("omissions.md")).unwrap();
    assert!(
        omissions.contains("`course`: needs the course meshes"),
        "{omissions}"
    );
    assert!(
        omissions.contains("`projective-dynamics` cannot run 2 of the 3 problems"),
        "{omissions}"
    );
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(report.contains("### The public problems (1)"), "{report}");
    // The problems table: BDF2 alone solves the beam, at each level, of the three methods that
    // run it.
    let line = report
        .lines()
        .find(|l| l.starts_with("| `beam` |"))
        .expect("the beam's row");
    assert!(line.ends_with("| 1, 1 of 3 |"), "{line}");
    assert!(report.contains("### The hidden problems (1)"), "{report}");
    // The footer names what made the numbers: versions, machine, the command, the load.
    let footer = report
        .split("## How these results were made")
        .nth(1)
        .expect("a footer");
    assert!(footer.contains("- Command: `softbench run "), "{footer}");
    assert!(footer.contains("--jobs 2`"), "{footer}");
    assert!(
        footer.contains("at the start,") && footer.contains("at the end"),
        "{footer}"
    );
    assert!(footer.contains("cores)"), "{footer}");
    for file in ["profiles.csv", "summary.csv", "costs.csv", "pairwise.csv"] {
        assert!(dir.join("profiles").join(file).is_file(), "{file}");
    }
    for chart in ["data-evaluations-tight.png", "performance-wall-loose.png"] {
        assert!(dir.join(chart).is_file(), "{chart}");
    }
    // The profiles: at each level BDF2 solves the public problem, the only one to.
    let summary = Table::read(&dir.join("profiles/summary.csv"))
        .unwrap()
        .unwrap();
    let line = summary
        .rows
        .iter()
        .find(|r| {
            summary.get(r, "dimension") == Some("tier")
                && summary.get(r, "stratum") == Some("public")
                && summary.get(r, "level") == Some("tight")
                && summary.get(r, "cost") == Some("evaluations")
                && summary.get(r, "method") == Some("bdf2")
        })
        .unwrap();
    assert_eq!(summary.get(line, "solved"), Some("1"));
    assert_eq!(summary.get(line, "best"), Some("1"));
}

/// A budget caps the runs it stops and nothing else: a run within it is the same run whatever
/// the budget, and a run it stops is `over-budget`, reported with the budget.
#[test]
fn a_budget_decides_only_the_runs_it_caps() {
    let tmp = TempDir::new("suite-budget");
    std::fs::create_dir_all(tmp.path().join("problems")).unwrap();
    let suite = SUITE.replace("[[methods]]\nmethod = \"rk4\"\n", "");
    let run = |budget: &str| -> Table {
        tmp.write("problems/beam.toml", &problem(0.05, budget, ""));
        let study = tmp.write("suite.toml", &suite);
        let out = tmp.path().join(format!("out-{}", budget.len()));
        run_study_ok(&study, &out, &[]);
        Table::read(&out.join("s/runs.csv")).unwrap().unwrap()
    };
    let free = run("");
    // Between what backward Euler and BDF2 spend at the tight level.
    let spent = |t: &Table, m: &str, level: &str| -> f64 {
        rows_of(t, m)
            .into_iter()
            .find(|r| t.get(r, "level") == Some(level))
            .and_then(|r| t.number(r, "evaluations"))
            .unwrap()
    };
    let (be, bdf2) = (
        spent(&free, "backward-euler", "tight"),
        spent(&free, "bdf2", "tight"),
    );
    assert!(be != bdf2, "{be} {bdf2}");
    let cap = 0.5 * (be + bdf2);
    let capped = run(&format!("budget = {{ evaluations = {cap} }}"));
    for (m, level) in [("backward-euler", "tight"), ("bdf2", "tight")] {
        let row = |t: &Table| {
            rows_of(t, m)
                .into_iter()
                .find(|r| t.get(r, "level") == Some(level))
                .cloned()
                .unwrap()
        };
        let (a, b) = (row(&free), row(&capped));
        let within = spent(&free, m, level) <= cap;
        if within {
            // The same run: same error, same verdict.
            assert_eq!(free.get(&a, "error"), capped.get(&b, "error"), "{m}");
            assert_eq!(free.get(&a, "failure"), capped.get(&b, "failure"), "{m}");
        } else {
            assert_eq!(capped.get(&b, "failure"), Some("over-budget"), "{m}");
            assert_eq!(capped.number(&b, "budget_evaluations"), Some(cap));
        }
    }
}

#[test]
fn bad_suites_and_problems_are_refused_before_anything_runs() {
    let tmp = TempDir::new("suite-bad");
    std::fs::create_dir_all(tmp.path().join("problems")).unwrap();
    tmp.write("problems/beam.toml", &problem(0.05, "", ""));
    let check = |suite: &str, expected: &str| {
        let study = tmp.write("suite.toml", suite);
        let o = common::softbench(&[
            "run",
            study.to_str().unwrap(),
            "--out",
            tmp.path().join("out").to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{suite}\n{err}");
        assert!(err.contains(expected), "expected `{expected}`:\n{err}");
        assert!(!tmp.path().join("out/s/runs.csv").exists());
    };
    check(
        &SUITE.replace("levels = [\"loose\", \"tight\"]", "levels = [\"only\"]"),
        "at least two cut-off levels",
    );
    check(
        &format!("{SUITE}[grid]\n\"run.dt\" = [0.01, 0.005]\n"),
        "a suite has no grid",
    );
    check(
        &format!("{SUITE}[set]\n\"run.dt\" = 0.001\n"),
        "a suite sets only integrator settings",
    );
    check(
        &format!("{SUITE}[[methods]]\nmethod = \"bdf2\"\n"),
        "`bdf2` has a second block",
    );
    check(
        &SUITE.replace(
            "[1e-3, 1e-9]\n[[methods]]\nmethod = \"bdf2\"",
            "[1e-3, 1e-6, 1e-9]\n[[methods]]\nmethod = \"bdf2\"",
        ),
        "give one per level",
    );
    check(
        &SUITE.replace(
            "\"integrator.projective_dynamics.iterations\" = [5, 20]",
            "\"integrator.projective_dynamics.iterations\" = [5, 20]\n\"integrator.projective_dynamics.anderson_history\" = [3, 5]",
        ),
        "more than one key has several values",
    );
    check(
        &SUITE.replace(
            "methods = \"listed\"",
            "methods = \"listed\"\nomit = { rk5 = \"no\" }",
        ),
        "suite.omit",
    );
    // A scene without [problem], and problems that state a protocol that cannot hold.
    tmp.write(
        "problems/plain.toml",
        problem(0.05, "", "").split("[problem]").next().unwrap(),
    );
    check(SUITE, "has no [problem] table");
    std::fs::remove_file(tmp.path().join("problems/plain.toml")).unwrap();
    for (bad, expected) in [
        ("samples = 2", "samples = 3"),
        ("difficulty = \"easy\"", "difficulty = \"hardest\""),
        ("tolerance = 0.05", "tolerance = -1"),
    ] {
        let _ = bad;
        let text = problem(0.05, "", "").replace(bad, expected);
        tmp.write("problems/beam.toml", &text);
        let key = expected.split(' ').next().unwrap();
        check(SUITE, &format!("problem.{key}"));
    }
}

/// The shipped suite in quick mode: every registered method either runs or is in the
/// omissions list with its reason, every run is judged, and the aggregates are written.
#[test]
fn the_shipped_suite_runs_every_registered_method_in_quick_mode() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let tmp = TempDir::new("suite-quick");
    let out = tmp.path().join("out");
    run_study_ok(
        &root.join("experiments/suite.toml"),
        &out,
        &["--quick", "--jobs", "2"],
    );
    let dir = out.join("suite");
    let runs = Table::read(&dir.join("runs.csv")).unwrap().unwrap();
    let omissions = std::fs::read_to_string(dir.join("omissions.md")).unwrap();
    for method in softbench::integrate::Method::all() {
        let name = method.name();
        let ran = runs
            .rows
            .iter()
            .any(|r| runs.get(r, "method") == Some(name));
        assert!(
            ran || omissions.contains(&format!("`{name}`")),
            "{name} neither runs nor is in the omissions list"
        );
    }
    for r in &runs.rows {
        let solved = runs.get(r, "solved").unwrap();
        assert!(solved == "yes" || solved == "no", "{r:?}");
        assert!(
            runs.number(r, "evaluations").is_some_and(|e| e > 0.0),
            "{r:?}"
        );
    }
    assert!(omissions.contains("`static`"), "{omissions}");
    // The peer methods' blocks: this binary registers none, so each is listed with how to
    // run it.
    for peer in [
        "pbat-vbd",
        "pbat-xpbd",
        "newton-vbd",
        "newton-xpbd",
        "newton-semi-implicit",
    ] {
        assert!(
            omissions.contains(&format!("- `{peer}`: a peer method"))
                && omissions.contains("python -m softbench"),
            "{peer}: {omissions}"
        );
    }
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(report.contains("## Suite aggregates"));
    assert!(report.contains("**Ordering across levels.**"));
}

/// Where the reference cannot resolve the tolerance (its error bar, twice over, reaches it),
/// accuracy is not judged: a run that reaches the horizon within the budget solves the
/// problem, with the reason in its message, and the problem is listed as judged on robustness.
#[test]
fn a_tolerance_below_the_reference_error_bar_is_judged_on_robustness() {
    let tmp = TempDir::new("suite-robustness");
    std::fs::create_dir_all(tmp.path().join("problems")).unwrap();
    tmp.write("problems/beam.toml", &problem(1e-14, "", ""));
    let study = tmp.write("suite.toml", SUITE);
    let out = tmp.path().join("out");
    run_study_ok(&study, &out, &[]);
    let runs = Table::read(&out.join("s/runs.csv")).unwrap().unwrap();
    for r in rows_of(&runs, "backward-euler") {
        assert!(runs.number(r, "reference_difference").unwrap() * 2.0 >= 1e-14);
        assert_eq!(runs.get(r, "solved"), Some("yes"), "{r:?}");
        assert!(
            runs.get(r, "message")
                .unwrap()
                .starts_with("accuracy not judged")
        );
    }
    // A blow-up still fails.
    for r in rows_of(&runs, "rk4") {
        assert_eq!(runs.get(r, "failure"), Some("unstable"));
    }
    let omissions = std::fs::read_to_string(out.join("s/omissions.md")).unwrap();
    assert!(
        omissions.contains("- `beam`: its reference differs from the independent solution"),
        "{omissions}"
    );
    let report = std::fs::read_to_string(out.join("s/report.md")).unwrap();
    assert!(report.contains("| robustness |"), "{report}");
}
