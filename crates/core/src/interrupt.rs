//! SIGINT and SIGTERM as a request to stop: the run loop finishes its current step, the
//! command writes what is done and exits 130 or 143. Every iteration and substep loop of a
//! step checks the request too ([`crate::integrate::StepError::stop_if_requested`]), and so does
//! loading a study. A second signal of either kind ends the process at once (exit 1) with a
//! message, for work that does not reach its next check soon.
//!
//! Nothing is requested until [`install`] is called (the CLI does; library users and tests
//! that do not call it never see a request).

use std::sync::atomic::{AtomicUsize, Ordering};

use signal_hook::consts::{SIGINT, SIGTERM};

/// A stop request.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Signal {
    /// SIGINT (Ctrl-C).
    Interrupt,
    /// SIGTERM.
    Terminate,
}

impl Signal {
    /// The conventional exit status after this signal (128 + its number).
    pub fn exit_code(self) -> u8 {
        match self {
            Signal::Interrupt => 130,
            Signal::Terminate => 143,
        }
    }

    /// `SIGINT` or `SIGTERM`.
    pub fn name(self) -> &'static str {
        match self {
            Signal::Interrupt => "SIGINT",
            Signal::Terminate => "SIGTERM",
        }
    }
}

/// The signal number received first (0: none).
static REQUESTED: AtomicUsize = AtomicUsize::new(0);

/// What a second signal prints before the process ends (written with `write(2)`, the only
/// output a signal handler may do).
const SECOND_SIGNAL: &[u8] = b"softbench: a second stop signal: exiting at once (exit 1); \
files being written are left as *.partial and never taken as finished\n";

/// Install the handlers for SIGINT and SIGTERM (idempotent enough: call once at start-up).
/// The first signal of either kind is recorded; a second one prints [`SECOND_SIGNAL`] and
/// ends the process at once with exit 1.
pub fn install() -> std::io::Result<()> {
    for signal in [SIGINT, SIGTERM] {
        let action = move || {
            let first =
                REQUESTED.compare_exchange(0, signal as usize, Ordering::SeqCst, Ordering::SeqCst);
            if first.is_err() {
                // SAFETY: write(2) and _exit(2) are async-signal-safe; the buffer is static.
                unsafe {
                    libc::write(2, SECOND_SIGNAL.as_ptr().cast(), SECOND_SIGNAL.len());
                }
                signal_hook::low_level::exit(1);
            }
        };
        // SAFETY: the action only performs an atomic compare-exchange, write(2) and _exit(2).
        unsafe { signal_hook::low_level::register(signal, action) }?;
    }
    Ok(())
}

/// The stop request received so far, if any.
pub fn requested() -> Option<Signal> {
    match REQUESTED.load(Ordering::SeqCst) {
        0 => None,
        n if n == SIGTERM as usize => Some(Signal::Terminate),
        _ => Some(Signal::Interrupt),
    }
}

/// Pretend `signal` arrived (for tests of the stop path without sending a real signal).
pub fn request(signal: Signal) {
    let n = match signal {
        Signal::Interrupt => SIGINT,
        Signal::Terminate => SIGTERM,
    };
    REQUESTED.store(n as usize, Ordering::SeqCst);
}
