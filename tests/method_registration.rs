//! A program registers a method of its own and uses it by name like a built-in one (a test
//! binary of its own, so the registration does not show up in other tests' method lists).

mod common;

use softbench::integrate::methods::{MethodEntry, explicit};
use softbench::integrate::{
    Integrator, IntegratorSettings, Method, State, StepError, StepReport, register_method,
};
use softbench::model::Model;

/// Explicit Euler written outside the crate.
struct OutsideEuler {
    g: Vec<f64>,
}

impl Integrator for OutsideEuler {
    fn name(&self) -> &'static str {
        "outside-euler"
    }
    fn order(&self) -> u32 {
        1
    }
    fn is_explicit(&self) -> bool {
        true
    }
    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        _report: &mut StepReport,
    ) -> Result<(), StepError> {
        // Lumped-free toy: unit masses, enough for the test.
        self.g.resize(state.q.len(), 0.0);
        model.gradient(&state.q, &mut self.g)?;
        for ((q, v), g) in state.q.iter_mut().zip(state.v.iter_mut()).zip(&self.g) {
            *q += dt * *v;
            *v -= dt * g;
        }
        Ok(())
    }
}

#[test]
fn a_program_registers_its_own_method_and_uses_it_by_name() {
    let entry: MethodEntry = explicit(
        "outside-euler",
        1,
        "explicit Euler written outside the crate",
        |_, _| Box::new(OutsideEuler { g: Vec::new() }),
    );
    let method = register_method(entry).unwrap();
    assert!(Method::names().contains(&"outside-euler"));
    let parsed: IntegratorSettings = toml::from_str("method = \"outside-euler\"").unwrap();
    assert_eq!(parsed.method, method);
    let mut model = common::bodies::block(true, true);
    let mut state = State::at_rest(&model);
    let mut integ = parsed.build();
    integ.step(&mut model, &mut state, 1e-4).unwrap();
    assert!(state.q.iter().all(|x| x.is_finite()));
    assert!(matches!(
        register_method(explicit("outside-euler", 1, "again", |_, _| Box::new(
            OutsideEuler { g: Vec::new() }
        ))),
        Err(softbench::registry::RegisterError::Duplicate { .. })
    ));
}

/// Alexander's two-stage SDIRK (γ = 1 − 1/√2): second order, L-stable, stiffly accurate, both
/// stages implicit; its first stage alone is a first-order embedded solution.
const SDIRK2: softbench::integrate::DirkTableau = {
    const G: f64 = 0.292_893_218_813_452_5;
    softbench::integrate::DirkTableau {
        name: "outside-sdirk2",
        order: 2,
        embedded_order: 1,
        a: &[&[G], &[1.0 - G, G]],
        b: &[1.0 - G, G],
        b_embedded: &[1.0, 0.0],
    }
};

#[test]
fn a_program_registers_a_dirk_tableau_at_fixed_steps_and_under_error_control() {
    use softbench::integrate::methods::implicit;
    use softbench::integrate::{Adaptive, Dirk, FixedStep};
    let fixed = register_method(implicit(
        "outside-sdirk2",
        2,
        false,
        "Alexander's SDIRK2 written outside the crate",
        |s, _| {
            let pair = Dirk::new(SDIRK2, s.linear_solver.build(&s.solver), s.newton);
            Box::new(FixedStep::new(pair, s.newton.retry_halvings))
        },
    ))
    .unwrap();
    let adaptive = register_method(
        implicit(
            "adaptive-outside-sdirk2",
            2,
            false,
            "SDIRK2 with its first stage as the embedded solution",
            |s, _| {
                let pair = Dirk::new(SDIRK2, s.linear_solver.build(&s.solver), s.newton);
                Box::new(Adaptive::embedded_named(
                    "adaptive-outside-sdirk2",
                    Box::new(pair),
                    s.adaptive,
                ))
            },
        )
        .with_error_control(),
    )
    .unwrap();
    assert!(!fixed.is_adaptive() && adaptive.is_adaptive());
    // Second order at fixed steps, against a tiny-step RK4 reference on the clamped block
    // (its stages both implicit: the engine's path without an explicit first stage).
    let mut model = common::bodies::block(true, true);
    let start = common::bodies::kicked(&model);
    let rk4 = Method::from_name("rk4").unwrap();
    let reference = common::bodies::integrate(&mut model, rk4, &start, 0.05, 6400);
    let errors: Vec<f64> = [50, 100, 200, 400]
        .iter()
        .map(|&steps| {
            let end = common::bodies::integrate(&mut model, fixed, &start, 0.05, steps);
            common::bodies::distance(&end.q, &reference.q)
                + 0.05 * common::bodies::distance(&end.v, &reference.v)
        })
        .collect();
    let order = (errors[0] / errors[3]).log2() / 3.0;
    eprintln!("outside-sdirk2: observed order {order:.3}, errors {errors:?}");
    assert!((order - 2.0).abs() <= 0.1, "order {order:.3}: {errors:?}");
    // Under error control by name, from a scene's settings.
    let settings: IntegratorSettings = toml::from_str(
        "method = \"adaptive-outside-sdirk2\"\nadaptive = { rtol = 1e-6, atol = 1e-9 }",
    )
    .unwrap();
    let mut integ = settings.build();
    let mut state = start.clone();
    let report = integ.step(&mut model, &mut state, 0.01).unwrap();
    assert!(report.substeps >= 2, "{report:?}");
    assert!(!integ.internal_steps().is_empty());
    assert!(common::bodies::distance(&state.q, &start.q) > 0.0);
}
