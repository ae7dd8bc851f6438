//! Interruption: SIGINT (Ctrl-C) and SIGTERM ask long commands to stop at the next safe
//! point (training finishes its iteration and writes a checkpoint) instead of killing the
//! process mid-write. A second signal exits at once.
//!
//! The request is one process-wide flag, because signals are process-wide: the binary
//! installs the handler ([`install`]); library users and tests may [`request`] a stop.

use super::error::{CommandResult, Context as _};
use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Installs the SIGINT/SIGTERM handler (once; later calls do nothing).
///
/// # Errors
/// The operating system refused the handler.
pub fn install() -> CommandResult<()> {
    static INSTALLED: AtomicBool = AtomicBool::new(false);
    if INSTALLED.swap(true, Ordering::SeqCst) {
        return Ok(());
    }
    ctrlc::set_handler(|| {
        if REQUESTED.swap(true, Ordering::SeqCst) {
            eprintln!("\nsecond interrupt: exiting now");
            std::process::exit(130);
        }
        eprintln!(
            "\ninterrupt: stopping at the next safe point (training: after this iteration, with a checkpoint; rendering: after this frame); interrupt again to exit now"
        );
    })
    .context("cannot install the interrupt handler")
}

/// Asks long commands to stop at their next safe point (what a signal does).
pub fn request() {
    REQUESTED.store(true, Ordering::SeqCst);
}

/// Whether a stop was asked for.
#[must_use]
pub fn requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}

/// Whether a stop was asked for, withdrawing the request (for a command that stops for it
/// now).
#[must_use]
pub fn take() -> bool {
    REQUESTED.swap(false, Ordering::SeqCst)
}

/// Withdraws a request (after a command has stopped for it, or in tests).
pub fn clear() {
    REQUESTED.store(false, Ordering::SeqCst);
}
