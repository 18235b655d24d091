//! The Newton loop's swappable components (`integrator.newton.direction`, `globalization`,
//! `criterion`, `lbfgs_initial`, a step filter): every one runs under every scheme on the
//! loop, every direction and globalization reaches the converged Newton step on an
//! indefinite problem, L-BFGS from the rest Hessian beats the scaled identity on a stiff
//! body, the trust region converges where the full step inverts an element, and a logged
//! solve re-scored under another criterion stops where a fresh solve with it stops.

mod common;

use common::bodies::{block, kicked};
use softbench::integrate::newton::{
    Criterion, Direction, Globalization, IterationRecord, LbfgsInitial, Newton, NewtonSettings,
    Problem, Rescored, StepFilter, Stop, rescore,
};
use softbench::integrate::{IntegratorSettings, Method, State, StepError, StepReport};
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::generate::box_mesh;
use softbench::model::{Model, ModelSpec};
use softbench::solve::{LinearSolverKind, SolverSettings};

/// Every direction (L-BFGS with each initial Hessian) with backtracking, and Newton with
/// every globalization: the component combinations that make sense.
fn variants() -> Vec<(String, NewtonSettings)> {
    let mut out = Vec::new();
    for &direction in Direction::ALL {
        if direction == Direction::Lbfgs {
            for &initial in LbfgsInitial::ALL {
                out.push((
                    format!("lbfgs from {initial}"),
                    NewtonSettings {
                        direction,
                        lbfgs_initial: initial,
                        ..Default::default()
                    },
                ));
            }
        } else {
            out.push((
                direction.to_string(),
                NewtonSettings {
                    direction,
                    ..Default::default()
                },
            ));
        }
    }
    for &globalization in Globalization::ALL {
        out.push((
            format!("newton with {globalization}"),
            NewtonSettings {
                globalization,
                ..Default::default()
            },
        ));
    }
    out.push((
        "modified newton".into(),
        NewtonSettings {
            refactor_every: 3,
            ..Default::default()
        },
    ));
    out
}

#[test]
fn every_component_runs_under_every_scheme_on_the_newton_loop() {
    // The adaptive variants run the stages of their fixed-step methods (tested here); with a
    // component that cannot converge a stage at dt = 0.01 their controller would shrink the
    // step until `max_substeps`, which is error control doing its job, not a component failing.
    let methods: Vec<Method> = Method::all()
        .into_iter()
        .filter(|m| m.uses_newton() && !m.is_adaptive())
        .collect();
    assert!(methods.len() >= 8, "{methods:?}");
    let mut settings_list = variants();
    for &criterion in Criterion::ALL {
        settings_list.push((
            format!("criterion {criterion}"),
            NewtonSettings {
                criterion,
                tolerance: 1e-6,
                ..Default::default()
            },
        ));
    }
    for method in methods {
        for (label, newton) in &settings_list {
            let mut model = block(true, true);
            let mut state = kicked(&model);
            let mut settings = IntegratorSettings {
                method,
                ..Default::default()
            };
            settings.newton = NewtonSettings {
                max_iterations: 50,
                ..*newton
            };
            settings.validate().unwrap();
            let mut integrator = settings.build();
            for step in 0..3 {
                integrator
                    .step(&mut model, &mut state, 0.01)
                    .unwrap_or_else(|e| panic!("{method}, {label}, step {step}: {e}"));
            }
            assert!(
                state.q.iter().chain(&state.v).all(|x| x.is_finite()),
                "{method}, {label}"
            );
        }
    }
}

/// St. Venant–Kirchhoff squashed to 35% of its length, one backward Euler step of 0.1 s: the
/// element Hessians and the system matrix are indefinite.
fn squashed() -> (Model, State) {
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name("stvk", lame).unwrap();
    let model = Model::new(ModelSpec::elastic(
        box_mesh([2, 1, 1], [0.2, 0.1, 0.1]),
        material,
        1000.0,
    ))
    .unwrap();
    let mut state = State::at_rest(&model);
    state.q.iter_mut().step_by(3).for_each(|x| *x *= 0.35);
    (model, state)
}

fn backward_euler_step(
    model: &mut Model,
    state: &State,
    dt: f64,
    newton: NewtonSettings,
) -> (Result<State, StepError>, StepReport) {
    let mut settings = IntegratorSettings {
        method: Method::from_name("backward-euler").unwrap(),
        ..Default::default()
    };
    settings.newton = newton;
    settings.validate().unwrap();
    let mut integrator = settings.build();
    let mut next = state.clone();
    match integrator.step(model, &mut next, dt) {
        Ok(report) => (Ok(next), report),
        Err(e) => (Err(e), StepReport::default()),
    }
}

#[test]
fn every_direction_and_globalization_reaches_the_converged_newton_step_on_an_indefinite_case() {
    let (mut model, start) = squashed();
    let reference_settings = NewtonSettings {
        tolerance: 1e-12,
        max_iterations: 100,
        require_convergence: true,
        ..Default::default()
    };
    let (reference, report) = backward_euler_step(&mut model, &start, 0.1, reference_settings);
    let reference = reference.unwrap();
    assert!(
        report.indefinite_fallbacks > 0,
        "the case is meant to be indefinite: {report:?}"
    );
    let size: f64 = reference
        .q
        .iter()
        .zip(&start.q)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    for (label, newton) in variants() {
        let settings = NewtonSettings {
            tolerance: 1e-12,
            max_iterations: 20_000,
            require_convergence: true,
            ..newton
        };
        let (next, report) = backward_euler_step(&mut model, &start, 0.1, settings);
        let next = next.unwrap_or_else(|e| panic!("{label}: {e}"));
        let distance: f64 = next
            .q
            .iter()
            .zip(&reference.q)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        eprintln!(
            "{label}: {} iterations, distance to converged Newton {:.2e} of the step {size:.2e}",
            report.newton_iterations,
            distance / size
        );
        if newton.globalization == Globalization::FullStep {
            // Unchecked full steps leave the basin: on this case they converge (the criterion
            // is required above) to another stationary point, 1.8 steps away. A finding, not a
            // defect; the other components must agree.
            continue;
        }
        // The squashed block is close to buckling (its Hessian nearly singular), so a gradient
        // at the tolerance leaves the position a little further off than on a stiff body.
        assert!(distance <= 2e-5 * size, "{label}: {distance:e} vs {size:e}");
    }
}

/// A stiff (E = 1e7 Pa) clamped cantilever 1 m long, 1080 tets, under gravity.
fn stiff_cantilever() -> Model {
    let lame = LameParameters::from_youngs_poisson(1e7, 0.3).unwrap();
    let material = MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
    let mut spec = ModelSpec::elastic(box_mesh([20, 3, 3], [1.0, 0.15, 0.15]), material, 1000.0);
    spec.fixed = common::bodies::clamped_at_min_x();
    spec.gravity = Some(nalgebra::Vector3::new(0.0, -9.81, 0.0));
    Model::new(spec).unwrap()
}

#[test]
fn lbfgs_from_the_rest_hessian_needs_fewer_iterations_than_from_the_scaled_identity() {
    let mut model = stiff_cantilever();
    let start = State::at_rest(&model);
    let iterations = |model: &mut Model, initial: LbfgsInitial| {
        let settings = NewtonSettings {
            direction: Direction::Lbfgs,
            lbfgs_initial: initial,
            criterion: Criterion::RelativeGradient,
            tolerance: 1e-3,
            max_iterations: 10_000,
            require_convergence: true,
            ..Default::default()
        };
        let (next, report) = backward_euler_step(model, &start, 0.01, settings);
        next.unwrap_or_else(|e| panic!("{initial}: {e}"));
        report.newton_iterations
    };
    let rest = iterations(&mut model, LbfgsInitial::Rest);
    let identity = iterations(&mut model, LbfgsInitial::Identity);
    let mass = iterations(&mut model, LbfgsInitial::Mass);
    eprintln!(
        "iterations to 1e-3 of the first gradient: rest {rest}, identity {identity}, mass {mass}"
    );
    assert!(3 * rest < identity, "rest {rest}, identity {identity}");
    assert!(rest < mass, "rest {rest}, mass {mass}");
}

/// A clamped block of the course Neo-Hookean (undefined for J <= 0, E = 1e5 Pa), its free
/// end pushed towards the clamp at `speed` (m/s at the tip): with a large step the first full
/// Newton steps invert an element.
fn pushed(speed: f64) -> (Model, State) {
    let lame = LameParameters::from_youngs_poisson(1e5, 0.3).unwrap();
    let material = MaterialModel::from_name("neo-hookean", lame).unwrap();
    let mut spec = ModelSpec::elastic(box_mesh([2, 1, 1], [0.2, 0.1, 0.1]), material, 1000.0);
    spec.fixed = common::bodies::clamped_at_min_x();
    let model = Model::new(spec).unwrap();
    let mut state = State::at_rest(&model);
    for (f, &v) in model.dofs().free_vertices().iter().enumerate() {
        state.v[3 * f] = -speed * model.rest_positions()[v].x / 0.2;
    }
    (model, state)
}

#[test]
fn the_trust_region_converges_where_the_full_newton_step_inverts_an_element() {
    for (speed, dt) in [(2.0, 0.05), (1.0, 0.1)] {
        let (mut model, start) = pushed(speed);
        let full = NewtonSettings {
            globalization: Globalization::FullStep,
            max_iterations: 200,
            ..Default::default()
        };
        let (result, _) = backward_euler_step(&mut model, &start, dt, full);
        match result {
            Err(StepError::NewtonFailed { reason, .. }) => {
                assert!(reason.contains("inverts"), "{reason}")
            }
            other => panic!("the full step was meant to invert an element: {other:?}"),
        }
        let trust = NewtonSettings {
            globalization: Globalization::TrustRegion,
            max_iterations: 200,
            tolerance: 1e-10,
            require_convergence: true,
            ..Default::default()
        };
        let (result, report) = backward_euler_step(&mut model, &start, dt, trust);
        let next = result.unwrap_or_else(|e| panic!("trust region: {e}"));
        assert_eq!(model.inverted_elements(&next.q).unwrap(), 0);
        // It is the step converged Newton with a line search finds.
        let (newton, _) = backward_euler_step(
            &mut model,
            &start,
            dt,
            NewtonSettings {
                tolerance: 1e-10,
                max_iterations: 200,
                require_convergence: true,
                ..Default::default()
            },
        );
        let newton = newton.unwrap();
        let d = next
            .q
            .iter()
            .zip(&newton.q)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(d < 1e-8, "{d:e}");
        eprintln!(
            "v {speed}, dt {dt}: trust region {} iterations, {} rejected steps",
            report.newton_iterations, report.line_search_backtracks
        );
    }
}

fn newton_minimizer(settings: NewtonSettings) -> Newton {
    Newton::new(
        LinearSolverKind::from_name("cholesky")
            .unwrap()
            .build(&SolverSettings::default()),
        settings,
    )
}

/// One backward Euler solve of `dt` from `state` with `settings`, logged.
fn logged_solve(
    model: &mut Model,
    state: &State,
    dt: f64,
    settings: NewtonSettings,
) -> Vec<IterationRecord> {
    let x_hat: Vec<f64> = state
        .q
        .iter()
        .zip(&state.v)
        .map(|(q, v)| q + dt * v)
        .collect();
    let mut newton = newton_minimizer(NewtonSettings {
        log_iterations: true,
        ..settings
    });
    let mut x = x_hat.clone();
    let mut report = StepReport::default();
    newton
        .minimize(
            model,
            &Problem {
                x_hat: &x_hat,
                x_ref: &state.q,
                beta: dt * dt,
                damping_anchor: &state.q,
                ..Default::default()
            },
            &mut x,
            &mut report,
        )
        .unwrap();
    let mut log = Vec::new();
    newton.drain_log(&mut log);
    log
}

/// The quantity a criterion compares with its tolerance (met iff `value <= tolerance`).
fn criterion_value(c: Criterion, r: &IterationRecord) -> f64 {
    match c {
        Criterion::ScaledGradient => r.gradient_norm / r.scaled_gradient_scale,
        Criterion::Gradient => r.gradient_norm,
        Criterion::RelativeGradient => r.gradient_norm / r.initial_gradient,
        Criterion::GravityGradient => r.gradient_norm / r.gravity_scale,
        Criterion::Decrement => 0.5 * r.decrement,
        Criterion::Step => r.step_norm,
        Criterion::Energy => r.energy_decrease.abs() / r.energy_scale,
    }
}

#[test]
fn a_logged_solve_rescored_under_another_criterion_stops_where_a_fresh_solve_stops() {
    let cases: Vec<(&str, Model, State, f64)> = vec![
        (
            "kicked block, dt 0.05",
            block(true, true),
            kicked(&block(true, true)),
            0.05,
        ),
        {
            let model = stiff_cantilever();
            let state = kicked(&model);
            ("stiff cantilever, dt 0.02", model, state, 0.02)
        },
    ];
    let mut compared = 0;
    for (name, mut model, state, dt) in cases {
        let tight = NewtonSettings {
            tolerance: 0.0,
            max_iterations: 12,
            ..Default::default()
        };
        let log = logged_solve(&mut model, &state, dt, tight);
        assert!(
            log.len() >= 4,
            "{name}: too few iterations to re-score: {log:?}"
        );
        for &criterion in Criterion::ALL {
            // A tolerance between the values at the second and third iterates, where the
            // criterion can answer (k >= 1 for the step and the energy).
            let values: Vec<f64> = log
                .iter()
                .map(|r| criterion_value(criterion, r))
                .filter(|v| v.is_finite() && *v > 0.0)
                .collect();
            assert!(values.len() >= 3, "{name}, {criterion}: {values:?}");
            let tolerance = (values[1] * values[2]).sqrt();
            let rescored = rescore(&log, criterion, tolerance);
            let fresh = logged_solve(
                &mut model,
                &state,
                dt,
                NewtonSettings {
                    criterion,
                    tolerance,
                    ..tight
                },
            );
            let last = fresh.last().unwrap();
            eprintln!(
                "{name}, {criterion} at {tolerance:.3e}: re-scored {rescored:?}, fresh stops at {} ({:?})",
                last.iteration, last.stop
            );
            assert_eq!(
                rescored,
                Rescored::At(last.iteration, last.stop),
                "{name}, {criterion} at {tolerance:e}"
            );
            // The fresh solve's records are the logged ones up to where it stopped.
            for (a, b) in fresh.iter().zip(&log) {
                assert_eq!(a.gradient_norm, b.gradient_norm, "{name}, {criterion}");
            }
            compared += 1;
        }
    }
    assert_eq!(compared, 2 * Criterion::ALL.len());
}

/// Allows at most a quarter of every step.
struct Quarter;

impl StepFilter for Quarter {
    fn max_step(&mut self, _x: &[f64], _dx: &[f64], _t: f64) -> f64 {
        0.25
    }
}

#[test]
fn a_step_filter_caps_the_first_length_of_every_line_search() {
    let mut model = block(true, true);
    let state = kicked(&model);
    let dt = 0.05;
    let x_hat: Vec<f64> = state
        .q
        .iter()
        .zip(&state.v)
        .map(|(q, v)| q + dt * v)
        .collect();
    let problem = Problem {
        x_hat: &x_hat,
        x_ref: &state.q,
        beta: dt * dt,
        damping_anchor: &state.q,
        ..Default::default()
    };
    let settings = NewtonSettings {
        max_iterations: 200,
        require_convergence: true,
        ..Default::default()
    };
    let mut free = newton_minimizer(settings);
    let mut x_free = x_hat.clone();
    let mut report_free = StepReport::default();
    free.minimize(&mut model, &problem, &mut x_free, &mut report_free)
        .unwrap();
    assert!(free.trace().first_step_lengths.iter().all(|&a| a == 1.0));
    assert_eq!(report_free.filtered_steps, 0);
    let mut capped = newton_minimizer(settings);
    capped.set_step_filter(Box::new(Quarter));
    let mut x = x_hat.clone();
    let mut report = StepReport::default();
    capped
        .minimize(&mut model, &problem, &mut x, &mut report)
        .unwrap();
    let lengths = &capped.trace().first_step_lengths;
    assert!(
        !lengths.is_empty() && lengths.iter().all(|&a| a == 0.25),
        "{lengths:?}"
    );
    assert_eq!(report.filtered_steps as usize, lengths.len());
    assert!(report.newton_iterations > report_free.newton_iterations);
    // Capped steps still reach the same minimizer.
    let d: f64 = x
        .iter()
        .zip(&x_free)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(d < 1e-7, "{d:e}");
    assert_ne!(capped.trace().stop, Stop::Cap);
}

fn simulate_cantilever(out: &std::path::Path, sets: &[&str]) -> std::process::Output {
    let mut args = vec!["--set", "run.steps=3"];
    for s in sets {
        args.push("--set");
        args.push(s);
    }
    common::simulate(&common::scene("cantilever.toml"), out, &args)
}

#[test]
fn simulate_writes_every_iteration_to_iterations_csv_when_asked() {
    let dir = common::TempDir::new("newton-log");
    let out = dir.path().join("run");
    let done = simulate_cantilever(
        &out,
        &[
            "integrator.newton.log_iterations=true",
            "integrator.newton.tolerance=1e-12",
        ],
    );
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    let text = std::fs::read_to_string(out.join("iterations.csv")).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        softbench::integrate::newton::log::CSV_HEADER.join(",")
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // Every step's solve starts at iteration 0 and ends with a stop reason.
    for step in 1..=3 {
        let of_step: Vec<_> = rows.iter().filter(|r| r[0] == step.to_string()).collect();
        assert!(of_step.len() >= 2, "step {step}: {of_step:?}");
        assert_eq!(of_step[0][2], "0");
        assert!(
            ["criterion", "roundoff", "cap"].contains(of_step.last().unwrap().last().unwrap()),
            "{of_step:?}"
        );
    }
    let summary = std::fs::read_to_string(out.join("summary.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&summary).unwrap();
    let iterations = json["summary"]["totals"]["newton_iterations"]
        .as_u64()
        .unwrap();
    // One row per iterate: the iterations plus each solve's first iterate, but for a solve
    // that ended on round-off (its last iteration's full step has no row of its own).
    let roundoff = rows
        .iter()
        .filter(|r| r.last() == Some(&"roundoff"))
        .count() as u64;
    assert_eq!(rows.len() as u64, iterations + 3 - roundoff, "{text}");
    // Without the setting, a previous log is removed, not left to describe another run.
    let again = simulate_cantilever(&out, &[]);
    assert!(again.status.success());
    assert!(!out.join("iterations.csv").exists());
}

#[test]
fn unknown_components_and_combinations_that_do_not_apply_are_refused_with_their_key() {
    let dir = common::TempDir::new("newton-bad");
    let out = dir.path().join("run");
    for (set, needles) in [
        (
            vec!["integrator.newton.direction=bfgs"],
            vec!["direction", "lbfgs", "gradient-descent"],
        ),
        (
            vec!["integrator.newton.globalization=wolfe"],
            vec!["globalization", "trust-region", "backtracking"],
        ),
        (
            vec!["integrator.newton.criterion=residual"],
            vec!["criterion", "decrement", "scaled-gradient"],
        ),
        (
            vec![
                "integrator.newton.globalization=trust-region",
                "integrator.newton.direction=lbfgs",
            ],
            vec!["trust-region", "direction = \"newton\""],
        ),
        (
            vec![
                "integrator.newton.criterion=gravity-gradient",
                "forces.gravity=[0.0, 0.0, 0.0]",
            ],
            vec!["integrator.newton.criterion", "gravity"],
        ),
        (
            vec![
                "integrator.newton.log_iterations=true",
                "integrator.method=rk4",
            ],
            vec!["integrator.newton.log_iterations", "rk4"],
        ),
        (
            vec!["integrator.newton.lbfgs_history=0"],
            vec!["lbfgs_history"],
        ),
        (
            vec![
                "integrator.newton.roundoff_stop=false",
                "integrator.method=rk4",
            ],
            vec!["integrator.newton.roundoff_stop", "rk4"],
        ),
    ] {
        let done = simulate_cantilever(&out, &set);
        let stderr = String::from_utf8_lossy(&done.stderr);
        assert_eq!(done.status.code(), Some(2), "{set:?}: {stderr}");
        for needle in needles {
            assert!(
                stderr.contains(needle),
                "{set:?}: `{needle}` not in {stderr}"
            );
        }
        assert!(!out.join("trajectory.csv").exists(), "{set:?} wrote output");
    }
}

/// With the round-off stop (the default) a solve ends where the energy can no longer tell a
/// decrease, above a tight gradient tolerance; `roundoff_stop = false` goes on with full
/// steps and meets it, and ends at working precision (a `roundoff` stop) when the tolerance
/// is out of reach.
#[test]
fn going_past_the_roundoff_stop_meets_gradient_tolerances_the_energy_cannot_resolve() {
    let state = kicked(&stiff_cantilever());
    let dt = 0.02;
    let settings = |tolerance: f64, roundoff_stop: bool| NewtonSettings {
        tolerance,
        max_iterations: 50,
        roundoff_stop,
        ..Default::default()
    };
    let residual = |r: &IterationRecord| Criterion::ScaledGradient.residual(r);
    let stopped = logged_solve(&mut stiff_cantilever(), &state, dt, settings(1e-12, true));
    let last = stopped.last().unwrap();
    assert_eq!(last.stop, Stop::Roundoff, "{stopped:?}");
    assert!(residual(last) > 1e-12, "{:e}", residual(last));
    let past = logged_solve(&mut stiff_cantilever(), &state, dt, settings(1e-12, false));
    let end = past.last().unwrap();
    assert_eq!(end.stop, Stop::Criterion, "{past:?}");
    assert!(residual(end) <= 1e-12 && residual(end) < residual(last));
    // The iterates agree up to the round-off point: only the stop differs.
    for (a, b) in stopped.iter().zip(&past).take(stopped.len() - 1) {
        assert_eq!(a.gradient_norm.to_bits(), b.gradient_norm.to_bits());
    }
    // Out of reach: ends at working precision, not at the cap.
    let floor = logged_solve(&mut stiff_cantilever(), &state, dt, settings(0.0, false));
    let end = floor.last().unwrap();
    assert_eq!(end.stop, Stop::Roundoff, "{floor:?}");
    assert!(floor.len() < 50 && residual(end) < 1e-12, "{floor:?}");
    // `residual` is what every criterion compares with its tolerance.
    for r in &floor {
        for &c in Criterion::ALL {
            let (a, b) = (c.residual(r), criterion_value(c, r));
            assert!(a == b || (a.is_nan() && b.is_nan()), "{c:?}: {a} vs {b}");
        }
    }
}

/// Inexact Newton: with CG + AMG a direction solved only to the forcing term reaches the same
/// converged step as directions solved to CG's tolerance (the Newton criterion decides), with
/// fewer CG iterations; a direct solver ignores the forcing and gives the same bits.
#[test]
fn inexact_newton_directions_reach_the_same_step_with_fewer_cg_iterations() {
    let mut model = stiff_cantilever();
    let start = State::at_rest(&model);
    let step = |model: &mut Model, solver: &str, forcing_max: f64| {
        let mut settings = IntegratorSettings {
            method: Method::from_name("backward-euler").unwrap(),
            linear_solver: LinearSolverKind::from_name(solver).unwrap(),
            ..Default::default()
        };
        settings.solver.cg.preconditioner = softbench::solve::Preconditioner::Amg;
        settings.newton = NewtonSettings {
            tolerance: 1e-8,
            max_iterations: 50,
            require_convergence: true,
            forcing_max,
            ..Default::default()
        };
        settings.validate().unwrap();
        let mut integrator = settings.build();
        let mut next = start.clone();
        let report = integrator
            .step(model, &mut next, 0.01)
            .unwrap_or_else(|e| panic!("{solver}, forcing_max {forcing_max}: {e}"));
        (next, report)
    };
    let (exact, exact_report) = step(&mut model, "cg", 0.0);
    let (inexact, inexact_report) = step(&mut model, "cg", 0.1);
    let size = norm_diff(&exact.q, &start.q);
    let distance = norm_diff(&exact.q, &inexact.q);
    eprintln!(
        "CG iterations {} exact, {} inexact; Newton iterations {} / {}; distance {:.2e} of the step",
        exact_report.linear_iterations,
        inexact_report.linear_iterations,
        exact_report.newton_iterations,
        inexact_report.newton_iterations,
        distance / size
    );
    assert!(distance <= 1e-6 * size, "{distance:e} of {size:e}");
    assert!(
        inexact_report.linear_iterations < exact_report.linear_iterations,
        "{} vs {}",
        inexact_report.linear_iterations,
        exact_report.linear_iterations
    );
    assert!(inexact_report.max_relative_residual > 1e-8);
    let (direct, _) = step(&mut model, "cholesky", 0.0);
    let (direct_forced, _) = step(&mut model, "cholesky", 0.1);
    assert!(
        direct.q == direct_forced.q,
        "a direct solver ignores the forcing"
    );
}

fn norm_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}
