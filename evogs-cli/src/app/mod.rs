//! The commands of the `evogs` binary as library functions (the binary only parses
//! arguments): training, evaluation, rendering, export, studies. Output goes through a [`Reporter`];
//! the library never prints.

pub mod bench;
pub mod cluster;
pub mod counts;
pub mod error;
pub mod evaluate;
pub mod export;
pub mod frame_writer;
pub mod inject;
pub mod interrupt;
pub mod load;
pub mod lock;
pub mod paths;
pub mod plot;
pub mod render;
pub mod scenes;
pub mod sequence_folder;
pub mod study;
pub mod train;
pub mod view;

/// Receives progress and messages from long-running commands.
pub trait Reporter {
    /// A new phase with `total` steps.
    fn start(&mut self, phase: &str, total: u64);
    /// Progress within the phase.
    fn progress(&mut self, done: u64, message: &str);
    /// The phase is done.
    fn finish(&mut self);
    /// A one-line message.
    fn info(&mut self, message: &str);
}

/// A reporter that discards everything (tests, library use).
#[derive(Clone, Copy, Debug, Default)]
pub struct Silent;

impl Reporter for Silent {
    fn start(&mut self, _: &str, _: u64) {}
    fn progress(&mut self, _: u64, _: &str) {}
    fn finish(&mut self) {}
    fn info(&mut self, _: &str) {}
}

/// A [`Reporter`] that shows nothing and keeps the information lines (notes, warnings), for
/// callers and tests that read them.
#[derive(Debug, Default)]
pub struct Notes(pub Vec<String>);

impl Reporter for Notes {
    fn start(&mut self, _: &str, _: u64) {}
    fn progress(&mut self, _: u64, _: &str) {}
    fn finish(&mut self) {}
    fn info(&mut self, line: &str) {
        self.0.push(line.to_string());
    }
}
