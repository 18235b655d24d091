//! Stability as a map over the whole judged range: BDF3 and BDF4 are unstable down to the
//! smallest step judged on undamped bodies (their stability regions leave out the imaginary
//! axis from the origin) and BDF5 stable below its edge at omega dt = 0.715, a bounded spurious oscillation counts as instability, and
//! no verdict changes when the scan is made twice as fine or the horizon, the step cap and the
//! energy limit four times larger.
//!
//! The bodies are built here (clamped boxes of other shapes, materials and stiffnesses than the
//! shipped scenes), so the criteria are checked beyond what they were built on.

mod common;

use common::TempDir;
use common::stability_study::{clamped_box, row, stability};
use softbench::study::table::Table;

/// The verdict, the stable intervals and the scan map of `method`'s row.
fn verdict(runs: &Table, method: &str) -> (String, String, String) {
    let r = row(runs, method);
    let get = |c: &str| runs.get(r, c).unwrap_or_default().to_owned();
    (get("stability"), get("stable_intervals"), get("scan_map"))
}

#[test]
fn bdf3_bdf4_blow_up_at_every_step_bdf5_above_its_edge_bdf2_nowhere() {
    let tmp = TempDir::new("maps-bdf");
    let (text, omega) = clamped_box([4, 1, 1], [0.4, 0.1, 0.1], "stvk", 1e6, 9.81);
    let methods = ["bdf2", "bdf3", "bdf4", "bdf5"];
    // From omega_max dt = 0.5 up to 0.04 s (the same range whatever the horizon): every mode
    // of the body near or below omega dt ~ 1 at the small steps. BDF3's top mode grows at
    // about omega (omega dt)^3 / 2 there (1.7e2/s), enough to be resolved over the base
    // horizon (a trend needs rates of at least 2 ln(1e3) over half the horizon: 69/s at
    // 0.4 s); from omega dt = 0.2 (9/s) only a horizon of 3 s would show it.
    let floor = 0.5 / omega;
    let table = |per_decade: f64, k: f64| {
        format!(
            "dt_min = {:e}\ndt_max = {:e}\ndt_floor = {floor:e}\ndt_ceiling = 0.04\n\
             horizon = {}\nmax_steps = {}\nmin_steps = 10\nscan_per_decade = {per_decade}\n\
             energy_factor = {k}\nrelative_precision = 0.05",
            10.0 * floor,
            100.0 * floor,
            0.4 * k,
            (0.4 * k / floor).ceil() as usize
        )
    };
    let base = stability(&tmp, "bdf-base", &text, &methods, &table(6.0, 1.0));
    let fine = stability(&tmp, "bdf-fine", &text, &methods, &table(12.0, 1.0));
    let caps = stability(&tmp, "bdf-caps", &text, &methods, &table(6.0, 4.0));
    for m in methods {
        let (word, set, map) = verdict(&base, m);
        eprintln!("{m}: {word} {set} {map}");
        for (name, other) in [("scan x2", &fine), ("caps x4", &caps)] {
            let (w, s, mp) = verdict(other, m);
            assert_eq!(w, word, "{m}, {name}: {s} {mp} vs {set} {map}");
        }
    }
    let (bdf2, _, map) = verdict(&base, "bdf2");
    assert_eq!(bdf2, "stable-to-ceiling", "{map}");
    // BDF3 and BDF4 amplify every undamped mode with omega dt below 1.94 and 4.71 (their
    // stability regions leave out the imaginary axis from the origin): no step of the range is
    // stable, down to the smallest judged. (Whether the trend also claims every smaller step
    // depends on how the growth rate bends as omega dt nears 1.94; the map is the finding.)
    for m in ["bdf3", "bdf4"] {
        let (word, set, map) = verdict(&base, m);
        assert!(
            ["unstable-at-every-dt", "no-stable-dt-in-range"].contains(&word.as_str()),
            "{m}: {word} {set} {map}"
        );
        assert!(!map.contains('#'), "{m}: {word} {set} {map}");
        assert_eq!(base.get(row(&base, m), "max_stable_dt"), Some(""), "{m}");
    }
    // BDF5 keeps the imaginary axis up to omega dt = 0.715 and loses it from there to 9.39:
    // stable at the smallest steps, a limit where the top mode crosses 0.715.
    let (word, set, map) = verdict(&base, "bdf5");
    assert_eq!(word, "limit-found", "bdf5: {set} {map}");
    let r = row(&base, "bdf5");
    let edge = base.number(r, "max_stable_dt").unwrap() * base.number(r, "omega_max").unwrap();
    eprintln!("bdf5: omega_max x max_stable_dt = {edge:.3} (theory 0.715)");
    assert!(
        (0.715..0.715 * 1.1).contains(&edge),
        "bdf5: {edge} {set} {map}"
    );
}

#[test]
fn a_bounded_spurious_oscillation_is_unstable_so_limits_land_on_the_theory_at_any_horizon() {
    let tmp = TempDir::new("maps-invented");
    for (name, cells, size, material, youngs) in [
        ("stvk", [5, 2, 1], [0.5, 0.15, 0.08], "stvk", 3e6),
        (
            "snh",
            [4, 2, 2],
            [0.3, 0.1, 0.12],
            "stable-neo-hookean",
            8e5,
        ),
    ] {
        let (text, omega) = clamped_box(cells, size, material, youngs, 9.81);
        let theory = 2.0 / omega;
        for k in [1.0, 4.0] {
            let runs = stability(
                &tmp,
                &format!("{name}-{k}"),
                &text,
                &["symplectic-euler", "velocity-verlet", "rk4"],
                &format!(
                    "dt_min = {:e}\ndt_max = {theory:e}\ndt_floor = {:e}\ndt_ceiling = {:e}\n\
                     horizon = {}\nmax_steps = {}\nenergy_factor = {k}\n\
                     relative_precision = 0.002",
                    0.5 * theory,
                    0.3 * theory,
                    3.0 * theory,
                    0.3 * k,
                    (0.3 * k / (0.3 * theory)).ceil() as usize
                ),
            );
            for (method, expected, tolerance) in [
                ("symplectic-euler", 1.0, 0.01),
                ("velocity-verlet", 1.0, 0.01),
                ("rk4", 2f64.sqrt(), 0.03),
            ] {
                let r = row(&runs, method);
                let (word, set, map) = verdict(&runs, method);
                assert_eq!(word, "limit-found", "{name} x{k} {method}: {set} {map}");
                let found = runs.number(r, "stable_over_theory").unwrap();
                eprintln!("{name}, horizon x{k}, {method}: {found:.4} x 2/omega_max ({map})");
                assert!(
                    (found / expected - 1.0).abs() <= tolerance,
                    "{name} x{k} {method}: {found:.4} x 2/omega_max, theory {expected:.4}"
                );
                assert_eq!(runs.number(r, "invented_energy_limit"), Some(0.05));
            }
        }
    }
}

#[test]
fn an_error_step_holds_at_every_tried_step_below_it() {
    let tmp = TempDir::new("maps-error");
    let (text, omega) = clamped_box([4, 1, 1], [0.4, 0.1, 0.1], "stvk", 1e6, 9.81);
    let floor = 0.5 / omega;
    let runs = stability(
        &tmp,
        "error",
        &text,
        &["implicit-midpoint", "backward-euler"],
        &format!(
            "dt_min = {:e}\ndt_max = {:e}\ndt_floor = {floor:e}\nhorizon = 0.3\n\
             max_steps = {}\nmin_steps = 5\nerror_samples = 10\nerror_dt_precision = 0.05\n\
             [stability.reference]\nmethod = \"rk4\"\ndt = {:e}",
            4.0 * floor,
            40.0 * floor,
            (0.3 / floor).ceil() as usize,
            0.25 / omega
        ),
    );
    let out = tmp.path().join("results").join("error");
    let mut claimed = 0;
    for r in &runs.rows {
        let id = runs.get(r, "run_id").unwrap();
        let trials = Table::read(&out.join("series").join(format!("{id}-trials.csv")))
            .unwrap()
            .unwrap();
        for (column, tolerance) in [("dt_error_1pct", 0.01), ("dt_error_10pct", 0.1)] {
            let Some(step) = runs.number(r, column) else {
                continue;
            };
            claimed += 1;
            for t in &trials.rows {
                let dt = trials.number(t, "dt").unwrap();
                let error = trials.number(t, "error");
                if dt <= step * (1.0 + 1e-12) {
                    assert!(
                        error.is_some_and(|e| e <= tolerance),
                        "{id}: {column} = {step:e} but the trial at {dt:e} has error {error:?}"
                    );
                }
            }
            // A larger tried step that meets it again is reported, never the claim.
            if let Some(again) = runs.number(r, &format!("{column}_met_again")) {
                assert!(again > step, "{id}: {again} <= {step}");
            }
        }
    }
    assert!(
        claimed >= 2,
        "no error step was claimed: the test is vacuous"
    );
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(report.contains("## Stability maps"), "{report}");
    let chart = std::fs::read_dir(&out)
        .unwrap()
        .filter_map(|e| e.ok())
        .any(|e| e.file_name().to_string_lossy().starts_with("error-dt-"));
    assert!(chart, "no error-against-dt chart in {}", out.display());
}
