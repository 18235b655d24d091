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
