//! SIGINT and SIGTERM as a request to stop: the run loop finishes its current step, the
//! command writes what is done and exits 130 or 143. A second signal of either kind ends the
//! process at once (exit 1), for a run that does not reach its next step soon.
//!
//! Nothing is requested until [`install`] is called (the CLI does; library users and tests
//! that do not call it never see a request).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

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

/// Install the handlers for SIGINT and SIGTERM (idempotent enough: call once at start-up).
pub fn install() -> std::io::Result<()> {
    let seen = Arc::new(AtomicBool::new(false));
    for signal in [SIGINT, SIGTERM] {
        // Order matters: the shutdown hook runs first and only fires when a signal was seen.
        signal_hook::flag::register_conditional_shutdown(signal, 1, Arc::clone(&seen))?;
        signal_hook::flag::register(signal, Arc::clone(&seen))?;
        let action = move || {
            let _ =
                REQUESTED.compare_exchange(0, signal as usize, Ordering::SeqCst, Ordering::SeqCst);
        };
        // SAFETY: the action only performs an atomic compare-exchange.
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
