//! Accelerated local solvers: Anderson lowers the iterations projective dynamics and VBD need
//! to reach a tolerance, and so does Chebyshev for VBD's two sweeps, every acceleration and every
//! VBD sweep converges to the converged step, the Jacobi sweep gives the same bits on any
//! thread count, every registered acceleration runs, and a bad name is refused.
//!
//! The tolerance is on `‖x_k − x*‖ / ‖x* − q‖`, with `x*` the step converged by Newton on the
//! same incremental potential (`backward-euler`, tolerance 1e-13). Run with `--nocapture` to
//! see the measured iteration counts.

mod common;

use common::bodies::{clamped_at_min_x, distance};
use common::{TempDir, scene, simulate};
use nalgebra::Vector3;
use softbench::integrate::acceleration::Acceleration;
use softbench::integrate::projective_dynamics::{ProjectiveDynamics, ProjectiveDynamicsSettings};
use softbench::integrate::vbd::{Vbd, VbdSettings, VbdSweep};
use softbench::integrate::{Integrator, IntegratorSettings, Method, State, StepReport};
use softbench::material::{LameParameters, MaterialModel};
use softbench::mesh::generate::box_mesh;
use softbench::model::{MassKind, Model, ModelSpec};
use softbench::parallel::Parallelism;
use softbench::solve::LinearSolverKind;

/// A body hanging under gravity, clamped at x = 0, at rest.
struct Body {
    material: &'static str,
    cells: [usize; 3],
    youngs: f64,
    poisson: f64,
    mass: MassKind,
    dt: f64,
}

/// Two generated bodies per solver (none is a shipped scene): a bar of soft rubber and a
/// stiffer, nearly incompressible plate with lumped mass and a larger step.
const BAR: Body = Body {
    material: "corotated",
    cells: [6, 2, 2],
    youngs: 1e4,
    poisson: 0.3,
    mass: MassKind::Consistent,
    dt: 0.01,
};
const PLATE: Body = Body {
    material: "corotated",
    cells: [4, 4, 1],
    youngs: 1e5,
    poisson: 0.45,
    mass: MassKind::Lumped,
    dt: 1.0 / 30.0,
};

impl Body {
    fn with(&self, material: &'static str) -> Body {
        Body { material, ..*self }
    }

    fn model(&self) -> Model {
        let lame = LameParameters::from_youngs_poisson(self.youngs, self.poisson).unwrap();
        let material = MaterialModel::from_name(self.material, lame).unwrap();
        let c = self.cells;
        let size = [0.1 * c[0] as f64, 0.1 * c[1] as f64, 0.1 * c[2] as f64];
        let mut spec = ModelSpec::elastic(box_mesh(c, size), material, 1000.0);
        spec.fixed = clamped_at_min_x();
        spec.gravity = Some(Vector3::new(0.0, -9.81, 0.0));
        spec.mass_kind = self.mass;
        Model::new(spec).unwrap()
    }
}

/// The step from rest converged by Newton.
fn converged(model: &mut Model, dt: f64) -> State {
    let mut settings = IntegratorSettings {
        method: Method::from_name("backward-euler").unwrap(),
        ..Default::default()
    };
    settings.newton.tolerance = 1e-13;
    settings.newton.max_iterations = 50;
    let mut state = State::at_rest(model);
    settings.build().step(model, &mut state, dt).unwrap();
    state
}

fn pd(settings: ProjectiveDynamicsSettings) -> ProjectiveDynamics {
    let defaults = IntegratorSettings::default();
    ProjectiveDynamics::new(
        settings,
        LinearSolverKind::cholesky().build(&defaults.solver),
    )
}

fn pd_settings(acceleration: Acceleration, iterations: u32) -> ProjectiveDynamicsSettings {
    ProjectiveDynamicsSettings {
        iterations,
        acceleration,
        ..Default::default()
    }
}

fn vbd_settings(sweep: VbdSweep, acceleration: Acceleration, iterations: u32) -> VbdSettings {
    VbdSettings {
        iterations,
        sweep,
        acceleration,
        ..Default::default()
    }
}

/// One step from rest by `integrator`, with its report.
fn step(model: &mut Model, mut integrator: impl Integrator, dt: f64) -> (State, StepReport) {
    let mut state = State::at_rest(model);
    let report = integrator.step(model, &mut state, dt).unwrap();
    (state, report)
}

/// The iteration counts tried: every count to 30, then 10% apart up to `max` (so a count
/// above 30 is known to within 10%).
fn grid(max: u32) -> Vec<u32> {
    let mut ks: Vec<u32> = (1..=30.min(max)).collect();
    while let Some(&k) = ks.last().filter(|&&k| k < max) {
        ks.push(((f64::from(k) * 1.1).ceil() as u32).min(max));
    }
    ks
}

/// `(k, relative error of the step after k iterations)` over [`grid`]`(max)`, each a fresh
/// step: an accelerated run's first k iterations are those of a run of k iterations.
fn errors(
    model: &mut Model,
    dt: f64,
    max: u32,
    run: impl Fn(&mut Model, u32) -> State,
) -> Vec<(u32, f64)> {
    let reference = converged(model, dt);
    let scale = distance(&reference.q, &State::at_rest(model).q);
    grid(max)
        .into_iter()
        .map(|k| (k, distance(&run(model, k).q, &reference.q) / scale))
        .collect()
}

/// The first tried count whose error is below `tol` and stays below it at every larger count
/// tried; `None` if the largest is still above.
fn iterations_to(errors: &[(u32, f64)], tol: f64) -> Option<u32> {
    match errors.iter().rposition(|&(_, e)| e >= tol || e.is_nan()) {
        None => Some(errors[0].0),
        Some(i) => errors.get(i + 1).map(|&(k, _)| k),
    }
}

const TOL: f64 = 1e-6;

fn pd_iterations(body: &Body, acceleration: Acceleration, max: u32) -> Option<u32> {
    let mut model = body.model();
    let e = errors(&mut model, body.dt, max, |m, k| {
        step(m, pd(pd_settings(acceleration, k)), body.dt).0
    });
    iterations_to(&e, TOL)
}

fn vbd_iterations(
    body: &Body,
    sweep: VbdSweep,
    acceleration: Acceleration,
    max: u32,
) -> Option<u32> {
    let mut model = body.model();
    let e = errors(&mut model, body.dt, max, |m, k| {
        step(m, Vbd::new(vbd_settings(sweep, acceleration, k)), body.dt).0
    });
    iterations_to(&e, TOL)
}

#[test]
fn anderson_lowers_projective_dynamics_iterations_to_a_tolerance() {
    for (name, body) in [("bar", BAR), ("plate", PLATE)] {
        let plain = pd_iterations(&body, Acceleration::None, 1000);
        let anderson = pd_iterations(&body, Acceleration::Anderson, 1000);
        eprintln!(
            "projective-dynamics {name}: iterations to {TOL:e}: none {plain:?}, anderson {anderson:?}"
        );
        let anderson = anderson.expect("anderson reaches the tolerance");
        assert!(
            plain.is_none_or(|p| anderson < p),
            "{name}: anderson {anderson} vs plain {plain:?}"
        );
    }
}

#[test]
fn anderson_and_chebyshev_lower_gauss_seidel_vbd_iterations_to_a_tolerance() {
    for (name, body) in [
        ("bar", BAR.with("stable-neo-hookean")),
        ("plate", PLATE.with("stable-neo-hookean")),
    ] {
        let plain = vbd_iterations(&body, VbdSweep::GaussSeidel, Acceleration::None, 2000);
        let anderson = vbd_iterations(&body, VbdSweep::GaussSeidel, Acceleration::Anderson, 2000);
        let chebyshev = vbd_iterations(&body, VbdSweep::GaussSeidel, Acceleration::Chebyshev, 2000);
        eprintln!(
            "vbd gauss-seidel {name}: iterations to {TOL:e}: none {plain:?}, anderson {anderson:?}, chebyshev {chebyshev:?}"
        );
        let anderson = anderson.expect("anderson reaches the tolerance");
        assert!(
            plain.is_none_or(|p| anderson < p),
            "{name}: anderson {anderson} vs plain {plain:?}"
        );
        // Measured: Chebyshev (ρ estimated) helps Gauss–Seidel VBD too, less than Anderson.
        let chebyshev = chebyshev.expect("chebyshev reaches the tolerance");
        assert!(
            plain.is_none_or(|p| chebyshev < p),
            "{name}: chebyshev {chebyshev} vs plain {plain:?}"
        );
    }
}

#[test]
fn chebyshev_and_anderson_lower_jacobi_vbd_iterations_to_a_tolerance() {
    for (name, body) in [
        ("bar", BAR.with("stable-neo-hookean")),
        ("plate", PLATE.with("stable-neo-hookean")),
    ] {
        let plain = vbd_iterations(&body, VbdSweep::Jacobi, Acceleration::None, 3000);
        let chebyshev = vbd_iterations(&body, VbdSweep::Jacobi, Acceleration::Chebyshev, 3000);
        let anderson = vbd_iterations(&body, VbdSweep::Jacobi, Acceleration::Anderson, 3000);
        eprintln!(
            "vbd jacobi {name}: iterations to {TOL:e}: none {plain:?}, chebyshev {chebyshev:?}, anderson {anderson:?}"
        );
        let chebyshev = chebyshev.expect("chebyshev reaches the tolerance");
        assert!(
            plain.is_none_or(|p| chebyshev < p),
            "{name}: chebyshev {chebyshev} vs plain {plain:?}"
        );
        let anderson = anderson.expect("anderson reaches the tolerance");
        assert!(
            plain.is_none_or(|p| anderson < p),
            "{name}: anderson {anderson} vs plain {plain:?}"
        );
    }
}

/// A small bar (3 × 1 × 1 cells) for the convergence claims, as in `tests/vbd.rs`.
const SMALL: Body = Body {
    material: "stable-neo-hookean",
    cells: [3, 1, 1],
    youngs: 1e4,
    poisson: 0.3,
    mass: MassKind::Consistent,
    dt: 0.01,
};

#[test]
fn every_acceleration_and_every_vbd_sweep_converges_to_the_converged_step() {
    let mut model = SMALL.model();
    let reference = converged(&mut model, SMALL.dt);
    let scale = distance(&reference.q, &State::at_rest(&model).q);
    for &sweep in VbdSweep::ALL {
        for &acceleration in Acceleration::ALL {
            let iterations = match sweep {
                VbdSweep::GaussSeidel => 300,
                VbdSweep::Jacobi => 1500,
            };
            let s = vbd_settings(sweep, acceleration, iterations);
            let (state, _) = step(&mut model, Vbd::new(s), SMALL.dt);
            let e = distance(&state.q, &reference.q) / scale;
            assert!(e < 1e-8, "vbd {sweep} {acceleration}: relative error {e:e}");
        }
    }
    let mut model = SMALL.with("corotated").model();
    let reference = converged(&mut model, SMALL.dt);
    let scale = distance(&reference.q, &State::at_rest(&model).q);
    for &acceleration in Acceleration::ALL {
        let (state, _) = step(&mut model, pd(pd_settings(acceleration, 300)), SMALL.dt);
        let e = distance(&state.q, &reference.q) / scale;
        assert!(
            e < 1e-8,
            "projective-dynamics {acceleration}: relative error {e:e}"
        );
    }
}

#[test]
fn jacobi_vbd_gives_the_same_bits_on_one_and_two_threads() {
    let mut model = Body {
        cells: [20, 10, 10],
        ..SMALL
    }
    .model();
    let start = State::at_rest(&model);
    for &acceleration in Acceleration::ALL {
        let settings = vbd_settings(VbdSweep::Jacobi, acceleration, 8);
        let mut run = |par: Parallelism, threads: usize| {
            model.set_parallelism(par);
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    let mut state = start.clone();
                    let mut vbd = Vbd::new(settings);
                    for _ in 0..2 {
                        vbd.step(&mut model, &mut state, 0.01).unwrap();
                    }
                    state
                })
        };
        let one = run(Parallelism::Sequential, 1);
        let two = run(Parallelism::Rayon, 2);
        let bits =
            |s: &State| -> Vec<u64> { s.q.iter().chain(&s.v).map(|x| x.to_bits()).collect() };
        assert_eq!(bits(&one), bits(&two), "jacobi {acceleration}");
        assert_ne!(one.q, start.q);
    }
}

#[test]
fn every_registered_acceleration_runs_in_both_local_solvers_and_reports_what_it_did() {
    assert_eq!(Acceleration::names(), ["none", "chebyshev", "anderson"]);
    let body = BAR;
    for &acceleration in Acceleration::ALL {
        let mut model = body.model();
        let reports = [
            step(&mut model, pd(pd_settings(acceleration, 20)), body.dt).1,
            step(
                &mut model,
                Vbd::new(vbd_settings(VbdSweep::GaussSeidel, acceleration, 20)),
                body.dt,
            )
            .1,
            step(
                &mut model,
                Vbd::new(vbd_settings(VbdSweep::Jacobi, acceleration, 20)),
                body.dt,
            )
            .1,
        ];
        for r in reports {
            assert_eq!(r.local_iterations, 20);
            match acceleration {
                // ρ estimated from the first iterations' update norms.
                Acceleration::Chebyshev => assert!(
                    r.chebyshev_rho > 0.0 && r.chebyshev_rho < 1.0,
                    "{acceleration}: rho {}",
                    r.chebyshev_rho
                ),
                _ => assert_eq!(r.chebyshev_rho, 0.0, "{acceleration}"),
            }
            if acceleration != Acceleration::Anderson {
                assert_eq!(r.anderson_fallbacks, 0, "{acceleration}");
            }
        }
    }
    // A given ρ is the one reported.
    let mut s = vbd_settings(VbdSweep::GaussSeidel, Acceleration::Chebyshev, 5);
    s.chebyshev_rho = 0.6;
    let (_, r) = step(&mut BAR.model(), Vbd::new(s), BAR.dt);
    assert_eq!(r.chebyshev_rho, 0.6);
}

#[test]
fn the_chebyshev_rho_of_each_step_reaches_the_trajectory_and_the_summary() {
    let dir = TempDir::new("local-acceleration-rho");
    let out = dir.path().join("out");
    let result = simulate(
        &scene("cantilever.toml"),
        &out,
        &[
            "--set",
            "integrator.method=vbd",
            "--set",
            "integrator.vbd.acceleration=chebyshev",
            "--set",
            "run.steps=3",
        ],
    );
    assert!(
        result.status.success(),
        "{}",
        String::from_utf8_lossy(&result.stderr)
    );
    let rows = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let mut lines = rows.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = header
        .iter()
        .position(|&h| h == "chebyshev_rho")
        .expect("a chebyshev_rho column");
    assert!(header.contains(&"anderson_fallbacks"));
    let rhos: Vec<f64> = lines
        .map(|l| l.split(',').nth(col).unwrap().parse().unwrap())
        .collect();
    assert_eq!(rhos[0], 0.0, "step 0 did no work");
    assert!(rhos[1..].iter().all(|&r| r > 0.0 && r < 1.0), "{rhos:?}");
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let total = summary["summary"]["totals"]["chebyshev_rho"]
        .as_f64()
        .unwrap();
    assert!(total > 0.0 && total < 1.0, "{summary}");
}

#[test]
fn an_unknown_acceleration_or_a_bare_chebyshev_rho_is_bad_input() {
    let dir = TempDir::new("local-acceleration-bad");
    for (method, section) in [
        ("vbd", "vbd"),
        ("projective-dynamics", "projective_dynamics"),
    ] {
        let out = dir.path().join(format!("out-{method}"));
        let set_method = format!("integrator.method={method}");
        let bad = format!("integrator.{section}.acceleration=andersen");
        let result = simulate(
            &scene("cantilever.toml"),
            &out,
            &[
                "--set",
                &set_method,
                "--set",
                &bad,
                "--set",
                "material.model=corotated",
            ],
        );
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains(&format!("integrator.{section}.acceleration"))
                && stderr.contains("did you mean `anderson`?")
                && stderr.contains("none, chebyshev, anderson"),
            "{stderr}"
        );
        assert!(!out.exists(), "nothing may be written for bad input");
        // chebyshev_rho no longer switches Chebyshev on by itself: the message names the key.
        let rho = format!("integrator.{section}.chebyshev_rho=0.8");
        let result = simulate(
            &scene("cantilever.toml"),
            &out,
            &[
                "--set",
                &set_method,
                "--set",
                &rho,
                "--set",
                "material.model=corotated",
            ],
        );
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{stderr}");
        assert!(
            stderr.contains(&format!("{section}.acceleration = \"chebyshev\"")),
            "{stderr}"
        );
        assert!(!out.exists());
    }
}
