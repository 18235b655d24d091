//! Progress of a study: a bar on a terminal, otherwise one line per finished run.
//!
//! The bar has two phases. While the work the runs share is prepared (highest modes,
//! reference solutions) it says what is being prepared and shows no ETA, since no run has
//! finished to estimate one from; [`Progress::begin_runs`] switches it to counting runs, with
//! the ETA estimated from runs only and shown once the first run has finished.

use indicatif::{HumanDuration, ProgressBar, ProgressState, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Mutex;

/// The progress bar (on a terminal) or one line per finished run (otherwise).
pub(super) struct Progress {
    bar: Option<ProgressBar>,
    enabled: bool,
    running: Mutex<Vec<String>>,
    finished: std::sync::atomic::AtomicU64,
    total: u64,
    /// Set by [`Progress::begin_runs`]: the shared work is done.
    counting: std::sync::atomic::AtomicBool,
}

/// The ETA cell of the run phase: unknown until a run has finished (an estimate from no
/// finished run would read "0s").
pub(super) fn eta_text(finished: u64, eta: std::time::Duration) -> String {
    if finished == 0 {
        "after the first run".to_owned()
    } else {
        format!("{:#}", HumanDuration(eta))
    }
}

/// The message of the preparing phase: what is being prepared, or that nothing is.
pub(super) fn preparing_text(running: &[String]) -> String {
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

fn runs_style() -> ProgressStyle {
    ProgressStyle::with_template(
        "{bar:30.cyan/blue} {pos}/{len} runs, {elapsed} elapsed, eta {run_eta}  {msg}",
    )
    .expect("valid template")
    .with_key(
        "run_eta",
        |state: &ProgressState, w: &mut dyn std::fmt::Write| {
            let _ = w.write_str(&eta_text(state.pos(), state.eta()));
        },
    )
}

impl Progress {
    pub(super) fn new(enabled: bool, runs: u64) -> Self {
        let bar = (enabled && std::io::stderr().is_terminal()).then(|| {
            let bar = ProgressBar::new(runs);
            bar.set_style(preparing_style());
            bar.set_message(preparing_text(&[]));
            bar.enable_steady_tick(std::time::Duration::from_millis(250));
            bar
        });
        Self {
            bar,
            enabled,
            running: Mutex::new(Vec::new()),
            finished: Default::default(),
            total: runs,
            counting: Default::default(),
        }
    }

    /// The shared work is ready: count runs from here, with an ETA from runs only.
    pub(super) fn begin_runs(&self) {
        self.counting
            .store(true, std::sync::atomic::Ordering::SeqCst);
        if let Some(bar) = &self.bar {
            bar.set_style(runs_style());
            bar.reset_eta();
            self.show(bar);
        }
    }

    fn show(&self, bar: &ProgressBar) {
        if let Ok(running) = self.running.lock() {
            bar.set_message(running.join(", "));
        }
    }

    pub(super) fn start(&self, what: &str) {
        if let Ok(mut running) = self.running.lock() {
            running.push(what.to_owned());
        }
        self.refresh();
    }

    pub(super) fn finish(&self, what: &str) {
        if let Ok(mut running) = self.running.lock() {
            running.retain(|r| r != what);
        }
        self.refresh();
    }

    fn refresh(&self) {
        let Some(bar) = &self.bar else { return };
        if !self.counting.load(std::sync::atomic::Ordering::SeqCst) {
            if let Ok(running) = self.running.lock() {
                bar.set_message(preparing_text(&running));
            }
        } else {
            self.show(bar);
        }
    }

    pub(super) fn line(&self, text: &str) {
        match &self.bar {
            Some(bar) => bar.println(text),
            None if self.enabled => {
                crate::console::err(text);
            }
            None => {}
        }
    }

    pub(super) fn position(&self) -> String {
        let done = self.finished.load(std::sync::atomic::Ordering::SeqCst);
        format!("[{}/{}]", done + 1, self.total)
    }

    pub(super) fn inc(&self) {
        self.finished
            .fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        if let Some(bar) = &self.bar {
            bar.inc(1);
        }
    }

    pub(super) fn done(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn no_eta_before_the_first_run_finishes() {
        assert_eq!(eta_text(0, Duration::ZERO), "after the first run");
        assert_eq!(eta_text(0, Duration::from_secs(90)), "after the first run");
        assert_eq!(eta_text(3, Duration::from_secs(30)), "30s");
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
