//! Damping: forces are D(q) v with D symmetric positive semi-definite; strain-rate damping
//! ignores rigid motion; every registered integrator keeps its order with damping on (which
//! checks the implicit methods' damping terms), but those listed in `ORDER_NOT_MEASURED` with
//! the reason; damping removes energy.

mod common;

use common::bodies::{distance, kicked, omega_max};
use nalgebra::{Vector3, Vector3 as V3};
use softbench::integrate::{IntegratorSettings, Method, State};
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::generate::box_mesh;
use softbench::model::{AxisRule, Damping, FixedSelection, Model, ModelSpec, Side, Spring};
use softbench::rng::Rng;
use softbench::run::Metrics;

/// The rubber block of the other integrator tests with the given damping and, if `dashpot`
/// is non-zero, two springs with dashpots across it.
fn damped_block(damping: Damping, dashpot: f64, clamped: bool) -> Model {
    let lame = LameParameters::from_youngs_poisson(1e4, 0.3).unwrap();
    let material = MaterialModel::from_name("stable-neo-hookean", lame).unwrap();
    let mut spec = ModelSpec::elastic(box_mesh([2, 1, 1], [0.2, 0.1, 0.1]), material, 1000.0);
    if clamped {
        spec.fixed = FixedSelection {
            rules: vec![AxisRule {
                axis: 0,
                side: Side::Min,
                tolerance: 1e-9,
            }],
            ..Default::default()
        };
    }
    spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
    spec.damping = damping;
    if dashpot > 0.0 {
        spec.springs = vec![
            Spring {
                i: 1,
                j: 11,
                rest_length: 0.12,
                stiffness: 100.0,
                damping: dashpot,
            },
            Spring {
                i: 2,
                j: 10,
                rest_length: 0.2,
                stiffness: 50.0,
                damping: dashpot,
            },
        ];
    }
    Model::new(spec).unwrap()
}

fn all_kinds() -> Vec<(&'static str, Damping, f64)> {
    vec![
        (
            "strain-rate",
            Damping {
                strain_rate: Some((2.0, 3.0)),
                ..Default::default()
            },
            0.0,
        ),
        (
            "rayleigh",
            Damping {
                rayleigh: Some((0.5, 2e-3)),
                ..Default::default()
            },
            0.0,
        ),
        ("dashpots", Damping::default(), 2.0),
        (
            "all",
            Damping {
                rayleigh: Some((0.5, 2e-3)),
                strain_rate: Some((2.0, 3.0)),
            },
            2.0,
        ),
    ]
}

fn random_state(model: &Model, seed: u64) -> State {
    let mut rng = Rng::new(seed);
    let mut state = State::at_rest(model);
    state
        .q
        .iter_mut()
        .for_each(|x| *x += rng.range(-0.005, 0.005));
    state.v.iter_mut().for_each(|v| *v = rng.range(-1.0, 1.0));
    state
}

#[test]
fn damping_force_is_the_damping_matrix_times_the_velocity() {
    for (name, damping, dashpot) in all_kinds() {
        let mut model = damped_block(damping, dashpot, true);
        let state = random_state(&model, 1);
        let mut f = vec![0.0; model.num_dofs()];
        model.damping_force(&state.q, &state.v, &mut f).unwrap();
        let mut d = model.new_hessian();
        model.damping_matrix(&state.q, &mut d).unwrap();
        let mut dv = vec![0.0; model.num_dofs()];
        d.mul_vec(&state.v, &mut dv);
        let err = distance(&f, &dv) / dv.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(err < 1e-12, "{name}: |f - D v| / |D v| = {err:.2e}");
    }
}

#[test]
fn damping_matrix_is_symmetric_positive_semidefinite() {
    for (name, damping, dashpot) in all_kinds() {
        let mut model = damped_block(damping, dashpot, true);
        // Compressed, so that the stiffness part would be indefinite without projection.
        let mut state = random_state(&model, 2);
        state.q.iter_mut().step_by(3).for_each(|x| *x *= 0.7);
        let mut d = model.new_hessian();
        model.damping_matrix(&state.q, &mut d).unwrap();
        let dense = d.to_dense();
        assert!(
            (&dense - dense.transpose()).norm() <= 1e-12 * dense.norm(),
            "{name}: not symmetric"
        );
        let min = dense.symmetric_eigenvalues().min();
        assert!(min >= -1e-10 * dense.norm(), "{name}: eigenvalue {min:.3e}");
    }
}

#[test]
fn strain_rate_damping_does_not_resist_rigid_motion() {
    let damping = Damping {
        strain_rate: Some((5.0, 7.0)),
        ..Default::default()
    };
    let mut model = damped_block(damping, 0.0, false);
    let mut state = random_state(&model, 3);
    let (omega, c) = (V3::new(0.3, -1.2, 0.7), V3::new(0.5, 0.1, -0.2));
    for (f, x) in state.q.chunks_exact(3).enumerate() {
        let v = omega.cross(&V3::new(x[0], x[1], x[2])) + c;
        state.v[3 * f..3 * f + 3].copy_from_slice(v.as_slice());
    }
    let mut force = vec![0.0; model.num_dofs()];
    model.damping_force(&state.q, &state.v, &mut force).unwrap();
    let max = force.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    // Scale: the same viscosity on a 10% strain rate gives forces of order psi * 0.1 * area.
    assert!(
        max < 1e-12 * 7.0 * 0.1 * 0.01,
        "rigid motion felt a viscous force {max:.3e}"
    );
}

fn integrate(model: &mut Model, method: Method, start: &State, t_end: f64, steps: usize) -> State {
    let mut settings = IntegratorSettings {
        method,
        ..Default::default()
    };
    settings.newton.tolerance = 1e-11;
    settings.newton.max_iterations = 30;
    settings.newton.require_convergence = true;
    let mut integ = settings.build();
    let mut state = start.clone();
    for _ in 0..steps {
        integ
            .step(model, &mut state, t_end / steps as f64)
            .unwrap_or_else(|e| panic!("{method}: {e}"));
    }
    state
}

/// The registered methods whose order `every_method_not_listed_keeps_its_order_with_damping`
/// does not measure, and why. Every other registered method is measured, but the adaptive
/// ones (their error control, not dt, sets their steps: tests/adaptive.rs and
/// tests/implicit_runge_kutta.rs measure them).
const ORDER_NOT_MEASURED: &[(&str, &str)] = &[
    // A defect, not a limit of the test: with this damping BDF4–6 converge at order 2 (the
    // slope is 2.0 from 400 to 1600 steps), while without damping BDF4 and BDF5 reach their
    // order (tests/integrator_convergence.rs). Measure them here once that is fixed.
    ("bdf4", "second order with damping (a defect to fix)"),
    ("bdf5", "second order with damping (a defect to fix)"),
    ("bdf6", "second order with damping (a defect to fix)"),
    // A limit of the method: RODAS3 is third order only with the exact Jacobian, and its
    // matrix leaves out the derivative of D(q) v in q (Rayleigh's stiffness part and strain-
    // rate damping vary with q): with this damping it is first order (0.99). ROS2, a W-method,
    // keeps order 2 (measured here); tests/implicit_runge_kutta.rs measures RODAS3 with
    // constant damping.
    (
        "rodas3",
        "first order with damping that varies with the positions",
    ),
    // A property of the method, not of the code: ESDIRK4(3) has stage order 2, and the
    // stiffness-proportional Rayleigh term (beta omega^2 h near 2 on this block's highest
    // modes) makes those modes stiff: pairwise 3.99, 3.51, 3.44 from 25 to 200 steps (order
    // reduction). tests/implicit_runge_kutta.rs measures order 4 with strain-rate and mass-
    // proportional damping.
    (
        "esdirk43",
        "order reduction under stiff stiffness-proportional damping",
    ),
    // Radau IIA is order 5 on this block without the stiffness-proportional Rayleigh term
    // (error ratios 29-31 per halving from 5 to 160 steps, and on the linear damped system of
    // tests/implicit_runge_kutta.rs), but with it the order drops in a band of steps: pairwise
    // 2.0, 1.8, 1.5, 2.3, 2.9 from 40 to 1280 steps (errors 1.8e-9 to 1.3e-12; the reference
    // and Newton are far below), order 4.7 from 5 to 40 steps. The beta term is stiff there
    // (h beta omega^2 from about 1.6 down to 0.05) and Rayleigh's K is PSD-projected per
    // element, so D(q) is not differentiable where an element eigenvalue crosses zero; which
    // of the two reduces the order is not yet separated.
    (
        "radau-iia",
        "order reduction under stiffness-proportional damping (a band of steps)",
    ),
    (
        "projective-dynamics",
        "refuses the block's stable Neo-Hookean material",
    ),
    ("xpbd", "refuses the block's stable Neo-Hookean material"),
    ("static", "has no time discretization"),
];

#[test]
fn every_method_not_listed_keeps_its_order_with_damping() {
    let damping = Damping {
        rayleigh: Some((0.5, 2e-3)),
        strain_rate: Some((2.0, 3.0)),
    };
    let t_end = 0.05;
    let mut model = damped_block(damping, 2.0, true);
    let start = kicked(&model);
    let reference = integrate(
        &mut model,
        Method::from_name("rk4").unwrap(),
        &start,
        t_end,
        6400,
    );
    for (name, _) in ORDER_NOT_MEASURED {
        assert!(Method::from_name(name).is_ok(), "{name} is not registered");
    }
    let measured: Vec<Method> = Method::all()
        .into_iter()
        .filter(|m| !m.is_adaptive())
        .filter(|m| ORDER_NOT_MEASURED.iter().all(|(n, _)| *n != m.name()))
        .collect();
    assert!(measured.len() >= 15, "{measured:?}");
    for method in measured {
        // Coarse enough that rounding stays far below the error at the finest of 4 halvings.
        let (expected, coarsest) = match method.order() {
            1 => (1.0, 200),
            4 => (4.0, 25),
            order => (f64::from(order), 50),
        };
        let errors: Vec<f64> = (0..4)
            .map(|k| {
                let end = integrate(&mut model, method, &start, t_end, coarsest << k);
                distance(&end.q, &reference.q) + t_end * distance(&end.v, &reference.v)
            })
            .collect();
        let order = (errors[0] / errors[3]).log2() / 3.0;
        eprintln!("{method} with damping: observed order {order:.3}");
        assert!(
            (order - expected).abs() <= 0.15,
            "{method}: order {order:.3} with damping; errors {errors:?}"
        );
    }
}

/// What the three listed for a limit of their method still do with the same damping:
/// ESDIRK4(3) converges at least at its stage order plus one, RODAS3 at least at order one,
/// Radau IIA at least at order 1.5 in its worst band (the figures docs/integrators.md quotes
/// come from here).
#[test]
fn the_methods_listed_for_a_limit_still_converge_at_the_order_the_limit_leaves() {
    let damping = Damping {
        rayleigh: Some((0.5, 2e-3)),
        strain_rate: Some((2.0, 3.0)),
    };
    let t_end = 0.05;
    let mut model = damped_block(damping, 2.0, true);
    let start = kicked(&model);
    let rk4 = Method::from_name("rk4").unwrap();
    let reference = integrate(&mut model, rk4, &start, t_end, 6400);
    for (name, coarsest, at_least) in [
        ("esdirk43", 25, 3.0),
        ("rodas3", 50, 0.9),
        ("radau-iia", 40, 1.5),
    ] {
        let method = Method::from_name(name).unwrap();
        let errors: Vec<f64> = (0..4)
            .map(|k| {
                let end = integrate(&mut model, method, &start, t_end, coarsest << k);
                distance(&end.q, &reference.q) + t_end * distance(&end.v, &reference.v)
            })
            .collect();
        let pairwise: Vec<String> = errors
            .windows(2)
            .map(|w| format!("{:.2}", (w[0] / w[1]).log2()))
            .collect();
        let order = (errors[0] / errors[3]).log2() / 3.0;
        eprintln!("{name} with damping: order {order:.3}, pairwise {pairwise:?}");
        assert!(
            order >= at_least,
            "{name}: order {order:.3} with damping; errors {errors:?}"
        );
    }
}

#[test]
fn damping_removes_energy_and_its_absence_keeps_it() {
    let mut metrics = Metrics::default();
    let run = |model: &mut Model, metrics: &mut Metrics| {
        let start = kicked(model);
        let dt = 2.0 / omega_max(model);
        let e0 = metrics.energies(model, &start).unwrap().total();
        let mut integ = IntegratorSettings {
            method: Method::from_name("implicit-midpoint").unwrap(),
            ..Default::default()
        }
        .build();
        let mut state = start;
        let mut energies = vec![e0];
        for _ in 0..400 {
            integ.step(model, &mut state, dt).unwrap();
            energies.push(metrics.energies(model, &state).unwrap().total());
        }
        energies
    };
    let undamped = run(
        &mut damped_block(Damping::default(), 0.0, true),
        &mut metrics,
    );
    let damped = run(
        &mut damped_block(
            Damping {
                strain_rate: Some((2.0, 3.0)),
                ..Default::default()
            },
            0.0,
            true,
        ),
        &mut metrics,
    );
    let e0 = undamped[0];
    // The kinetic + elastic part at the start: what damping can remove.
    let drift = undamped.iter().fold(0.0f64, |m, e| m.max((e - e0).abs()));
    let lost = damped[0] - damped.last().unwrap();
    assert!(
        drift < 1e-2 * lost,
        "undamped drift {drift:.3e} vs damped loss {lost:.3e}"
    );
    assert!(lost > 0.0, "damping should remove energy");
    assert!(
        damped.windows(2).all(|w| w[1] <= w[0] + 1e-9 * e0.abs()),
        "damped energy rose"
    );
}
