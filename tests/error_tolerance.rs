//! Methods stable up to the ceiling are ranked by a measurement, not tied at the ceiling: the
//! largest stable step whose position error against the converged reference stays within 1%
//! and 10%, found by bisection, with what bounds it and the energy lost by then.

mod common;

use common::{TempDir, run_study_ok};
use softbench::study::table::Table;

/// A clamped Stable Neo-Hookean bar released from rest under gravity: it swings, so larger
/// steps of an implicit method damp it more and its error grows with dt.
const BAR: &str = r#"
[mesh]
generate = { box = [5, 1, 1], size = [0.5, 0.1, 0.1] }
[material]
model = "stable-neo-hookean"
youngs_modulus = 2e5
poisson_ratio = 0.3
density = 1000.0
mass = "consistent"
[fixed]
rule = { axis = "x", side = "min", tolerance = 1e-6 }
[forces]
gravity = [0.0, -9.81, 0.0]
[integrator]
method = "backward-euler"
[run]
dt = 0.001
steps = 10
"#;

#[test]
fn unconditionally_stable_methods_are_ranked_by_the_largest_step_within_an_error_tolerance() {
    let tmp = TempDir::new("error-tolerance");
    tmp.write("bar.toml", BAR);
    let study = tmp.write(
        "tol.toml",
        "name = \"tol\"\nstudy = \"stability\"\nscenes = [\"bar.toml\"]\n\
         [grid]\n\"integrator.method\" = [\"backward-euler\", \"bdf2\"]\n\
         [stability]\ndt_min = 1e-4\ndt_max = 0.02\nhorizon = 0.5\nerror_samples = 20\n\
         error_dt_precision = 0.05\n",
    );
    let out = tmp.path().join("results");
    run_study_ok(&study, &out, &[]);
    let dir = out.join("tol");
    let runs = Table::read(&dir.join("runs.csv")).unwrap().unwrap();
    let mut found = Vec::new();
    for r in &runs.rows {
        let method = runs.get(r, "method").unwrap().to_owned();
        assert_eq!(
            runs.get(r, "stability"),
            Some("stable-to-ceiling"),
            "{method}"
        );
        let ceiling = runs.number(r, "max_stable_dt").unwrap();
        let trials = Table::read(&dir.join("series").join(format!("{}-trials.csv", r[0])))
            .unwrap()
            .unwrap();
        let mut per_tolerance = Vec::new();
        for (tolerance, column) in [(0.01, "dt_error_1pct"), (0.1, "dt_error_10pct")] {
            let dt = runs
                .number(r, column)
                .unwrap_or_else(|| panic!("{method}: {column}"));
            let error = runs.number(r, &format!("error_at_{column}")).unwrap();
            assert!(
                error <= tolerance && dt <= ceiling,
                "{method}: {dt} {error}"
            );
            // Bounded by the error: a trial at most 5% (the precision) above it is beyond the
            // tolerance.
            if runs.get(r, &format!("{column}_bound")) == Some("error") {
                let beyond = trials.rows.iter().any(|t| {
                    let d = trials.number(t, "dt").unwrap();
                    d > dt
                        && d <= dt * 1.05 * (1.0 + 1e-9)
                        && trials.number(t, "error").is_none_or(|e| e > tolerance)
                });
                assert!(
                    beyond,
                    "{method}: nothing just above {dt} is beyond {tolerance}"
                );
            }
            // The energy lost by then is reported, signed (an implicit method loses energy).
            let excess = runs
                .number(r, &format!("energy_excess_at_{column}"))
                .unwrap();
            assert!(excess <= 0.0, "{method}: {excess}");
            per_tolerance.push(dt);
        }
        assert!(
            per_tolerance[0] < per_tolerance[1],
            "{method}: {per_tolerance:?}"
        );
        found.push((method, per_tolerance));
    }
    // Second order takes larger steps than first order at 1%: the number ranks them.
    eprintln!("{found:?}");
    assert!(found[1].1[0] > 2.0 * found[0].1[0], "{found:?}");
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(
        report.contains(
            "largest dt below which every tried step is stable with a position error of at most 1%"
        ),
        "{report}"
    );
}

#[test]
fn errors_are_scored_per_phase_next_to_statistics_that_survive_chaos() {
    let tmp = TempDir::new("error-phases");
    tmp.write("bar.toml", BAR);
    let study = |name: &str, phases: &str| {
        let path = tmp.write(
            &format!("{name}.toml"),
            &format!(
                "name = \"{name}\"\nstudy = \"stability\"\nscenes = [\"bar.toml\"]\n\
                 [grid]\n\"integrator.method\" = [\"backward-euler\"]\n\
                 [stability]\ndt_min = 1e-3\ndt_max = 0.02\nhorizon = 0.5\nerror_samples = 20\n\
                 {phases}\n"
            ),
        );
        let out = tmp.path().join("results");
        let o = common::run_study(&path, &out, &[]);
        (o, out.join(name).join("runs.csv"))
    };
    // One phase over the whole horizon is the whole error.
    let (o, csv) = study("whole", "phases = [[0.0, 0.5]]");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let runs = Table::read(&csv).unwrap().unwrap();
    let r = &runs.rows[0];
    let whole = runs.number(r, "error_at_stable_dt").unwrap();
    let phase = runs.number(r, "error_phase1").unwrap();
    assert!((phase / whole - 1.0).abs() < 1e-12, "{phase} vs {whole}");
    assert!(runs.number(r, "reference_difference_phase1").unwrap() > 0.0);
    assert_eq!(runs.get(r, "error_phase2"), Some(""));
    // Two phases: each reported with the reference's own difference in it, and the
    // statistics next to them.
    let (o, csv) = study("two", "phases = [[0.0, 0.2], [0.2, 0.5]]");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let runs = Table::read(&csv).unwrap().unwrap();
    let r = &runs.rows[0];
    assert_eq!(runs.get(r, "phases"), Some("[0, 0.2] [0.2, 0.5]"));
    for c in [
        "error_phase1",
        "error_phase2",
        "reference_difference_phase1",
        "reference_difference_phase2",
        "centroid_error",
        "bounding_box_error",
    ] {
        let v = runs.number(r, c).unwrap_or_else(|| panic!("{c}"));
        assert!(v > 0.0 && v < 1.0, "{c} = {v}");
    }
    // A phase holding no sample time, or past the horizon, is refused with the key.
    for (name, phases) in [
        ("between", "phases = [[0.001, 0.002]]"),
        ("past", "phases = [[0.0, 0.7]]"),
    ] {
        let (o, _) = study(name, phases);
        assert_eq!(o.status.code(), Some(2), "{name}");
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(stderr.contains("stability.phases"), "{stderr}");
    }
}
