//! Conservation claims: linear momentum by every method on a free body; bounded energy error
//! for symplectic Euler; monotone energy decay for backward Euler; tiny drift for RK4.

mod common;

use common::bodies::{block, integrator, kicked, omega_max};
use softbench::integrate::{Method, State};
use softbench::model::Model;
use softbench::run::Metrics;

fn total_energy(metrics: &mut Metrics, model: &mut Model, state: &State) -> f64 {
    metrics.energies(model, state).unwrap().total()
}

#[test]
fn every_method_conserves_linear_momentum_of_a_free_body() {
    let mut model = block(false, false);
    let start = kicked(&model);
    // Short and well inside every method's stability limit (explicit Euler and midpoint grow
    // without bound on undamped oscillation, only slowly at this step).
    let dt = 0.1 * 2.0 / omega_max(&mut model);
    let mut metrics = Metrics::default();
    let (p0, _) = metrics.momenta(&model, &start);
    let mass: f64 = model.vertex_masses().iter().sum();
    // Round-off scale: total mass times the largest speed, or, for the methods that recover
    // velocities from positions (every implicit scheme divides x - q by the step; a DIRK
    // stage by h a_ii, a quarter of it for ESDIRK4(3)), the positions' rounding over the
    // smallest step taken.
    let speed = start.v.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let extent = start.q.iter().fold(0.0f64, |m, q| m.max(q.abs()));
    // Every time integrator (order 0 is the static solve, which has no velocity to conserve).
    // VBD conserves momentum only once converged; projective dynamics and XPBD need their
    // own energies: tests/vbd.rs, tests/projective_dynamics.rs and tests/xpbd.rs check them.
    let own_test = ["vbd", "projective-dynamics", "xpbd"];
    for method in Method::all()
        .into_iter()
        .filter(|m| m.order() > 0 && !own_test.contains(&m.name()))
    {
        let mut integ = integrator(method);
        let mut state = start.clone();
        // The smallest step taken (an adaptive method's internal steps).
        let mut smallest = dt;
        for _ in 0..100 {
            integ
                .step(&mut model, &mut state, dt)
                .unwrap_or_else(|e| panic!("{method}: {e}"));
            smallest = integ
                .internal_steps()
                .iter()
                .fold(smallest, |m, h| m.min(*h));
        }
        let roundoff = (1e-12 * speed).max(20.0 * f64::EPSILON * extent / smallest);
        let (p, _) = metrics.momenta(&model, &state);
        for k in 0..3 {
            let drift = (p[k] - p0[k]).abs();
            assert!(
                drift <= mass * roundoff,
                "{method}: momentum[{k}] drifted by {drift:.3e} (p0 = {:.6e})",
                p0[k]
            );
        }
    }
}

#[test]
fn symplectic_euler_energy_stays_bounded_over_ten_thousand_steps() {
    let mut model = block(true, false);
    let start = kicked(&model);
    let dt = 0.5 * 2.0 / omega_max(&mut model);
    let mut integ = integrator(Method::from_name("symplectic-euler").unwrap());
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
    // A symplectic method's energy error oscillates with an amplitude set by dt and does not
    // drift: the average over the last thousand steps matches the first thousand.
    assert!(max < 0.2, "energy error reached {max:.3}");
    assert!(
        (last - first).abs() < 0.1 * max,
        "energy drifts: mean error {first:.3e} -> {last:.3e} (max {max:.3e})"
    );
}

#[test]
fn backward_euler_never_gains_energy() {
    let mut model = block(true, true);
    let start = kicked(&model);
    let mut integ = integrator(Method::from_name("backward-euler").unwrap());
    let mut metrics = Metrics::default();
    let mut state = start;
    let mut previous = total_energy(&mut metrics, &mut model, &state);
    let e0 = previous.abs();
    for step in 0..300 {
        integ.step(&mut model, &mut state, 1e-3).unwrap();
        let e = total_energy(&mut metrics, &mut model, &state);
        assert!(
            e <= previous + 1e-12 * e0,
            "step {step}: energy rose from {previous:.12e} to {e:.12e}"
        );
        previous = e;
    }
    assert!(
        previous < e0 * (1.0 - 1e-6) || previous < e0 - 1e-6,
        "backward Euler should dissipate"
    );
}

#[test]
fn rk4_energy_drift_is_tiny_at_small_dt() {
    let mut model = block(true, false);
    let start = kicked(&model);
    let dt = 0.1 * 2.0 / omega_max(&mut model);
    let mut integ = integrator(Method::from_name("rk4").unwrap());
    let mut metrics = Metrics::default();
    let e0 = total_energy(&mut metrics, &mut model, &start);
    let mut state = start;
    for _ in 0..2000 {
        integ.step(&mut model, &mut state, dt).unwrap();
    }
    let drift = (total_energy(&mut metrics, &mut model, &state) - e0).abs() / e0;
    assert!(
        drift < 1e-6,
        "RK4 relative energy drift {drift:.3e} over 2000 steps"
    );
}

/// Relative energy errors of implicit midpoint over 0.4 s at step `dt`.
fn implicit_midpoint_energy_errors(dt: f64) -> Vec<f64> {
    let mut model = block(true, true);
    let start = kicked(&model);
    let mut integ = integrator(Method::from_name("implicit-midpoint").unwrap());
    let mut metrics = Metrics::default();
    let e0 = total_energy(&mut metrics, &mut model, &start);
    let mut state = start;
    let steps = (0.4 / dt).round() as usize;
    (0..steps)
        .map(|_| {
            integ.step(&mut model, &mut state, dt).unwrap();
            (total_energy(&mut metrics, &mut model, &state) - e0) / e0.abs()
        })
        .collect()
}

#[test]
fn implicit_midpoint_energy_error_is_small_and_second_order() {
    // Symplectic, not energy-conserving for a non-quadratic potential: the energy error is
    // of order dt^2 (and, unlike backward Euler's, it is not a steady loss).
    let coarse = implicit_midpoint_energy_errors(2e-3);
    let fine = implicit_midpoint_energy_errors(1e-3);
    let max = |e: &[f64]| e.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let ratio = max(&coarse) / max(&fine);
    assert!(
        (3.0..5.5).contains(&ratio),
        "energy error ratio for dt halved: {ratio:.2} (expected about 4)"
    );
    assert!(
        max(&fine) < 1e-4,
        "energy error {:.3e} at dt = 1e-3",
        max(&fine)
    );
    eprintln!(
        "implicit midpoint max energy error: {:.3e} (dt 2e-3), {:.3e} (dt 1e-3)",
        max(&coarse),
        max(&fine)
    );
}
