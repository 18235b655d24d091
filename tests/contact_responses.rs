//! Contact responses on a ball and the ground: the penalty potential against finite
//! differences, resting contact with every response, restitution, the constrained QP step's
//! feasibility, and penalty against constrained on the same drop.
//!
//! The ball: radius 0.1 m, resolution 2 (125 vertices, 384 tets), Stable Neo-Hookean,
//! E = 1e6 Pa, nu = 0.3, 1000 kg/m^3 (3.9 kg), under gravity. Run with `-- --nocapture` to see
//! the measured numbers.

mod common;

use nalgebra::Vector3;
use softbench::contact::{
    Capsule, ContactResponse, Cuboid, HalfSpace, Obstacle, Obstacles, PenaltyContact, Response,
    Shape, Sphere, VelocityRule, WithContactResponse,
};
use softbench::data::DataPaths;
use softbench::integrate::{Integrator, IntegratorSettings, State, StepReport};
use softbench::mesh::generate;
use softbench::model::{
    FixedSelection, HessianOptions, InvertedTets, MassKind, Model, ModelSpec, VertexPotential,
};
use softbench::parallel::Parallelism;
use softbench::rng::Rng;
use softbench::scene::{self, LoadedScene, Scene};
use std::path::PathBuf;
use std::sync::Arc;

const BALL_ON_GROUND: &str = r#"
[mesh]
generate = { ball = 2, radius = 0.1, origin = [0.0, 0.1, 0.0] }

[material]
model = "stable-neo-hookean"
youngs_modulus = 1e7
poisson_ratio = 0.3
density = 1000.0

[forces]
gravity = [0.0, -9.81, 0.0]

[integrator]
newton = { max_iterations = 20 }

[run]
dt = 0.001
steps = 1
"#;

const GROUND: &str = r#"
[[obstacles]]
kind = "plane"
normal = [0.0, 1.0, 0.0]
"#;

/// The ball scene with `obstacles` (TOML) and `--set` style overrides.
fn scene_with(obstacles: &str, overrides: &[&str]) -> Scene {
    let text = format!("{BALL_ON_GROUND}\n{obstacles}");
    let path = PathBuf::from("ball-on-ground.toml");
    let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
    let config = scene::parse(&text, &path, &overrides).unwrap();
    let loaded = LoadedScene { path, config };
    scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential).unwrap()
}

/// The ball over the ground, with overrides.
fn scene(overrides: &[&str]) -> Scene {
    scene_with(GROUND, overrides)
}

/// What a run did, step by step.
struct Trajectory {
    /// Height of the centre of mass after each step (index 0: the start).
    com_height: Vec<f64>,
    /// Vertical velocity of the centre of mass after each step.
    com_velocity: Vec<f64>,
    reports: Vec<StepReport>,
    last: State,
}

impl Trajectory {
    fn max_penetration(&self) -> f64 {
        self.reports
            .iter()
            .map(|r| r.max_penetration)
            .fold(0.0, f64::max)
    }

    /// max - min of the centre's height over the steps `from..`.
    fn height_range(&self, from: usize) -> f64 {
        let s = &self.com_height[from..];
        s.iter().copied().fold(f64::MIN, f64::max) - s.iter().copied().fold(f64::MAX, f64::min)
    }
}

fn center_of_mass(model: &Model, state: &State) -> (f64, f64) {
    let masses = model.vertex_masses();
    let (mut m, mut y, mut vy) = (0.0, 0.0, 0.0);
    for (f, &v) in model.dofs().free_vertices().iter().enumerate() {
        m += masses[v];
        y += masses[v] * state.q[3 * f + 1];
        vy += masses[v] * state.v[3 * f + 1];
    }
    (y / m, vy / m)
}

fn simulate(mut scene: Scene, steps: usize) -> Trajectory {
    let mut integrator = scene.take_integrator();
    let dt = scene.config.run.dt;
    let mut state = scene.initial.clone();
    let (y, vy) = center_of_mass(&scene.model, &state);
    let mut t = Trajectory {
        com_height: vec![y],
        com_velocity: vec![vy],
        reports: Vec::new(),
        last: state.clone(),
    };
    for step in 1..=steps {
        let report = integrator
            .step(&mut scene.model, &mut state, dt)
            .unwrap_or_else(|e| panic!("step {step}: {e}"));
        let (y, vy) = center_of_mass(&scene.model, &state);
        t.com_height.push(y);
        t.com_velocity.push(vy);
        t.reports.push(report);
    }
    t.last = state;
    t
}

fn response_override(r: ContactResponse) -> String {
    format!("contact.response={}", r.name())
}

/// The ball's vertices as free particles (tet masses, lumped, no elasticity) under gravity,
/// its centre at `height`.
fn particles(height: f64) -> Model {
    let mut mesh = generate::ball(0.1, 2);
    mesh.positions.iter_mut().for_each(|p| p.y += height);
    let spec = ModelSpec {
        mesh,
        material: None,
        density: Some(1000.0),
        mass_kind: MassKind::Lumped,
        point_masses: None,
        springs: Vec::new(),
        gravity: Some(Vector3::new(0.0, -9.81, 0.0)),
        fixed: FixedSelection::none(),
        inverted_tets: InvertedTets::Refuse,
        parallelism: Parallelism::Sequential,
        damping: Default::default(),
    };
    Model::new(spec).unwrap()
}

/// Particles with every kind of obstacle cutting into them, so the potential is gravity plus
/// the penalty.
fn penalty_model() -> (Model, Arc<Obstacles>) {
    let mut model = particles(0.0);
    let turned = nalgebra::Rotation3::from_axis_angle(&Vector3::z_axis(), 0.4);
    let obstacles: Obstacles = [
        Shape::HalfSpace(HalfSpace::new(
            Vector3::new(0.0, -0.06, 0.0),
            Vector3::new(0.1, 1.0, 0.0),
        )),
        Shape::Sphere(Sphere::new(Vector3::new(0.12, 0.05, 0.0), 0.07)),
        Shape::Cuboid(Cuboid::new(
            Vector3::new(-0.1, 0.05, 0.02),
            Vector3::new(0.05, 0.04, 0.06),
            turned,
        )),
        Shape::Capsule(Capsule::new(
            Vector3::new(-0.1, 0.0, 0.1),
            Vector3::new(0.1, 0.02, 0.1),
            0.04,
        )),
    ]
    .into_iter()
    .map(Obstacle::new)
    .collect();
    let obstacles = Arc::new(obstacles);
    model.add_vertex_potential(Box::new(PenaltyContact::new(obstacles.clone(), 1e4)));
    (model, obstacles)
}

#[test]
fn penalty_gradient_and_hessian_match_finite_differences_through_the_model() {
    let (mut model, obstacles) = penalty_model();
    let mut rng = Rng::new(11);
    let q: Vec<f64> = model
        .rest_state()
        .iter()
        .map(|x| x + rng.range(-2e-3, 2e-3))
        .collect();
    let inside = q
        .chunks_exact(3)
        .filter(|p| obstacles.distance(&Vector3::new(p[0], p[1], p[2]), 0.0) < 0.0)
        .count();
    assert!(inside >= 10, "only {inside} vertices penetrate");
    let n = q.len();
    let mut g = vec![0.0; n];
    model.gradient(&q, &mut g).unwrap();
    let mut h = model.new_hessian();
    model
        .hessian(&q, &mut h, HessianOptions::default())
        .unwrap();
    let step = 1e-7;
    let (mut worst_g, mut worst_h) = (0.0f64, 0.0f64);
    let mut gp = vec![0.0; n];
    let mut gm = vec![0.0; n];
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
            worst_h = worst_h.max(((gp[j] - gm[j]) / (2.0 * step) - h.get(j, i)).abs());
        }
    }
    let g_scale = g.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    eprintln!(
        "penalty FD: {inside} vertices inside, max gradient error {worst_g:.2e} (|g| {g_scale:.2e}), max Hessian error {worst_h:.2e} (k = 1e4)"
    );
    assert!(worst_g < 1e-6 * g_scale, "gradient error {worst_g:e}");
    assert!(worst_h < 1e-5 * 1e4, "Hessian error {worst_h:e}");
}

#[test]
fn projected_penalty_hessian_blocks_are_positive_semi_definite() {
    let (model, obstacles) = penalty_model();
    let penalty = PenaltyContact::new(obstacles, 1e4);
    // Deep inside every shape, where the curvature term is most negative.
    let x: Vec<Vector3<f64>> = model.rest_positions().iter().map(|p| p * 1.3).collect();
    let mut blocks = 0;
    let mut indefinite = 0;
    penalty.hessian(0.0, &x, false, &mut |_, b| {
        indefinite += usize::from(b.symmetric_eigenvalues().min() < -1e-9);
    });
    penalty.hessian(0.0, &x, true, &mut |_, b| {
        blocks += 1;
        let lowest = b.symmetric_eigenvalues().min();
        assert!(
            lowest > -1e-9 * 1e4,
            "projected block has eigenvalue {lowest}"
        );
    });
    eprintln!("penalty Hessian: {blocks} blocks, {indefinite} indefinite before projection");
    assert!(blocks > 0 && indefinite > 0);
}

/// Total work of a run (wall time included).
fn totals(run: &Trajectory) -> StepReport {
    run.reports.iter().fold(StepReport::default(), |mut a, r| {
        a.absorb(r);
        a.times.total += r.times.total;
        a
    })
}

/// The ball resting on the ground: it starts touching, undeformed, at rest, and settles by its
/// elastic sag (about 0.08 mm) plus, for the penalty, `m g / k` (0.4 mm for one vertex in
/// contact at k = 1e5 N/m). Each response runs at a time step that suits it (backward Euler):
/// - penalty and constrained at the course's 10 ms, where backward Euler damps the sag
///   oscillation within a few steps;
/// - projection and (predictive) velocity-flip at 0.1 ms: both keep the contact vertex on or
///   above the ground and the body follows their correction.
#[test]
fn ball_resting_on_the_ground_stays_put() {
    let cases: [(ContactResponse, f64, f64, f64, f64); 4] = [
        // response, dt, duration, largest |height change|, largest height range over the
        // second half
        (ContactResponse::Penalty, 1e-2, 1.0, 1e-3, 1e-8),
        (ContactResponse::Constrained, 1e-2, 1.0, 2e-4, 1e-8),
        (ContactResponse::Projection, 1e-4, 0.2, 2e-4, 1e-4),
        (ContactResponse::VelocityFlip, 1e-4, 0.2, 2e-4, 1e-4),
    ];
    for (response, dt, duration, drift, jitter) in cases {
        let dt_set = format!("run.dt={dt}");
        let run = simulate(
            scene(&[&response_override(response), &dt_set]),
            (duration / dt).round() as usize,
        );
        let start = run.com_height[0];
        let moved = run
            .com_height
            .iter()
            .fold(0.0f64, |a, y| a.max((y - start).abs()));
        let half = run.com_height.len() / 2;
        let range = run.height_range(half);
        let work = totals(&run);
        eprintln!(
            "resting ball, {response}, dt {dt}: moved at most {moved:.3e} m, height range over the \
             second half {range:.3e} m, max penetration {:.3e} m, {} contacts at the end; \
             {:.2} ms per step, {} QPs ({:.2} ms each)",
            run.max_penetration(),
            run.reports.last().unwrap().contacts,
            1e3 * work.times.total / run.reports.len() as f64,
            work.qp_solves,
            1e3 * work.times.qp / f64::from(work.qp_solves.max(1)),
        );
        assert!(moved < drift, "{response}: the ball moved {moved:e} m");
        assert!(
            range < jitter,
            "{response}: the ball jitters by {range:e} m"
        );
        assert!(run.reports.last().unwrap().contacts >= 1);
    }
}

/// The lowest particle of a cloud dropped from `height` with `response`: its highest point
/// after it first moves up, as a fraction of its drop height (0 if it never moves up).
fn particle_rebound(method: &str, response: Response, height: f64, dt: f64) -> f64 {
    let mut model = particles(0.1 + height);
    let obstacles: Obstacles = [Obstacle::new(Shape::HalfSpace(HalfSpace::new(
        Vector3::zeros(),
        Vector3::y(),
    )))]
    .into_iter()
    .collect();
    let settings = IntegratorSettings {
        method: method.parse().unwrap(),
        ..Default::default()
    };
    let mut integrator =
        WithContactResponse::new(settings.build(), Arc::new(obstacles), response, 1e-3);
    let mut state = State::at_rest(&model);
    let lowest = (0..model.num_dofs() / 3)
        .min_by(|a, b| state.q[3 * a + 1].total_cmp(&state.q[3 * b + 1]))
        .unwrap();
    let (mut up, mut peak) = (false, 0.0f64);
    for _ in 0..(3.0 * (2.0 * height / 9.81).sqrt() / dt) as usize {
        integrator.step(&mut model, &mut state, dt).unwrap();
        let (y, vy) = (state.q[3 * lowest + 1], state.v[3 * lowest + 1]);
        up |= vy > 0.0;
        if up {
            peak = peak.max(y);
        }
    }
    peak / height
}

/// Restitution is the fraction of the approaching normal velocity reversed, so free particles
/// rebound to `e^2` of their drop height — with projection and velocity-flip, after an
/// explicit or an implicit method.
#[test]
fn restitution_sets_the_rebound_height_of_free_particles() {
    for method in ["symplectic-euler", "backward-euler"] {
        for e in [1.0, 0.5, 0.0] {
            let rule = VelocityRule {
                restitution: e,
                friction: 0.0,
            };
            for response in [Response::Projection(rule), Response::VelocityFlip(rule)] {
                let ratio = particle_rebound(method, response, 0.05, 1e-4);
                eprintln!(
                    "particles, {method}, {response:?}: rebound {:.3} of the drop height",
                    ratio
                );
                assert!(
                    (ratio - e * e).abs() < 0.02,
                    "{method}, {response:?}: rebound {ratio} instead of {}",
                    e * e
                );
            }
        }
    }
}

/// Drop the ball from `height` (its lowest point above the ground) and measure the rebound:
/// the highest centre of mass after it first moves up, above the resting centre (0.1 m), as a
/// fraction of the drop height.
fn rebound(overrides: &[&str], height: f64, duration: f64) -> (f64, Trajectory) {
    let origin = format!("mesh.generate.origin=[0.0, {}, 0.0]", 0.1 + height);
    let mut all = vec![origin.as_str()];
    all.extend_from_slice(overrides);
    let scene = scene(&all);
    let steps = (duration / scene.config.run.dt).round() as usize;
    let run = simulate(scene, steps);
    let first_up = run
        .com_velocity
        .iter()
        .position(|v| *v > 0.0)
        .expect("the ball never moves up");
    let peak = run.com_height[first_up..]
        .iter()
        .copied()
        .fold(f64::MIN, f64::max);
    ((peak - 0.1) / height, run)
}

/// An elastic ball bounces by its elasticity: the restitution acts on the few vertices that
/// touch, which carry little of its momentum, so e = 1 and e = 0 give nearly the same rebound.
#[test]
fn elastic_ball_rebounds_by_its_elasticity_whatever_the_restitution() {
    let projection = response_override(ContactResponse::Projection);
    let mut ratios = Vec::new();
    for e in ["1", "0"] {
        let restitution = format!("contact.restitution={e}");
        let (ratio, _) = rebound(&[&projection, &restitution, "run.dt=2e-4"], 0.05, 0.3);
        eprintln!(
            "elastic ball, projection, restitution {e}: rebound {:.1}% of the drop height",
            100.0 * ratio
        );
        ratios.push(ratio);
    }
    assert!(ratios.iter().all(|r| *r > 0.5), "{ratios:?}");
    assert!((ratios[0] - ratios[1]).abs() < 0.05, "{ratios:?}");
}

/// The ball dropped off-centre onto a spherical bump on the ground, next to a tilted box:
/// after every constrained step, every vertex is outside every obstacle (to 1e-9 m), while the
/// ball hits the bump, slides off it and lands.
#[test]
fn constrained_steps_never_leave_a_vertex_inside_an_obstacle() {
    let obstacles = r#"
[[obstacles]]
kind = "plane"
normal = [0.0, 1.0, 0.0]

[[obstacles]]
kind = "sphere"
center = [0.0, 0.0, 0.0]
radius = 0.1

[[obstacles]]
kind = "box"
center = [-0.25, 0.05, 0.0]
half_extents = [0.05, 0.1, 0.2]
rotation = { axis = [0, 0, 1], degrees = 20 }
"#;
    let constrained = response_override(ContactResponse::Constrained);
    let scene = scene_with(
        obstacles,
        &[
            &constrained,
            "run.dt=5e-3",
            "mesh.generate.origin=[-0.04, 0.3, 0.0]",
        ],
    );
    let run = simulate(scene, 120);
    let work = totals(&run);
    let worst = run.max_penetration();
    let lowest = run.com_height.iter().copied().fold(f64::MAX, f64::min);
    eprintln!(
        "constrained over a bump: deepest penetration after any step {worst:.3e} m; \
         {} steps, {} SQP iterations, {} QPs, {:.2} ms per QP, {:.2} ms per step",
        run.reports.len(),
        work.newton_iterations,
        work.qp_solves,
        1e3 * work.times.qp / f64::from(work.qp_solves.max(1)),
        1e3 * work.times.total / run.reports.len() as f64,
    );
    assert!(worst <= 1e-9, "a vertex ended {worst:e} m inside");
    assert!(work.qp_solves > 0);
    assert!(run.reports.iter().any(|r| r.contacts > 0));
    // It fell past the bump's top (0.1 m) onto the ground: centre below 0.2 + 0.1 - ...
    assert!(
        lowest < 0.15,
        "the ball did not slide off the bump (lowest centre {lowest})"
    );
}

/// The same drop with the penalty and the constrained response (backward Euler, dt = 5 ms):
/// both land and come to rest, and the constrained one never penetrates while the penalty
/// needs a visible depth to stop the ball.
#[test]
fn constrained_penetrates_less_than_penalty_on_the_same_drop() {
    let mut deepest = Vec::new();
    for response in [ContactResponse::Penalty, ContactResponse::Constrained] {
        let set = response_override(response);
        let scene = scene(&[&set, "run.dt=5e-3", "mesh.generate.origin=[0.0, 0.15, 0.0]"]);
        let run = simulate(scene, 200);
        let work = totals(&run);
        let end = *run.com_height.last().unwrap();
        let speed = run.com_velocity.last().unwrap().abs();
        eprintln!(
            "drop from 5 cm, {response}: deepest penetration {:.3e} m, resting centre {end:.5} m, \
             final |v_com| {speed:.2e} m/s; {:.2} ms per step, {} QPs ({:.2} ms each)",
            run.max_penetration(),
            1e3 * work.times.total / run.reports.len() as f64,
            work.qp_solves,
            1e3 * work.times.qp / f64::from(work.qp_solves.max(1)),
        );
        assert!((end - 0.1).abs() < 2e-3, "{response}: rests at {end}");
        assert!(speed < 1e-3, "{response}: still moving at {speed} m/s");
        deepest.push(run.max_penetration());
    }
    assert!(deepest[1] <= 1e-9 && deepest[0] > 1e-4, "{deepest:?}");
}

/// Friction scales the tangential velocity of a contact: particles sliding on the ground keep
/// their speed with friction 0 and stop with friction 1.
#[test]
fn friction_one_stops_sliding_and_friction_zero_keeps_it() {
    for friction in [0.0, 1.0] {
        let mut model = particles(0.0);
        let ground: Obstacles = [Obstacle::new(Shape::HalfSpace(HalfSpace::new(
            Vector3::new(0.0, -0.1, 0.0),
            Vector3::y(),
        )))]
        .into_iter()
        .collect();
        let rule = VelocityRule {
            restitution: 0.0,
            friction,
        };
        let settings = IntegratorSettings::default();
        let mut integrator = WithContactResponse::new(
            settings.build(),
            Arc::new(ground),
            Response::Projection(rule),
            1e-3,
        );
        let mut state = State::at_rest(&model);
        for v in state.v.chunks_exact_mut(3) {
            v[0] = 1.0;
        }
        for _ in 0..300 {
            integrator.step(&mut model, &mut state, 1e-3).unwrap();
        }
        // The bottom vertex has been on the ground from the start.
        let lowest = (0..model.num_dofs() / 3)
            .min_by(|a, b| state.q[3 * a + 1].total_cmp(&state.q[3 * b + 1]))
            .unwrap();
        let vx = state.v[3 * lowest];
        eprintln!("sliding particles, friction {friction}: bottom vertex moves at {vx:.3} m/s");
        assert!(
            (vx - (1.0 - friction)).abs() < 1e-9,
            "friction {friction}: {vx}"
        );
    }
}

/// A ground moving up 2 cm lifts the resting ball by as much (penalty and constrained).
#[test]
fn moving_ground_lifts_the_ball() {
    let moving = r#"
[[obstacles]]
kind = "plane"
normal = [0.0, 1.0, 0.0]
path = { times = [0.1, 0.3], offsets = [[0.0, 0.0, 0.0], [0.0, 0.02, 0.0]] }
"#;
    for response in [ContactResponse::Penalty, ContactResponse::Constrained] {
        let set = response_override(response);
        let still = simulate(scene(&[&set, "run.dt=1e-2"]), 60);
        let lifted = simulate(scene_with(moving, &[&set, "run.dt=1e-2"]), 60);
        let rise = lifted.com_height.last().unwrap() - still.com_height.last().unwrap();
        eprintln!("moving ground, {response}: the ball rises {rise:.5} m");
        assert!((rise - 0.02).abs() < 5e-4, "{response}: rises {rise}");
    }
}

/// 1/2 Σ m |v|² with the vertex masses.
fn kinetic(model: &Model, state: &State) -> f64 {
    let masses = model.vertex_masses();
    model
        .dofs()
        .free_vertices()
        .iter()
        .enumerate()
        .map(|(f, &v)| {
            0.5 * masses[v] * state.v[3 * f..3 * f + 3].iter().map(|x| x * x).sum::<f64>()
        })
        .sum()
}

#[test]
fn constrained_contact_runs_with_damping_and_with_an_end_position_scheme_of_each_family() {
    // The constraints live inside the one Newton loop, so damping (a term of the objective)
    // and every scheme whose unknown is the end-of-step position come with them. The ball is
    // thrown down at 1 m/s onto the ground it rests on. Backward Euler (the scene's method),
    // BDF2 and BDF3 (one scheme for every k; BDF1 is backward Euler) and the Newmark family;
    // not `static`, whose end position has no kinetic energy to damp.
    let constrained = response_override(ContactResponse::Constrained);
    let throw = "initial.velocity=[0.0, -1.0, 0.0]";
    let damping = "damping.strain_rate={ phi = 1000.0, psi = 1000.0 }";
    let end_energy = |sets: &[&str]| {
        let mut all = vec![constrained.as_str(), throw];
        all.extend_from_slice(sets);
        let s = scene(&all);
        let model_masses = scene(&all);
        let run = simulate(s, 60);
        let k = kinetic(&model_masses.model, &run.last);
        eprintln!(
            "{sets:?}: max penetration {:.2e} m, end kinetic energy {k:.3e} J",
            run.max_penetration()
        );
        assert!(
            run.max_penetration() <= 1e-6,
            "{sets:?}: penetrates {:.3e} m",
            run.max_penetration()
        );
        assert!(
            run.reports.iter().any(|r| r.qp_solves > 0),
            "{sets:?}: no QP was solved"
        );
        k
    };
    let undamped = end_energy(&[]);
    let damped = end_energy(&[damping]);
    assert!(
        damped < 0.5 * undamped,
        "damping must dissipate: end kinetic energy {damped:.3e} J damped vs {undamped:.3e} J"
    );
    for method in ["bdf2", "bdf3", "newmark", "generalized-alpha", "hht-alpha"] {
        let set = format!("integrator.method={method}");
        let (undamped, damped) = (end_energy(&[&set]), end_energy(&[&set, damping]));
        assert!(
            damped < 0.8 * undamped,
            "{method}: {damped:.3e} J damped vs {undamped:.3e} J"
        );
    }
    // A scheme whose unknown is not the end position is refused up front, with the list.
    let text = format!("{BALL_ON_GROUND}\n{GROUND}");
    let sets = vec![
        constrained.clone(),
        "integrator.method=implicit-midpoint".to_string(),
    ];
    let err = scene::parse(&text, &PathBuf::from("ball.toml"), &sets)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("methods that can:") && err.contains("newmark"),
        "{err}"
    );
}

/// The shipped `ball-drop.toml` (ball of radius 0.1 m, 1296 tets, E = 1e7 Pa, dropped 5 cm,
/// backward Euler) through `softbench simulate` with every step sampled: the exit code,
/// stderr, and each trajectory column by name.
fn ball_drop(sets: &[&str]) -> (Option<i32>, String, BallDrop) {
    let dir = common::TempDir::new("ball-drop-energy");
    let out = dir.path().join("run");
    let mut args = vec!["--set", "run.sample_every=1"];
    for s in sets {
        args.extend(["--set", s]);
    }
    let result = common::simulate(&common::scene("ball-drop.toml"), &out, &args);
    let csv = std::fs::read_to_string(out.join("trajectory.csv")).unwrap_or_default();
    let mut lines = csv.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap_or("")
        .split(',')
        .map(str::to_owned)
        .collect();
    let rows = lines
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
    (
        result.status.code(),
        String::from_utf8_lossy(&result.stderr).into_owned(),
        BallDrop { header, rows },
    )
}

/// The sampled rows of a `ball_drop` run.
struct BallDrop {
    header: Vec<String>,
    rows: Vec<Vec<f64>>,
}

impl BallDrop {
    fn column(&self, name: &str) -> Vec<f64> {
        let at = self.header.iter().position(|h| h == name).unwrap();
        self.rows.iter().map(|r| r[at]).collect()
    }
}

/// Predictive velocity-flip (the seeds' meaning): a vertex that would end a step inside the
/// ground gets its flipped velocity and moves by dt times it from where it started, so the
/// dropped ball never sinks. The after-the-fact flip it replaced left vertices inside and let
/// the ball sink 246 mm in 3 s at dt = 5 ms (65 mm at 0.2 ms, still growing).
#[test]
fn velocity_flip_never_leaves_the_dropped_ball_inside_the_ground() {
    for (dt, duration) in [(5e-3f64, 3.0), (2e-4, 0.5)] {
        let steps = format!("run.steps={}", (duration / dt).round() as usize);
        let dt_set = format!("run.dt={dt}");
        let (code, stderr, run) = ball_drop(&["contact.response=velocity-flip", &dt_set, &steps]);
        assert_eq!(code, Some(0), "dt {dt}: {stderr}");
        let depth = run.column("max_penetration");
        let half = depth.len() / 2;
        let first = depth[..half].iter().copied().fold(0.0, f64::max);
        let second = depth[half..].iter().copied().fold(0.0, f64::max);
        eprintln!(
            "ball-drop, velocity-flip, dt {dt}: deepest penetration {first:.3e} m in the first \
             half of {duration} s, {second:.3e} m in the second"
        );
        assert!(
            first <= 1e-9 && second <= 1e-9,
            "dt {dt}: {first:e}, {second:e}"
        );
    }
}

/// Projection after backward Euler used to pump energy at impact for dt >= 1 ms (26 J of
/// elastic energy from a 2 J drop at dt = 5 ms, a blow-up at step 109): the contact vertices
/// were moved alone, against stiff neighbours. Now the body follows the correction as in a
/// backward Euler step, and the mechanical energy (kinetic + elastic + gravity, which counts
/// the work gravity did) never rises above its initial value.
#[test]
fn projection_after_backward_euler_never_gains_energy_at_impact() {
    for dt in [1e-3f64, 2e-3, 5e-3] {
        let steps = format!("run.steps={}", (1.0 / dt).round() as usize);
        let dt_set = format!("run.dt={dt}");
        let (code, stderr, run) = ball_drop(&["contact.response=projection", &dt_set, &steps]);
        assert_eq!(code, Some(0), "dt {dt}: {stderr}");
        let total = run.column("total");
        let elastic = run.column("elastic");
        let gain = total.iter().map(|e| e - total[0]).fold(f64::MIN, f64::max);
        let peak_elastic = elastic.iter().copied().fold(0.0, f64::max);
        eprintln!(
            "ball-drop, projection, backward Euler, dt {dt}: largest gain of mechanical energy \
             {gain:.3e} J (drop energy ~2 J), peak elastic {peak_elastic:.3} J, final total {:.3} J \
             from {:.3} J",
            total.last().unwrap(),
            total[0]
        );
        assert!(
            gain <= 1e-3 * total[0].abs().max(1.0),
            "dt {dt}: gains {gain} J"
        );
        assert!(run.rows.len() > (0.9 / dt) as usize, "dt {dt}: completes");
    }
}
