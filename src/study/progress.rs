//! Progress of a study: a bar on a terminal, otherwise one line per finished run.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Mutex;

/// The progress bar (on a terminal) or one line per finished run (otherwise).
pub(super) struct Progress {
    bar: Option<ProgressBar>,
    enabled: bool,
    running: Mutex<Vec<String>>,
    finished: std::sync::atomic::AtomicU64,
    total: u64,
}

impl Progress {
    pub(super) fn new(enabled: bool, runs: u64) -> Self {
        let bar = (enabled && std::io::stderr().is_terminal()).then(|| {
            let bar = ProgressBar::new(runs);
            bar.set_style(
                ProgressStyle::with_template(
                    "{bar:30.cyan/blue} {pos}/{len} runs, {elapsed} elapsed, eta {eta}  {msg}",
                )
                .expect("valid template"),
            );
            bar.enable_steady_tick(std::time::Duration::from_millis(250));
            bar
        });
        Self {
            bar,
            enabled,
            running: Mutex::new(Vec::new()),
            finished: Default::default(),
            total: runs,
        }
    }

    pub(super) fn start(&self, what: &str) {
        if let Ok(mut running) = self.running.lock() {
            running.push(what.to_owned());
            if let Some(bar) = &self.bar {
                bar.set_message(running.join(", "));
            }
        }
    }

    pub(super) fn finish(&self, what: &str) {
        if let Ok(mut running) = self.running.lock() {
            running.retain(|r| r != what);
            if let Some(bar) = &self.bar {
                bar.set_message(running.join(", "));
            }
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
