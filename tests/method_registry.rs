//! The method table is the one source: every registered method is listed by `softbench list`
//! with its order and kind and builds from its name into an integrator of that name.
//! (Registering a method of one's own: tests/method_registration.rs, a process of its own.)

mod common;

use softbench::integrate::{IntegratorSettings, Method};

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
        let lines: Vec<&str> = text.lines().collect();
        let at = lines
            .iter()
            .position(|l| l.split_whitespace().next() == Some(m.name()))
            .unwrap_or_else(|| panic!("`{m}` missing from softbench list:\n{text}"));
        assert!(lines[at].contains(m.description()), "{}", lines[at]);
        let facts = lines[at + 1];
        assert!(facts.contains(&format!("order={order}")), "{facts}");
        assert!(facts.contains(&format!("kind={kind}")), "{facts}");
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
