//! The method table is the one source: every registered method is listed by `softbench list`
//! with its order and kind, builds from its name into an integrator of that name, and a
//! program can register its own and use it by name in a scene.

mod common;

use softbench::integrate::methods::{MethodEntry, explicit};
use softbench::integrate::{
    Integrator, IntegratorSettings, Method, State, StepError, StepReport, register_method,
};
use softbench::model::Model;

#[test]
fn every_registered_method_is_listed_with_its_order_and_kind() {
    let out = common::softbench(&["list"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    // The binary lists the built-in methods; `outside-euler` exists only in this test process
    // (registered by the test below, which may run first).
    for m in Method::all()
        .into_iter()
        .filter(|m| m.name() != "outside-euler")
    {
        let kind = if m.is_explicit() {
            "explicit"
        } else {
            "implicit"
        };
        let order = match m.order() {
            0 => "-".to_string(),
            o => o.to_string(),
        };
        let line = text
            .lines()
            .find(|l| l.split_whitespace().next() == Some(m.name()))
            .unwrap_or_else(|| panic!("`{m}` missing from softbench list:\n{text}"));
        let fields: Vec<&str> = line.split_whitespace().collect();
        assert_eq!(fields[1], order, "{line}");
        assert_eq!(fields[2], kind, "{line}");
        assert!(line.contains(m.description()), "{line}");
    }
}

#[test]
fn every_registered_method_builds_from_its_name() {
    for name in Method::names() {
        let method: Method = name.parse().unwrap();
        let settings = IntegratorSettings {
            method,
            ..Default::default()
        };
        let integrator = settings.build();
        assert_eq!(integrator.name(), name);
        assert_eq!(integrator.is_explicit(), method.is_explicit(), "{name}");
        assert_eq!(integrator.order(), method.order(), "{name}");
        // And through a scene file's TOML.
        let toml = format!("method = \"{name}\"");
        let parsed: IntegratorSettings = toml::from_str(&toml).unwrap();
        assert_eq!(parsed.method, method);
    }
    let err = Method::from_name("newmrak").unwrap_err().to_string();
    assert!(err.contains("did you mean `newmark`?"), "{err}");
}

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
