//! Shared pieces of the command tests: the smallest model that trains on the shipped scene
//! in seconds, scratch folders and a tiny trained run.

#![allow(dead_code, reason = "each test binary uses a different part")]

use evogs_cli::app::Silent;
use evogs_cli::app::paths::shipped_scene;
use evogs_cli::app::train::{TrainArgs, train};
use std::path::{Path, PathBuf};

/// The data and field sections of the tiny test model (the shipped scene at 1/8 size, a
/// 2-channel single-level HexPlane, an 8-wide MLP); tests add their schedule.
pub(crate) const TINY_MODEL: &str = r"
[data]
downscale = 8

[field]
width = 8

[field.hexplane]
channels = 2
resolution = [4, 4, 4, 4]
multires = [1]
";

/// A fresh, empty scratch folder named after the test and the process.
pub(crate) fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("evogs-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).expect("scratch folder");
    dir
}

/// Writes `dir/tiny.toml`: [`TINY_MODEL`] followed by `rest` (a schedule, densification...).
pub(crate) fn tiny_config(dir: &Path, rest: &str) -> PathBuf {
    let p = dir.join("tiny.toml");
    std::fs::write(&p, format!("{TINY_MODEL}\n{rest}")).expect("config");
    p
}

/// Trains the tiny model for six iterations (dynamics on after three) into `dir/run`, without
/// the end-of-training evaluation and GIF.
pub(crate) fn tiny_run(dir: &Path) -> PathBuf {
    let cfg = tiny_config(
        dir,
        "[schedule]\nwarmup_iters = 3\niterations = 6\ncurriculum_iters = 0\n",
    );
    let run = dir.join("run");
    train(
        &TrainArgs {
            data: Some(shipped_scene()),
            out: run.clone(),
            config: Some(cfg),
            skip_outputs: true,
            ..TrainArgs::default()
        },
        &mut Silent,
    )
    .expect("a tiny run");
    run
}

/// Copies a folder tree (a dataset to modify in a test).
pub(crate) fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("copy destination");
    for e in std::fs::read_dir(from).expect("copy source") {
        let e = e.expect("entry");
        let dst = to.join(e.file_name());
        if e.file_type().expect("type").is_dir() {
            copy_tree(&e.path(), &dst);
        } else {
            std::fs::copy(e.path(), &dst).expect("copy");
        }
    }
}

/// A reporter that keeps the info lines.
#[derive(Default)]
pub(crate) struct Infos(pub(crate) Vec<String>);

impl evogs_cli::app::Reporter for Infos {
    fn start(&mut self, _: &str, _: u64) {}
    fn progress(&mut self, _: u64, _: &str) {}
    fn finish(&mut self) {}
    fn info(&mut self, m: &str) {
        self.0.push(m.to_string());
    }
}
