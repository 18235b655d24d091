//! Threads as a value: a run and a study take their thread count as a setting (a pool of their
//! own), two runs of one process may use different counts side by side, and the results are
//! the same bits for any count. (A test binary of its own: it registers a method.)

mod common;

use std::sync::Mutex;

use common::TempDir;
use softbench::data::DataPaths;
use softbench::integrate::methods::explicit;
use softbench::integrate::{Integrator, State, StepError, StepReport, register_method};
use softbench::model::Model;
use softbench::parallel::Parallelism;
use softbench::pipeline::{SimulateOptions, Simulation};
use softbench::scene;
use softbench::study::{self, RunOptions};
use std::path::Path;

/// The thread counts the probe's steps saw, in order of the steps (every run of the process).
static SEEN: Mutex<Vec<usize>> = Mutex::new(Vec::new());

/// Held by a test that reads [`SEEN`], so two such tests do not mix their steps.
static PROBING: Mutex<()> = Mutex::new(());

/// Records the size of the pool each step runs in, and evaluates the forces (so the step
/// does the model's parallel work); the body stays where it is.
struct Probe {
    g: Vec<f64>,
}

impl Integrator for Probe {
    fn name(&self) -> &'static str {
        "threads-probe"
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
        _dt: f64,
        _report: &mut StepReport,
    ) -> Result<(), StepError> {
        SEEN.lock().unwrap().push(rayon::current_num_threads());
        self.g.resize(state.q.len(), 0.0);
        model
            .gradient(&state.q, &mut self.g)
            .map_err(StepError::from)
    }
}

fn register_probe() {
    let _ = register_method(explicit(
        "threads-probe",
        1,
        "records the pool size of each step",
        |_, _| Box::new(Probe { g: Vec::new() }),
    ));
}

fn options(threads: Option<usize>) -> SimulateOptions {
    SimulateOptions {
        export: None,
        every: 1,
        pictures: false,
        progress: false,
        threads,
    }
}

/// Simulate the cantilever with `overrides` in a pool of `threads` into `out`.
fn simulate(out: &Path, overrides: &[&str], threads: Option<usize>) {
    let overrides: Vec<String> = overrides.iter().map(|s| (*s).to_owned()).collect();
    let loaded = scene::load(&common::scene("cantilever.toml"), &overrides).unwrap();
    std::fs::create_dir_all(out).unwrap();
    Simulation::prepare(
        loaded,
        &DataPaths::new(None),
        Parallelism::Rayon,
        options(threads),
    )
    .unwrap()
    .run(out)
    .unwrap();
}

#[test]
fn two_runs_side_by_side_take_their_own_thread_counts_and_agree_to_the_bit() {
    let _probing = PROBING.lock().unwrap_or_else(|e| e.into_inner());
    register_probe();
    let dir = TempDir::new("threads-side-by-side");
    let probe = ["integrator.method=threads-probe", "run.steps=5"];
    SEEN.lock().unwrap().clear();
    std::thread::scope(|s| {
        s.spawn(|| simulate(&dir.path().join("one"), &probe, Some(1)));
        s.spawn(|| simulate(&dir.path().join("three"), &probe, Some(3)));
    });
    let mut seen = SEEN.lock().unwrap().clone();
    seen.sort_unstable();
    assert_eq!(seen, [1, 1, 1, 1, 1, 3, 3, 3, 3, 3]);

    // A method whose steps go parallel (Newton with a sparse Cholesky, element loops), on one
    // thread and on three at once: the same trajectory and end state to the bit.
    let implicit = ["integrator.method=backward-euler", "run.steps=4"];
    std::thread::scope(|s| {
        s.spawn(|| simulate(&dir.path().join("be-1"), &implicit, Some(1)));
        s.spawn(|| simulate(&dir.path().join("be-3"), &implicit, Some(3)));
    });
    for file in ["trajectory.csv", "final_positions.csv"] {
        assert_eq!(
            common::csv_without_timings(&dir.path().join("be-1").join(file)),
            common::csv_without_timings(&dir.path().join("be-3").join(file)),
            "{file}"
        );
    }
}

#[test]
fn a_thread_count_of_zero_is_bad_input() {
    let loaded = scene::load(&common::scene("cantilever.toml"), &[]).unwrap();
    let Err(e) = Simulation::prepare(
        loaded,
        &DataPaths::new(None),
        Parallelism::Rayon,
        options(Some(0)),
    ) else {
        panic!("a pool of no threads was accepted")
    };
    assert!(
        softbench::error::Error::from(e).class().is_bad_input(),
        "threads = 0 is the input's"
    );
}

#[test]
fn a_study_runs_in_its_own_pool() {
    let _probing = PROBING.lock().unwrap_or_else(|e| e.into_inner());
    register_probe();
    let dir = TempDir::new("threads-study");
    let study_file = dir.path().join("probe.toml");
    let scene_file = common::scene("cantilever.toml");
    std::fs::write(
        &study_file,
        format!(
            "name = \"probe\"\nstudy = \"trajectory\"\nscenes = [\"{}\"]\n\n[set]\n\
             \"run.steps\" = 3\n\n[grid]\n\"integrator.method\" = [\"threads-probe\"]\n",
            scene_file.display()
        ),
    )
    .unwrap();
    let study = study::load(&study_file, false, &DataPaths::new(None)).unwrap();
    SEEN.lock().unwrap().clear();
    study::run(
        &study,
        &RunOptions {
            threads: Some(2),
            ..RunOptions::new(dir.path().join("out"))
        },
    )
    .unwrap();
    assert_eq!(*SEEN.lock().unwrap(), [2, 2, 2]);
}
