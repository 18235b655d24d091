//! A progress bar for one run (`softbench simulate`): steps, simulated time and ETA, drawn on
//! stderr only when it is a terminal, so piped and tested output stays as it was.

use super::run_loop::{Observer, Sample};
use indicatif::{ProgressBar, ProgressStyle};
use softbench_core::integrate::State;
use softbench_core::model::Model;
use std::io::IsTerminal;
use std::time::{Duration, Instant};

/// How often the simulated-time message is rewritten (the position is set every step, an
/// atomic store; the message is a string).
const MESSAGE_EVERY: Duration = Duration::from_millis(100);

/// An [`Observer`] that moves a progress bar on every step and passes everything on to the
/// observer it wraps.
pub struct RunProgress<'a> {
    inner: &'a mut dyn Observer,
    bar: ProgressBar,
    horizon: f64,
    last_message: Option<Instant>,
}

impl<'a> RunProgress<'a> {
    /// A bar over `steps` steps reaching simulated time `horizon` (s) when stderr is a
    /// terminal and `enabled`; a hidden one otherwise.
    pub fn new(inner: &'a mut dyn Observer, steps: usize, horizon: f64, enabled: bool) -> Self {
        let bar = if enabled && std::io::stderr().is_terminal() {
            let bar = ProgressBar::new(steps as u64);
            bar.set_style(
                ProgressStyle::with_template(
                    "{bar:30.cyan/blue} {pos}/{len} steps, {msg}, {elapsed} elapsed, eta {step_eta}",
                )
                .expect("valid template")
                // No estimate before the first step (indicatif would say "0s").
                .with_key(
                    "step_eta",
                    |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                        let _ = match state.pos() {
                            0 => w.write_str("?"),
                            _ => write!(w, "{:#}", indicatif::HumanDuration(state.eta())),
                        };
                    },
                ),
            );
            bar.enable_steady_tick(Duration::from_millis(250));
            bar
        } else {
            ProgressBar::hidden()
        };
        Self::with_bar(inner, bar, horizon)
    }

    /// The same with a given bar (tests pass a hidden one).
    pub fn with_bar(inner: &'a mut dyn Observer, bar: ProgressBar, horizon: f64) -> Self {
        bar.set_message(Self::time_text(0.0, horizon));
        Self {
            inner,
            bar,
            horizon,
            last_message: None,
        }
    }

    /// The bar's position (steps taken).
    pub fn position(&self) -> u64 {
        self.bar.position()
    }

    /// The bar's message: `t = 0.1250 of 1 s`.
    pub fn time_text(t: f64, horizon: f64) -> String {
        format!("t = {t:.4} of {horizon} s")
    }

    /// Remove the bar (call before printing the run's result).
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

impl Observer for RunProgress<'_> {
    fn sample(&mut self, sample: &Sample) -> std::io::Result<()> {
        self.inner.sample(sample)
    }

    fn newton_iterations(
        &mut self,
        step: usize,
        records: &[softbench_core::integrate::newton::IterationRecord],
    ) -> std::io::Result<()> {
        self.inner.newton_iterations(step, records)
    }

    fn after_step(&mut self, step: usize, model: &Model, state: &State) -> std::io::Result<()> {
        self.bar.set_position(step as u64);
        let now = Instant::now();
        if self
            .last_message
            .is_none_or(|t| now.duration_since(t) >= MESSAGE_EVERY)
        {
            self.last_message = Some(now);
            self.bar.set_message(Self::time_text(state.t, self.horizon));
        }
        self.inner.after_step(step, model, state)
    }
}

impl Drop for RunProgress<'_> {
    fn drop(&mut self) {
        self.bar.finish_and_clear();
    }
}
