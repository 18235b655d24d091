//! The claims ledger: each rule kind decides validated, qualified (with its condition),
//! refuted and unmeasured on tables whose answer is known; the ledger counts problems, not
//! the rungs of a ladder, and times by their spreads; bad claim files are refused with the
//! key; and the committed ledger page is exactly what the committed claims and results give
//! (so no verdict on it was typed by hand).

mod common;

use common::TempDir;
use softbench::ledger::rule::RuleSpec;
use softbench::ledger::verdict::{Class, Counts, Stratum, Verdict, evaluate};
use softbench::ledger::{Claim, judge, page, read_claims};
use softbench::study::table::Table;
use std::path::Path;

fn table(header: &[&str], rows: &[&[&str]]) -> Table {
    let mut t = Table::new(header.iter().map(|s| s.to_string()).collect());
    t.rows = rows
        .iter()
        .map(|r| r.iter().map(|s| s.to_string()).collect())
        .collect();
    t
}

fn rule(text: &str) -> RuleSpec {
    let t: toml::Table = toml::from_str(text).unwrap();
    RuleSpec::parse(&t).unwrap()
}

/// Held, decided and tied problems.
fn problems(v: &Verdict) -> (usize, usize, usize) {
    (v.problems.held, v.problems.decided(), v.problems.tied)
}

/// Held, decided and tied cases.
fn cases(v: &Verdict) -> (usize, usize, usize) {
    (v.cases.held, v.cases.decided(), v.cases.tied)
}

/// Whether `v` has the stratum `column = value` with `held` of `decided` problems.
fn has_stratum(v: &Verdict, column: &str, value: &str, held: usize, decided: usize) -> bool {
    v.strata.iter().any(|s: &Stratum| {
        s.column == column
            && s.value == value
            && s.problems.held == held
            && s.problems.decided() == decided
    })
}

/// Four problems where `a` is cheaper on three (one of them in the `hard` stratum only).
fn costs() -> Table {
    table(
        &["scene", "method", "cost", "difficulty"],
        &[
            &["p1", "a", "1", "easy"],
            &["p1", "b", "2", "easy"],
            &["p2", "a", "1", "easy"],
            &["p2", "b", "3", "easy"],
            &["p3", "a", "1", "easy"],
            &["p3", "b", "5", "easy"],
            &["p4", "a", "9", "hard"],
            &["p4", "b", "2", "hard"],
            &["p5", "a", "4", "hard"],
            &["p5", "b", "4", "hard"],
        ],
    )
}

#[test]
fn compare_counts_wins_and_ties_and_decides_by_its_share() {
    let spec = rule(
        r#"kind = "compare"
a = { method = "a" }
b = { method = "b" }
pair_by = ["scene"]
metric = "cost"
better = "smaller"
qualify_by = ["difficulty"]"#,
    );
    let v = evaluate(&spec, &costs());
    // Three wins of four decided (p5 ties): 75 %, validated at the default 0.75. Each scene
    // is a problem with one case.
    assert_eq!(problems(&v), (3, 4, 1));
    assert_eq!(cases(&v), (3, 4, 1));
    assert_eq!(v.class, Class::Validated);
    assert!(has_stratum(&v, "difficulty", "easy", 3, 3));
    // The opposite claim is refuted.
    let spec = rule(
        r#"kind = "compare"
a = { method = "a" }
b = { method = "b" }
pair_by = ["scene"]
metric = "cost"
better = "larger""#,
    );
    assert_eq!(evaluate(&spec, &costs()).class, Class::Refuted);
}

#[test]
fn a_share_in_between_is_qualified_with_the_strata_where_it_holds() {
    let spec = rule(
        r#"kind = "compare"
a = { method = "a" }
b = { method = "b" }
pair_by = ["scene"]
metric = "cost"
better = "smaller"
holds_at = 0.9
qualify_by = ["difficulty"]"#,
    );
    let v = evaluate(&spec, &costs());
    assert_eq!(v.class, Class::Qualified);
    assert_eq!(
        v.condition,
        "holds where difficulty = easy (3 of 3 problems)"
    );
    // Without strata the condition is the share itself.
    let spec = rule(
        r#"kind = "compare"
a = { method = "a" }
b = { method = "b" }
pair_by = ["scene"]
metric = "cost"
better = "smaller"
holds_at = 0.9"#,
    );
    let v = evaluate(&spec, &costs());
    assert_eq!(v.class, Class::Qualified);
    assert!(
        v.condition.starts_with("holds on 3 of 4 problems (75 %)"),
        "{}",
        v.condition
    );
}

#[test]
fn too_few_decided_cases_leave_a_claim_unmeasured() {
    let spec = rule(
        r#"kind = "compare"
a = { method = "a" }
b = { method = "b" }
both = { difficulty = "hard" }
pair_by = ["scene"]
metric = "cost"
better = "smaller""#,
    );
    let v = evaluate(&spec, &costs());
    // p4 decides (b cheaper), p5 ties: one decided problem.
    assert_eq!((v.problems.decided(), v.problems.tied), (1, 1));
    assert_eq!(v.class, Class::Unmeasured);
    assert!(v.condition.contains("fewer than the 3"), "{}", v.condition);
}

#[test]
fn a_missing_cost_is_worse_than_any_or_a_tie() {
    // Times with their spreads, which p4's do not overlap.
    let t = table(
        &[
            "scene",
            "solver",
            "wall_seconds",
            "wall_seconds_low",
            "wall_seconds_high",
        ],
        &[
            &["p1", "a", "1", "0.9", "1.1"],
            &["p1", "b", "", "", ""],
            &["p2", "a", "1", "0.9", "1.1"],
            &["p2", "b", "", "", ""],
            &["p3", "a", "", "", ""],
            &["p3", "b", "", "", ""],
            &["p4", "a", "2", "1.9", "2.1"],
            &["p4", "b", "1", "0.9", "1.1"],
        ],
    );
    let text = |missing: &str| {
        format!(
            "kind = \"compare\"\na = {{ solver = \"a\" }}\nb = {{ solver = \"b\" }}\n\
             pair_by = [\"scene\"]\nmetric = \"wall_seconds\"\nbetter = \"smaller\"\n\
             missing = \"{missing}\"\nmin_cases = 1\n"
        )
    };
    let worst = evaluate(&rule(&text("worst")), &t);
    assert_eq!(problems(&worst), (2, 3, 1));
    let tie = evaluate(&rule(&text("tie")), &t);
    assert_eq!(problems(&tie), (0, 1, 3));
}

#[test]
fn ranked_categories_share_a_rank_within_a_group() {
    let t = table(
        &["scene", "material", "outcome"],
        &[
            &["x", "snh", "unstable"],
            &["x", "nh", "left-material-domain"],
            &["y", "snh", "completed"],
            &["y", "nh", "unstable"],
            &["z", "snh", "completed"],
            &["z", "nh", "left-material-domain"],
        ],
    );
    let spec = rule(
        r#"kind = "compare"
a = { material = "snh" }
b = { material = "nh" }
pair_by = ["scene"]
metric = "outcome"
better = ["completed|unstable"]"#,
    );
    let v = evaluate(&spec, &t);
    // y ties (completed and unstable share the first rank); x and z hold.
    assert_eq!(problems(&v), (2, 2, 1));
}

#[test]
fn dominates_counts_the_runs_beaten_in_cost_and_error() {
    // Times with a ±1 % spread: equal times overlap, the others do not.
    let t = table(
        &[
            "scene",
            "method",
            "wall_seconds",
            "error",
            "wall_seconds_low",
            "wall_seconds_high",
        ],
        &[
            // a's front: (1, 0.1), (2, 0.01)
            &["s", "a", "1", "0.1", "0.99", "1.01"],
            &["s", "a", "2", "0.01", "1.98", "2.02"],
            // b: beaten (3, 0.2), beaten (2, 0.05), on the front (0.5, 0.5): neither.
            &["s", "b", "3", "0.2", "2.97", "3.03"],
            &["s", "b", "2", "0.05", "1.98", "2.02"],
            &["s", "b", "0.5", "0.5", "0.495", "0.505"],
            // b beats a here: a's (1, 0.1) is worse than (0.9, 0.05).
            &["t", "a", "1", "0.1", "0.99", "1.01"],
            &["t", "b", "0.9", "0.05", "0.891", "0.909"],
        ],
    );
    let spec = rule(
        r#"kind = "dominates"
a = { method = "a" }
b = { method = "b" }
group_by = ["scene"]
cost = "wall_seconds"
error = "error"
min_cases = 1"#,
    );
    let v = evaluate(&spec, &t);
    assert_eq!(cases(&v), (2, 3, 1));
    // Counted by group: s holds (two runs beaten, one on the front), t fails.
    assert_eq!(problems(&v), (1, 2, 0));
    assert_eq!(v.problems.failed, 1);
}

#[test]
fn trends_read_the_shape_of_a_line() {
    let t = table(
        &["scene", "method", "iterations", "error"],
        &[
            // Linear convergence: the log-log slope steepens (late faster).
            &["lin", "m", "1", "0.5"],
            &["lin", "m", "2", "0.25"],
            &["lin", "m", "4", "0.0625"],
            &["lin", "m", "8", "0.00390625"],
            // A stall: fast early, slow late.
            &["stall", "m", "1", "1"],
            &["stall", "m", "2", "0.1"],
            &["stall", "m", "4", "0.09"],
            &["stall", "m", "8", "0.089"],
            // Not decreasing.
            &["up", "m", "1", "0.1"],
            &["up", "m", "2", "0.05"],
            &["up", "m", "4", "0.07"],
        ],
    );
    let decreasing = rule(
        r#"kind = "trend"
rows = { method = "m" }
group_by = ["scene"]
x = "iterations"
y = "error"
expect = "decreasing"
min_cases = 1
qualify_by = ["scene"]"#,
    );
    let v = evaluate(&decreasing, &t);
    assert_eq!((v.problems.held, v.problems.decided()), (2, 3));
    assert!(has_stratum(&v, "scene", "up", 0, 1));
    let early = rule(
        r#"kind = "trend"
rows = { method = "m" }
group_by = ["scene"]
x = "iterations"
y = "error"
expect = "early-faster"
min_cases = 1
qualify_by = ["scene"]"#,
    );
    let v = evaluate(&early, &t);
    assert!(has_stratum(&v, "scene", "stall", 1, 1));
    assert!(has_stratum(&v, "scene", "lin", 0, 1));
}

#[test]
fn bounds_hold_per_row() {
    // One row per scene: a bound's problem is its scene by default.
    let t = table(
        &["run_id", "scene", "method", "drift", "outcome"],
        &[
            &["r1", "s1", "em", "1e-9", "completed"],
            &["r2", "s2", "em", "3e-8", "completed"],
            &["r3", "s3", "em", "2e-3", "completed"],
            &["r4", "s4", "other", "1", "unstable"],
        ],
    );
    let spec = rule(
        r#"kind = "bound"
rows = { method = "em" }
metric = "drift"
at_most = 1e-6
holds_at = 0.6"#,
    );
    let v = evaluate(&spec, &t);
    assert_eq!(
        (v.problems.held, v.problems.decided(), v.class),
        (2, 3, Class::Validated)
    );
    let spec = rule(
        r#"kind = "bound"
rows = { method = "em|other" }
metric = "outcome"
one_of = ["completed"]"#,
    );
    assert_eq!(evaluate(&spec, &t).problems.held, 3);
}

fn claim_file(rule: &str, extra: &str) -> String {
    format!(
        "claim = \"a beats b\"\npaper = \"someone 2020\"\ndimension = \"speed\"\nstudy = \"s\"\n{extra}\n[rule]\n{rule}\n"
    )
}

#[test]
fn bad_claim_files_are_refused_with_the_key() {
    let tmp = TempDir::new("ledger-bad");
    let good_rule = "kind = \"bound\"\nmetric = \"x\"\nat_most = 1.0";
    for (rule, extra, expected) in [
        (good_rule, "", None),
        ("kind = \"faster\"", "", Some("rule kind")),
        (
            "kind = \"bound\"\nmetric = \"x\"\nat_most = 1.0\npair_by = [\"scene\"]",
            "",
            Some("`pair_by` is not a key of a `bound` rule"),
        ),
        (
            "kind = \"bound\"\nmetric = \"x\"",
            "",
            Some("needs `at_most`"),
        ),
        (
            "kind = \"bound\"\nmetric = \"x\"\nat_most = 1.0\nholds_at = 0.5",
            "",
            Some("holds_at"),
        ),
        (
            "kind = \"bound\"\nmetric = \"x\"\nat_most = 1.0\nrows = { error = \"< x\" }",
            "",
            Some("needs a number"),
        ),
        (good_rule, "tags = 1", Some("unknown field `tags`")),
    ] {
        let text = claim_file(rule, extra);
        let path = tmp.write("c.toml", &text);
        match (Claim::read(&path), expected) {
            (Ok(_), None) => {}
            (Err(e), Some(want)) => {
                let message = e.to_string();
                assert!(message.contains(want), "{message}\n{text}");
                assert!(message.contains("c.toml"), "{message}");
            }
            (r, want) => panic!("{text}: expected {want:?}, got {r:?}"),
        }
    }
    let path = tmp.write(
        "d.toml",
        &claim_file(good_rule, "").replace("\"speed\"", "\"sped\""),
    );
    assert!(
        Claim::read(&path)
            .unwrap_err()
            .to_string()
            .contains("did you mean `speed`")
    );
    // The command exits 2 on a bad claim, 0 on good ones.
    let o = common::softbench(&["ledger", tmp.path().to_str().unwrap()]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn a_claim_whose_results_are_missing_is_unmeasured_with_the_reason() {
    let tmp = TempDir::new("ledger-missing");
    let path = tmp.write(
        "c.toml",
        &claim_file("kind = \"bound\"\nmetric = \"x\"\nat_most = 1.0", ""),
    );
    let judged = judge(&[Claim::read(&path).unwrap()], &tmp.path().join("results"));
    assert_eq!(judged[0].verdict.class, Class::Unmeasured);
    assert!(judged[0].verdict.condition.contains("does not exist"));
    // A table that lacks a column the rule reads.
    std::fs::create_dir_all(tmp.path().join("results/s")).unwrap();
    tmp.write("results/s/runs.csv", "run_id,scene,y\nr,s,1\n");
    let judged = judge(&[Claim::read(&path).unwrap()], &tmp.path().join("results"));
    assert!(judged[0].verdict.condition.contains("no column `x`"));
}

/// A claim about one method is judged on softbench's implementation and on each original,
/// each verdict naming which; a timed claim its paper makes on a GPU gets an open GPU verdict
/// for an original that can run on one, and its CPU verdict reads the CPU rows alone.
#[test]
fn a_claim_about_a_method_is_judged_on_each_implementation() {
    let tmp = TempDir::new("ledger-originals");
    let rule = "kind = \"dominates\"\na = { method = \"vbd\" }\nb = { method = \"newton\" }\n\
                group_by = [\"scene\"]\ncost = \"wall_seconds\"\nerror = \"error\"";
    let originals = "\n[[originals]]\nmethod = \"peer-vbd\"\npackage = \"peerpkg\"\ngpu = true\n";
    let text = claim_file(rule, "subject = \"vbd\"\nclaimed_on = \"gpu\"") + originals;
    let path = tmp.write("c.toml", &text);
    std::fs::create_dir_all(tmp.path().join("results/s")).unwrap();
    // softbench's vbd is beaten by Newton in all three scenes; the peer beats Newton in all
    // (every time ±10 %, so none overlap).
    let mut rows =
        String::from("scene,method,wall_seconds,error,wall_seconds_low,wall_seconds_high\n");
    for scene in ["p1", "p2", "p3"] {
        rows += &format!(
            "{scene},newton,1,0.1,0.9,1.1\n{scene},vbd,2,0.2,1.8,2.2\n\
             {scene},peer-vbd,0.5,0.05,0.45,0.55\n"
        );
    }
    tmp.write("results/s/runs.csv", &rows);
    let judged = judge(&[Claim::read(&path).unwrap()], &tmp.path().join("results"));
    let verdicts: Vec<(String, Class)> = judged
        .iter()
        .map(|j| {
            (
                j.implementation.as_ref().unwrap().label(j.timed()),
                j.verdict.class,
            )
        })
        .collect();
    assert_eq!(
        verdicts,
        [
            ("softbench's `vbd`, CPU".to_owned(), Class::Refuted),
            ("peerpkg's `peer-vbd`, CPU".to_owned(), Class::Validated),
            ("peerpkg's `peer-vbd`, GPU".to_owned(), Class::Unmeasured),
        ]
    );
    assert!(
        judged[2]
            .verdict
            .condition
            .starts_with("open: no run of `peer-vbd` on a GPU"),
        "{}",
        judged[2].verdict.condition
    );
    let page = page::render(&judged, "results");
    assert!(
        page.contains("- Judged on peerpkg's `peer-vbd`, CPU: **validated**"),
        "{page}"
    );
    assert!(
        page.contains("the paper claims its speed on a GPU"),
        "{page}"
    );
    // Rows run on a GPU are judged apart: here the GPU rows lose, the CPU rows still win.
    let mut rows = String::from(
        "scene,method,wall_seconds,error,integrator.peer.device,wall_seconds_low,\
         wall_seconds_high\n",
    );
    for scene in ["p1", "p2", "p3"] {
        rows += &format!(
            "{scene},newton,1,0.1,,0.9,1.1\n{scene},peer-vbd,0.5,0.05,cpu,0.45,0.55\n\
             {scene},peer-vbd,3,0.3,cuda,2.7,3.3\n"
        );
    }
    tmp.write("results/s/runs.csv", &rows);
    let judged = judge(&[Claim::read(&path).unwrap()], &tmp.path().join("results"));
    assert_eq!(judged[1].verdict.class, Class::Validated);
    assert_eq!(judged[2].verdict.class, Class::Refuted);
    // Results made without the peers say so, rather than "too few cases".
    tmp.write(
        "results/s/runs.csv",
        "scene,method,wall_seconds,error\np1,newton,1,0.1\np1,vbd,2,0.2\n",
    );
    let judged = judge(&[Claim::read(&path).unwrap()], &tmp.path().join("results"));
    assert!(
        judged[1]
            .verdict
            .condition
            .starts_with("no run of `peer-vbd` in `s/runs.csv`"),
        "{}",
        judged[1].verdict.condition
    );
    // Originals need the subject they implement; `claimed_on` is cpu or gpu.
    for (extra, want) in [
        ("", "originals: name the method"),
        ("subject = \"vbd\"\nclaimed_on = \"tpu\"", "claimed_on"),
    ] {
        let path = tmp.write("d.toml", &(claim_file(rule, extra) + originals));
        let message = Claim::read(&path).unwrap_err().to_string();
        assert!(message.contains(want), "{message}");
    }
}

/// A profile's cost table: one row per scene, target and solver, with the time's spread.
/// `rows` are `(scene, target, solver, wall_seconds)`; every time gets a ±2 % spread.
fn profile_costs(rows: &[(&str, &str, &str, f64)]) -> Table {
    let mut t = table(
        &[
            "scene",
            "target",
            "solver",
            "wall_seconds",
            "wall_seconds_low",
            "wall_seconds_high",
        ],
        &[],
    );
    for (scene, target, solver, w) in rows {
        t.rows.push(vec![
            scene.to_string(),
            target.to_string(),
            solver.to_string(),
            w.to_string(),
            (w * 0.98).to_string(),
            (w * 1.02).to_string(),
        ]);
    }
    t
}

const NESTED_TARGETS: &str = r#"kind = "compare"
table = "profiles/costs.csv"
a = { solver = "radau" }
b = { solver = "esdirk" }
both = { target = "<= 1e-6" }
pair_by = ["scene", "target"]
metric = "wall_seconds"
better = "smaller"
missing = "worst""#;

/// The ledger counts: three nested targets of one pair of ladders on one scene are one
/// problem, as in "Radau IIA is cheaper than ESDIRK4(3) at 1e-6 and below" (issue 50), so
/// they decide nothing alone; three scenes decide it.
#[test]
fn the_ledger_counts_nested_targets_once_per_problem() {
    let spec = rule(NESTED_TARGETS);
    assert_eq!(spec.problem_by, ["scene"], "target is a ladder column");
    assert!(spec.problem_by_default);
    let mut rows = Vec::new();
    for target in ["1e-6", "1e-7", "1e-8"] {
        rows.push(("beam", target, "radau", 1.0));
        rows.push(("beam", target, "esdirk", 2.0));
    }
    let v = evaluate(&spec, &profile_costs(&rows));
    assert_eq!(cases(&v), (3, 3, 0));
    assert_eq!(problems(&v), (1, 1, 0));
    assert_eq!(v.class, Class::Unmeasured);
    assert!(
        v.condition
            .starts_with("1 problem decided (3 cases): fewer than the 3"),
        "{}",
        v.condition
    );
    // Counted by target, as the ledger once did, the same runs would validate it.
    let by_target = rule(&format!(
        "{NESTED_TARGETS}\nproblem_by = [\"scene\", \"target\"]"
    ));
    assert!(!by_target.problem_by_default);
    assert_eq!(
        evaluate(&by_target, &profile_costs(&rows)).class,
        Class::Validated
    );
    // Two more scenes: three problems of three cases each.
    for scene in ["ball", "bar"] {
        for target in ["1e-6", "1e-7", "1e-8"] {
            rows.push((scene, target, "radau", 1.0));
            rows.push((scene, target, "esdirk", 2.0));
        }
    }
    let v = evaluate(&spec, &profile_costs(&rows));
    assert_eq!((problems(&v), cases(&v)), ((3, 3, 0), (9, 9, 0)));
    assert_eq!(v.class, Class::Validated);
    assert_eq!(v.tally(), "3 of 3 problems held; 9 cases");
    // The default leaves out every ladder column: targets, levels, steps, tolerances and an
    // integrator's iterations; a bound's problem is its scene.
    let spec = rule(
        r#"kind = "compare"
a = { method = "a" }
b = { method = "b" }
pair_by = ["scene", "material.model", "dt", "level", "integrator.newton.tolerance", "integrator.vbd.iterations"]
metric = "error"
better = "smaller""#,
    );
    assert_eq!(spec.problem_by, ["scene", "material.model"]);
    let bound = rule("kind = \"bound\"\nmetric = \"x\"\nat_most = 1.0");
    assert_eq!(bound.problem_by, ["scene"]);
}

/// A problem whose cases disagree along its ladder is split: decided, but neither for the
/// claim nor against it, so it keeps a claim from being validated and from being refuted; a
/// stratum of a ladder column reads each problem's cases at that value.
#[test]
fn a_problem_split_along_its_ladder_neither_validates_nor_refutes() {
    let text = format!("{NESTED_TARGETS}\nqualify_by = [\"target\"]");
    let spec = rule(&text);
    // s1 and s2: radau cheaper at both targets; s3 and s4: at 1e-6 only.
    let mut rows = Vec::new();
    for scene in ["s1", "s2", "s3", "s4"] {
        let late = if scene < "s3" { 2.0 } else { 0.5 };
        rows.extend([
            (scene, "1e-6", "radau", 1.0),
            (scene, "1e-6", "esdirk", 2.0),
            (scene, "1e-8", "radau", 1.0),
            (scene, "1e-8", "esdirk", late),
        ]);
    }
    let v = evaluate(&spec, &profile_costs(&rows));
    assert_eq!(
        v.problems,
        Counts {
            held: 2,
            split: 2,
            ..Counts::default()
        }
    );
    assert_eq!(v.class, Class::Qualified);
    assert_eq!(
        v.condition, "holds where target = 1e-6 (4 of 4 problems)",
        "the stratum of a target is every problem's case at it"
    );
    assert!(has_stratum(&v, "target", "1e-8", 2, 4));
    let split = v
        .examples
        .iter()
        .find(|e| e.problem == "s3")
        .expect("the split problem is shown");
    assert_eq!(split.outcome.name(), "split");
    assert_eq!(split.cases.len(), 2);
    // Without strata the condition gives the shares and the splits.
    let v = evaluate(&rule(NESTED_TARGETS), &profile_costs(&rows));
    assert!(
        v.condition
            .starts_with("holds on 2 of 4 problems (50 %; 2 split)"),
        "{}",
        v.condition
    );
    // Every problem split: qualified, not refuted; every problem failing: refuted.
    let all_split: Vec<_> = rows
        .iter()
        .map(|&(s, t, m, w)| (s, t, m, if t == "1e-8" && m == "esdirk" { 0.5 } else { w }))
        .collect();
    let v = evaluate(&rule(NESTED_TARGETS), &profile_costs(&all_split));
    assert_eq!((v.problems.split, v.class), (4, Class::Qualified));
    let all_fail: Vec<_> = rows
        .iter()
        .map(|&(s, t, m, w)| (s, t, m, if m == "esdirk" { 0.5 } else { w }))
        .collect();
    let v = evaluate(&rule(NESTED_TARGETS), &profile_costs(&all_fail));
    assert_eq!((v.problems.failed, v.class), (4, Class::Refuted));
}

/// A run table's row whose total time gets its spread from its step-time quartiles: 11
/// steps, the ten steady ones with median `m` and quartiles `m − 0.005`, `m + 0.01`, so the
/// spread is `[w − 0.05, w + 0.1]`.
fn timed_run(scene: &str, method: &str, wall: f64, error: f64) -> Vec<String> {
    let m = (wall - 0.1) / 10.0;
    [
        scene.to_owned(),
        method.to_owned(),
        format!("{wall}"),
        format!("{error}"),
        "11".to_owned(),
        format!("{m}"),
        format!("{}", m - 0.005),
        format!("{}", m + 0.01),
    ]
    .to_vec()
}

fn timed_runs(rows: Vec<Vec<String>>) -> Table {
    let mut t = table(
        &[
            "scene",
            "method",
            "wall_seconds",
            "error",
            "steps",
            "step_seconds_median",
            "step_seconds_q1",
            "step_seconds_q3",
        ],
        &[],
    );
    t.rows = rows;
    t
}

/// A speed claim compares spreads: times whose spreads overlap tie (in a `compare`), are
/// equal costs (in a `dominates`, where the error then decides), and straddle a bound.
#[test]
fn times_whose_spreads_overlap_tie() {
    // p1–p3: 1.0 against 1.05, spreads [0.95, 1.1] and [1.0, 1.15]: ties. p4–p6: 1.0 against
    // 2.0: a is faster.
    let mut rows = Vec::new();
    for (scene, b) in [
        ("p1", 1.05),
        ("p2", 1.05),
        ("p3", 1.05),
        ("p4", 2.0),
        ("p5", 2.0),
        ("p6", 2.0),
    ] {
        rows.push(timed_run(scene, "a", 1.0, 0.1));
        rows.push(timed_run(scene, "b", b, 0.1));
    }
    let t = timed_runs(rows);
    let compare = r#"kind = "compare"
a = { method = "a" }
b = { method = "b" }
pair_by = ["scene"]
metric = "wall_seconds"
better = "smaller""#;
    let v = evaluate(&rule(compare), &t);
    assert_eq!(problems(&v), (3, 3, 3));
    assert_eq!(v.class, Class::Validated);
    assert_eq!(v.tally(), "3 of 3 problems held (3 more tied); 6 cases");
    // As single numbers every pair would decide.
    let single = rule(&format!("{compare}\nsingle_timings = true"));
    assert_eq!(problems(&evaluate(&single, &t)), (6, 6, 0));
    assert!(single.describe().contains("`single_timings`"));
    // dominates: overlapping costs are equal, so the error decides. b is beaten where its
    // error is larger at an equal cost, and beats a where its error is smaller.
    let t = timed_runs(vec![
        timed_run("q1", "a", 1.0, 0.1),
        timed_run("q1", "b", 1.05, 0.2),
        timed_run("q2", "a", 1.0, 0.1),
        timed_run("q2", "b", 1.05, 0.05),
    ]);
    let dominates = r#"kind = "dominates"
a = { method = "a" }
b = { method = "b" }
group_by = ["scene"]
cost = "wall_seconds"
error = "error"
min_cases = 1"#;
    let v = evaluate(&rule(dominates), &t);
    assert_eq!((v.problems.held, v.problems.failed), (1, 1));
    // As single numbers q2's b costs more (1.05 against 1.0) and errs less: on a's front, a
    // tie.
    let v = evaluate(&rule(&format!("{dominates}\nsingle_timings = true")), &t);
    assert_eq!(
        (v.problems.held, v.problems.failed, v.problems.tied),
        (1, 0, 1)
    );
    // bound: within when the whole spread is, outside when the whole spread is, else a tie.
    let t = timed_runs(vec![
        timed_run("r1", "a", 1.0, 0.1),
        timed_run("r2", "a", 2.0, 0.1),
        timed_run("r3", "a", 3.0, 0.1),
    ]);
    let v = evaluate(
        &rule("kind = \"bound\"\nmetric = \"wall_seconds\"\nat_most = 2.05\nmin_cases = 1"),
        &t,
    );
    assert_eq!(
        v.problems,
        Counts {
            held: 1,
            failed: 1,
            tied: 1,
            ..Counts::default()
        }
    );
}

/// A time without a spread (one timing, one step) decides nothing, and the verdict says so,
/// unless the claim compares single timings on purpose.
#[test]
fn times_without_a_spread_decide_nothing_unless_the_claim_opts_out() {
    let t = table(
        &["scene", "method", "wall_seconds"],
        &[
            &["p1", "a", "1"],
            &["p1", "b", "2"],
            &["p2", "a", "1"],
            &["p2", "b", "2"],
            &["p3", "a", "1"],
            &["p3", "b", "2"],
        ],
    );
    let compare = r#"kind = "compare"
a = { method = "a" }
b = { method = "b" }
pair_by = ["scene"]
metric = "wall_seconds"
better = "smaller""#;
    let v = evaluate(&rule(compare), &t);
    assert_eq!(v.problems.unspread, 3);
    assert_eq!(v.cases.unspread, 3);
    assert_eq!(v.class, Class::Unmeasured);
    assert!(
        v.condition
            .contains("timings without a spread decide nothing")
            && v.condition.contains("single_timings = true"),
        "{}",
        v.condition
    );
    assert_eq!(
        v.tally(),
        "0 of 0 problems held (3 more timed without a spread); 3 cases"
    );
    let v = evaluate(&rule(&format!("{compare}\nsingle_timings = true")), &t);
    assert_eq!((problems(&v), v.class), ((3, 3, 0), Class::Validated));
    // A time that is not `wall_seconds` and has no spread columns needs them too; a count
    // is not a time and needs none.
    let mut t = t;
    t.header[2] = "solve_seconds".into();
    let v = evaluate(&rule(&compare.replace("wall_seconds", "solve_seconds")), &t);
    assert_eq!(v.problems.unspread, 3);
    t.header[2] = "newton_iterations".into();
    let v = evaluate(
        &rule(&compare.replace("wall_seconds", "newton_iterations")),
        &t,
    );
    assert_eq!(v.class, Class::Validated);
    // A run of one step has no step-time quartiles: its time has no spread.
    let mut one_step = timed_run("p1", "b", 2.0, 0.1);
    one_step[4] = "1".into();
    let t = timed_runs(vec![timed_run("p1", "a", 1.0, 0.1), one_step]);
    let v = evaluate(&rule(&format!("{compare}\nmin_cases = 1")), &t);
    assert_eq!((v.cases.unspread, v.class), (1, Class::Unmeasured));
}

/// Every verdict says how many problems decided it, on the page (its table and its
/// evidence) and in what `softbench ledger` prints, with the cases behind them.
#[test]
fn every_verdict_says_how_many_problems_decided_it() {
    let tmp = TempDir::new("ledger-problems");
    std::fs::create_dir_all(tmp.path().join("claims")).unwrap();
    std::fs::create_dir_all(tmp.path().join("results/s/profiles")).unwrap();
    tmp.write("claims/c.toml", &claim_file(NESTED_TARGETS, ""));
    // Three scenes with three nested targets where radau is faster; a fourth where neither
    // solves any target (ties).
    let mut csv =
        String::from("scene,target,solver,wall_seconds,wall_seconds_low,wall_seconds_high\n");
    for scene in ["s1", "s2", "s3"] {
        for target in ["1e-6", "1e-7", "1e-8"] {
            csv +=
                &format!("{scene},{target},radau,1,0.9,1.1\n{scene},{target},esdirk,2,1.9,2.1\n");
        }
    }
    csv += "s4,1e-6,radau,,,\ns4,1e-6,esdirk,,,\n";
    tmp.write("results/s/profiles/costs.csv", &csv);
    let claims = read_claims(&tmp.path().join("claims")).unwrap();
    let judged = judge(&claims, &tmp.path().join("results"));
    let v = &judged[0].verdict;
    assert_eq!(v.class, Class::Validated);
    assert_eq!(v.tally(), "3 of 3 problems held (1 more tied); 10 cases");
    let page = page::render(&judged, "results");
    assert!(
        page.contains("| **validated** | 3 of 3 problems held (1 more tied); 10 cases |"),
        "{page}"
    );
    assert!(
        page.contains(
            "- Evidence: decided by 3 problems: it held on 3, failed on 0, was split on 0; 1 \
             more tied, and decide nothing. Behind them, 10 cases: 9 held, 0 did not, 1 tied."
        ),
        "{page}"
    );
    assert!(
        page.contains("Counted by problem (a problem per scene, the default)"),
        "{page}"
    );
    assert!(
        page.contains("  - holds on s1 (3 decided cases): "),
        "{page}"
    );
    let out = tmp.path().join("ledger.md");
    let o = common::softbench(&[
        "ledger",
        tmp.path().join("claims").to_str().unwrap(),
        "--results",
        tmp.path().join("results").to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let printed = String::from_utf8_lossy(&o.stdout);
    assert!(
        printed.contains("c: validated, 3 of 3 problems held (1 more tied); 10 cases"),
        "{printed}"
    );
    let results = tmp.path().join("results").display().to_string();
    assert_eq!(
        std::fs::read_to_string(&out).unwrap(),
        page::render(&judged, &results)
    );
}

/// A `problem_by` that does not name a set of cases, or names none, is refused when the
/// claim is read, naming the file and the key; so are the other keys of counting.
#[test]
fn a_bad_problem_by_is_refused_naming_the_file_and_the_key() {
    let tmp = TempDir::new("ledger-problem-by");
    let dominates = "kind = \"dominates\"\na = { method = \"a\" }\nb = { method = \"b\" }\n\
                     group_by = [\"scene\"]\ncost = \"wall_seconds\"\nerror = \"error\"";
    for (rule, want) in [
        (
            format!("{NESTED_TARGETS}\nproblem_by = [\"solver\"]"),
            "rule: `problem_by`: `solver` is not one of the columns that key a case \
             (`pair_by` = [\"scene\", \"target\"])",
        ),
        (
            format!("{dominates}\nproblem_by = [\"integrator.newton.tolerance\"]"),
            "`problem_by`: `integrator.newton.tolerance` is not one of the columns that key a \
             case (`group_by` = [\"scene\"])",
        ),
        (
            format!("{NESTED_TARGETS}\nproblem_by = []"),
            "`problem_by`: name at least one column",
        ),
        (
            format!("{NESTED_TARGETS}\nproblem_by = \"scene\""),
            "`problem_by`: a list of column names",
        ),
        (
            format!("{NESTED_TARGETS}\nproblem_by = [\"scene\", \"scene\"]"),
            "`problem_by`: `scene` is named twice",
        ),
        (
            format!("{NESTED_TARGETS}\nsingle_timings = \"yes\""),
            "`single_timings`: true or false",
        ),
        (
            "kind = \"trend\"\ngroup_by = [\"scene\"]\nx = \"tets\"\ny = \"wall_seconds\"\n\
             expect = \"decreasing\""
                .to_owned(),
            "`y`: `wall_seconds` is a time",
        ),
    ] {
        let text = claim_file(&rule, "");
        let path = tmp.write("c.toml", &text);
        let message = Claim::read(&path).unwrap_err().to_string();
        assert!(message.contains(want), "{message}\n{text}");
        assert!(message.contains("c.toml"), "{message}");
        let o = common::softbench(&["ledger", tmp.path().to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(2), "{text}");
    }
    // A bound's problem may be any columns; a good `problem_by` is read as written.
    let path = tmp.write(
        "c.toml",
        &claim_file(
            "kind = \"bound\"\nmetric = \"x\"\nat_most = 1.0\nproblem_by = [\"scene\", \"material.model\"]",
            "",
        ),
    );
    assert_eq!(
        Claim::read(&path).unwrap().rule.problem_by,
        ["scene", "material.model"]
    );
}

/// The committed ledger page is what the committed claims and results give, byte for byte:
/// every verdict on it was computed, and a change of results or rules shows here until the
/// page is rendered again (`softbench ledger`).
#[test]
fn the_committed_ledger_is_computed_from_the_committed_results() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let claims = read_claims(&root.join("claims")).unwrap();
    assert!(claims.len() >= 12, "at least 12 claims: {}", claims.len());
    let judged = judge(&claims, &root.join("results"));
    for j in &judged {
        assert!(
            !j.verdict.condition.contains("does not exist")
                && !j.verdict.condition.contains("no column"),
            "{}: its study's results are not committed: {}",
            j.claim.id,
            j.verdict.condition
        );
    }
    let rendered = page::render(&judged, "results");
    let committed = std::fs::read_to_string(root.join("results/suite/ledger.md")).unwrap();
    assert!(
        committed == rendered,
        "results/suite/ledger.md is not what `softbench ledger` computes from claims/ and \
         results/: run it and commit the page"
    );
}
