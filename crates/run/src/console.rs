//! Writing to stdout and stderr without panicking when the stream is closed.
//!
//! `println!` and `eprintln!` panic when a write fails, which a closed pipe
//! (`softbench run ... 2>&1 | head -2`) makes happen. These helpers report failure instead;
//! a closed stream is remembered, so later messages are dropped quietly and the work goes on.

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};

static STDOUT_CLOSED: AtomicBool = AtomicBool::new(false);
static STDERR_CLOSED: AtomicBool = AtomicBool::new(false);

/// Writes a line to stdout; false if stdout is closed (then nothing more is written to it).
pub fn out(line: &str) -> bool {
    write_line(&mut std::io::stdout().lock(), line, &STDOUT_CLOSED)
}

/// Writes a line to stderr; false if stderr is closed (then nothing more is written to it).
pub fn err(line: &str) -> bool {
    write_line(&mut std::io::stderr().lock(), line, &STDERR_CLOSED)
}

/// Whether a write to stdout has failed.
pub fn stdout_closed() -> bool {
    STDOUT_CLOSED.load(Ordering::Relaxed)
}

fn write_line(w: &mut dyn Write, line: &str, closed: &AtomicBool) -> bool {
    if closed.load(Ordering::Relaxed) {
        return false;
    }
    let ok = writeln!(w, "{line}").and_then(|()| w.flush()).is_ok();
    if !ok {
        closed.store(true, Ordering::Relaxed);
    }
    ok
}

/// Whether an error chain ends in a broken pipe (the reader of our output went away).
pub fn is_broken_pipe(err: &(dyn std::error::Error + 'static)) -> bool {
    let mut current = Some(err);
    while let Some(e) = current {
        if let Some(io) = e.downcast_ref::<std::io::Error>()
            && io.kind() == std::io::ErrorKind::BrokenPipe
        {
            return true;
        }
        // serde_json keeps the io::Error inside (its `source` skips it): `mesh-info --json`.
        if e.downcast_ref::<serde_json::Error>()
            .and_then(serde_json::Error::io_error_kind)
            == Some(std::io::ErrorKind::BrokenPipe)
        {
            return true;
        }
        current = e.source();
    }
    false
}
