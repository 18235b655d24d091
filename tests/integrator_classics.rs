//! The classical methods' own claims, beyond their order (tests/integrator_convergence.rs):
//! velocity Verlet's bounded energy and exact momenta, trapezoidal Newmark's second-order
//! energy error, the static solve against a long dissipative run (and its gravity ramp), and
//! BDF's start-up limiting the order.

mod common;

use common::bodies::{block, integrator, kicked, omega_max};
use nalgebra::Vector3;
use softbench::integrate::bdf::{BdfSettings, BdfStartup};
use softbench::integrate::{Integrator, IntegratorSettings, Method, State, StepReport};
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::generate::box_mesh;
use softbench::model::{MassKind, Model, ModelSpec};
use softbench::run::Metrics;

fn method(name: &str) -> Method {
    Method::from_name(name).unwrap()
}

fn total_energy(metrics: &mut Metrics, model: &mut Model, state: &State) -> f64 {
    metrics.energies(model, state).unwrap().total()
}

/// The free block with lumped mass (angular momentum is exact for a diagonal mass).
fn free_lumped_block() -> Model {
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
    let mut spec = ModelSpec::elastic(box_mesh([2, 1, 1], [0.2, 0.1, 0.1]), material, 1000.0);
    spec.mass_kind = MassKind::Lumped;
    Model::new(spec).unwrap()
}

#[test]
fn velocity_verlet_energy_stays_bounded_over_ten_thousand_steps() {
    let mut model = block(true, false);
    let start = kicked(&model);
    let dt = 0.5 * 2.0 / omega_max(&mut model);
    let mut integ = integrator(method("velocity-verlet"));
    let mut metrics = Metrics::default();
    let e0 = total_energy(&mut metrics, &mut model, &start);
    let mut state = start;
    let mut errors = Vec::with_capacity(10_000);
    for _ in 0..10_000 {
        integ.step(&mut model, &mut state, dt).unwrap();
        errors.push((total_energy(&mut metrics, &mut model, &state) - e0) / e0);
    }
    let max = errors.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    let mean = |s: &[f64]| s.iter().sum::<f64>() / s.len() as f64;
    let (first, last) = (mean(&errors[..1000]), mean(&errors[9000..]));
    eprintln!("verlet: max relative energy error {max:.3e}, mean {first:.3e} -> {last:.3e}");
    assert!(max < 0.05, "energy error reached {max:.3}");
    assert!(
        (last - first).abs() < 0.1 * max,
        "energy drifts: mean error {first:.3e} -> {last:.3e} (max {max:.3e})"
    );
}

#[test]
fn velocity_verlet_conserves_linear_and_angular_momentum_to_round_off() {
    // The step is set by the consistent-mass block (lumping lowers the highest frequency).
    let dt = 0.5 * 2.0 / omega_max(&mut block(false, false));
    let mut model = free_lumped_block();
    let start = kicked(&model);
    let mut integ = integrator(method("velocity-verlet"));
    let mut metrics = Metrics::default();
    let (p0, l0) = metrics.momenta(&model, &start);
    let mut state = start.clone();
    for _ in 0..10_000 {
        integ.step(&mut model, &mut state, dt).unwrap();
    }
    let (p, l) = metrics.momenta(&model, &state);
    let mass: f64 = model.vertex_masses().iter().sum();
    let speed = start.v.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let size = 0.3;
    for k in 0..3 {
        let (dp, dl) = ((p[k] - p0[k]).abs(), (l[k] - l0[k]).abs());
        eprintln!("momentum[{k}] drift {dp:.2e}, angular momentum[{k}] drift {dl:.2e}");
        assert!(
            dp <= 1e-11 * mass * speed,
            "momentum[{k}] drifted by {dp:.3e}"
        );
        assert!(
            dl <= 1e-10 * mass * speed * size,
            "angular momentum[{k}] drifted by {dl:.3e}"
        );
    }
}

/// Largest relative energy error of `name` over 0.4 s at step `dt` on the clamped block.
fn max_energy_error(name: &str, dt: f64) -> f64 {
    let mut model = block(true, true);
    let start = kicked(&model);
    let mut integ = integrator(method(name));
    let mut metrics = Metrics::default();
    let e0 = total_energy(&mut metrics, &mut model, &start);
    let mut state = start;
    let steps = (0.4 / dt).round() as usize;
    (0..steps)
        .map(|_| {
            integ.step(&mut model, &mut state, dt).unwrap();
            ((total_energy(&mut metrics, &mut model, &state) - e0) / e0.abs()).abs()
        })
        .fold(0.0, f64::max)
}

#[test]
fn trapezoidal_newmark_energy_error_is_second_order() {
    // Exactly conserving for a quadratic potential; O(dt²) for this nonlinear one.
    let (coarse, fine) = (
        max_energy_error("newmark", 2e-3),
        max_energy_error("newmark", 1e-3),
    );
    let ratio = coarse / fine;
    eprintln!(
        "newmark: max energy error {coarse:.3e} at 2e-3, {fine:.3e} at 1e-3, ratio {ratio:.2}"
    );
    assert!(coarse < 1e-2, "energy error {coarse:.3e}");
    assert!(
        (3.0..5.5).contains(&ratio),
        "ratio {ratio:.2}, expected about 4"
    );
}

#[test]
fn generalized_alpha_dissipates_where_trapezoidal_newmark_does_not() {
    let mut energies = Vec::new();
    for name in ["newmark", "generalized-alpha"] {
        let mut model = block(true, false);
        let mut state = kicked(&model);
        let dt = 4.0 * 2.0 / omega_max(&mut model);
        let mut integ = integrator(method(name));
        let mut metrics = Metrics::default();
        let e0 = total_energy(&mut metrics, &mut model, &state);
        for _ in 0..200 {
            integ.step(&mut model, &mut state, dt).unwrap();
        }
        energies.push(total_energy(&mut metrics, &mut model, &state) / e0);
    }
    eprintln!(
        "energy left after 200 steps at 4x the explicit limit: newmark {:.4}, generalized-alpha {:.4}",
        energies[0], energies[1]
    );
    // Trapezoidal Newmark loses some energy here only through the nonlinearity (it conserves
    // a quadratic potential's exactly); generalized-α damps the high modes on top.
    assert!(
        energies[1] < energies[0] - 0.05,
        "generalized-alpha kept {:.4}, newmark {:.4}",
        energies[1],
        energies[0]
    );
}

/// A clamped, sagging block run to equilibrium: the static solve, and backward Euler at a
/// large step for 20 s (it dissipates every mode), both with tight Newton tolerances.
#[test]
fn the_static_solve_matches_a_long_backward_euler_run() {
    let mut model = block(true, true);
    let rest = State::at_rest(&model);
    let mut statics = integrator(method("static"));
    let mut equilibrium = rest.clone();
    let report = statics.step(&mut model, &mut equilibrium, 0.05).unwrap();
    assert!(equilibrium.v.iter().all(|v| *v == 0.0));
    let mut settled = rest.clone();
    let mut be = integrator(method("backward-euler"));
    for _ in 0..400 {
        be.step(&mut model, &mut settled, 0.05).unwrap();
    }
    let sag = common::bodies::distance(&equilibrium.q, &rest.q);
    let difference = common::bodies::distance(&equilibrium.q, &settled.q);
    eprintln!(
        "static: sag {sag:.4e} m in {} Newton iterations; |static - backward Euler| = {difference:.3e} m",
        report.newton_iterations
    );
    assert!(sag > 1e-3, "the block must sag ({sag:.3e} m)");
    assert!(
        difference <= 1e-8 * sag,
        "static and settled differ by {difference:.3e} m"
    );
}

#[test]
fn the_static_solve_ramps_gravity_when_the_full_load_fails() {
    // A soft block under 10 g: Newton capped at 6 iterations cannot reach the full-load
    // equilibrium from rest, but the ramp (λ = 1/2, 1/4, ... and back up) can.
    let soft = |g: f64| {
        let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
        let material = MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
        let mut spec = ModelSpec::elastic(box_mesh([2, 1, 1], [0.2, 0.1, 0.1]), material, 1000.0);
        spec.fixed = common::bodies::clamped_at_min_x();
        spec.gravity = Some(Vector3::new(0.0, -g, 0.0));
        Model::new(spec).unwrap()
    };
    let build = |max_iterations: u32, tolerance: f64| -> Box<dyn Integrator> {
        let mut s = IntegratorSettings {
            method: method("static"),
            ..Default::default()
        };
        s.newton.tolerance = tolerance;
        s.newton.max_iterations = max_iterations;
        s.newton.require_convergence = true;
        s.build()
    };
    let mut model = soft(10.0 * 9.81);
    let rest = State::at_rest(&model);
    let mut reference = rest.clone();
    build(100, 1e-12)
        .step(&mut model, &mut reference, 0.05)
        .unwrap();
    let mut ramped = rest.clone();
    let report: StepReport = build(6, 1e-9).step(&mut model, &mut ramped, 0.05).unwrap();
    let difference = common::bodies::distance(&ramped.q, &reference.q);
    let sag = common::bodies::distance(&reference.q, &rest.q);
    eprintln!(
        "ramp: {} solves, {} rejected, |ramped - reference| = {difference:.3e} m (sag {sag:.3e} m)",
        report.substeps, report.rejected_substeps
    );
    assert!(
        report.rejected_substeps >= 1,
        "the full load should have failed first"
    );
    assert!(report.substeps >= 2, "the ramp takes several solves");
    assert!(
        difference <= 1e-6 * sag,
        "ramped and direct equilibria differ by {difference:.3e} m"
    );
}

#[test]
fn bdf3_started_by_lower_orders_is_only_second_order() {
    // The reason the extrapolated start-up exists: BDF1's first-step error stays.
    let t_end = 0.05;
    let mut model = block(true, true);
    let start = kicked(&model);
    let reference = common::bodies::integrate(&mut model, method("rk4"), &start, t_end, 6400);
    let run = |startup: BdfStartup, steps: usize, model: &mut Model| {
        let mut s = IntegratorSettings {
            method: method("bdf3"),
            bdf: BdfSettings { startup },
            ..Default::default()
        };
        s.newton.tolerance = 1e-11;
        s.newton.max_iterations = 30;
        let mut integ = s.build();
        let mut state = start.clone();
        for _ in 0..steps {
            integ.step(model, &mut state, t_end / steps as f64).unwrap();
        }
        common::bodies::distance(&state.q, &reference.q)
    };
    let order =
        |startup, model: &mut Model| (run(startup, 50, model) / run(startup, 100, model)).log2();
    let lower = order(BdfStartup::LowerOrders, &mut model);
    let extrapolated = order(BdfStartup::ExtrapolatedMidpoint, &mut model);
    eprintln!(
        "bdf3 observed order: lower-orders start-up {lower:.2}, extrapolated {extrapolated:.2}"
    );
    assert!(
        (lower - 2.0).abs() < 0.3,
        "lower-orders start-up: order {lower:.2}"
    );
    assert!(
        (extrapolated - 3.0).abs() < 0.3,
        "extrapolated start-up: order {extrapolated:.2}"
    );
}
