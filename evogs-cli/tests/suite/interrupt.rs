//! Interrupted training loses nothing: `evogs train` stopped by SIGINT or SIGTERM writes a
//! checkpoint at the iteration it was on and says how to go on; killed by SIGKILL it leaves
//! its last periodic checkpoint. Either way `--resume` ends bit for bit where an
//! uninterrupted run ends. A folder holding a run is not trained over without `--resume`
//! or `--force`.

#![cfg(unix)]

use evogs::run::checkpoint;
use std::io::{BufRead as _, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use crate::common;

const SCHEDULE: &str = r"
[schedule]
warmup_iters = 10
iterations = 80
curriculum_iters = 0
checkpoint_every = 10
checkpoint_minutes = 0.0

[densify]
from_iter = 5
until_iter = 60
interval = 20
";

fn evogs() -> Command {
    Command::new(env!("CARGO_BIN_EXE_evogs"))
}

fn data() -> PathBuf {
    evogs_cli::app::paths::shipped_scene()
}

struct Work {
    dir: PathBuf,
    cfg: PathBuf,
}

impl Work {
    fn new(name: &str) -> Self {
        let dir = std::env::temp_dir().join(format!("evogs-int-{name}-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        std::fs::create_dir_all(&dir).expect("tmp");
        let cfg = common::tiny_config(&dir, SCHEDULE);
        Self { dir, cfg }
    }

    fn train(&self, run: &str, extra: &[&str]) -> Command {
        let mut c = evogs();
        c.args(["train", "--data"])
            .arg(data())
            .arg("--config")
            .arg(&self.cfg)
            .arg("--out")
            .arg(self.dir.join(run))
            .args(extra);
        c
    }
}

impl Drop for Work {
    fn drop(&mut self) {
        std::fs::remove_dir_all(&self.dir).ok();
    }
}

/// Starts a training run and sends `signal` once its progress passes `at` iterations;
/// returns its exit status and standard error.
fn train_and_signal(mut cmd: Command, signal: &str, at: u64) -> (std::process::ExitStatus, String) {
    let mut child = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("evogs starts");
    let stderr = child.stderr.take().expect("stderr");
    let mut text = String::new();
    let mut sent = false;
    for line in BufReader::new(stderr).lines() {
        let line = line.expect("utf-8");
        if !sent
            && let Some(done) = line
                .strip_prefix("train ")
                .and_then(|r| r.split('/').next())
                .and_then(|d| d.parse::<u64>().ok())
            && done >= at
        {
            let ok = Command::new("kill")
                .args([signal, &child.id().to_string()])
                .status()
                .expect("kill runs");
            assert!(ok.success(), "signal sent");
            sent = true;
        }
        text.push_str(&line);
        text.push('\n');
    }
    assert!(sent, "the run reached iteration {at}: {text}");
    (child.wait().expect("exit"), text)
}

/// Model arrays of a checkpoint: canonical Gaussians, anchors and field.
fn model_of(path: &Path) -> (String, Vec<f32>, u64) {
    let l = checkpoint::load_model(path).expect("checkpoint");
    let it = l.archive.meta["iteration"].as_u64().expect("iteration");
    (
        format!("{:?} {:?}", l.model.canonical, l.model.anchors),
        l.model.field.params().to_vec(),
        it,
    )
}

#[test]
fn interrupted_runs_resume_bit_for_bit() {
    let w = Work::new("resume");
    let full = w.train("full", &[]).output().expect("runs");
    assert!(
        full.status.success(),
        "{}",
        String::from_utf8_lossy(&full.stderr)
    );
    let reference = model_of(&w.dir.join("full/checkpoint.safetensors"));
    assert_eq!(reference.2, 80, "finished");

    // Stop points differ between runs of the test (any iteration must do).
    let jitter = u64::from(std::process::id() % 5) * 4;
    for (run, signal, at) in [
        ("int", "-INT", 12 + jitter),
        ("term", "-TERM", 36 + jitter),
        ("kill", "-KILL", 24 + jitter),
    ] {
        let (status, text) = train_and_signal(w.train(run, &[]), signal, at);
        assert!(!status.success(), "{signal}: a stopped run does not exit 0");
        assert!(!text.contains("panicked"), "{signal}: {text}");
        let ck = w.dir.join(run).join("checkpoint.safetensors");
        let (_, _, stopped) = model_of(&ck);
        assert!(stopped < 80, "{signal}: stopped early, at {stopped}");
        if signal == "-KILL" {
            assert_eq!(
                stopped % 10,
                0,
                "SIGKILL leaves the last periodic checkpoint"
            );
        } else {
            assert!(
                stopped >= at,
                "{signal}: checkpoint at the stop ({stopped} >= {at})"
            );
            assert!(
                text.contains(&format!("interrupted at iteration {stopped} of 80"))
                    && text.contains("--resume"),
                "{signal}: the message says where it stopped and how to go on: {text}"
            );
        }
        // Training over the interrupted run without --resume or --force is refused.
        let again = w.train(run, &[]).output().expect("runs");
        let err = String::from_utf8_lossy(&again.stderr);
        assert!(
            !again.status.success() && err.contains("--resume") && err.contains("--force"),
            "{err}"
        );
        let resumed = w.train(run, &["--resume"]).output().expect("runs");
        assert!(
            resumed.status.success(),
            "{signal}: {}",
            String::from_utf8_lossy(&resumed.stderr)
        );
        assert_eq!(model_of(&ck), reference, "{signal}: resumed bit for bit");
    }
    // --force replaces the run.
    let forced = w
        .train("int", &["--force", "--iters", "30"])
        .output()
        .expect("runs");
    assert!(
        forced.status.success(),
        "{}",
        String::from_utf8_lossy(&forced.stderr)
    );
    assert_eq!(
        model_of(&w.dir.join("int/checkpoint.safetensors")).2,
        30,
        "a new run"
    );
}
