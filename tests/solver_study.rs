//! The solver study kind: every run of a scene solves the same frozen steps (one fingerprint);
//! its ladder agrees with fresh solves that stop on each criterion; a larger iteration cap
//! does not change a tolerance already reached; what it cannot measure is refused at load.

mod common;

use common::TempDir;
use softbench::data::DataPaths;
use softbench::integrate::newton::{Criterion, Direction, Newton};
use softbench::integrate::{NewtonSettings, State, StepReport, solve_frozen};
use softbench::parallel::Parallelism;
use softbench::scene;
use softbench::study::table::Table;
use softbench::study::{RunOptions, load, run};
use std::path::Path;

/// A small hanging beam (no data needed), ν = 0.45.
const BEAM: &str = r#"
[mesh]
generate = { box = [6, 2, 2], size = [1.0, 0.2, 0.2] }
[material]
model = "stable-neo-hookean"
youngs_modulus = 1e5
poisson_ratio = 0.45
density = 1000.0
mass = "lumped"
[fixed]
rule = { axis = "x", side = "min", tolerance = 1e-6 }
[forces]
gravity = [0.0, -9.81, 0.0]
[integrator]
method = "backward-euler"
linear_solver = "cholesky"
[run]
dt = 0.02
steps = 10
"#;

/// The same beam spun about its axis while clamped: a twisted body.
fn twisted() -> String {
    format!("{BEAM}[initial]\nangular_velocity = [20.0, 0.0, 0.0]\n")
}

fn options(dir: &Path) -> RunOptions {
    RunOptions::new(dir.to_owned())
}

/// Runs a solver study over `beam.toml` and `twisted.toml` with `body` after the header;
/// returns its `runs.csv` and the results folder.
fn run_study(tmp: &TempDir, name: &str, body: &str) -> (Table, std::path::PathBuf) {
    tmp.write("beam.toml", BEAM);
    tmp.write("twisted.toml", &twisted());
    let text = format!(
        "name = \"{name}\"\nstudy = \"solver\"\nscenes = [\"beam.toml\", \"twisted.toml\"]\n\n\
         {body}"
    );
    let path = tmp.write(&format!("{name}.toml"), &text);
    let study = load(&path, false, &DataPaths::new(None)).unwrap_or_else(|e| panic!("{e}"));
    let dir = tmp.path().join(name);
    let done = run(&study, &options(&dir)).unwrap_or_else(|e| panic!("{e}"));
    assert!(done.not_ok.is_empty(), "{:?}", done.not_ok);
    (Table::read(&dir.join("runs.csv")).unwrap().unwrap(), dir)
}

const COMBINATIONS: &str = r#"
[[methods]]
method = "backward-euler"
"integrator.newton.direction" = ["newton", "lbfgs", "gradient-descent"]

[[methods]]
method = "backward-euler"
"integrator.newton.filter" = ["clamp", "abs"]

[[methods]]
method = "backward-euler"
"integrator.newton.globalization" = ["trust-region"]
"#;

#[test]
fn every_run_of_a_scene_solves_the_same_steps_and_newton_reaches_what_descent_does_not() {
    let tmp = TempDir::new("solver-study");
    let body =
        format!("{COMBINATIONS}\n[solver]\nsteps = [1, 4]\nmax_iterations = 40\nrepeats = 2\n");
    let (runs, dir) = run_study(&tmp, "components", &body);
    assert_eq!(runs.rows.len(), 12, "6 combinations x 2 scenes");
    for scene in ["beam", "twisted"] {
        let rows: Vec<&Vec<String>> = runs
            .rows
            .iter()
            .filter(|r| runs.get(r, "scene") == Some(scene))
            .collect();
        let prints: Vec<&str> = rows
            .iter()
            .map(|r| runs.get(r, "problems_fingerprint").unwrap())
            .collect();
        assert!(
            prints.iter().all(|p| *p == prints[0] && p.len() == 16),
            "{scene}: {prints:?}"
        );
        for r in &rows {
            assert_eq!(runs.get(r, "outcome"), Some("completed"));
            assert_eq!(runs.get(r, "iterates_repeatable"), Some("true"));
            assert_eq!(runs.get(r, "solved_steps"), Some("1, 4"));
            assert_eq!(runs.get(r, "solve_max_iterations"), Some("40"));
        }
        let cell = |direction: &str, column: &str| {
            rows.iter()
                .find(|r| runs.get(r, "integrator.newton.direction") == Some(direction))
                .and_then(|r| runs.get(r, column))
                .unwrap()
                .to_owned()
        };
        // Newton converges quadratically: a handful of iterations per step to 1e-8.
        let newton: u32 = cell("newton", "iterations_1e-8").parse().unwrap();
        assert!((2..=20).contains(&newton), "{scene}: newton {newton}");
        // Past the energy's round-off the trust region goes on too (full steps in the region).
        let trust: u32 = rows
            .iter()
            .find(|r| runs.get(r, "integrator.newton.globalization") == Some("trust-region"))
            .and_then(|r| runs.get(r, "iterations_1e-8"))
            .unwrap()
            .parse()
            .unwrap();
        assert!(
            trust >= newton,
            "{scene}: trust region {trust}, newton {newton}"
        );
        // Steepest descent in the mass metric does not get there within 40 iterations a step,
        // and says why.
        assert_eq!(cell("gradient-descent", "iterations_1e-8"), "");
        assert!(cell("gradient-descent", "stops").contains("cap"));
        // Each step's log and its ladder under every criterion are written.
        let id = rows[0][0].clone();
        let log = Table::read(&dir.join(format!("series/{id}-iterations.csv")))
            .unwrap()
            .unwrap();
        assert!(log.column("residual").is_some() && log.column("gradient_norm").is_some());
        let solves = Table::read(&dir.join(format!("series/{id}-solves.csv")))
            .unwrap()
            .unwrap();
        assert_eq!(solves.rows.len(), 2 * Criterion::ALL.len() * 5);
        for step in [1, 4] {
            assert!(
                dir.join(format!("residual-iterations-{scene}-step{step}.png"))
                    .is_file()
            );
            assert!(
                dir.join(format!("residual-time-{scene}-step{step}.png"))
                    .is_file()
            );
        }
    }
    // The twist is a different problem from the plain hanging beam.
    let print = |scene: &str| {
        runs.rows
            .iter()
            .find(|r| runs.get(r, "scene") == Some(scene))
            .and_then(|r| runs.get(r, "problems_fingerprint"))
            .unwrap()
            .to_owned()
    };
    assert_ne!(print("beam"), print("twisted"));
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(report.contains("**40 iterations**"), "the cap is stated");
    assert!(report.contains("Newton iterations to reach scaled-gradient <= 1e-8"));
}

/// The ladder is read off one log: it must say where a fresh solve that stops on that
/// criterion stops, for every criterion and tolerance, and the cost must be what that solve
/// reports.
#[test]
fn the_ladder_agrees_with_fresh_solves_that_stop_on_each_criterion() {
    let tmp = TempDir::new("solver-ladder");
    let path = tmp.write("twisted.toml", &twisted());
    let (runs, _) = run_study(
        &tmp,
        "ladder",
        "[[methods]]\nmethod = \"backward-euler\"\n\n[solver]\nsteps = [3]\n\
         criterion = \"relative-gradient\"\n",
    );
    // The frozen step 3 of the twisted beam, made as the study makes it.
    let config = scene::parse(&twisted(), &path, &[]).unwrap();
    let loaded = scene::LoadedScene {
        path: path.clone(),
        config,
    };
    let mut built = scene::build(&loaded, &DataPaths::new(None), Parallelism::Sequential).unwrap();
    // The driver the docs describe: default Newton settings at 1e-10, required; Cholesky.
    let mut driver_settings = built.config.integrator;
    driver_settings.newton = NewtonSettings {
        tolerance: 1e-10,
        max_iterations: 100,
        require_convergence: true,
        ..NewtonSettings::default()
    };
    let mut driver = driver_settings.build();
    let mut state: State = built.initial.clone();
    let dt = built.config.run.dt;
    for _ in 0..2 {
        driver.step(&mut built.model, &mut state, dt).unwrap();
    }
    let frozen = driver
        .freeze_step(&mut built.model, &state, dt)
        .unwrap()
        .unwrap();
    let row = runs
        .rows
        .iter()
        .find(|r| runs.get(r, "scene") == Some("twisted"))
        .unwrap();
    for (column, tolerance) in [
        ("iterations_1e-2", 1e-2),
        ("iterations_1e-4", 1e-4),
        ("iterations_1e-6", 1e-6),
        ("iterations_1e-8", 1e-8),
    ] {
        let mut settings = driver_settings.newton;
        settings.criterion = Criterion::RelativeGradient;
        settings.tolerance = tolerance;
        settings.require_convergence = true;
        settings.direction = Direction::Newton;
        let solver = driver_settings.linear_solver.build(&driver_settings.solver);
        let mut newton = Newton::new(solver, settings);
        let mut x = Vec::new();
        let mut report = StepReport::default();
        solve_frozen(&mut newton, &mut built.model, &frozen, &mut x, &mut report).unwrap();
        assert_eq!(
            runs.get(row, column),
            Some(report.newton_iterations.to_string().as_str()),
            "{column}"
        );
        let factorizations = column.replace("iterations", "factorizations");
        assert_eq!(
            runs.get(row, &factorizations),
            Some(report.factorizations.to_string().as_str()),
            "{factorizations}"
        );
    }
}

/// A tolerance reached within a cap is reached at the same iteration under a larger cap; one
/// not reached is reported empty, never as a number.
#[test]
fn a_larger_cap_does_not_change_a_reached_tolerance() {
    let tmp = TempDir::new("solver-cap");
    let methods = "[[methods]]\nmethod = \"backward-euler\"\n\
                   \"integrator.newton.direction\" = [\"newton\", \"lbfgs\"]\n";
    let (small, _) = run_study(
        &tmp,
        "small",
        &format!("{methods}\n[solver]\nsteps = [2]\nmax_iterations = 12\n"),
    );
    let (large, _) = run_study(
        &tmp,
        "large",
        &format!("{methods}\n[solver]\nsteps = [2]\nmax_iterations = 400\n"),
    );
    let mut compared = 0;
    for (a, b) in small.rows.iter().zip(&large.rows) {
        for level in ["1e-2", "1e-4", "1e-6", "1e-8", "1e-10"] {
            let column = format!("iterations_{level}");
            let (x, y) = (
                small.get(a, &column).unwrap(),
                large.get(b, &column).unwrap(),
            );
            if !x.is_empty() {
                assert_eq!(x, y, "{column}");
                compared += 1;
            }
            let n: u32 = y.parse().unwrap_or(0);
            assert!(
                !(x.is_empty() && n > 0 && n <= 12),
                "{column}: {x:?} vs {y:?}"
            );
        }
    }
    assert!(
        compared >= 6,
        "only {compared} levels were reached under the small cap"
    );
}

#[test]
fn what_a_solver_study_cannot_measure_is_refused_at_load_naming_the_key() {
    let tmp = TempDir::new("solver-refused");
    tmp.write("beam.toml", BEAM);
    tmp.write(
        "ground.toml",
        &format!(
            "{BEAM}[[obstacles]]\nkind = \"plane\"\npoint = [0.0, -1.0, 0.0]\n\
             normal = [0.0, 1.0, 0.0]\n"
        ),
    );
    let cases = [
        (
            "beam.toml",
            "[[methods]]\nmethod = \"vbd\"\n\n[solver]\n",
            "backward-euler",
        ),
        ("beam.toml", "[solver]\nsteps = [0]\n", "solver.steps"),
        ("beam.toml", "[solver]\nsteps = [3, 2]\n", "must increase"),
        (
            "beam.toml",
            "[solver]\ncriterion = \"residual\"\n",
            "scaled-gradient",
        ),
        ("beam.toml", "[solver]\nrepeats = 0\n", "solver.repeats"),
        (
            "beam.toml",
            "[solver]\nmax_iteration = 3\n",
            "max_iteration",
        ),
        ("beam.toml", "", "[solver] table"),
        (
            "ground.toml",
            "[[methods]]\nmethod = \"backward-euler\"\n\n[solver]\n",
            "without obstacles",
        ),
    ];
    for (scene, body, needle) in cases {
        let text = format!("name = \"bad\"\nstudy = \"solver\"\nscenes = [\"{scene}\"]\n{body}");
        let path = tmp.write("bad.toml", &text);
        let error = load(&path, false, &DataPaths::new(None))
            .err()
            .unwrap_or_else(|| panic!("accepted:\n{text}"))
            .to_string();
        assert!(error.contains(needle), "`{needle}` not in: {error}\n{text}");
        assert!(error.contains("bad.toml"), "{error}");
    }
}

/// A multistep scheme's step is frozen with its history: BDF2's steps 1 (a lower-order
/// start) and 4 are one minimization each; BDF3's extrapolated start-up step is not, and the
/// run says so.
#[test]
fn a_bdf_step_is_frozen_with_its_history_and_its_start_up_step_is_refused_by_name() {
    let tmp = TempDir::new("solver-bdf");
    let (runs, _) = run_study(
        &tmp,
        "bdf",
        "[[methods]]\nmethod = \"bdf2\"\n\n[solver]\nsteps = [1, 4]\n",
    );
    for r in &runs.rows {
        let n: u32 = runs.get(r, "iterations_1e-8").unwrap().parse().unwrap();
        assert!((1..=20).contains(&n), "{n}");
    }
    tmp.write("beam.toml", BEAM);
    let path = tmp.write(
        "startup.toml",
        "name = \"startup\"\nstudy = \"solver\"\nscenes = [\"beam.toml\"]\n\
         [[methods]]\nmethod = \"bdf3\"\n\
         [solver]\nsteps = [1]\n",
    );
    let study = load(&path, false, &DataPaths::new(None)).unwrap_or_else(|e| panic!("{e}"));
    let dir = tmp.path().join("startup");
    let done = run(&study, &options(&dir)).unwrap();
    assert_eq!(done.not_ok.len(), 1, "{:?}", done.not_ok);
    let runs = Table::read(&dir.join("runs.csv")).unwrap().unwrap();
    assert_eq!(runs.get(&runs.rows[0], "outcome"), Some("solver-failed"));
    let report = std::fs::read_to_string(dir.join("report.md")).unwrap();
    assert!(
        report.contains("does not minimize one incremental potential at step 1"),
        "{report}"
    );
}
