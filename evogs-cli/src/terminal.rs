//! The binary's [`Reporter`]: progress bars and messages on the terminal.

use evogs_cli::app::Reporter;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal as _;

/// Progress bars and messages on the terminal; when stderr is not a terminal (logs, CI), a
/// progress line every 5% of a phase instead of a bar.
pub(crate) struct Terminal {
    bar: Option<ProgressBar>,
    phase: String,
    total: u64,
    next_line: u64,
    started: std::time::Instant,
}

impl Reporter for Terminal {
    fn start(&mut self, phase: &str, total: u64) {
        self.phase = phase.to_string();
        self.total = total;
        self.next_line = 0;
        self.started = std::time::Instant::now();
        if !std::io::stderr().is_terminal() {
            return;
        }
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template("{prefix:>14} [{bar:30}] {pos}/{len} {msg} (eta {eta})")
                .unwrap_or_else(|_| ProgressStyle::default_bar())
                .progress_chars("=> "),
        );
        bar.set_prefix(phase.to_string());
        self.bar = Some(bar);
    }
    fn progress(&mut self, done: u64, message: &str) {
        if self.bar.is_none() && done >= self.next_line && self.total > 0 {
            let secs = self.started.elapsed().as_secs_f64();
            eprintln!(
                "{} {done}/{} ({secs:.0} s) {message}",
                self.phase, self.total
            );
            self.next_line = done + (self.total / 20).max(1);
        }
        if let Some(b) = &self.bar {
            b.set_position(done);
            if !message.is_empty() {
                b.set_message(message.to_string());
            }
        }
    }
    fn finish(&mut self) {
        if let Some(b) = self.bar.take() {
            b.finish();
        }
    }
    fn info(&mut self, message: &str) {
        match &self.bar {
            Some(b) => b.println(message),
            None => eprintln!("{message}"),
        }
    }
}

impl Terminal {
    /// A terminal reporter with no phase yet.
    pub(crate) fn new() -> Self {
        Self {
            bar: None,
            phase: String::new(),
            total: 0,
            next_line: 0,
            started: std::time::Instant::now(),
        }
    }
}
