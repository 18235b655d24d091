//! Bring your own method: a program that depends on softbench implements an integrator the
//! crate does not have — the three-stage strong-stability-preserving Runge–Kutta method
//! (SSPRK3, Shu & Osher 1988) — registers it under a name, registers a linear solver of its
//! own (CG with an incomplete-Cholesky preconditioner, under the name `cg-ic0`), and runs a
//! study that compares them with RK4 and backward Euler on the same scene, with the same CSVs,
//! plots and report; and runs the new method once more through `simulate`'s pipeline as a
//! library call ([`softbench::pipeline::Simulation`]), which writes what `softbench simulate`
//! does:
//!
//! `cargo run --release --example custom_integrator -- [out folder, default out]`
//!
//! The study (written beside the results) is the soft cantilever of `experiments/scenes`,
//! which needs no downloaded data.

use softbench::data::DataPaths;
use softbench::integrate::methods::explicit;
use softbench::integrate::{Dynamics, Integrator, State, StepError, StepReport, register_method};
use softbench::model::Model;
use softbench::parallel::Parallelism;
use softbench::pipeline::{SimulateOptions, Simulation};
use softbench::scene;
use softbench::solve::{CgSettings, CgSolver, LINEAR_SOLVERS, Preconditioner, SolverEntry};
use softbench::study;
use std::path::{Path, PathBuf};

/// SSPRK3 in Shu–Osher form on `y = (q, v)`, `y' = (v, a(q, v, t))`:
/// `y1 = y + dt f(y)`, `y2 = 3/4 y + 1/4 (y1 + dt f(y1))`, `y' = 1/3 y + 2/3 (y2 + dt f(y2))`.
/// Third order; each stage is a forward Euler step, so it keeps any strong-stability property
/// forward Euler has, with a step up to 1x forward Euler's.
#[derive(Default)]
struct SspRk3 {
    dynamics: Dynamics,
    stage: State,
    a: Vec<f64>,
}

impl SspRk3 {
    /// `stage = stage + dt f(stage)` at time `t`.
    fn euler(
        &mut self,
        model: &mut Model,
        t: f64,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        self.a.resize(self.stage.q.len(), 0.0);
        model.set_time(t);
        self.dynamics
            .acceleration(model, &self.stage.q, &self.stage.v, &mut self.a, report)?;
        for ((q, v), a) in self.stage.q.iter_mut().zip(&mut self.stage.v).zip(&self.a) {
            *q += dt * *v;
            *v += dt * a;
        }
        Ok(())
    }

    /// `stage = w y + (1 - w) stage`.
    fn blend(&mut self, w: f64, y: &State) {
        for (s, x) in self.stage.q.iter_mut().zip(&y.q) {
            *s = w * x + (1.0 - w) * *s;
        }
        for (s, x) in self.stage.v.iter_mut().zip(&y.v) {
            *s = w * x + (1.0 - w) * *s;
        }
    }
}

impl Integrator for SspRk3 {
    fn name(&self) -> &'static str {
        "ssprk3"
    }

    fn order(&self) -> u32 {
        3
    }

    fn is_explicit(&self) -> bool {
        true
    }

    fn advance(
        &mut self,
        model: &mut Model,
        state: &mut State,
        dt: f64,
        report: &mut StepReport,
    ) -> Result<(), StepError> {
        // The state is changed only once every stage has succeeded.
        self.stage.clone_from(state);
        self.euler(model, state.t, dt, report)?;
        self.euler(model, state.t + dt, dt, report)?;
        self.blend(0.75, state);
        self.euler(model, state.t + 0.5 * dt, dt, report)?;
        self.blend(1.0 / 3.0, state);
        state.q.clone_from(&self.stage.q);
        state.v.clone_from(&self.stage.v);
        report.substeps = 1;
        Ok(())
    }
}

/// Register SSPRK3 (once per process), run the comparison study into `out` and one simulation
/// with SSPRK3 into `out/ssprk3`; returns the study's results folder and the simulation's.
fn run(out: &Path) -> anyhow::Result<(PathBuf, PathBuf)> {
    if softbench::integrate::Method::from_name("ssprk3").is_err() {
        register_method(explicit(
            "ssprk3",
            3,
            "three-stage strong-stability-preserving Runge-Kutta (from examples/)",
            |_, _| Box::new(SspRk3::default()),
        ))?;
    }
    if softbench::solve::LinearSolverKind::from_name("cg-ic0").is_err() {
        LINEAR_SOLVERS.register(SolverEntry {
            name: "cg-ic0",
            description: "CG with an IC(0) preconditioner (from examples/)",
            direct: false,
            reports_inertia: false,
            build: |s| {
                Box::new(CgSolver::new(CgSettings {
                    preconditioner: Preconditioner::IncompleteCholesky,
                    ..s.cg
                }))
            },
        })?;
    }
    std::fs::create_dir_all(out)?;
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("experiments/scenes/soft_beam.toml");
    let study_file = out.join("custom_integrator.toml");
    std::fs::write(
        &study_file,
        format!(
            r#"name = "custom_integrator"
study = "trajectory"
description = "A method registered by a program (ssprk3) beside two built-in ones."
scenes = [{scene:?}]

[grid]
"integrator.method" = ["ssprk3", "rk4", "backward-euler"]
"integrator.linear_solver" = ["cholesky", "cg-ic0"]

[set]
"run.dt" = 0.002
"run.steps" = 100
"#
        ),
    )?;
    let data = DataPaths::from_env();
    let study = study::load(&study_file, false, &data)?;
    let options = study::RunOptions {
        force: true,
        ..study::RunOptions::new(out.join(&study.file.name))
    };
    let done = study::run(&study, &options)?;

    // The registered method through the run pipeline `softbench simulate` uses.
    let overrides = ["integrator.method=ssprk3", "run.dt=0.002", "run.steps=100"].map(String::from);
    let loaded = scene::load(&scene, &overrides)?;
    let options = SimulateOptions {
        export: None,
        every: 1,
        pictures: false,
        progress: false,
        threads: None,
    };
    let simulated = out.join("ssprk3");
    std::fs::create_dir_all(&simulated)?;
    Simulation::prepare(loaded, &data, Parallelism::Rayon, options)?.run(&simulated)?;
    Ok((done.dir, simulated))
}

fn main() -> anyhow::Result<()> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "out".into()));
    let (dir, simulated) = run(&out)?;
    eprintln!("wrote {} and {}", dir.display(), simulated.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    /// CI runs this (the example is built with `test = true`): the study's runs.csv holds the
    /// registered method and solver beside the built-in ones, each completed, and the
    /// simulation's summary.json names the method and a completed run.
    #[test]
    fn the_registered_method_runs_in_a_study() {
        let out = std::env::temp_dir().join(format!("softbench-custom-{}", std::process::id()));
        let (dir, simulated) = super::run(&out).unwrap();
        let runs = std::fs::read_to_string(dir.join("runs.csv")).unwrap();
        for method in ["ssprk3", "rk4", "backward-euler", "cg-ic0"] {
            let row = runs
                .lines()
                .find(|l| l.contains(method))
                .unwrap_or_else(|| panic!("{method} missing from runs.csv:\n{runs}"));
            assert!(row.contains("completed"), "{row}");
        }
        assert!(dir.join("report.md").exists());
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(simulated.join("summary.json")).unwrap())
                .unwrap();
        assert_eq!(summary["summary"]["method"], "ssprk3");
        assert_eq!(summary["summary"]["outcome"]["status"], "completed");
        assert_eq!(summary["summary"]["steps_completed"], 100);
        std::fs::remove_dir_all(&out).ok();
    }
}
