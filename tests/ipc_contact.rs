//! Incremental potential contact (`contact.response = "ipc"`) through the model and the run:
//! the barrier's and friction's gradients and Hessians (self-contact blocks outside the
//! element pattern included) against finite differences, the barrier adding exactly nothing
//! where nothing is within d̂, and the scenes of the contact study staying intersection-free.

use softbench::data::DataPaths;
use softbench::model::{HessianOptions, Model};
use softbench::parallel::Parallelism;
use softbench::scene::{self, LoadedScene, Scene};
use std::path::PathBuf;

fn scene_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("experiments/scenes/contact")
}

/// A shipped contact scene with `--set` style overrides.
fn shipped(name: &str, overrides: &[&str]) -> Scene {
    let path = scene_dir().join(name);
    let text = std::fs::read_to_string(&path).unwrap();
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let config = scene::parse(&text, &path, &overrides).unwrap();
    let loaded = LoadedScene { path, config };
    scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential).unwrap()
}

/// The full Hessian (element pattern plus the contact blocks outside it) as a dense matrix.
fn dense_hessian(model: &mut Model, q: &[f64], options: HessianOptions) -> nalgebra::DMatrix<f64> {
    let mut h = model.new_hessian();
    model.hessian(q, &mut h, options).unwrap();
    let mut d = h.to_dense();
    for b in model.off_pattern_blocks() {
        for i in 0..3 {
            for j in 0..3 {
                d[(3 * b.row as usize + i, 3 * b.col as usize + j)] += b.block[(i, j)];
            }
        }
    }
    d
}

/// The two cubes with the upper one lowered to `gap` (m) above the lower one.
fn stacked(gap: f64, overrides: &[&str]) -> (Scene, Vec<f64>) {
    let scene = shipped("stack.toml", overrides);
    let mut q = scene.model.rest_state();
    for (k, p) in q.chunks_exact_mut(3).enumerate() {
        if k >= 125 {
            p[1] -= 0.1 - gap;
        }
    }
    (scene, q)
}

#[test]
fn barrier_gradient_and_hessian_match_finite_differences_across_self_contact() {
    let (mut scene, q) = stacked(4e-4, &[]);
    check_derivatives(&mut scene.model, &q);
    assert!(
        !scene.model.off_pattern_blocks().is_empty(),
        "the cubes share no element: their contact blocks are outside the pattern"
    );
}

#[test]
fn barrier_gradient_and_hessian_match_finite_differences_against_analytic_obstacles() {
    // The cube 0.5 mm above the ground (a plane), and a sphere and a capsule placed 0.3 mm
    // from two of its faces (vertex–signed-distance contacts, curved ones included).
    let obstacles = [
        "obstacles=[{ kind = \"plane\", normal = [0.0, 1.0, 0.0] }, \
         { kind = \"sphere\", center = [0.1503, 0.05, 0.0], radius = 0.1 }, \
         { kind = \"capsule\", a = [-0.1, 0.05, -0.0803], b = [0.1, 0.05, -0.0803], radius = 0.03 }]",
    ];
    let mut scene = shipped("slope.toml", &obstacles);
    let q = scene.model.rest_state();
    let x = scene.model.full_positions(&q);
    let ipc = scene.contact.as_ref().unwrap().ipc().unwrap().clone();
    let (contacts, distance, admissible) = ipc.contact_stats(&x, 0.0);
    assert!(
        admissible && contacts >= 3 && distance < 1e-3,
        "{contacts} contacts at {distance}"
    );
    check_derivatives(&mut scene.model, &q);
}

/// The model's gradient and Hessian (off-pattern blocks included) at `q` against central
/// differences of its potential and gradient; the projected Hessian is PSD.
fn check_derivatives(model: &mut Model, q: &[f64]) {
    let q = q.to_vec();
    let n = q.len();
    let mut g = vec![0.0; n];
    model.gradient(&q, &mut g).unwrap();
    let h = dense_hessian(model, &q, HessianOptions::default());
    let step = 1e-8;
    let (mut worst_g, mut worst_h) = (0.0f64, 0.0f64);
    let (mut gp, mut gm) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..n {
        let mut x = q.clone();
        x[i] += step;
        let ep = model.potential(&x).unwrap();
        model.gradient(&x, &mut gp).unwrap();
        x[i] -= 2.0 * step;
        let em = model.potential(&x).unwrap();
        model.gradient(&x, &mut gm).unwrap();
        worst_g = worst_g.max(((ep - em) / (2.0 * step) - g[i]).abs());
        for j in 0..n {
            worst_h = worst_h.max(((gp[j] - gm[j]) / (2.0 * step) - h[(j, i)]).abs());
        }
    }
    let g_scale = g.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    let h_scale = h.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    eprintln!(
        "ipc FD: gradient error {worst_g:.2e} of {g_scale:.2e}, Hessian {worst_h:.2e} of {h_scale:.2e}"
    );
    assert!(worst_g < 1e-5 * g_scale, "gradient error {worst_g:e}");
    assert!(worst_h < 1e-4 * h_scale, "Hessian error {worst_h:e}");
    // Projected, the whole matrix is positive semi-definite.
    let p = dense_hessian(model, &q, HessianOptions::projected());
    let min = p.symmetric_eigenvalues().min();
    assert!(
        min > -1e-8 * h_scale,
        "projected Hessian eigenvalue {min:e}"
    );
}

#[test]
fn the_barrier_adds_nothing_where_nothing_is_within_dhat() {
    let (mut with, q) = stacked(0.05, &[]);
    // Without any contact: no obstacles, and a response that then builds nothing.
    let (mut without, _) = stacked(0.05, &["contact.response=penalty", "obstacles=[]"]);
    assert!(without.contact.is_none() && without.model.contact_potential().is_none());
    let (a, b) = (&mut with.model, &mut without.model);
    assert_eq!(
        a.potential(&q).unwrap().to_bits(),
        b.potential(&q).unwrap().to_bits()
    );
    let (mut ga, mut gb) = (vec![0.0; q.len()], vec![0.0; q.len()]);
    a.gradient(&q, &mut ga).unwrap();
    b.gradient(&q, &mut gb).unwrap();
    assert!(ga.iter().zip(&gb).all(|(x, y)| x.to_bits() == y.to_bits()));
    let (ha, hb) = (
        dense_hessian(a, &q, HessianOptions::default()),
        dense_hessian(b, &q, HessianOptions::default()),
    );
    assert!(
        ha.iter()
            .zip(hb.iter())
            .all(|(x, y)| x.to_bits() == y.to_bits())
    );
}

#[test]
fn the_linear_system_carries_the_self_contact_blocks_outside_the_element_pattern() {
    use softbench::integrate::StepReport;
    use softbench::integrate::newton::{ImplicitSystem, NewtonSettings};
    let (mut scene, q) = stacked(4e-4, &[]);
    let model = &mut scene.model;
    let settings = NewtonSettings::default();
    let solver = softbench::solve::LinearSolverKind::cholesky().build(&Default::default());
    let mut system = ImplicitSystem::new(solver, settings.filter_settings());
    let beta = 1e-4;
    let mut report = StepReport::default();
    let a = system
        .assemble_matrix(model, &q, beta, true, &mut report)
        .unwrap()
        .to_dense();
    let mut expected = dense_hessian(model, &q, HessianOptions::projected()) * beta;
    let mut mass = model.new_hessian();
    model.mass().add_scaled_to(1.0, &mut mass);
    expected += mass.to_dense();
    let worst = (&a - &expected).abs().max();
    assert!(
        worst <= 1e-12 * expected.abs().max(),
        "assembled vs expected: {worst:e}"
    );
}

/// A run's rows.
fn run(
    mut scene: Scene,
    steps: usize,
) -> (Vec<softbench::run::Sample>, softbench::integrate::State) {
    let mut integrator = scene.take_integrator();
    let mut state = scene.initial.clone();
    let mut config = scene.config.run;
    config.steps = steps;
    let mut rows = Vec::new();
    let mut keep = |s: &softbench::run::Sample| {
        rows.push(s.clone());
        Ok(())
    };
    let summary = softbench::run::run(
        &mut scene.model,
        integrator.as_mut(),
        &mut state,
        &config,
        &mut keep,
    )
    .unwrap();
    assert!(summary.outcome.is_completed(), "{:?}", summary.outcome);
    (rows, state)
}

/// The lowest y of any vertex of `state`.
fn lowest(scene_model: &Model, state: &softbench::integrate::State) -> f64 {
    scene_model
        .full_positions(&state.q)
        .iter()
        .map(|p| p.y)
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn ipc_stops_the_fast_ball_on_the_thin_plate_where_the_vertex_responses_let_it_through() {
    let scene = shipped("plate.toml", &[]);
    let (rows, state) = run(shipped("plate.toml", &[]), 40);
    assert!(rows.iter().all(|r| r.intersection_free == Some(1)));
    assert!(
        rows.iter()
            .skip(1)
            .all(|r| r.min_distance.is_some_and(|d| d > 0.0))
    );
    // The plate's top is at y = 0.005: the ball rests on it.
    let low = lowest(&scene.model, &state);
    assert!(low > 0.005 && low < 0.01, "lowest vertex at {low}");
    for response in ["penalty", "projection", "constrained"] {
        let set = format!("contact.response={response}");
        let s = shipped("plate.toml", &[&set]);
        let (rows, state) = run(s, 40);
        let low = lowest(&scene.model, &state);
        eprintln!(
            "{response}: lowest vertex {low:.3} m, {} intersecting frame(s)",
            rows.iter()
                .filter(|r| r.intersection_free == Some(0))
                .count()
        );
        assert!(
            low < -0.005,
            "{response} did not tunnel (lowest vertex {low})"
        );
    }
}

#[test]
fn self_contact_stops_the_upper_cube_and_nothing_else_does() {
    let (rows, _) = run(shipped("stack.toml", &[]), 100);
    assert!(rows.iter().all(|r| r.intersection_free == Some(1)));
    let touched = rows
        .iter()
        .filter_map(|r| r.min_distance)
        .fold(1.0, f64::min);
    assert!(
        touched < 1e-3,
        "the cubes never came within dhat ({touched})"
    );
    let (rows, _) = run(shipped("stack.toml", &["contact.response=penalty"]), 100);
    assert!(rows.iter().any(|r| r.intersection_free == Some(0)));
}

/// The cube's speed (root-mean-square, from its kinetic energy) after 1 s under gravity
/// tilted by `degrees`, mu = 0.5.
fn final_speed(degrees: f64) -> f64 {
    let t = degrees.to_radians();
    let g = format!(
        "forces.gravity=[{}, {}, 0.0]",
        9.81 * t.sin(),
        -9.81 * t.cos()
    );
    let scene = shipped("slope.toml", &[&g]);
    let mass: f64 = scene.model.vertex_masses().iter().sum();
    let (rows, _) = run(scene, 100);
    assert!(rows.iter().all(|r| r.intersection_free == Some(1)));
    (2.0 * rows.last().unwrap().kinetic / mass).sqrt()
}

#[test]
fn friction_holds_below_the_friction_angle_and_lets_go_above_it() {
    // atan(0.5) = 26.565 degrees; 2 degrees either side. Sticking, lagged smooth friction
    // creeps below epsilon_v = 1 mm/s; sliding accelerates at g (sin - mu cos) = 0.38 m/s^2.
    let stick = final_speed(24.565);
    let slip = final_speed(28.565);
    eprintln!("speed after 1 s: {stick:.2e} m/s at 24.6 degrees, {slip:.2e} m/s at 28.6 degrees");
    assert!(stick < 1e-3, "{stick} m/s below the friction angle");
    assert!(slip > 0.2, "only {slip} m/s above the friction angle");
}

#[test]
fn every_end_position_method_runs_ipc_and_other_methods_are_refused_with_the_list() {
    // The ball at 20 m/s on the plate for the dissipative schemes; the trapezoidal rule
    // (newmark's default) gains energy at that impact, so it lands the stack.
    for method in ["backward-euler", "bdf2"] {
        let set = format!("integrator.method={method}");
        let (rows, _) = run(shipped("plate.toml", &[&set]), 5);
        assert!(
            rows.iter().all(|r| r.intersection_free == Some(1)),
            "{method}"
        );
    }
    let (rows, _) = run(shipped("stack.toml", &["integrator.method=newmark"]), 40);
    assert!(
        rows.iter().all(|r| r.intersection_free == Some(1)),
        "newmark"
    );
    // Static: a cantilever that sags onto a sphere rests on it.
    let text = r#"
[mesh]
generate = { box = [8, 2, 2], size = [0.4, 0.05, 0.05], origin = [0.0, 0.0, -0.025] }
[material]
model = "stable-neo-hookean"
youngs_modulus = 1e5
poisson_ratio = 0.3
density = 1000.0
[fixed]
rule = { axis = "x", side = "min", tolerance = 1e-6 }
[forces]
gravity = [0.0, -9.81, 0.0]
[integrator]
method = "static"
[run]
dt = 0.01
steps = 1
[[obstacles]]
kind = "sphere"
center = [0.3, -0.1005, 0.0]
radius = 0.1
[contact]
response = "ipc"
"#;
    let path = PathBuf::from("cantilever.toml");
    let config = scene::parse(text, &path, &[]).unwrap();
    let loaded = LoadedScene { path, config };
    let s = scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential).unwrap();
    let (rows, _) = run(s, 1);
    let last = rows.last().unwrap();
    assert_eq!(last.intersection_free, Some(1));
    assert!(last.contacts > 0 && last.min_distance.is_some_and(|d| d > 0.0 && d < 1e-3));
    let path = scene_dir().join("plate.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let config = scene::parse(&text, &path, &["integrator.method=rk4".to_string()]);
    let message = match config {
        Err(e) => e.to_string(),
        Ok(c) => {
            let loaded = LoadedScene { path, config: c };
            match scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential) {
                Err(e) => e.to_string(),
                Ok(_) => panic!("rk4 accepted with ipc"),
            }
        }
    };
    assert!(
        message.contains("ipc") && message.contains("backward-euler"),
        "{message}"
    );
}

#[test]
fn ipc_settings_and_mesh_obstacles_are_checked() {
    let path = scene_dir().join("plate.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let refused = |sets: &[&str]| {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        scene::parse(&text, &path, &sets)
            .err()
            .map(|e| e.to_string())
    };
    let m = refused(&["contact.ipc.dhat=0"]).unwrap();
    assert!(m.contains("contact.ipc.dhat"), "{m}");
    let m = refused(&["contact.ipc.min_separation=0.01"]).unwrap();
    assert!(m.contains("contact.ipc.min_separation"), "{m}");
    let m = refused(&["contact.response=penalty", "contact.ipc.mu=0.3"]).unwrap();
    assert!(m.contains("contact.ipc") && m.contains("penalty"), "{m}");
    let m = refused(&["contact.ipc.kappa=\"often\""]).unwrap();
    assert!(m.contains("kappa"), "{m}");
}

#[test]
fn a_ball_dropped_on_a_mesh_obstacle_rests_on_it_intersection_free() {
    let dir = tempfile::tempdir().unwrap();
    // A 1 m square plate at y = 0 as two triangles (a codimensional obstacle).
    std::fs::write(
        dir.path().join("plate.obj"),
        "v -0.5 0 -0.5\nv 0.5 0 -0.5\nv 0.5 0 0.5\nv -0.5 0 0.5\nf 1 3 2\nf 1 4 3\n",
    )
    .unwrap();
    let text = std::fs::read_to_string(scene_dir().join("plate.toml"))
        .unwrap()
        .replace(
            "kind = \"box\"\ncenter = [0.0, 0.0, 0.0]\nhalf_extents = [0.5, 0.005, 0.5]",
            "kind = \"mesh\"\nfile = \"plate.obj\"",
        );
    assert!(text.contains("kind = \"mesh\""));
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, &text).unwrap();
    let config = scene::parse(&text, &path, &[]).unwrap();
    let loaded = LoadedScene { path, config };
    let scene = scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential).unwrap();
    let model = shipped("plate.toml", &[]).model;
    let (rows, state) = run(scene, 40);
    assert!(rows.iter().all(|r| r.intersection_free == Some(1)));
    let low = lowest(&model, &state);
    assert!(low > 0.0 && low < 0.005, "lowest vertex at {low}");
    // Penalty cannot see a mesh obstacle: refused.
    let text2 = text.replace(
        "response = \"ipc\"\nipc = { dhat = 1e-3 }",
        "response = \"penalty\"",
    );
    let path2 = dir.path().join("scene2.toml");
    let config = scene::parse(&text2, &path2, &[]).unwrap_err().to_string();
    assert!(config.contains("mesh obstacle"), "{config}");
}

#[test]
fn the_distance_log_barrier_and_repeated_friction_lagging_run_intersection_free() {
    let (rows, _) = run(
        shipped("stack.toml", &["contact.ipc.barrier=\"distance-log\""]),
        60,
    );
    assert!(rows.iter().all(|r| r.intersection_free == Some(1)));
    // Friction between the two pieces (self-contact stencils) and with the floor.
    let (rows, _) = run(shipped("stack.toml", &["contact.ipc.mu=0.3"]), 60);
    assert!(rows.iter().all(|r| r.intersection_free == Some(1)));
    let (a, _) = run(shipped("slope.toml", &[]), 30);
    let (b, _) = run(
        shipped("slope.toml", &["contact.ipc.friction_iterations=3"]),
        30,
    );
    assert!(b.iter().all(|r| r.intersection_free == Some(1)));
    let iterations =
        |rows: &[softbench::run::Sample]| rows.iter().map(|r| r.newton_iterations).sum::<u64>();
    assert!(iterations(&b) > iterations(&a), "re-lagging solves again");
}

#[test]
fn a_start_that_touches_is_refused_with_the_key() {
    let path = scene_dir().join("plate.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    // The ball's lowest vertex on the plate's top.
    let sets = vec!["mesh.generate.origin=[0.0, 0.105, 0.0]".to_string()];
    let config = scene::parse(&text, &path, &sets).unwrap();
    let loaded = LoadedScene { path, config };
    let err = scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential)
        .err()
        .expect("a touching start is refused")
        .to_string();
    assert!(
        err.contains("contact.response") && err.contains("touch"),
        "{err}"
    );
}

/// Moving analytic obstacles: a ground that lifts the resting ball by 2 cm (each step it
/// comes onto the body, whose nearby surface vertices start the solve carried along) and a
/// sphere that sweeps in sideways and pushes it. Intersection-free, the ball lifted by the
/// ground's rise, and the energy balance counts the obstacles' work (no blow-up verdict).
#[test]
fn moving_obstacles_lift_and_push_the_ball_intersection_free() {
    let ball = |paths: [&str; 2]| {
        let text = format!(
            r#"
[mesh]
generate = {{ ball = 2, radius = 0.1, origin = [0.0, 0.1005, 0.0] }}
[material]
model = "stable-neo-hookean"
youngs_modulus = 1e7
poisson_ratio = 0.3
density = 1000.0
[forces]
gravity = [0.0, -9.81, 0.0]
[integrator]
newton = {{ max_iterations = 50 }}
[run]
dt = 0.01
steps = 60
[[obstacles]]
kind = "plane"
normal = [0.0, 1.0, 0.0]
{}
[[obstacles]]
kind = "sphere"
center = [0.3, 0.1, 0.0]
radius = 0.05
{}
[contact]
response = "ipc"
"#,
            paths[0], paths[1]
        );
        let path = PathBuf::from("moving.toml");
        let config = scene::parse(&text, &path, &[]).unwrap();
        let loaded = LoadedScene { path, config };
        scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential).unwrap()
    };
    let height = |s: &Scene, state: &softbench::integrate::State| {
        let x = s.model.full_positions(&state.q);
        x.iter().map(|p| p.y).sum::<f64>() / x.len() as f64
    };
    let still = ball(["", ""]);
    let reference = ball(["", ""]);
    let (rows, state) = run(still, 60);
    assert!(rows.iter().all(|r| r.intersection_free == Some(1)));
    let rest = height(&reference, &state);
    let lift = "path = { times = [0.1, 0.3], offsets = [[0.0, 0.0, 0.0], [0.0, 0.02, 0.0]] }";
    let (rows, state) = run(ball([lift, ""]), 60);
    assert!(rows.iter().all(|r| r.intersection_free == Some(1)));
    let rise = height(&reference, &state) - rest;
    assert!((rise - 0.02).abs() < 5e-4, "the ball rose {rise} m");
    assert!(rows.last().unwrap().driven_work > 0.0);
    let push = "path = { times = [0.0, 0.6], offsets = [[0.0, 0.0, 0.0], [-0.2, 0.0, 0.0]] }";
    let (rows, state) = run(ball(["", push]), 60);
    assert!(rows.iter().all(|r| r.intersection_free == Some(1)));
    let x = reference.model.full_positions(&state.q);
    let moved = x.iter().map(|p| p.x).sum::<f64>() / x.len() as f64;
    assert!(
        moved < -0.01,
        "the sphere did not push the ball ({moved} m)"
    );
}

/// The jello cube (a mass-spring body) in its bowl of still boxes: the boxes take part as
/// triangle meshes, so their edges and corners meet the cube's faces and edges, and every
/// sampled frame is intersection-free.
#[test]
fn the_jello_cube_lands_in_its_bowl_of_boxes_intersection_free() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("experiments/scenes/jello_cube.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let sets = vec![
        "contact.response=ipc".to_string(),
        "integrator.newton.max_iterations=50".to_string(),
    ];
    let config = scene::parse(&text, &path, &sets).unwrap();
    let loaded = LoadedScene { path, config };
    let scene = scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential).unwrap();
    let (rows, _) = run(scene, 250);
    assert!(rows.iter().all(|r| r.intersection_free == Some(1)));
    assert!(
        rows.iter().any(|r| r.contacts > 0),
        "the cube never reached the bowl"
    );
}
