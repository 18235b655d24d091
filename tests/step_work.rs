//! The work a step reports beyond the Newton and linear-solver counts: mass-matrix solves of
//! explicit methods (counted and timed as their own phase), the time of force evaluations,
//! and the adaptive controller's internal step sizes, per row and per run.

mod common;

use common::bodies::{block, kicked};
use softbench::integrate::{AdaptiveSettings, IntegratorSettings, Method, State, StepReport};
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::generate::box_mesh;
use softbench::model::{MassKind, Model, ModelSpec};
use softbench::run::{self, Sample};
use softbench::scene::RunConfig;

fn method(name: &str) -> Method {
    Method::from_name(name).unwrap()
}

/// The reports of `steps` steps of `name` from the kicked state.
fn reports(model: &mut Model, name: &str, steps: usize, dt: f64) -> Vec<StepReport> {
    let mut integ = IntegratorSettings {
        method: method(name),
        ..Default::default()
    }
    .build();
    let mut state = kicked(model);
    (0..steps)
        .map(|_| integ.step(model, &mut state, dt).unwrap())
        .collect()
}

fn lumped_block() -> Model {
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
    let mut spec = ModelSpec::elastic(box_mesh([2, 1, 1], [0.2, 0.1, 0.1]), material, 1000.0);
    spec.mass_kind = MassKind::Lumped;
    spec.fixed = common::bodies::clamped_at_min_x();
    Model::new(spec).unwrap()
}

#[test]
fn explicit_methods_with_consistent_mass_solve_once_per_force_evaluation() {
    // Force evaluations per step without damping: symplectic Euler 1, RK4 4, velocity Verlet
    // 1 (its end-of-step acceleration is the next step's first; the first step needs 2).
    for (name, per_step, first) in [
        ("symplectic-euler", 1, 1),
        ("rk4", 4, 4),
        ("velocity-verlet", 1, 2),
    ] {
        let mut model = block(true, false);
        assert_eq!(model.mass().kind(), MassKind::Consistent);
        let r = reports(&mut model, name, 5, 1e-4);
        let solves: Vec<u32> = r.iter().map(|r| r.mass_solves).collect();
        assert_eq!(
            solves,
            [first, per_step, per_step, per_step, per_step],
            "{name}"
        );
        for r in &r {
            assert_eq!(u64::from(r.mass_solves), r.evaluations.gradient, "{name}");
            assert_eq!(r.linear_solves, 0, "{name}: mass solves are counted apart");
            assert!(r.times.mass_solve > 0.0, "{name}: mass solves are timed");
            assert!(r.times.forces > 0.0, "{name}: force evaluations are timed");
            let phases = r.times.mass_solve + r.times.forces + r.times.factor;
            assert!(phases <= r.times.total, "{name}: phases {phases} > step");
        }
        // The mass matrix is analysed and factored once, on the first step.
        let factorizations: Vec<u32> = r.iter().map(|r| r.factorizations).collect();
        let analyses: Vec<u32> = r.iter().map(|r| r.symbolic_analyses).collect();
        assert_eq!(factorizations, [1, 0, 0, 0, 0], "{name}");
        assert_eq!(analyses, [1, 0, 0, 0, 0], "{name}");
    }
}

#[test]
fn lumped_mass_needs_no_mass_solve() {
    let mut model = lumped_block();
    for r in reports(&mut model, "rk4", 3, 1e-4) {
        assert_eq!(r.mass_solves, 0);
        assert_eq!(r.times.mass_solve, 0.0);
        assert_eq!(r.factorizations, 0);
        assert!(r.times.forces > 0.0);
    }
}

#[test]
fn newmark_solves_with_the_mass_matrix_only_for_its_start_acceleration() {
    let mut model = block(true, false);
    let r = reports(&mut model, "newmark", 3, 1e-3);
    let solves: Vec<u32> = r.iter().map(|r| r.mass_solves).collect();
    assert_eq!(solves, [1, 0, 0]);
}

/// Every sampled row and the summary of a run of `name` from `state`.
fn run_rows(
    model: &mut Model,
    settings: IntegratorSettings,
    mut state: State,
    config: RunConfig,
) -> (Vec<Sample>, run::RunSummary) {
    let mut integ = settings.build();
    let mut rows = Vec::new();
    let mut keep = |s: &Sample| {
        rows.push(s.clone());
        Ok(())
    };
    let summary = run::run(model, integ.as_mut(), &mut state, &config, &mut keep).unwrap();
    (rows, summary)
}

fn config(dt: f64, steps: usize, sample_every: usize) -> RunConfig {
    RunConfig {
        dt,
        steps,
        sample_every,
        energy_limit: 1.0,
        budget: None,
    }
}

#[test]
fn an_adaptive_method_at_rest_takes_its_largest_internal_step() {
    // At rest without loads the error estimate is zero, so every internal step is the
    // largest allowed: max_dt = dt/4, four per output step.
    let dt = 1e-3;
    let mut model = block(true, false);
    let state = State::at_rest(&model);
    let settings = IntegratorSettings {
        method: method("adaptive-rk4"),
        adaptive: AdaptiveSettings {
            max_dt: Some(dt / 4.0),
            ..Default::default()
        },
        ..Default::default()
    };
    let (rows, summary) = run_rows(&mut model, settings, state, config(dt, 6, 2));
    assert_eq!(rows.len(), 4);
    assert_eq!(
        rows[0].internal_dt_median, None,
        "the initial row has no steps"
    );
    for r in &rows[1..] {
        assert_eq!(r.substeps, 4 * r.steps);
        for x in [r.internal_dt_min, r.internal_dt_median, r.internal_dt_max] {
            common::assert_close(x.unwrap(), dt / 4.0, 1e-9);
        }
    }
    let d = summary.internal_dt.unwrap();
    for x in [d.min, d.median, d.max] {
        common::assert_close(x, dt / 4.0, 1e-9);
    }
}

#[test]
fn adaptive_internal_steps_bound_each_rows_interval() {
    // A kicked body at a tight tolerance: the controller takes several internal steps per
    // output step, never more than dt, and they add up to the row's simulated time.
    let dt = 2e-3;
    let mut model = block(true, false);
    let state = kicked(&model);
    let settings = IntegratorSettings {
        method: method("dopri5"),
        adaptive: AdaptiveSettings {
            tolerance: 1e-9,
            absolute_tolerance: 1e-12,
            ..Default::default()
        },
        ..Default::default()
    };
    let (rows, summary) = run_rows(&mut model, settings, state, config(dt, 20, 5));
    assert_eq!(summary.steps_completed, 20);
    let mut lo = f64::INFINITY;
    let mut hi: f64 = 0.0;
    for r in &rows[1..] {
        let (min, median, max) = (
            r.internal_dt_min.unwrap(),
            r.internal_dt_median.unwrap(),
            r.internal_dt_max.unwrap(),
        );
        assert!(
            min <= median && median <= max && max <= dt * (1.0 + 1e-12),
            "{r:?}"
        );
        let span = r.steps as f64 * dt;
        let n = r.substeps as f64;
        assert!(n > r.steps as f64, "the tolerance needs sub-steps: {r:?}");
        assert!(min * n <= span * (1.0 + 1e-9) && span <= max * n * (1.0 + 1e-9));
        lo = lo.min(min);
        hi = hi.max(max);
    }
    let d = summary.internal_dt.unwrap();
    assert_eq!((d.min, d.max), (lo, hi), "the run's range covers its rows'");
    assert!(d.min <= d.median && d.median <= d.max);
}

#[test]
fn fixed_step_methods_report_no_internal_steps() {
    let mut model = block(true, false);
    let state = kicked(&model);
    let settings = IntegratorSettings {
        method: method("rk4"),
        ..Default::default()
    };
    let (rows, summary) = run_rows(&mut model, settings, state, config(1e-4, 4, 2));
    assert!(rows.iter().all(|r| r.internal_dt_min.is_none()));
    assert!(summary.internal_dt.is_none());
    // The rows carry the mass solves and their time (consistent mass, 4 per step).
    assert_eq!(rows.iter().map(|r| r.mass_solves).sum::<u64>(), 16);
    assert!(rows[1..].iter().all(|r| r.mass_solve_seconds > 0.0));
    assert!(rows[1..].iter().all(|r| r.force_seconds > 0.0));
}
