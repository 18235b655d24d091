//! The claims ledger: each rule kind decides validated, qualified (with its condition),
//! refuted and unmeasured on tables whose answer is known; bad claim files are refused with
//! the key; and the committed ledger page is exactly what the committed claims and results
//! give (so no verdict on it was typed by hand).

mod common;

use common::TempDir;
use softbench::ledger::rule::RuleSpec;
use softbench::ledger::verdict::{Class, evaluate};
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
    // Three wins of four decided (p5 ties): 75 %, validated at the default 0.75.
    assert_eq!((v.held, v.decided, v.ties), (3, 4, 1));
    assert_eq!(v.class, Class::Validated);
    assert!(
        v.strata
            .contains(&("difficulty".into(), "easy".into(), 3, 3))
    );
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
    assert_eq!(v.condition, "holds where difficulty = easy (3 of 3)");
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
        v.condition.starts_with("holds in 3 of 4 cases (75 %)"),
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
    // p4 decides (b cheaper), p5 ties: one decided case.
    assert_eq!((v.decided, v.ties), (1, 1));
    assert_eq!(v.class, Class::Unmeasured);
    assert!(v.condition.contains("fewer than the 3"), "{}", v.condition);
}

#[test]
fn a_missing_cost_is_worse_than_any_or_a_tie() {
    let t = table(
        &["scene", "solver", "wall_seconds"],
        &[
            &["p1", "a", "1"],
            &["p1", "b", ""],
            &["p2", "a", "1"],
            &["p2", "b", ""],
            &["p3", "a", ""],
            &["p3", "b", ""],
            &["p4", "a", "2"],
            &["p4", "b", "1"],
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
    assert_eq!((worst.held, worst.decided, worst.ties), (2, 3, 1));
    let tie = evaluate(&rule(&text("tie")), &t);
    assert_eq!((tie.held, tie.decided, tie.ties), (0, 1, 3));
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
    assert_eq!((v.held, v.decided, v.ties), (2, 2, 1));
}

#[test]
fn dominates_counts_the_runs_beaten_in_cost_and_error() {
    let t = table(
        &["scene", "method", "wall_seconds", "error"],
        &[
            // a's front: (1, 0.1), (2, 0.01)
            &["s", "a", "1", "0.1"],
            &["s", "a", "2", "0.01"],
            // b: beaten (3, 0.2), beaten (2, 0.05), on the front (0.5, 0.5): neither.
            &["s", "b", "3", "0.2"],
            &["s", "b", "2", "0.05"],
            &["s", "b", "0.5", "0.5"],
            // b beats a here: a's (1, 0.1) is worse than (0.9, 0.05).
            &["t", "a", "1", "0.1"],
            &["t", "b", "0.9", "0.05"],
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
    assert_eq!((v.held, v.decided, v.ties), (2, 3, 1));
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
    assert_eq!((v.held, v.decided), (2, 3));
    assert!(v.strata.contains(&("scene".into(), "up".into(), 0, 1)));
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
    assert!(v.strata.contains(&("scene".into(), "stall".into(), 1, 1)));
    assert!(v.strata.contains(&("scene".into(), "lin".into(), 0, 1)));
}

#[test]
fn bounds_hold_per_row() {
    let t = table(
        &["run_id", "method", "drift", "outcome"],
        &[
            &["r1", "em", "1e-9", "completed"],
            &["r2", "em", "3e-8", "completed"],
            &["r3", "em", "2e-3", "completed"],
            &["r4", "other", "1", "unstable"],
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
    assert_eq!((v.held, v.decided, v.class), (2, 3, Class::Validated));
    let spec = rule(
        r#"kind = "bound"
rows = { method = "em|other" }
metric = "outcome"
one_of = ["completed"]"#,
    );
    assert_eq!(evaluate(&spec, &t).held, 3);
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
    tmp.write("results/s/runs.csv", "run_id,y\nr,1\n");
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
    // softbench's vbd is beaten by Newton in all three scenes; the peer beats Newton in all.
    let mut rows = String::from("scene,method,wall_seconds,error\n");
    for scene in ["p1", "p2", "p3"] {
        rows += &format!("{scene},newton,1,0.1\n{scene},vbd,2,0.2\n{scene},peer-vbd,0.5,0.05\n");
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
    let mut rows = String::from("scene,method,wall_seconds,error,integrator.peer.device\n");
    for scene in ["p1", "p2", "p3"] {
        rows += &format!(
            "{scene},newton,1,0.1,\n{scene},peer-vbd,0.5,0.05,cpu\n{scene},peer-vbd,3,0.3,cuda\n"
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
