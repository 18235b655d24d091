//! Obstacles and contact in scene files: every kind parses and builds, unknown names list the
//! valid ones, bad values name their key, a scene without obstacles runs no contact code, and
//! `softbench simulate` writes the contact columns with every response.

mod common;

use common::{TempDir, simulate};
use softbench::contact::{ContactResponse, ObstacleKind, query_count};
use softbench::data::DataPaths;
use softbench::parallel::Parallelism;
use softbench::scene::{self, LoadedScene, Scene, SceneError};
use std::path::{Path, PathBuf};

const BODY: &str = r#"
[mesh]
generate = { box = [2, 1, 1], size = [0.2, 0.1, 0.1], origin = [0.0, 0.5, 0.0] }

[material]
model = "stable-neo-hookean"
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0

[forces]
gravity = [0.0, -9.81, 0.0]

[run]
dt = 0.01
steps = 20
"#;

fn parse(extra: &str) -> Result<scene::SceneConfig, SceneError> {
    scene::parse(&format!("{BODY}\n{extra}"), Path::new("scene.toml"), &[])
}

fn build(extra: &str) -> Scene {
    let config = parse(extra).unwrap();
    let loaded = LoadedScene {
        path: PathBuf::from("scene.toml"),
        config,
    };
    scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential).unwrap()
}

/// Step a built scene with its own integrator; returns the largest contact count reported.
fn run(scene: &mut Scene) -> u32 {
    let mut integrator = scene.take_integrator();
    let mut state = scene.initial.clone();
    let mut contacts = 0;
    for _ in 0..scene.config.run.steps {
        let report = integrator
            .step(&mut scene.model, &mut state, scene.config.run.dt)
            .unwrap();
        contacts = contacts.max(report.contacts);
    }
    contacts
}

const EVERY_KIND: &str = r#"
[[obstacles]]
kind = "plane"
point = [0.0, 0.0, 0.0]
normal = [0.0, 1.0, 0.0]

[[obstacles]]
kind = "sphere"
center = [0.0, -1.2, 0.0]
radius = 1.0
transform = { translation = [0.5, 0.0, 0.0], rotation = { axis = [0, 0, 1], degrees = 30 } }
path = { times = [0.0, 1.0], offsets = [[0, 0, 0], [0, 0.2, 0]] }

[[obstacles]]
kind = "box"
center = [1.0, 0.1, 0.0]
half_extents = [0.1, 0.1, 0.3]
rotation = { axis = [0, 1, 0], degrees = 45 }

[[obstacles]]
kind = "capsule"
a = [-1.0, 0.1, 0.0]
b = [-1.0, 0.1, 1.0]
radius = 0.05

[[obstacles]]
kind = "group"
members = [
  { kind = "sphere", center = [2.0, 0.0, 0.0], radius = 0.2 },
  { kind = "box", half_extents = [0.1, 0.1, 0.1], transform = { translation = [2.5, 0.0, 0.0] } },
]

[contact]
response = "projection"
restitution = 0.5
friction = 0.25
margin = 2e-3
"#;

#[test]
fn every_obstacle_kind_parses_and_builds() {
    let scene = build(EVERY_KIND);
    let contact = scene.contact.as_ref().expect("obstacles give contact");
    assert_eq!(contact.obstacles().len(), 5);
    let c = contact.config();
    assert_eq!(c.response, ContactResponse::Projection);
    assert_eq!((c.restitution, c.friction, c.margin), (0.5, 0.25, 2e-3));
    // Projection is a wrapper, not a potential.
    assert!(scene.model.vertex_potentials().is_empty());
    // Every kind with a signed distance (a mesh obstacle needs ipc and a file: see
    // tests/ipc_contact.rs).
    let kinds: Vec<_> = scene.config.obstacles.iter().map(|o| o.kind).collect();
    let sdf_kinds: Vec<ObstacleKind> = ObstacleKind::ALL
        .iter()
        .copied()
        .filter(|k| *k != ObstacleKind::Mesh)
        .collect();
    assert_eq!(kinds, sdf_kinds);
}

#[test]
fn penalty_response_adds_a_potential_to_the_model() {
    let scene = build(&format!("{EVERY_KIND}\n").replace("\"projection\"", "\"penalty\""));
    let names: Vec<_> = scene
        .model
        .vertex_potentials()
        .iter()
        .map(|p| p.name().to_owned())
        .collect();
    assert_eq!(names, ["contact"]);
}

#[test]
fn unknown_obstacle_kind_and_response_list_the_valid_names() {
    let err = parse("[[obstacles]]\nkind = \"sphre\"\nradius = 1.0\n")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("unknown obstacle kind `sphre`; did you mean `sphere`?"),
        "{err}"
    );
    assert!(
        err.contains("(valid: plane, sphere, box, capsule, group, mesh)"),
        "{err}"
    );
    assert!(err.contains("line"), "the message has the line: {err}");
    let err = parse("[contact]\nresponse = \"velocity_flip\"\n")
        .unwrap_err()
        .to_string();
    assert!(err.contains("did you mean `velocity-flip`?"), "{err}");
    assert!(
        err.contains("(valid: penalty, projection, velocity-flip, constrained, ipc)"),
        "{err}"
    );
    let err = parse("[contact]\nstiffnes = 1.0\n")
        .unwrap_err()
        .to_string();
    assert!(err.contains("stiffnes"), "{err}");
}

#[test]
fn bad_obstacle_and_contact_values_name_their_key() {
    let plane = "[[obstacles]]\nkind = \"plane\"\nnormal = [0.0, 1.0, 0.0]\n";
    let cases = [
        (
            format!("{plane}[contact]\nrestitution = 1.5\n"),
            "contact.restitution",
        ),
        (
            format!("{plane}[contact]\nfriction = -0.1\n"),
            "contact.friction",
        ),
        (
            format!("{plane}[contact]\nstiffness = 0.0\n"),
            "contact.stiffness",
        ),
        (
            format!("{plane}[contact]\nmargin = -1.0\n"),
            "contact.margin",
        ),
        (
            format!(
                "{plane}[integrator]\nmethod = \"rk4\"\n[contact]\nresponse = \"constrained\"\n"
            ),
            "contact.response",
        ),
        (
            "[[obstacles]]\nkind = \"plane\"\nnormal = [0.0, 0.0, 0.0]\n".into(),
            "obstacles[0].normal",
        ),
        (
            "[[obstacles]]\nkind = \"plane\"\n".into(),
            "obstacles[0].normal",
        ),
        (
            format!("{plane}[[obstacles]]\nkind = \"sphere\"\nradius = 0.0\n"),
            "obstacles[1].radius",
        ),
        (
            "[[obstacles]]\nkind = \"sphere\"\nradius = 1.0\nnormal = [0.0, 1.0, 0.0]\n".into(),
            "obstacles[0].normal",
        ),
        (
            "[[obstacles]]\nkind = \"box\"\nhalf_extents = [0.1, -0.1, 0.1]\n".into(),
            "obstacles[0].half_extents",
        ),
        (
            "[[obstacles]]\nkind = \"capsule\"\na = [0, 0, 0]\nradius = 0.1\n".into(),
            "obstacles[0].b",
        ),
        (
            "[[obstacles]]\nkind = \"group\"\nmembers = []\n".into(),
            "obstacles[0].members",
        ),
        (
            "[[obstacles]]\nkind = \"group\"\nmembers = [{ kind = \"sphere\", radius = -1.0 }]\n"
                .into(),
            "obstacles[0].members[0].radius",
        ),
        (
            format!("{plane}transform = {{ rotation = {{ axis = [0, 0, 0], degrees = 10 }} }}\n"),
            "obstacles[0].transform.rotation.axis",
        ),
        (
            format!("{plane}path = {{ times = [1.0, 0.0], offsets = [[0, 0, 0], [0, 1, 0]] }}\n"),
            "obstacles[0].path.times",
        ),
        (
            format!("{plane}path = {{ times = [0.0], offsets = [] }}\n"),
            "obstacles[0].path",
        ),
    ];
    for (text, key) in cases {
        match parse(&text) {
            Err(SceneError::Invalid {
                key: got, message, ..
            }) => {
                assert_eq!(got, key, "{text}: {message}");
            }
            other => panic!("{text}: expected an invalid {key}, got {other:?}"),
        }
    }
}

/// No obstacles: no contact setup, no potential, and not one obstacle query while stepping —
/// even with a `[contact]` section (incremental potential contact alone builds its
/// self-contact, and still queries no obstacle). The same scene with a far-away obstacle
/// does query.
#[test]
fn scene_without_obstacles_runs_no_contact_code() {
    for response in ContactResponse::ALL {
        let contact = format!("[contact]\nresponse = \"{response}\"\n");
        let mut scene = build(&contact);
        assert_eq!(
            scene.contact.is_some(),
            *response == ContactResponse::Ipc,
            "{response}"
        );
        assert!(scene.model.vertex_potentials().is_empty());
        let before = query_count();
        let contacts = run(&mut scene);
        assert_eq!(query_count(), before, "{response}: contact code ran");
        assert_eq!(contacts, 0);

        let far = "[[obstacles]]\nkind = \"plane\"\npoint = [0.0, -100.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\n";
        let mut scene = build(&format!("{contact}{far}"));
        let before = query_count();
        run(&mut scene);
        assert!(
            query_count() > before,
            "{response}: the obstacle was never queried"
        );
    }
}

/// The shipped ball-drop scene with each response (a coarser ball, starting on the ground;
/// projection and velocity-flip at 0.1 ms, which they need): exit 0, the contact columns at the
/// end of each row, contacts reported, QPs only for the constrained response.
#[test]
fn simulate_ball_drop_reports_contacts_with_every_response() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/scenes/ball-drop.toml");
    let dir = TempDir::new("ball-drop");
    for response in ContactResponse::ALL {
        let out = dir.path().join(response.name());
        let set_response = format!("contact.response={response}");
        let dt = match response {
            ContactResponse::Projection | ContactResponse::VelocityFlip => "run.dt=1e-4",
            _ => "run.dt=5e-3",
        };
        // Incremental potential contact refuses a start that touches: 0.5 mm above.
        let origin = match response {
            ContactResponse::Ipc => "mesh.generate.origin=[0.0, 0.1005, 0.0]",
            _ => "mesh.generate.origin=[0.0, 0.1, 0.0]",
        };
        let result = simulate(
            &scene,
            &out,
            &[
                "--set",
                &set_response,
                "--set",
                "mesh.generate.ball=2",
                "--set",
                origin,
                "--set",
                "run.steps=20",
                "--set",
                dt,
            ],
        );
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(0), "{response}: {stderr}");
        let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
        let mut lines = csv.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        // The contact columns, together and in this order (after the required columns).
        let at = header
            .iter()
            .position(|h| *h == "contacts")
            .expect("a contacts column");
        assert!(at > 12, "contact columns come after the required ones");
        assert_eq!(
            header[at..at + 9],
            [
                "contacts",
                "max_penetration",
                "qp_solves",
                "qp_seconds",
                "min_distance",
                "barrier_stiffness",
                "ccd_queries",
                "ccd_limited_steps",
                "intersection_free"
            ]
        );
        let rows: Vec<Vec<f64>> = lines
            .map(|l| {
                l.split(',')
                    .map(|x| {
                        if x.is_empty() {
                            f64::NAN
                        } else {
                            x.parse().unwrap()
                        }
                    })
                    .collect()
            })
            .collect();
        let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
        let (contacts, depth, qps) = (
            column("contacts"),
            column("max_penetration"),
            column("qp_solves"),
        );
        assert!(
            rows.iter().any(|r| r[contacts] > 0.0),
            "{response}: no contact"
        );
        let deepest = rows.iter().map(|r| r[depth]).fold(0.0, f64::max);
        let total_qps: f64 = rows.iter().map(|r| r[qps]).sum();
        match response {
            ContactResponse::Constrained => {
                assert!(deepest <= 1e-9 && total_qps > 0.0, "{deepest} {total_qps}")
            }
            ContactResponse::Penalty => assert!(deepest > 0.0 && total_qps == 0.0),
            _ => assert_eq!(total_qps, 0.0),
        }
    }
}

/// The local solvers reach obstacles through the responses that wrap an integrator; penalty
/// contact, a potential projective dynamics and XPBD have no form for, is refused when the
/// scene is built, naming the responses that work.
#[test]
fn local_solvers_take_obstacles_through_projection_and_refuse_penalty_at_build() {
    let ground = |response: &str| {
        format!(
            "[[obstacles]]\nkind = \"plane\"\npoint = [0.0, 0.0, 0.0]\nnormal = [0.0, 1.0, 0.0]\n\
             [contact]\nresponse = \"{response}\"\n"
        )
    };
    for (method, material) in [
        ("vbd", "stable-neo-hookean"),
        ("projective-dynamics", "corotated"),
        ("xpbd", "xpbd-neo-hookean"),
    ] {
        for response in ["projection", "velocity-flip"] {
            let mut config = parse(&ground(response)).unwrap();
            config.integrator.method = softbench::integrate::Method::from_name(method).unwrap();
            let m = config.material.as_mut().unwrap();
            m.model = material.into();
            m.mass = softbench::model::MassKind::Lumped;
            config.run.steps = 60;
            let loaded = LoadedScene {
                path: PathBuf::from("scene.toml"),
                config,
            };
            let mut scene =
                scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential).unwrap();
            let mut integrator = scene.take_integrator();
            let mut state = scene.initial.clone();
            let mut contacts = 0;
            for _ in 0..scene.config.run.steps {
                let report = integrator
                    .step(&mut scene.model, &mut state, scene.config.run.dt)
                    .unwrap();
                contacts = contacts.max(report.contacts);
            }
            // It fell from 0.5 m onto the ground, and no vertex ended below it.
            assert!(
                contacts > 0,
                "{method} / {response}: never touched the ground"
            );
            let lowest = state
                .q
                .iter()
                .skip(1)
                .step_by(3)
                .fold(f64::INFINITY, |a, &y| a.min(y));
            assert!(
                lowest > -1e-6,
                "{method} / {response}: a vertex at y = {lowest}"
            );
        }
    }
    for (method, material) in [
        ("projective-dynamics", "corotated"),
        ("xpbd", "xpbd-neo-hookean"),
    ] {
        let mut config = parse(&ground("penalty")).unwrap();
        config.integrator.method = softbench::integrate::Method::from_name(method).unwrap();
        let m = config.material.as_mut().unwrap();
        m.model = material.into();
        m.mass = softbench::model::MassKind::Lumped;
        let loaded = LoadedScene {
            path: PathBuf::from("scene.toml"),
            config,
        };
        let err = match scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential) {
            Ok(_) => panic!("{method} with penalty contact was built"),
            Err(e) => e.to_string(),
        };
        assert!(
            err.contains("integrator.method") && err.contains("projection"),
            "{method}: {err}"
        );
    }
}

/// The scene asks a response's facts and never its name: for every registered response, a
/// mesh obstacle is accepted exactly when the response sees mesh obstacles, a scene without
/// obstacles has contact exactly when the response keeps the body off itself, and a Newton
/// direction of the scene's own is refused exactly when the response chooses it.
#[test]
fn every_response_is_built_and_validated_as_its_facts_say() {
    let dir = TempDir::new("response-facts");
    let obj = dir.path().join("floor.obj");
    std::fs::write(
        &obj,
        "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 3 2\nf 1 4 3\n",
    )
    .unwrap();
    for &response in ContactResponse::ALL {
        let facts = response.facts();
        let method = "[integrator]\nmethod = \"backward-euler\"\n";
        let contact = format!("[contact]\nresponse = \"{response}\"\n");
        let mesh = format!(
            "{method}{contact}[[obstacles]]\nkind = \"mesh\"\nfile = \"{}\"\n",
            obj.display()
        );
        match parse(&mesh) {
            Ok(_) => assert!(facts.sees_mesh_obstacles, "{response} took a mesh obstacle"),
            Err(e) => {
                assert!(!facts.sees_mesh_obstacles, "{response}: {e}");
                assert!(e.to_string().contains("obstacles[0].kind"), "{e}");
            }
        }
        let alone = build(&format!("{method}{contact}"));
        assert_eq!(
            alone.contact.is_some(),
            facts.self_contact,
            "{response} without obstacles"
        );
        let direction = format!(
            "[integrator]\nmethod = \"backward-euler\"\nnewton = {{ direction = \"lbfgs\" }}\n\
             {contact}[[obstacles]]\nkind = \"plane\"\nnormal = [0.0, 1.0, 0.0]\n"
        );
        match parse(&direction) {
            Ok(_) => assert!(!facts.owns_newton_components, "{response} took a direction"),
            Err(e) => {
                assert!(facts.owns_newton_components, "{response}: {e}");
                assert!(e.to_string().contains("integrator.newton.direction"), "{e}");
            }
        }
    }
}
