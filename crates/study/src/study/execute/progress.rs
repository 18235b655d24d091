//! Progress of a study: a bar on a terminal, otherwise one line per finished run.
//!
//! The bar has two phases. While the work the runs share is prepared (highest modes,
//! reference solutions) it says what is being prepared and shows no ETA;
//! [`Progress::begin_runs`] switches it to counting runs. The ETA is [`Eta`]'s, fed here the
//! runs' starts, their meters and their finishes: "estimating…" until a run has finished or
//! enough of one has run. A finished run's line carries the ETA too, so a log without a
//! terminal shows it.

use crate::study::execute::eta::{Eta, Planned};
use crate::study::vocabulary::meter::StepMeter;
use indicatif::{HumanDuration, ProgressBar, ProgressState, ProgressStyle};
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// The progress bar (on a terminal) or one line per finished run (otherwise).
pub(in crate::study) struct Progress {
    bar: Option<ProgressBar>,
    enabled: bool,
    running: Mutex<Vec<String>>,
    finished: AtomicU64,
    /// The runs to do now (the plan's, less those already complete).
    total: AtomicU64,
    /// Set by [`Progress::begin_runs`]: the shared work is done.
    counting: AtomicBool,
    tracker: Arc<Tracker>,
}

/// What the ETA is estimated from: the estimator, each planned run's step meter, and the
/// clock the events are timed on. Shared with the bar's ETA cell, which draws on its own
/// thread. The estimator's lock is never held while the bar is touched (the bar holds its
/// own lock while it draws the cell, which takes this one).
struct Tracker {
    eta: Mutex<Eta>,
    meters: Vec<StepMeter>,
    clock: Instant,
}

impl Tracker {
    fn now(&self) -> f64 {
        self.clock.elapsed().as_secs_f64()
    }

    /// Tell `eta` what run `run`'s meter says: when it began stepping, and its steps; the
    /// steps it counted (`None`: none, its kind counts none).
    fn read(&self, eta: &mut Eta, run: usize) -> Option<f64> {
        let reading = self.meters[run].read()?;
        let at = |t: Instant| t.duration_since(self.clock).as_secs_f64();
        eta.stepping(run, at(reading.began));
        eta.progress(run, reading.steps as f64, at(reading.last_step));
        Some(reading.steps as f64)
    }

    /// The time left as of now, with the runs' meters read first.
    fn remaining(&self) -> Option<f64> {
        let now = self.now();
        let mut eta = self.eta.lock().ok()?;
        for run in 0..self.meters.len() {
            self.read(&mut eta, run);
        }
        eta.remaining(now)
    }
}

/// The ETA cell: "estimating…" until there is something to estimate from.
pub(in crate::study) fn eta_text(remaining: Option<f64>) -> String {
    match remaining {
        None => "estimating…".to_owned(),
        Some(seconds) => format!(
            "{:#}",
            HumanDuration(std::time::Duration::from_secs_f64(seconds.max(0.0)))
        ),
    }
}

/// The message of the preparing phase: what is being prepared, or that nothing is.
pub(in crate::study) fn preparing_text(running: &[String]) -> String {
    if running.is_empty() {
        "preparing the shared work".to_owned()
    } else {
        format!("preparing {}", running.join("; "))
    }
}

fn preparing_style() -> ProgressStyle {
    ProgressStyle::with_template("{spinner:.cyan} {len} runs; {elapsed} elapsed; {msg}")
        .expect("valid template")
}

fn runs_style(tracker: Arc<Tracker>) -> ProgressStyle {
    ProgressStyle::with_template(
        "{bar:30.cyan/blue} {pos}/{len} runs, {elapsed} elapsed, eta {run_eta}  {msg}",
    )
    .expect("valid template")
    .with_key(
        "run_eta",
        move |_: &ProgressState, w: &mut dyn std::fmt::Write| {
            let _ = w.write_str(&eta_text(tracker.remaining()));
        },
    )
}

impl Progress {
    /// Progress over the runs of `plan` (in the order they are handed out), `jobs` at a
    /// time; [`Progress::skip`] the ones already complete.
    pub(in crate::study) fn new(enabled: bool, plan: Vec<Planned>, jobs: usize) -> Self {
        let runs = plan.len() as u64;
        let bar = (enabled && std::io::stderr().is_terminal()).then(|| {
            let bar = ProgressBar::new(runs);
            bar.set_style(preparing_style());
            bar.set_message(preparing_text(&[]));
            bar.enable_steady_tick(std::time::Duration::from_millis(250));
            bar
        });
        let tracker = Tracker {
            meters: plan.iter().map(|_| StepMeter::default()).collect(),
            eta: Mutex::new(Eta::new(plan, jobs)),
            clock: Instant::now(),
        };
        Self {
            bar,
            enabled,
            running: Mutex::new(Vec::new()),
            finished: Default::default(),
            total: AtomicU64::new(runs),
            counting: Default::default(),
            tracker: Arc::new(tracker),
        }
    }

    /// Progress with no runs (for preparing shared work only).
    pub(in crate::study) fn without_runs(enabled: bool) -> Self {
        Self::new(enabled, Vec::new(), 1)
    }

    /// Run `run` of the plan is complete already: not run now, not counted.
    pub(in crate::study) fn skip(&self, run: usize) {
        if let Ok(mut eta) = self.tracker.eta.lock() {
            eta.skip(run);
        }
        let total = self.total.fetch_sub(1, Ordering::SeqCst) - 1;
        if let Some(bar) = &self.bar {
            bar.set_length(total);
        }
    }

    /// Where run `run` of the plan counts its steps.
    pub(in crate::study) fn meter(&self, run: usize) -> &StepMeter {
        &self.tracker.meters[run]
    }

    /// The shared work is ready: count runs from here.
    pub(in crate::study) fn begin_runs(&self) {
        self.counting.store(true, Ordering::SeqCst);
        if let Some(bar) = &self.bar {
            bar.set_style(runs_style(Arc::clone(&self.tracker)));
            self.show(bar);
        }
    }

    fn show(&self, bar: &ProgressBar) {
        if let Ok(running) = self.running.lock() {
            bar.set_message(running.join(", "));
        }
    }

    /// Something named `what` (shared work, or a run) started.
    pub(in crate::study) fn start(&self, what: &str) {
        if let Ok(mut running) = self.running.lock() {
            running.push(what.to_owned());
        }
        self.refresh();
    }

    /// Something named `what` finished.
    pub(in crate::study) fn finish(&self, what: &str) {
        if let Ok(mut running) = self.running.lock() {
            running.retain(|r| r != what);
        }
        self.refresh();
    }

    /// Run `run` of the plan, `id`, started.
    pub(in crate::study) fn start_run(&self, run: usize, id: &str) {
        let now = self.tracker.now();
        if let Ok(mut eta) = self.tracker.eta.lock() {
            eta.start(run, now);
        }
        self.start(id);
    }

    /// Run `run` of the plan, `id`, finished (whatever its outcome), with the steps its
    /// meter counted.
    pub(in crate::study) fn finish_run(&self, run: usize, id: &str) {
        let now = self.tracker.now();
        if let Ok(mut eta) = self.tracker.eta.lock() {
            let steps = self.tracker.read(&mut eta, run);
            eta.finish(run, steps, now);
        }
        self.finish(id);
    }

    fn refresh(&self) {
        let Some(bar) = &self.bar else { return };
        if !self.counting.load(Ordering::SeqCst) {
            if let Ok(running) = self.running.lock() {
                bar.set_message(preparing_text(&running));
            }
        } else {
            self.show(bar);
        }
    }

    pub(in crate::study) fn line(&self, text: &str) {
        match &self.bar {
            Some(bar) => bar.println(text),
            None if self.enabled => {
                softbench_run::console::err(text);
            }
            None => {}
        }
    }

    /// The line of a finished run: `[3/10] <id>: <what>`, and the ETA while runs are left.
    pub(in crate::study) fn run_line(&self, id: &str, what: &str) -> String {
        let done = self.finished.load(Ordering::SeqCst) + 1;
        let total = self.total.load(Ordering::SeqCst);
        let eta = if done < total {
            format!("; eta {}", eta_text(self.tracker.remaining()))
        } else {
            String::new()
        };
        format!("[{done}/{total}] {id}: {what}{eta}")
    }

    pub(in crate::study) fn inc(&self) {
        self.finished.fetch_add(1, Ordering::SeqCst);
        if let Some(bar) = &self.bar {
            bar.inc(1);
        }
    }

    pub(in crate::study) fn done(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_eta_until_there_is_something_to_estimate_from() {
        assert_eq!(eta_text(None), "estimating…");
        assert_eq!(eta_text(Some(30.0)), "30s");
        assert_eq!(eta_text(Some(-1.0)), "0s");
    }

    #[test]
    fn a_finished_runs_line_carries_the_eta_while_runs_are_left() {
        let plan = vec![
            Planned {
                scene: 0,
                group: 0,
                steps: 10.0,
                step_weight: 1.0,
            };
            3
        ];
        let progress = Progress::new(false, plan, 1);
        progress.skip(0);
        progress.begin_runs();
        assert_eq!(
            progress.run_line("a", "completed"),
            "[1/2] a: completed; eta estimating…"
        );
        progress.inc();
        assert_eq!(progress.run_line("b", "completed"), "[2/2] b: completed");
    }

    #[test]
    fn the_preparing_phase_names_what_it_prepares() {
        assert_eq!(preparing_text(&[]), "preparing the shared work");
        let tasks = [
            "reference for cantilever: rk4 at dt = 1e-4 s and dt/2".to_owned(),
            "highest mode of box".to_owned(),
        ];
        assert_eq!(
            preparing_text(&tasks),
            "preparing reference for cantilever: rk4 at dt = 1e-4 s and dt/2; highest mode of box"
        );
    }
}
