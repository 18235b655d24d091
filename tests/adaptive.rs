//! Adaptive step control: it meets its tolerance (the error follows it down) and, on a
//! problem with fast and slow phases, reaches a given accuracy with fewer steps than any
//! fixed step.

mod common;

use nalgebra::Vector3;
use softbench::integrate::{AdaptiveSettings, IntegratorSettings, Method, State};
use softbench::material::{MaterialModel, NeoHookean};
use softbench::mesh::TetMesh;
use softbench::model::{FixedSelection, Model, ModelSpec};

/// One course Neo-Hookean tet with its base fixed and its apex thrown at the base: the
/// J^(-2/3) term stiffens sharply near collapse, so each bounce is fast and the rebound slow.
fn bouncing_tet() -> (Model, State) {
    let mesh = TetMesh {
        positions: vec![Vector3::zeros(), Vector3::x(), Vector3::y(), Vector3::z()],
        tets: vec![[0, 1, 2, 3]],
    };
    let material = MaterialModel::NeoHookean(NeoHookean::from_c_d(200.0, 300.0));
    let mut spec = ModelSpec::elastic(mesh, material, 1.0);
    spec.fixed = FixedSelection {
        indices: vec![0, 1, 2],
        ..Default::default()
    };
    let model = Model::new(spec).unwrap();
    let mut state = State::at_rest(&model);
    state.v[2] = -150.0;
    (model, state)
}

/// Integrate over `t_end` in one call per output interval `interval`; returns the final state
/// and the number of internal steps (accepted + rejected) and force evaluations.
fn run(method: Method, adaptive: AdaptiveSettings, dt: f64, t_end: f64) -> (State, u64, u64) {
    let (mut model, mut state) = bouncing_tet();
    let mut integ = IntegratorSettings {
        method,
        adaptive,
        ..Default::default()
    }
    .build();
    let steps = (t_end / dt).round() as usize;
    let (mut substeps, mut evals) = (0u64, 0u64);
    for _ in 0..steps {
        let r = integ
            .step(&mut model, &mut state, dt)
            .unwrap_or_else(|e| panic!("{method}: {e}"));
        substeps += u64::from(r.substeps + r.rejected_substeps);
        evals += r.evaluations.gradient;
    }
    (state, substeps, evals)
}

const T_END: f64 = 0.2;

fn reference() -> State {
    run(
        Method::from_name("rk4").unwrap(),
        AdaptiveSettings::default(),
        T_END / 200_000.0,
        T_END,
    )
    .0
}

fn error(s: &State, reference: &State) -> f64 {
    common::bodies::distance(&s.q, &reference.q)
}

fn settings(tolerance: f64) -> AdaptiveSettings {
    AdaptiveSettings {
        tolerance,
        absolute_tolerance: 1e-3 * tolerance,
        ..Default::default()
    }
}

#[test]
fn adaptive_control_meets_its_tolerance() {
    let reference = reference();
    for method in [
        Method::from_name("adaptive-rk4").unwrap(),
        Method::from_name("dopri5").unwrap(),
    ] {
        let errors: Vec<f64> = [1e-5, 1e-7]
            .iter()
            .map(|&tol| {
                // One call covers the whole interval: every internal step is the controller's.
                let (end, _, _) = run(method, settings(tol), T_END, T_END);
                let e = error(&end, &reference);
                // The bound is on the local error per step; the global error after a few
                // hundred steps stays within a modest multiple of it (q is O(1) here).
                assert!(
                    e <= 50.0 * tol,
                    "{method} with tolerance {tol:e}: error {e:.3e}"
                );
                e
            })
            .collect();
        assert!(
            errors[1] < errors[0] / 20.0,
            "{method}: error does not follow the tolerance: {errors:?}"
        );
    }
}

#[test]
fn adaptive_control_takes_fewer_steps_than_a_fixed_step_of_equal_error() {
    let reference = reference();
    for method in [
        Method::from_name("adaptive-rk4").unwrap(),
        Method::from_name("dopri5").unwrap(),
    ] {
        let (end, steps, evals) = run(method, settings(1e-8), T_END, T_END);
        let target = error(&end, &reference);
        // The fewest fixed RK4 steps (by doubling) that are at least as accurate.
        let mut fixed = 250;
        let (fixed_steps, fixed_evals) = loop {
            let (s, n, e) = run(
                Method::from_name("rk4").unwrap(),
                AdaptiveSettings::default(),
                T_END / fixed as f64,
                T_END,
            );
            if error(&s, &reference) <= target {
                break (n, e);
            }
            fixed *= 2;
            assert!(fixed <= 1 << 20, "fixed RK4 never reached {target:.3e}");
        };
        eprintln!(
            "{method}: error {target:.2e} in {steps} steps / {evals} force evaluations; fixed RK4 needs {fixed_steps} / {fixed_evals}"
        );
        assert!(
            steps < fixed_steps,
            "{method}: {steps} steps (accepted + rejected) vs {fixed_steps} fixed"
        );
        assert!(
            evals < fixed_evals,
            "{method}: {evals} force evaluations vs {fixed_evals} fixed"
        );
    }
}

#[test]
fn adaptive_control_fails_cleanly_below_its_minimum_step() {
    let (mut model, mut state) = bouncing_tet();
    let adaptive = AdaptiveSettings {
        tolerance: 1e-14,
        absolute_tolerance: 1e-17,
        min_dt: 1e-3,
        ..Default::default()
    };
    let mut integ = IntegratorSettings {
        method: Method::from_name("adaptive-rk4").unwrap(),
        adaptive,
        ..Default::default()
    }
    .build();
    let before = state.clone();
    let err = integ.step(&mut model, &mut state, 0.01).unwrap_err();
    assert!(
        matches!(err, softbench::integrate::StepError::StepTooSmall { .. }),
        "{err}"
    );
    assert_eq!(state, before, "a failed step leaves the state as it was");
}

#[test]
fn adaptive_control_stops_at_its_substep_budget() {
    let (mut model, mut state) = bouncing_tet();
    let adaptive = AdaptiveSettings {
        tolerance: 1e-12,
        absolute_tolerance: 1e-15,
        max_substeps: 50,
        ..Default::default()
    };
    let mut integ = IntegratorSettings {
        method: Method::from_name("adaptive-midpoint").unwrap(),
        adaptive,
        ..Default::default()
    }
    .build();
    let before = state.clone();
    let err = integ.step(&mut model, &mut state, 0.1).unwrap_err();
    assert!(
        matches!(
            err,
            softbench::integrate::StepError::TooManySubsteps { substeps: 50, .. }
        ),
        "{err}"
    );
    assert_eq!(err.cause(), "too many substeps");
    assert_eq!(state, before);
}

#[test]
fn controllers_propose_steps_from_their_gains_and_never_grow_after_a_rejection() {
    use softbench::integrate::{Controller, StepController};
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    // The elementary controller: h e^(-1/k).
    let mut i = StepController::new(Controller::I.facts().0);
    assert!(close(i.accepted(0.5, 2.0), 0.5f64.powf(-0.5)));
    // PI: the previous accepted error enters with exponent +k2/k (1 before the first).
    let [k1, k2, _] = Controller::Pi.facts().0;
    let mut pi = StepController::new(Controller::Pi.facts().0);
    assert!(close(pi.accepted(0.5, 3.0), 0.5f64.powf(-k1 / 3.0)));
    let second = 0.25f64.powf(-k1 / 3.0) * 0.5f64.powf(k2 / 3.0);
    assert!(close(pi.accepted(0.25, 3.0), second));
    // PID: the one before that with exponent -k3/k.
    let [p1, p2, p3] = Controller::Pid.facts().0;
    let mut pid = StepController::new(Controller::Pid.facts().0);
    pid.accepted(0.5, 2.0);
    pid.accepted(0.25, 2.0);
    let third = 0.1f64.powf(-p1 / 2.0) * 0.25f64.powf(p2 / 2.0) * 0.5f64.powf(-p3 / 2.0);
    assert!(close(pid.accepted(0.1, 2.0), third));
    // A rejection retries with the elementary rule, below 1, and the next step cannot grow.
    assert!(close(pid.rejected(4.0, 2.0), 0.5));
    assert_eq!(pid.accepted(1e-6, 2.0), 1.0);
    assert!(pid.accepted(1e-6, 2.0) > 1.0);
    // So does a failed attempt.
    pid.failed();
    assert_eq!(pid.accepted(1e-6, 2.0), 1.0);
    // A reset forgets the history: PID's first step is the elementary rule with k1.
    pid.reset();
    assert!(close(pid.accepted(0.5, 2.0), 0.5f64.powf(-p1 / 2.0)));
}
