//! How far a running study run is: the steps it has taken, counted by the run's own thread
//! and read by the progress bar's, so the ETA knows the unfinished part of runs in flight
//! and how many steps a run that stopped early did.

use crate::integrate::State;
use crate::model::Model;
use crate::run::{Observer, Sample};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// The steps one run has taken (every trajectory it runs, together).
#[derive(Debug, Default)]
pub(super) struct StepMeter {
    steps: AtomicU64,
    /// Whether any trajectory was counted: a kind that runs none counts no steps.
    counting: AtomicBool,
}

impl StepMeter {
    /// The steps taken so far; `None` when the run has counted none (its kind runs no
    /// counted trajectory, or it has not begun one yet).
    pub(super) fn steps(&self) -> Option<u64> {
        self.counting
            .load(Ordering::Relaxed)
            .then(|| self.steps.load(Ordering::Relaxed))
    }
}

/// An [`Observer`] that counts every step on a [`StepMeter`] and passes everything on.
pub(super) struct Counting<'a> {
    inner: &'a mut dyn Observer,
    meter: &'a StepMeter,
}

impl<'a> Counting<'a> {
    pub(super) fn new(inner: &'a mut dyn Observer, meter: &'a StepMeter) -> Self {
        meter.counting.store(true, Ordering::Relaxed);
        Self { inner, meter }
    }
}

impl Observer for Counting<'_> {
    fn sample(&mut self, sample: &Sample) -> std::io::Result<()> {
        self.inner.sample(sample)
    }

    fn after_step(&mut self, step: usize, model: &Model, state: &State) -> std::io::Result<()> {
        // Step 0 is the initial state, not a step taken.
        if step > 0 {
            self.meter.steps.fetch_add(1, Ordering::Relaxed);
        }
        self.inner.after_step(step, model, state)
    }

    fn newton_iterations(
        &mut self,
        step: usize,
        records: &[crate::integrate::newton::IterationRecord],
    ) -> std::io::Result<()> {
        self.inner.newton_iterations(step, records)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_counts_the_steps_it_takes_over_every_trajectory() {
        let text = r#"
            [mesh]
            generate = { box = [2, 1, 1], size = [0.2, 0.1, 0.1] }
            [material]
            model = "neo-hookean"
            youngs_modulus = 1e5
            poisson_ratio = 0.3
            density = 1000.0
            [fixed]
            rule = { axis = "x", side = "min", tolerance = 1e-6 }
            [forces]
            gravity = [0.0, -9.81, 0.0]
            [integrator]
            method = "symplectic-euler"
            [run]
            dt = 1e-4
            steps = 7
        "#;
        let path = std::path::Path::new("meter-test.toml");
        let loaded = crate::scene::LoadedScene {
            path: path.to_owned(),
            config: crate::scene::parse(text, path, &[]).unwrap(),
        };
        let data = crate::data::DataPaths::new(None);
        let meter = StepMeter::default();
        assert_eq!(meter.steps(), None, "nothing counted yet");
        for _trial in 0..2 {
            let mut scene =
                crate::scene::build(&loaded, &data, crate::parallel::Parallelism::Sequential)
                    .unwrap();
            let run = scene.config.run;
            let mut keep = |_: &Sample| Ok(());
            let (summary, _, _) = super::super::measured::run_observed(
                &mut scene,
                &run,
                None,
                &mut keep,
                Some(&meter),
            );
            assert_eq!(summary.steps_completed, 7);
        }
        assert_eq!(meter.steps(), Some(14));
    }
}
