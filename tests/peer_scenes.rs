//! Peer methods in scenes (a test binary of its own: the registrations stay out of other tests'
//! method lists). A peer's `[integrator.peer]` settings are resolved with its defaults and
//! recorded; what it cannot run is refused at load, naming the key and the package.

use std::path::Path;
use std::sync::Once;

use softbench::integrate::methods::{MethodEntry, explicit};
use softbench::integrate::peer::{PeerFacts, PeerSetting, PeerValue};
use softbench::integrate::register_method;
use softbench::scene::{self, SceneError};

fn facts(version: Option<&str>) -> &'static PeerFacts {
    let setting = |key: &str, default: PeerValue, choices: &[&str]| PeerSetting {
        key: key.into(),
        default,
        choices: choices.iter().map(|c| c.to_string()).collect(),
        positive: true,
        description: String::new(),
        twin_key: None,
        twin_values: Vec::new(),
        neutral: None,
    };
    Box::leak(Box::new(PeerFacts {
        package: "peerpkg".into(),
        version: version.map(str::to_owned),
        install: "pip install peerpkg==2.0".into(),
        twin: Some("vbd".into()),
        materials: vec!["stable-neo-hookean".into()],
        settings: vec![
            setting("iterations", PeerValue::Int(20), &[]),
            setting("device", PeerValue::Text("cpu".into()), &["cpu", "cuda"]),
        ],
    }))
}

fn register() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let build = |_: &_, _| -> Box<dyn softbench::integrate::Integrator> {
            unreachable!("these tests load scenes, they do not run them")
        };
        let peer = |name: &'static str, version| MethodEntry {
            peer: Some(facts(version)),
            ..explicit(name, 1, "a peer for tests", build)
        };
        register_method(peer("test-peer", Some("2.0"))).unwrap();
        register_method(peer("absent-peer", None)).unwrap();
    });
}

const BOX: &str = r#"
[mesh]
generate = { box = [2, 1, 1], size = [1.0, 0.5, 0.5] }
[material]
model = "stable-neo-hookean"
youngs_modulus = 1e5
poisson_ratio = 0.4
density = 1000.0
mass = "lumped"
[forces]
gravity = [0.0, -9.81, 0.0]
[integrator]
method = "test-peer"
[run]
dt = 0.01
steps = 2
"#;

fn load(overrides: &[&str]) -> Result<scene::SceneConfig, SceneError> {
    register();
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    scene::parse(BOX, Path::new("peer.toml"), &overrides)
}

fn refused(overrides: &[&str]) -> (String, String) {
    match load(overrides) {
        Err(SceneError::Invalid { key, message, .. }) => (key, message),
        other => panic!("{overrides:?} was not refused as an invalid key: {other:?}"),
    }
}

#[test]
fn a_peers_settings_are_resolved_with_its_defaults_and_recorded() {
    let config = load(&["integrator.peer.device=\"cuda\""]).unwrap();
    let peer = config.integrator.peer.values();
    assert_eq!(peer["iterations"], PeerValue::Int(20));
    assert_eq!(peer["device"], PeerValue::Text("cuda".into()));
    // The resolved configuration a run writes holds every setting.
    let written = toml::to_string(&config.integrator).unwrap();
    assert!(written.contains("[peer]"), "{written}");
    assert!(written.contains("iterations = 20"), "{written}");
    assert!(written.contains("device = \"cuda\""), "{written}");
}

#[test]
fn what_a_peer_cannot_run_is_refused_naming_the_key_and_the_package() {
    let cases: &[(&[&str], &str, &str)] = &[
        (
            &["material.model=\"stvk\""],
            "material.model",
            "no \"stvk\" material",
        ),
        (
            &["material.mass=\"consistent\""],
            "material.mass",
            "lumped mass only",
        ),
        (
            &["damping.rayleigh.alpha=0.1", "damping.rayleigh.beta=0.0"],
            "damping.rayleigh",
            "Rayleigh",
        ),
        (
            &["damping.strain_rate.phi=0.1", "damping.strain_rate.psi=0.1"],
            "damping.strain_rate",
            "strain-rate",
        ),
        (
            &["integrator.peer.iteratons=3"],
            "integrator.peer.iteratons",
            "iterations, device",
        ),
        (
            &["integrator.peer.iterations=0"],
            "integrator.peer.iterations",
            "positive",
        ),
        (
            &["integrator.peer.iterations=2.5"],
            "integrator.peer.iterations",
            "an integer",
        ),
        (
            &["integrator.peer.device=\"tpu\""],
            "integrator.peer.device",
            "\"cpu\", \"cuda\"",
        ),
        (
            &["integrator.method=\"absent-peer\""],
            "integrator.method",
            "pip install peerpkg==2.0",
        ),
        (
            &["integrator.method=\"vbd\"", "integrator.peer.iterations=3"],
            "integrator.peer.iterations",
            "softbench's own method",
        ),
    ];
    for (overrides, key, says) in cases {
        let (k, message) = refused(overrides);
        assert_eq!(&k, key, "{overrides:?}: {message}");
        assert!(message.contains(says), "{overrides:?}: {message}");
        if !key.starts_with("integrator.peer") || *key == "integrator.peer.iteratons" {
            assert!(
                message.contains("peerpkg") || message.contains("softbench's own"),
                "{overrides:?}: {message}"
            );
        }
    }
}

#[test]
fn an_obstacle_or_a_drag_is_refused_for_a_peer() {
    register();
    let with = |extra: &str| scene::parse(&format!("{BOX}\n{extra}"), Path::new("peer.toml"), &[]);
    let obstacle = with(
        "[[obstacles]]\nkind = \"plane\"\npoint = [0.0, -1.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\n",
    );
    match obstacle {
        Err(SceneError::Invalid { key, message, .. }) => {
            assert_eq!(key, "obstacles[0]", "{message}");
            assert!(message.contains("peerpkg"), "{message}");
        }
        other => panic!("an obstacle was not refused: {other:?}"),
    }
    let drag = with(
        "[[drag]]\npoint = [1.0, 0.5, 0.5]\nradius = 0.1\nstiffness = 1e3\n\
         path = [{ t = 0.0, offset = [0.0, 0.0, 0.0] }, { t = 0.01, offset = [0.1, 0.0, 0.0] }]\n",
    );
    match drag {
        Err(SceneError::Invalid { key, message, .. }) => {
            assert_eq!(key, "drag", "{message}");
            assert!(message.contains("peerpkg"), "{message}");
        }
        other => panic!("a drag was not refused: {other:?}"),
    }
}
