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
        // Loading a study asks the method whether it can run each scene, which builds it:
        // stand in with symplectic Euler (these tests do not step).
        let build = |_: &_, _| -> Box<dyn softbench::integrate::Integrator> {
            softbench::integrate::methods::IntegratorSettings {
                method: softbench::integrate::Method::from_name("symplectic-euler").unwrap(),
                ..Default::default()
            }
            .build()
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

/// A trajectory study of `blocks` on two boxes, one of them damped (which a peer cannot run),
/// written into `dir`; `extra` goes at the top.
fn peer_study(dir: &Path, extra: &str, blocks: &str) -> std::path::PathBuf {
    let plain = BOX.replace("method = \"test-peer\"", "method = \"backward-euler\"");
    std::fs::write(dir.join("plain.toml"), &plain).unwrap();
    std::fs::write(
        dir.join("damped.toml"),
        format!("{plain}\n[damping]\nrayleigh = {{ alpha = 0.1, beta = 0.0 }}\n"),
    )
    .unwrap();
    let study = format!(
        "name = \"peers\"\nstudy = \"trajectory\"\nscenes = [\"plain.toml\", \"damped.toml\"]\n\
         {extra}\n[[methods]]\nmethod = \"symplectic-euler\"\n\n{blocks}"
    );
    let path = dir.join("study.toml");
    std::fs::write(&path, study).unwrap();
    path
}

fn load_study(path: &Path) -> Result<softbench::study::Study, String> {
    register();
    softbench::study::load(path, false, &softbench::data::DataPaths::new(None))
        .map_err(|e| e.to_string())
}

#[test]
fn a_peer_block_runs_where_its_peer_is_registered_and_is_an_omission_where_not() {
    let dir = tempfile::tempdir().unwrap();
    let path = peer_study(
        dir.path(),
        "leave_out_what_cannot_run = true",
        "[[methods]]\nmethod = \"test-peer\"\npeer = \"peerpkg\"\n\
         \"integrator.peer.iterations\" = [5, 10]\n\n\
         [[methods]]\nmethod = \"unregistered-peer\"\npeer = \"otherpkg\"\n",
    );
    let study = load_study(&path).unwrap();
    let runs: Vec<(&str, &str)> = study
        .runs
        .iter()
        .map(|r| (r.scene.as_str(), r.method.name()))
        .collect();
    // The registered peer runs the plain box at both counts; the damped box it cannot run.
    assert_eq!(
        runs.iter().filter(|(_, m)| *m == "test-peer").count(),
        2,
        "{runs:?}"
    );
    assert!(!runs.contains(&("damped", "test-peer")), "{runs:?}");
    assert!(runs.contains(&("damped", "symplectic-euler")), "{runs:?}");
    assert!(
        study
            .parameters
            .contains(&"integrator.peer.iterations".to_owned()),
        "{:?}",
        study.parameters
    );
    let omitted = |method: &str| {
        study
            .omitted
            .iter()
            .find(|o| o.method.as_deref() == Some(method))
            .unwrap_or_else(|| panic!("{method} not omitted: {:?}", study.omitted))
            .clone()
    };
    let damped = omitted("test-peer");
    assert_eq!(damped.scene, "damped");
    assert!(
        damped.reason.contains("damping.rayleigh") && damped.reason.contains("peerpkg"),
        "{}",
        damped.reason
    );
    let absent = omitted("unregistered-peer");
    assert_eq!(absent.scene, "", "left out of every scene");
    assert!(
        absent.reason.contains("otherpkg") && absent.reason.contains("python -m softbench"),
        "{}",
        absent.reason
    );
}

#[test]
fn without_leave_out_a_scene_a_peer_cannot_run_refuses_the_study() {
    let dir = tempfile::tempdir().unwrap();
    let path = peer_study(
        dir.path(),
        "",
        "[[methods]]\nmethod = \"test-peer\"\npeer = \"peerpkg\"\n",
    );
    let error = load_study(&path).unwrap_err();
    assert!(
        error.contains("damping.rayleigh") && error.contains("peerpkg"),
        "{error}"
    );
}

#[test]
fn a_peer_key_that_does_not_match_its_method_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (block, expected) in [
        (
            "[[methods]]\nmethod = \"test-peer\"\npeer = \"wrongpkg\"\n",
            "runs peerpkg's code, not wrongpkg's",
        ),
        (
            "[[methods]]\nmethod = \"vbd\"\npeer = \"pbatoolkit\"\n",
            "`vbd` is softbench's own method",
        ),
        (
            "[[methods]]\nmethod = \"test-peer\"\npeer = 3\n",
            "must be the peer's package as a string",
        ),
    ] {
        let path = peer_study(dir.path(), "leave_out_what_cannot_run = true", block);
        let error = load_study(&path).unwrap_err();
        assert!(
            error.contains("methods[1].peer") && error.contains(expected),
            "{block}: {error}"
        );
    }
    // A study whose only blocks are peers this command has not registered runs nothing.
    std::fs::write(
        dir.path().join("only.toml"),
        "name = \"p\"\nstudy = \"trajectory\"\nscenes = [\"plain.toml\"]\n\
         [[methods]]\nmethod = \"unregistered-peer\"\npeer = \"otherpkg\"\n",
    )
    .unwrap();
    let error = load_study(&dir.path().join("only.toml")).unwrap_err();
    assert!(
        error.contains("every [[methods]] block names a peer method")
            && error.contains("unregistered-peer"),
        "{error}"
    );
}
