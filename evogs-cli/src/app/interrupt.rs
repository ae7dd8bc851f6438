//! Interruption: SIGINT (Ctrl-C) and SIGTERM ask long commands to stop at the next safe
//! point (training finishes its iteration and writes a checkpoint) instead of killing the
//! process mid-write. A second signal exits at once.
//!
//! A signal's request is one process-wide flag, because signals are process-wide: the
//! binary installs the handler ([`install`]); library users may [`request`] the same stop.
//! A caller running several commands at once on different threads (an embedding
//! application, a test harness) stops one of them with [`request_on_this_thread`], from the
//! thread that runs it (its [`Reporter`](super::Reporter) is called there): the others,
//! on other threads, go on.

use super::error::{CommandResult, Context as _};
use std::cell::Cell;
use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

std::thread_local! {
    static REQUESTED_HERE: Cell<bool> = const { Cell::new(false) };
}

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

/// Asks every long command of the process to stop at its next safe point (what a signal
/// does).
pub fn request() {
    REQUESTED.store(true, Ordering::SeqCst);
}

/// Asks the long command running on the calling thread to stop at its next safe point;
/// commands on other threads do not see it.
pub fn request_on_this_thread() {
    REQUESTED_HERE.with(|r| r.set(true));
}

/// Whether a stop was asked for, of the whole process or of this thread.
#[must_use]
pub fn requested() -> bool {
    REQUESTED_HERE.with(Cell::get) || REQUESTED.load(Ordering::SeqCst)
}

/// Whether a stop was asked for, withdrawing the request (for a command that stops for it
/// now).
#[must_use]
pub fn take() -> bool {
    let here = REQUESTED_HERE.with(|r| r.replace(false));
    REQUESTED.swap(false, Ordering::SeqCst) || here
}

/// Withdraws a request, the process's and this thread's (after a command has stopped for
/// it).
pub fn clear() {
    REQUESTED_HERE.with(|r| r.set(false));
    REQUESTED.store(false, Ordering::SeqCst);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_request_on_one_thread_is_not_seen_on_another() {
        request_on_this_thread();
        assert!(requested());
        let other = std::thread::spawn(requested).join().expect("thread");
        assert!(!other, "another thread's command goes on");
        assert!(take(), "taken where it was asked");
        assert!(!requested(), "and withdrawn");
    }
}
