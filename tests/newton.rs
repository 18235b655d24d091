//! Newton's method on the incremental potential: quadratic convergence, the round-off-aware
//! line search, fallback on indefinite systems, dt/2 retries, and agreement of the linear
//! solvers on the Newton step.

mod common;

use common::bodies::{block, kicked};
use softbench::integrate::newton::{Newton, NewtonSettings, Problem};
use softbench::integrate::{IntegratorSettings, Method, State, StepError, StepReport};
use softbench::model::Model;
use softbench::solve::{CgSettings, LinearSolverKind, SolverSettings};

/// Backward Euler's incremental potential for `state`: (x_hat, beta).
fn backward_euler_problem(state: &State, dt: f64) -> (Vec<f64>, f64) {
    (
        state
            .q
            .iter()
            .zip(&state.v)
            .map(|(q, v)| q + dt * v)
            .collect(),
        dt * dt,
    )
}

fn newton(settings: NewtonSettings) -> Newton {
    Newton::new(
        LinearSolverKind::from_name("cholesky")
            .unwrap()
            .build(&SolverSettings::default()),
        settings,
    )
}

#[test]
fn newton_converges_quadratically_near_the_solution() {
    let mut model = block(true, true);
    let state = kicked(&model);
    // A large step makes the problem nonlinear enough to need several iterations.
    let (x_hat, beta) = backward_euler_problem(&state, 0.05);
    let mut solver = newton(NewtonSettings {
        tolerance: 1e-13,
        max_iterations: 30,
        ..Default::default()
    });
    let mut x = x_hat.clone();
    let mut report = StepReport::default();
    solver
        .minimize(
            &mut model,
            &Problem {
                x_hat: &x_hat,
                x_ref: &state.q,
                beta,
                damping_anchor: &state.q,
                ..Default::default()
            },
            &mut x,
            &mut report,
        )
        .unwrap();
    let g = &solver.trace().gradient_norms;
    // Quadratic convergence: ‖g_k+1‖ / ‖g_k‖² stays bounded while ‖g_k+1‖ / ‖g_k‖ -> 0.
    // Look at the iterations above round-off (1e-9 of the starting gradient).
    let useful: Vec<f64> = g.iter().copied().take_while(|&n| n > 1e-9 * g[0]).collect();
    let linear: Vec<f64> = useful.windows(2).map(|w| w[1] / w[0]).collect();
    let quadratic: Vec<f64> = useful.windows(2).map(|w| w[1] / (w[0] * w[0])).collect();
    let sci = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:.2e}"))
            .collect::<Vec<_>>()
            .join(" ")
    };
    eprintln!(
        "gradient norms {}\nlinear ratios {}\nquadratic ratios {}",
        sci(g),
        sci(&linear),
        sci(&quadratic)
    );
    assert!(useful.len() >= 4, "too few iterations to judge: {g:?}");
    let tail = &linear[linear.len() - 3..];
    assert!(
        tail.windows(2).all(|w| w[1] < 0.5 * w[0]),
        "not superlinear: {linear:?}"
    );
    let q_tail = &quadratic[quadratic.len() - 3..];
    let (lo, hi) = q_tail
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(l, h), &r| (l.min(r), h.max(r)));
    assert!(
        hi / lo < 30.0,
        "quadratic ratios not bounded: {quadratic:?}"
    );
}

#[test]
fn line_search_accepts_full_steps_once_the_decrease_is_below_round_off() {
    // Far from the origin under gravity, the potential is huge (m g y with y ~ 1e6) while the
    // step's energy change is tiny: an Armijo test on raw energies would reject the last steps.
    let mut shifted = {
        let mut mesh = softbench::mesh::generate::box_mesh([2, 1, 1], [0.2, 0.1, 0.1]);
        mesh.positions.iter_mut().for_each(|p| p.y += 1e6);
        let lame = softbench::material::LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
        let material =
            softbench::material::MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
        let mut spec = softbench::model::ModelSpec::elastic(mesh, material, 1000.0);
        spec.gravity = Some(nalgebra::Vector3::new(0.0, -9.81, 0.0));
        spec.fixed = softbench::model::FixedSelection {
            rules: vec![softbench::model::AxisRule {
                axis: 0,
                side: softbench::model::Side::Min,
                tolerance: 1e-9,
            }],
            ..Default::default()
        };
        Model::new(spec).unwrap()
    };
    // The same motion as the unshifted block (kicked() would read velocities off positions).
    let mut state = State::at_rest(&shifted);
    state.v = kicked(&block(true, true)).v;
    let (x_hat, beta) = backward_euler_problem(&state, 0.01);
    // Tolerance 0 can never be met by the gradient test: Newton must stop on round-off.
    let settings = NewtonSettings {
        tolerance: 0.0,
        max_iterations: 30,
        require_convergence: true,
        ..Default::default()
    };
    let mut solver = newton(settings);
    let mut x = x_hat.clone();
    let mut report = StepReport::default();
    let result = solver.minimize(
        &mut shifted,
        &Problem {
            x_hat: &x_hat,
            x_ref: &state.q,
            beta,
            damping_anchor: &state.q,
            ..Default::default()
        },
        &mut x,
        &mut report,
    );
    eprintln!(
        "trace {:?} backtracks {}",
        solver.trace(),
        report.line_search_backtracks
    );
    result.unwrap();
    assert!(
        solver.trace().roundoff_accepted,
        "the round-off rule should have ended the iteration"
    );
    assert_eq!(
        report.line_search_backtracks, 0,
        "full Newton steps should never be cut near the solution"
    );
    assert!(solver.trace().converged);
}

#[test]
fn every_linear_solver_gives_the_same_newton_step() {
    let mut results = Vec::new();
    for kind in LinearSolverKind::all() {
        let mut model = block(true, true);
        let mut state = kicked(&model);
        let mut settings = IntegratorSettings {
            method: Method::from_name("backward-euler").unwrap(),
            linear_solver: kind,
            ..Default::default()
        };
        settings.newton.tolerance = 1e-12;
        settings.newton.max_iterations = 30;
        settings.solver = SolverSettings {
            cg: CgSettings {
                tolerance: 1e-13,
                ..Default::default()
            },
            ..Default::default()
        };
        let mut integ = settings.build();
        for _ in 0..5 {
            integ
                .step(&mut model, &mut state, 0.01)
                .unwrap_or_else(|e| panic!("{kind}: {e}"));
        }
        results.push((kind, state.q));
    }
    let (_, reference) = &results[0];
    let scale = reference.iter().map(|x| x * x).sum::<f64>().sqrt();
    for (kind, q) in &results[1..] {
        let diff = reference
            .iter()
            .zip(q)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(
            diff <= 1e-10 * scale,
            "{kind} differs from cholesky by {diff:.3e}"
        );
    }
}

#[test]
fn an_indefinite_system_falls_back_to_projected_hessians() {
    // St. Venant–Kirchhoff squashed to a third of its length has strongly negative
    // stiffness; with a large step M + dt^2 K is indefinite and Cholesky fails.
    let lame = softbench::material::LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = softbench::material::MaterialModel::from_name("stvk", lame).unwrap();
    let mesh = softbench::mesh::generate::box_mesh([2, 1, 1], [0.2, 0.1, 0.1]);
    let mut model =
        Model::new(softbench::model::ModelSpec::elastic(mesh, material, 1000.0)).unwrap();
    let mut state = State::at_rest(&model);
    state.q.iter_mut().step_by(3).for_each(|x| *x *= 0.35);
    let mut integ = IntegratorSettings {
        method: Method::from_name("backward-euler").unwrap(),
        ..Default::default()
    }
    .build();
    let report = integ.step(&mut model, &mut state, 0.1).unwrap();
    assert!(
        report.indefinite_fallbacks > 0,
        "expected an indefinite system: {report:?}"
    );
}

#[test]
fn a_failed_step_is_retried_as_two_half_steps_when_asked() {
    let run = |halvings: u32| {
        let mut model = block(true, true);
        let mut state = kicked(&model);
        let mut settings = IntegratorSettings {
            method: Method::from_name("backward-euler").unwrap(),
            ..Default::default()
        };
        settings.newton.max_iterations = 1;
        settings.newton.tolerance = 1e-6;
        settings.newton.require_convergence = true;
        settings.newton.retry_halvings = halvings;
        let result = settings.build().step(&mut model, &mut state, 0.02);
        (result, state)
    };
    let (failed, untouched) = run(0);
    assert!(
        matches!(failed, Err(StepError::NewtonFailed { .. })),
        "{failed:?}"
    );
    assert_eq!(untouched.t, 0.0, "a failed step leaves the state as it was");
    let (retried, state) = run(6);
    let report = retried.expect("halving should rescue the step");
    assert!(report.dt_halvings >= 1);
    assert!(report.substeps >= 2);
    assert!((state.t - 0.02).abs() < 1e-15, "the step still covers dt");
}

#[test]
fn a_body_exactly_at_rest_without_gravity_takes_a_step() {
    // Every term of the incremental potential is zero up to round-off; the elastic energy
    // itself is a difference of O(mu) terms (J^(-2/3) I1 - 3), so its noise is far above the
    // Newton decrement. Newton must recognise the rest state, not fail its line search.
    for method in [
        Method::from_name("backward-euler").unwrap(),
        Method::from_name("implicit-midpoint").unwrap(),
        Method::from_name("bdf2").unwrap(),
    ] {
        let mut model = block(true, false);
        let mut state = State::at_rest(&model);
        let mut integ = IntegratorSettings {
            method,
            ..Default::default()
        }
        .build();
        for _ in 0..3 {
            integ
                .step(&mut model, &mut state, 0.01)
                .unwrap_or_else(|e| panic!("{method}: {e}"));
        }
        let moved = state
            .q
            .iter()
            .zip(&model.rest_state())
            .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
        assert!(
            moved < 1e-12,
            "{method}: a body at rest moved by {moved:.3e}"
        );
    }
}

#[test]
fn a_damped_jello_cube_settles_to_rest_without_newton_failing() {
    use softbench::springs::{JelloCube, ParticleMass, SpringCoefficients};
    let body = JelloCube {
        n: 4,
        size: 0.3,
        origin: nalgebra::Vector3::zeros(),
    }
    .build(|_| SpringCoefficients {
        stiffness: 500.0,
        damping: 2.0,
    });
    let mut model = Model::new(body.into_model_spec(ParticleMass::Each(0.01))).unwrap();
    let mut state = State::at_rest(&model);
    state.v.iter_mut().enumerate().for_each(|(i, v)| {
        *v = if i % 3 == 0 {
            0.3 * ((i / 3) as f64).sin()
        } else {
            0.0
        }
    });
    for method in [
        Method::from_name("backward-euler").unwrap(),
        Method::from_name("implicit-midpoint").unwrap(),
        Method::from_name("bdf2").unwrap(),
    ] {
        let mut s = state.clone();
        let mut integ = IntegratorSettings {
            method,
            ..Default::default()
        }
        .build();
        for step in 0..1500 {
            integ
                .step(&mut model, &mut s, 0.01)
                .unwrap_or_else(|e| panic!("{method} at step {step}: {e}"));
        }
    }
}

#[test]
fn a_spring_cube_released_without_gravity_keeps_stepping() {
    // Regression: after the drag lets go, every energy term is small while the springs'
    // (l - L)^2 carries round-off of order k L |l - L| eps; the Armijo test must not chase it.
    use nalgebra::Vector3;
    use softbench::model::{AxisRule, Drag, DragPath, FixedSelection, Side, Waypoint};
    use softbench::springs::{JelloCube, ParticleMass, SpringCoefficients};
    let body = JelloCube {
        n: 4,
        size: 0.3,
        origin: Vector3::zeros(),
    }
    .build(|_| SpringCoefficients::stiffness(200.0));
    let mut spec = body.into_model_spec(ParticleMass::Each(0.001));
    spec.fixed = FixedSelection {
        rules: vec![AxisRule {
            axis: 1,
            side: Side::Min,
            tolerance: 1e-9,
        }],
        ..Default::default()
    };
    let mut model = Model::new(spec).unwrap();
    let rest = model.rest_positions().to_vec();
    let picked = Drag::pick(&rest, &Vector3::new(0.3, 0.3, 0.3), 0.11);
    let path = DragPath::new(vec![
        Waypoint {
            t: 0.0,
            offset: Vector3::zeros(),
        },
        Waypoint {
            t: 0.2,
            offset: Vector3::new(0.1, 0.0, 0.0),
        },
    ])
    .unwrap();
    model.add_vertex_potential(Box::new(
        Drag::new(&rest, picked, 1000.0, path, Some(0.25)).unwrap(),
    ));
    for method in [
        Method::from_name("backward-euler").unwrap(),
        Method::from_name("implicit-midpoint").unwrap(),
        Method::from_name("bdf2").unwrap(),
    ] {
        let mut state = State::at_rest(&model);
        let mut integ = IntegratorSettings {
            method,
            ..Default::default()
        }
        .build();
        for step in 0..300 {
            integ
                .step(&mut model, &mut state, 0.01)
                .unwrap_or_else(|e| panic!("{method} at step {step}: {e}"));
        }
    }
}

#[test]
fn steps_report_the_size_of_their_factor() {
    let mut model = block(true, true);
    let lower_triangle = {
        let p = model.hessian_pattern();
        (p.nnz() + p.dim()) / 2
    };
    let mut state = kicked(&model);
    let implicit = IntegratorSettings {
        method: Method::from_name("backward-euler").unwrap(),
        ..Default::default()
    }
    .build()
    .step(&mut model, &mut state, 0.01)
    .unwrap();
    // A Cholesky factor holds at least A's lower triangle.
    assert!(
        implicit.factor_nnz >= lower_triangle,
        "nnz(L) = {} < {lower_triangle}",
        implicit.factor_nnz
    );
    let explicit = IntegratorSettings {
        method: Method::from_name("rk4").unwrap(),
        ..Default::default()
    }
    .build()
    .step(&mut model, &mut state, 1e-4)
    .unwrap();
    assert_eq!(
        explicit.factor_nnz, 0,
        "explicit methods factor no system (the mass factor is not a step's)"
    );
}

/// Ten backward-Euler steps of the clamped, kicked block with Newton converged tightly and
/// the factorization kept for `refactor_every` iterations: (positions, totals).
fn modified_newton_run(refactor_every: u32) -> (Vec<f64>, StepReport) {
    let mut model = block(true, true);
    let mut state = kicked(&model);
    let mut integ = IntegratorSettings {
        method: Method::from_name("backward-euler").unwrap(),
        newton: NewtonSettings {
            tolerance: 1e-10,
            max_iterations: 100,
            require_convergence: true,
            refactor_every,
            ..Default::default()
        },
        ..Default::default()
    }
    .build();
    let mut total = StepReport::default();
    for _ in 0..10 {
        let r = integ.step(&mut model, &mut state, 0.02).unwrap();
        total.absorb(&r);
    }
    (state.q, total)
}

#[test]
fn modified_newton_trades_factorizations_for_iterations_and_reaches_the_same_step() {
    let (q_full, full) = modified_newton_run(1);
    let (q_mod, modified) = modified_newton_run(4);
    // Full Newton factors once per iteration.
    assert_eq!(full.factorizations, full.newton_iterations);
    assert!(
        modified.factorizations < full.factorizations,
        "factorizations {} vs {}",
        modified.factorizations,
        full.factorizations
    );
    assert!(modified.newton_iterations > full.newton_iterations);
    // At most one factorization per four iterations, plus the forced refactors.
    assert!(modified.factorizations as f64 >= f64::from(modified.newton_iterations) / 4.0);
    let scale = q_full.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = q_full
        .iter()
        .zip(&q_mod)
        .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()));
    assert!(
        diff < 1e-7 * scale,
        "modified Newton moved the state by {diff:e}"
    );
}

#[test]
fn refactor_every_zero_is_rejected_with_its_name() {
    let s = NewtonSettings {
        refactor_every: 0,
        ..Default::default()
    };
    assert!(s.validate().unwrap_err().contains("newton.refactor_every"));
}
