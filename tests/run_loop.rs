//! The run loop's blow-up detection: it stops unstable runs, and does not mistake energy put
//! in by a driven potential (a moving anchor, like a drag spring) for a blow-up.

mod common;

use common::bodies::{block, block_with_moving_anchor, kicked, omega_max};
use softbench::integrate::{IntegratorSettings, Method, State};
use softbench::run::{OutcomeKind, Sample, run};
use softbench::scene::RunConfig;

fn config(dt: f64, steps: usize) -> RunConfig {
    RunConfig {
        dt,
        steps,
        sample_every: 1,
        energy_limit: 10.0,
        budget: None,
    }
}

#[test]
fn a_body_driven_from_rest_is_not_a_blow_up() {
    let mut model = block_with_moving_anchor();
    let mut state = State::at_rest(&model);
    let mut integ = IntegratorSettings {
        method: Method::from_name("backward-euler").unwrap(),
        ..Default::default()
    }
    .build();
    let mut rows = Vec::new();
    let summary = run(
        &mut model,
        integ.as_mut(),
        &mut state,
        &config(2e-3, 200),
        &mut |s: &Sample| {
            rows.push(s.kinetic + s.elastic);
            Ok(())
        },
    )
    .unwrap();
    assert!(summary.outcome.is_completed(), "{:?}", summary.outcome);
    // The anchor really did put energy in (from exactly zero at rest).
    assert!(
        rows[0].abs() < 1e-9 && rows.iter().cloned().fold(0.0, f64::max) > 1e-4,
        "{:?}",
        &rows[..5]
    );
}

#[test]
fn an_unstable_explicit_run_is_stopped_with_its_cause() {
    let mut model = block(true, false);
    let mut state = kicked(&model);
    let dt = 3.0 * 2.0 / omega_max(&mut model);
    let mut integ = IntegratorSettings {
        method: Method::from_name("symplectic-euler").unwrap(),
        ..Default::default()
    }
    .build();
    let summary = run(
        &mut model,
        integ.as_mut(),
        &mut state,
        &config(dt, 500),
        &mut |_: &Sample| Ok(()),
    )
    .unwrap();
    let outcome = &summary.outcome;
    assert_eq!(
        outcome.status,
        OutcomeKind::Unstable,
        "symplectic Euler at 3x its stability limit should blow up: {outcome:?}"
    );
    assert!(
        outcome.cause == "energy growth" || outcome.cause == "non-finite state",
        "cause {}",
        outcome.cause
    );
    assert!(outcome.step.unwrap() < 500 && summary.steps_completed < 500);
}

/// Counts what an observer is given.
#[derive(Default)]
struct Counting {
    samples: usize,
    steps: Vec<usize>,
}

impl softbench::run::Observer for Counting {
    fn sample(&mut self, _: &Sample) -> std::io::Result<()> {
        self.samples += 1;
        Ok(())
    }
    fn after_step(
        &mut self,
        step: usize,
        _: &softbench::model::Model,
        _: &State,
    ) -> std::io::Result<()> {
        self.steps.push(step);
        Ok(())
    }
}

#[test]
fn the_progress_bar_follows_every_step_and_passes_everything_on() {
    let mut model = block(true, false);
    let mut state = kicked(&model);
    let mut integ = IntegratorSettings {
        method: Method::from_name("symplectic-euler").unwrap(),
        ..Default::default()
    }
    .build();
    let mut counting = Counting::default();
    let cfg = RunConfig {
        sample_every: 4,
        ..config(1e-4, 10)
    };
    let bar = indicatif::ProgressBar::hidden();
    let mut progress = softbench::run::RunProgress::with_bar(&mut counting, bar, 1e-3);
    let summary = run(&mut model, integ.as_mut(), &mut state, &cfg, &mut progress).unwrap();
    assert_eq!(progress.position(), 10);
    drop(progress);
    assert_eq!(summary.steps_completed, 10);
    assert_eq!(counting.samples, 4, "rows at steps 0, 4, 8 and 10");
    assert_eq!(counting.steps, (0..=10).collect::<Vec<_>>());
    assert_eq!(
        softbench::run::RunProgress::time_text(5e-4, 1e-3),
        "t = 0.0005 of 0.001 s"
    );
}

/// The clamped rubber block of `block`, under gravity, with mass-proportional Rayleigh damping
/// `alpha` (1/s).
fn damped_sagging_block(alpha: f64) -> softbench::model::Model {
    use softbench::material::{LameParameters, MaterialModel};
    use softbench::mesh::generate::box_mesh;
    use softbench::model::{Damping, Model, ModelSpec};
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
    let mut spec = ModelSpec::elastic(box_mesh([2, 1, 1], [0.2, 0.1, 0.1]), material, 1000.0);
    spec.fixed = common::bodies::clamped_at_min_x();
    spec.gravity = Some(nalgebra::Vector3::new(0.0, -9.81, 0.0));
    spec.damping = Damping {
        rayleigh: Some((alpha, 0.0)),
        ..Default::default()
    };
    Model::new(spec).unwrap()
}

/// Issue 24: a damped body that sags from rest to its equilibrium turns half of gravity's
/// work into heat; the drift used to count that loss (exactly 0.5 once settled) as the
/// method's. Its largest value is early, while the scale is still small.
#[test]
fn a_damped_body_settling_from_rest_has_no_energy_drift() {
    let mut model = damped_sagging_block(20.0);
    let mut state = State::at_rest(&model);
    let mut integ = IntegratorSettings {
        method: Method::from_name("implicit-midpoint").unwrap(),
        ..Default::default()
    }
    .build();
    let summary = run(
        &mut model,
        integ.as_mut(),
        &mut state,
        &config(1e-3, 1500),
        &mut |_: &Sample| Ok(()),
    )
    .unwrap();
    assert!(summary.outcome.is_completed(), "{:?}", summary.outcome);
    // The damping did remove energy: a large share of what gravity released.
    assert!(
        summary.dissipated > 0.3 * summary.energy_scale.gravity,
        "{summary:?}"
    );
    assert!(
        summary.energy_drift_max < 0.05 && summary.energy_drift_final < 1e-3,
        "drift {} (final {})",
        summary.energy_drift_max,
        summary.energy_drift_final
    );
}

/// The drift is the energy balance's excess over its scale (drag work and damping included):
/// its largest value is the magnitude of the signed peak excess, after every step.
#[test]
fn the_energy_drift_is_the_balance_excess_over_its_scale() {
    for (mut model, method) in [
        (block_with_moving_anchor(), "backward-euler"),
        (damped_sagging_block(5.0), "backward-euler"),
        (block(true, true), "implicit-midpoint"),
    ] {
        let mut state = State::at_rest(&model);
        let mut integ = IntegratorSettings {
            method: Method::from_name(method).unwrap(),
            ..Default::default()
        }
        .build();
        let mut c = config(2e-3, 200);
        c.sample_every = 7;
        let summary = run(
            &mut model,
            integ.as_mut(),
            &mut state,
            &c,
            &mut |_: &Sample| Ok(()),
        )
        .unwrap();
        assert!(summary.outcome.is_completed(), "{:?}", summary.outcome);
        let peak = summary.energy_excess_peak.abs();
        assert!(
            peak > 0.0 && (summary.energy_drift_max / peak - 1.0).abs() < 1e-9,
            "{method}: drift {} vs |peak excess| {peak}",
            summary.energy_drift_max
        );
    }
}

/// Issue 24: a run can complete with inverted elements (the cow's feet); the summary says how
/// many tets were inverted at worst.
#[test]
fn a_run_that_completes_with_inverted_elements_reports_them() {
    let mut model = block(true, false);
    let mut state = State::at_rest(&model);
    let mut integ = IntegratorSettings {
        method: Method::from_name("backward-euler").unwrap(),
        ..Default::default()
    }
    .build();
    let quiet = run(
        &mut model,
        integ.as_mut(),
        &mut state.clone(),
        &config(1e-3, 5),
        &mut |_: &Sample| Ok(()),
    )
    .unwrap();
    assert_eq!(quiet.inverted_elements_max, 0);
    // The far corner pushed back through the block: Stable Neo-Hookean is defined there,
    // and the run completes.
    let far = (0..state.q.len() / 3)
        .max_by(|&a, &b| state.q[3 * a].total_cmp(&state.q[3 * b]))
        .unwrap();
    state.q[3 * far] -= 0.2;
    let summary = run(
        &mut model,
        integ.as_mut(),
        &mut state,
        &config(1e-4, 3),
        &mut |_: &Sample| Ok(()),
    )
    .unwrap();
    assert!(summary.outcome.is_completed(), "{:?}", summary.outcome);
    assert!(summary.inverted_elements_max > 0, "{summary:?}");
}

#[test]
fn the_first_step_is_timed_apart_and_the_others_have_quartiles() {
    let mut model = block(true, true);
    let mut state = State::at_rest(&model);
    let mut integrator = IntegratorSettings {
        method: Method::from_name("backward-euler").unwrap(),
        ..Default::default()
    }
    .build();
    let config = RunConfig {
        dt: 0.01,
        steps: 40,
        sample_every: 10,
        energy_limit: 1.0,
        budget: None,
    };
    let s = run(
        &mut model,
        integrator.as_mut(),
        &mut state,
        &config,
        &mut |_: &Sample| Ok(()),
    )
    .unwrap();
    assert!(s.first_step_seconds > 0.0);
    assert!(
        s.step_seconds_q1 <= s.step_seconds_median
            && s.step_seconds_median <= s.step_seconds_q3
            && s.step_seconds_q3 <= s.step_seconds_p95,
        "{s:?}"
    );
    assert!(s.step_seconds_q1 > 0.0);
}

/// A cost budget stops a run after the first step that passes it, before the horizon, with
/// the limit named; a run that reaches its horizon is never stopped by it, and a larger
/// budget lets the same run go on (the budget caps the run, it does not change its steps).
#[test]
fn a_cost_budget_stops_the_run_after_the_step_that_passes_it() {
    let build = || {
        IntegratorSettings {
            method: Method::from_name("backward-euler").unwrap(),
            ..Default::default()
        }
        .build()
    };
    let go = |budget: Option<softbench::scene::CostBudget>| {
        let mut model = block(true, false);
        let mut state = kicked(&model);
        let mut integ = build();
        let cfg = RunConfig {
            budget,
            ..config(1e-3, 20)
        };
        let mut rows = Vec::new();
        let summary = run(
            &mut model,
            integ.as_mut(),
            &mut state,
            &cfg,
            &mut |s: &Sample| {
                rows.push(s.step);
                Ok(())
            },
        )
        .unwrap();
        (summary, rows, state.q)
    };
    let (free, _, q_free) = go(None);
    assert!(free.outcome.is_completed());
    let per_run = (free.totals.evaluations.gradient + free.totals.evaluations.hessian) as f64;
    // Half of what the whole run evaluates: it stops near the middle.
    let half = softbench::scene::CostBudget {
        evaluations: Some(per_run / 2.0),
        ..Default::default()
    };
    let (stopped, rows, _) = go(Some(half));
    assert_eq!(stopped.outcome.status, OutcomeKind::HorizonNotReached);
    assert_eq!(stopped.outcome.cause, "budget");
    assert!(stopped.outcome.message.contains("run.budget.evaluations"));
    let spent = (stopped.totals.evaluations.gradient + stopped.totals.evaluations.hessian) as f64;
    assert!(
        spent > per_run / 2.0,
        "it stops only once the budget is passed"
    );
    let last = *rows.last().unwrap();
    assert!(last > 1 && last < 20, "stopped at step {last}");
    assert_eq!(
        last, stopped.steps_completed,
        "the stopping step has its row"
    );
    // A budget the run stays within changes nothing, bit for bit.
    let ample = softbench::scene::CostBudget {
        evaluations: Some(per_run),
        wall_seconds: Some(1e6),
        factorizations: Some(1e9),
        linear_iterations: Some(1e9),
    };
    let (within, _, q_within) = go(Some(ample));
    assert!(within.outcome.is_completed());
    assert_eq!(q_within, q_free);
}

/// An adaptive method covers one step with as many internal steps as its error control asks
/// for: the budget stops it inside that step, close to the limit, not after the step at many
/// times the limit.
#[test]
fn a_cost_budget_stops_an_adaptive_method_inside_its_step() {
    let mut model = block(true, false);
    let mut state = kicked(&model);
    let mut settings = IntegratorSettings {
        method: Method::from_name("adaptive-rk4").unwrap(),
        ..Default::default()
    };
    settings.adaptive.tolerance = 1e-10;
    let mut integ = settings.build();
    let limit = 200.0;
    let cfg = RunConfig {
        budget: Some(softbench::scene::CostBudget {
            evaluations: Some(limit),
            ..Default::default()
        }),
        ..config(0.5, 2)
    };
    let summary = run(
        &mut model,
        integ.as_mut(),
        &mut state,
        &cfg,
        &mut |_: &Sample| Ok(()),
    )
    .unwrap();
    assert_eq!(summary.outcome.status, OutcomeKind::HorizonNotReached);
    assert_eq!(summary.outcome.cause, "budget");
    assert_eq!(summary.outcome.step, Some(1), "{:?}", summary.outcome);
    assert!(
        summary
            .outcome
            .message
            .contains("run.budget.evaluations = 200 was passed inside the step"),
        "{}",
        summary.outcome.message
    );
    // One internal step (a few evaluations) past the limit at most.
    let c = model.counters();
    assert!((c.gradient + c.hessian) as f64 <= limit + 20.0, "{c:?}");
}
