//! How far a running study run is: when it began stepping, the steps it has taken and when
//! it took the last, counted by the run's own thread and read by the progress bar's, so the
//! ETA knows the unfinished part of runs in flight, their time spent other than stepping, and
//! how many steps a run that stopped early did.

use softbench_core::integrate::State;
use softbench_core::model::Model;
use softbench_run::run::{Observer, Sample};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// The steps one run has taken (every trajectory it runs, together).
#[derive(Debug, Default)]
pub(in crate::study) struct StepMeter {
    steps: AtomicU64,
    /// When its first counted trajectory took its initial state (its setup done); unset for
    /// a kind that runs none.
    began: OnceLock<Instant>,
    /// Nanoseconds from `began` to its latest step.
    last_step: AtomicU64,
}

/// What a meter says: when stepping began, the steps taken, and when the last was.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::study) struct Reading {
    pub began: Instant,
    pub steps: u64,
    /// `began` before the first step.
    pub last_step: Instant,
}

impl StepMeter {
    /// The meter's reading; `None` when the run has counted nothing (its kind runs no counted
    /// trajectory, or it has not begun one yet).
    pub(in crate::study) fn read(&self) -> Option<Reading> {
        let began = *self.began.get()?;
        let steps = self.steps.load(Ordering::Acquire);
        let last = Duration::from_nanos(self.last_step.load(Ordering::Relaxed));
        Some(Reading {
            began,
            steps,
            last_step: began + last,
        })
    }
}

/// An [`Observer`] that counts every step on a [`StepMeter`], with its time, and passes
/// everything on.
pub(in crate::study) struct Counting<'a> {
    inner: &'a mut dyn Observer,
    meter: &'a StepMeter,
    began: Option<Instant>,
}

impl<'a> Counting<'a> {
    pub(in crate::study) fn new(inner: &'a mut dyn Observer, meter: &'a StepMeter) -> Self {
        Self {
            inner,
            meter,
            began: None,
        }
    }
}

impl Observer for Counting<'_> {
    fn sample(&mut self, sample: &Sample) -> std::io::Result<()> {
        self.inner.sample(sample)
    }

    fn after_step(&mut self, step: usize, model: &Model, state: &State) -> std::io::Result<()> {
        match self.began {
            // Step 0 is the initial state: stepping begins (the first trajectory's counts).
            None => self.began = Some(*self.meter.began.get_or_init(Instant::now)),
            Some(began) if step > 0 => {
                let since = began.elapsed().as_nanos().min(u128::from(u64::MAX)) as u64;
                self.meter.last_step.store(since, Ordering::Relaxed);
                self.meter.steps.fetch_add(1, Ordering::Release);
            }
            Some(_) => {}
        }
        self.inner.after_step(step, model, state)
    }

    fn newton_iterations(
        &mut self,
        step: usize,
        records: &[softbench_core::integrate::newton::IterationRecord],
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
        let loaded = softbench_run::scene::LoadedScene {
            path: path.to_owned(),
            config: softbench_run::scene::parse(text, path, &[]).unwrap(),
        };
        let data = softbench_run::data::DataPaths::new(None);
        let meter = StepMeter::default();
        assert_eq!(meter.read(), None, "nothing counted yet");
        for _trial in 0..2 {
            let mut scene = softbench_run::scene::build(
                &loaded,
                &data,
                softbench_core::parallel::Parallelism::Sequential,
            )
            .unwrap();
            let run = scene.config.run;
            let mut keep = |_: &Sample| Ok(());
            let (summary, _, _) = crate::study::vocabulary::measured::run_observed(
                &mut scene,
                &run,
                None,
                &mut keep,
                Some(&meter),
            );
            assert_eq!(summary.steps_completed, 7);
        }
        let reading = meter.read().unwrap();
        assert_eq!(reading.steps, 14);
        assert!(reading.last_step >= reading.began);
    }
}
