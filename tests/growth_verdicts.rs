//! A blow-up is growth, measured: stability limits land on the linear theory, a transient
//! that decays is not a blow-up, methods unstable at every dt are called so with the exponent
//! of their growth, a limit below the judged range is not worded as a property of the method,
//! and no verdict moves when the horizon, the step cap and the energy limit are made larger.
//!
//! The bodies here are not the shipped scenes: StVK and Stable Neo-Hookean boxes of other
//! shapes, stiffnesses and gravities, so the criterion is checked beyond what it was built on.

mod common;

use common::stability_study::{clamped_box, row, stability};
use common::{TempDir, scene, simulate};

#[test]
fn rk4_and_symplectic_euler_limits_are_the_linear_theory_at_full_and_one_percent_gravity() {
    let tmp = TempDir::new("growth-limits");
    for g in [9.81, 0.0981] {
        let (text, omega) = clamped_box([5, 2, 2], [0.5, 0.12, 0.16], "stvk", 2e6, g);
        let theory = 2.0 / omega;
        let runs = stability(
            &tmp,
            &format!("limits-{}", (g * 100.0) as u32),
            &text,
            &["symplectic-euler", "rk4"],
            &format!(
                "dt_min = {:e}\ndt_max = {:e}\nhorizon = 0.5\nmax_steps = 100000\n\
                 relative_precision = 0.002",
                0.5 * theory,
                2.0 * theory
            ),
        );
        for (method, expected) in [("symplectic-euler", 1.0), ("rk4", 2f64.sqrt())] {
            let r = row(&runs, method);
            assert_eq!(
                runs.get(r, "stability"),
                Some("limit-found"),
                "{method} at g {g}"
            );
            let found = runs.number(r, "stable_over_theory").unwrap();
            eprintln!("{method} at g = {g}: limit {found:.5} x 2/omega_max");
            assert!(
                (found / expected - 1.0).abs() < 0.02,
                "{method} at g = {g}: limit {found:.4} x 2/omega_max, theory {expected:.4}"
            );
            // softbench's own omega_max agrees with the dense eigen-solve.
            let dt_theory = runs.number(r, "dt_theory").unwrap();
            assert!(
                (dt_theory / theory - 1.0).abs() < 1e-6,
                "{dt_theory} vs {theory}"
            );
            // Trials 1e-6 (relative) either side of the bracket's ends agree with them.
            assert_eq!(
                runs.get(r, "limit_robust"),
                Some("yes"),
                "{method} at g {g}"
            );
        }
    }
}

/// `simulate` the free ball from a 0.1 % stretch at rest with `sets`; its exit status and
/// summary.json.
fn free_ball(tmp: &TempDir, name: &str, sets: &[&str]) -> (Option<i32>, serde_json::Value) {
    let out = tmp.path().join(name);
    let mut args = vec![
        "--set",
        "initial.stretch=[1.001,1.0,1.0]",
        "--set",
        "initial.angular_velocity=[0.0,0.0,0.0]",
        "--set",
        "run.dt=0.05",
        "--set",
        "run.steps=40",
    ];
    for s in sets {
        args.extend(["--set", s]);
    }
    let o = simulate(&scene("free_ball.toml"), &out, &args);
    let summary = std::fs::read_to_string(out.join("summary.json"))
        .unwrap_or_else(|_| panic!("{name}: {}", String::from_utf8_lossy(&o.stderr)));
    let json: serde_json::Value = serde_json::from_str(&summary).unwrap();
    (o.status.code(), json["summary"].clone())
}

#[test]
fn a_first_step_overshoot_that_decays_is_not_a_blow_up_and_growth_that_keeps_on_is() {
    let tmp = TempDir::new("growth-transient");
    let mut peaks = Vec::new();
    for (name, sets) in [
        (
            "generalized-alpha",
            &[
                "integrator.method=generalized-alpha",
                "integrator.generalized_alpha.rho_infinity=0.0",
            ][..],
        ),
        (
            "hht",
            &[
                "integrator.method=hht-alpha",
                "integrator.hht.alpha=-0.3333",
            ][..],
        ),
        (
            "newmark",
            &[
                "integrator.method=newmark",
                "integrator.newmark.gamma=0.9",
                "integrator.newmark.beta=0.49",
            ][..],
        ),
    ] {
        let (code, summary) = free_ball(&tmp, name, sets);
        assert_eq!(code, Some(0), "{name}: {}", summary["outcome"]);
        assert_eq!(summary["outcome"]["status"], "completed", "{name}");
        // Whatever it gained or lost on the way (the signed peak), by the end nothing grows and
        // the motion is damped out.
        peaks.push(summary["energy_excess_peak"].as_f64().unwrap());
        let factor = summary["energy_growth"]["factor"].as_f64().unwrap();
        assert!(factor < 1.0 + 1e-9, "{name}: {}", summary["energy_growth"]);
        let end = &summary["final_energy"];
        assert!(end["kinetic"].as_f64().unwrap() + end["elastic"].as_f64().unwrap() < 1e-6);
    }
    // Generalized-alpha's first step passes the limit (more than the energy the body holds):
    // only the growth criterion tells it from a blow-up.
    assert!(peaks[0] > 1.0, "{peaks:?}");
    // Newmark with 2 beta < gamma is only conditionally stable: at this step its top modes
    // grow without bound, and that is a blow-up.
    let (code, summary) = free_ball(
        &tmp,
        "newmark-conditional",
        &[
            "integrator.method=newmark",
            "integrator.newmark.gamma=0.6",
            "integrator.newmark.beta=0.05",
        ],
    );
    assert_ne!(code, Some(0));
    assert_eq!(summary["outcome"]["status"], "unstable", "{summary}");
    assert!(summary["energy_growth"]["rate"].as_f64().unwrap() > 0.0);
}

#[test]
fn explicit_euler_and_midpoint_are_unstable_at_every_dt_with_the_exponent_of_their_growth() {
    let tmp = TempDir::new("growth-every-dt");
    let (text, omega) = clamped_box([3, 1, 1], [0.3, 0.1, 0.12], "stable-neo-hookean", 1e6, 9.81);
    // Below the explicit limit the top mode's energy grows at omega^2 dt (explicit Euler) and
    // omega^4 dt^3 / 4 (explicit midpoint) per second: the smallest steps judged are an eighth
    // and a quarter of 1/omega_max, and the horizon lets either grow by e^60 there.
    for (method, omega_dt, rate, exponent) in [
        ("explicit-euler", 0.125, 0.124, 1.0),
        ("midpoint", 0.25, 0.0039, 3.0),
    ] {
        let lowest = omega_dt / omega;
        let horizon = 60.0 / (rate * omega);
        let max_steps = (horizon / lowest).ceil() as usize;
        let runs = stability(
            &tmp,
            method,
            &text,
            &[method],
            &format!(
                "dt_min = {:e}\ndt_max = {:e}\ndt_floor = {:e}\nhorizon = {horizon:e}\n\
                 max_steps = {max_steps}\nmin_steps = 20\nrelative_precision = 0.05",
                4.0 * lowest,
                20.0 * lowest,
                lowest
            ),
        );
        let r = &runs.rows[0];
        assert_eq!(
            runs.get(r, "stability"),
            Some("unstable-at-every-dt"),
            "{method}: {:?}",
            runs.get(r, "message")
        );
        let fitted = runs.number(r, "growth_exponent").unwrap();
        eprintln!("{method}: growth exponent {fitted:.3} (theory {exponent})");
        assert!(
            (fitted - exponent).abs() < 0.35,
            "{method}: growth exponent {fitted}, theory {exponent}"
        );
        assert_eq!(runs.get(r, "max_stable_dt"), Some(""));
    }
}

#[test]
fn a_limit_below_the_judged_range_is_no_stable_dt_in_range_not_a_property_of_the_method() {
    let tmp = TempDir::new("growth-below-range");
    let (text, omega) = clamped_box([4, 2, 2], [0.4, 0.1, 0.1], "stvk", 1e6, 9.81);
    // Symplectic Euler's limit is 2/omega_max; judge only steps from 1.5 times it.
    let lowest = 1.5 * 2.0 / omega;
    let runs = stability(
        &tmp,
        "below",
        &text,
        &["symplectic-euler"],
        &format!(
            "dt_min = {:e}\ndt_max = {:e}\ndt_floor = {lowest:e}\nhorizon = {:e}\n\
             max_steps = 100000\nrelative_precision = 0.05",
            2.0 * lowest,
            4.0 * lowest,
            200.0 * lowest
        ),
    );
    let r = &runs.rows[0];
    assert_eq!(runs.get(r, "stability"), Some("no-stable-dt-in-range"));
    let message = runs.get(r, "message").unwrap();
    assert!(message.contains("may lie below the range"), "{message}");
}

#[test]
fn verdicts_do_not_move_when_the_horizon_the_step_cap_and_the_energy_limit_are_four_times_larger() {
    let tmp = TempDir::new("growth-caps");
    let (text, omega) = clamped_box([4, 2, 2], [0.4, 0.1, 0.12], "stable-neo-hookean", 1e6, 9.81);
    let theory = 2.0 / omega;
    let methods = [
        "explicit-euler",
        "symplectic-euler",
        "rk4",
        "backward-euler",
        "generalized-alpha",
    ];
    let table = |k: f64| {
        format!(
            "dt_min = {:e}\ndt_max = {:e}\ndt_ceiling = 0.005\nhorizon = {:e}\n\
             max_steps = {}\nenergy_factor = {k}\nrelative_precision = 0.01",
            0.3 * theory,
            2.0 * theory,
            0.1 * k,
            (2000.0 * k) as usize
        )
    };
    let base = stability(&tmp, "caps1", &text, &methods, &table(1.0));
    let large = stability(&tmp, "caps4", &text, &methods, &table(4.0));
    for m in methods {
        let (a, b) = (row(&base, m), row(&large, m));
        assert_eq!(
            base.get(a, "stability"),
            large.get(b, "stability"),
            "{m}: {:?} vs {:?}",
            base.get(a, "message"),
            large.get(b, "message")
        );
        if let (Some(x), Some(y)) = (
            base.number(a, "max_stable_dt"),
            large.number(b, "max_stable_dt"),
        ) {
            assert!((x / y - 1.0).abs() < 0.03, "{m}: {x:e} vs {y:e}");
        }
    }
    // The base study is not vacuous: it found limits and ceilings.
    let words: Vec<&str> = base
        .rows
        .iter()
        .filter_map(|r| base.get(r, "stability"))
        .collect();
    assert!(
        words.contains(&"limit-found") && words.contains(&"stable-to-ceiling"),
        "{words:?}"
    );
}

#[test]
fn slow_growth_below_a_bracket_is_not_a_limit_whatever_the_horizon() {
    // Explicit midpoint grows at every dt (omega^4 dt^3 / 4 per second), so slowly at small
    // steps that a trial completes without sustained growth within the horizon: a bracket
    // found there is the horizon's. Its largest "stable" trial still grew, and the growth
    // above it follows dt^3: unstable at every dt, for the horizon and four times it.
    let tmp = TempDir::new("growth-detection");
    let (text, omega) = clamped_box([4, 2, 2], [0.3, 0.12, 0.12], "neo-hookean", 5e5, 9.81);
    for k in [1.0, 4.0] {
        let runs = stability(
            &tmp,
            &format!("detect{k}"),
            &text,
            &["midpoint", "rk4"],
            &format!(
                "dt_min = {:e}\ndt_max = {:e}\nhorizon = {}\nmax_steps = {}\n\
                 relative_precision = 0.01",
                0.02 / omega,
                2.0 / omega,
                0.3 * k,
                (20000.0 * k) as usize
            ),
        );
        let r = row(&runs, "midpoint");
        assert_eq!(
            runs.get(r, "stability"),
            Some("unstable-at-every-dt"),
            "horizon x{k}: {:?}",
            runs.get(r, "message")
        );
        let fitted = runs.number(r, "growth_exponent").unwrap();
        eprintln!("midpoint, horizon x{k}: growth exponent {fitted:.3}");
        assert!((fitted - 3.0).abs() < 0.5, "{fitted}");
        assert_eq!(runs.get(r, "max_stable_dt"), Some(""));
        // RK4's limit is a limit: nothing grows below it.
        let r = row(&runs, "rk4");
        assert_eq!(runs.get(r, "stability"), Some("limit-found"));
    }
}
