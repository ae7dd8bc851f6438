//! `mpirun -np 2 evogs train` gives the same bits as one process with the same batch
//! (`schedule.views_per_step = 2`), every rank holding the same parameters; `mpirun -np 2
//! evogs study` spreads the runs over the ranks and rank 0 writes the summary.
//!
//! Needs the `mpi` feature and an MPI launcher (`mpirun` on the PATH); without a launcher
//! each test says that it is skipped and passes. Both sides run with one thread per
//! process (`RAYON_NUM_THREADS=1`): results are deterministic for a given thread count.

#![cfg(all(unix, feature = "mpi"))]

use evogs::run::checkpoint;
use std::io::{BufRead as _, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use crate::common;

const SCHEDULE: &str = r"
[schedule]
views_per_step = 2
warmup_iters = 10
iterations = 50
curriculum_iters = 10
checkpoint_every = 25
checkpoint_minutes = 0.0

[densify]
from_iter = 10
until_iter = 45
interval = 15
";

/// `mpirun` from the PATH, or `None` after saying that the test is skipped.
fn launcher() -> Option<PathBuf> {
    let found = std::env::var_os("PATH").and_then(|path| {
        std::env::split_paths(&path)
            .map(|d| d.join("mpirun"))
            .find(|p| p.is_file())
    });
    if found.is_none() {
        eprintln!("skipped: no mpirun on the PATH (install Open MPI or MPICH)");
    }
    found
}

fn evogs() -> &'static str {
    env!("CARGO_BIN_EXE_evogs")
}

/// `mpirun -np 2 evogs ARGS` with one thread per rank (root allowed, as in CI containers,
/// and more ranks than cores allowed).
fn mpirun_command(mpirun: &Path, args: &[&str]) -> Command {
    let mut c = Command::new(mpirun);
    c.args(["-np", "2", "--oversubscribe", "-x", "RAYON_NUM_THREADS=1"])
        .args(["-x", "EVOGS_MPI_TIMEOUT"])
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("RAYON_NUM_THREADS", "1")
        .env("EVOGS_MPI_TIMEOUT", "120")
        .arg(evogs())
        .args(args);
    c
}

fn mpirun(mpirun: &Path, args: &[&str]) -> Output {
    mpirun_command(mpirun, args)
        .output()
        .expect("mpirun starts")
}

/// Runs `cmd`, and once rank 0's progress passes iteration `at` runs `act`; returns the exit
/// status and standard error.
fn run_and_act(
    mut cmd: Command,
    at: u64,
    act: impl FnOnce(u32),
) -> (std::process::ExitStatus, String) {
    let mut child = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("mpirun starts");
    let stderr = child.stderr.take().expect("stderr");
    let mut text = String::new();
    let mut act = Some(act);
    for line in BufReader::new(stderr).lines() {
        let line = line.expect("utf-8");
        let done = line
            .strip_prefix("train ")
            .and_then(|r| r.split('/').next())
            .and_then(|d| d.parse::<u64>().ok());
        if done.is_some_and(|d| d >= at)
            && let Some(f) = act.take()
        {
            f(child.id());
        }
        text.push_str(&line);
        text.push('\n');
    }
    assert!(act.is_none(), "the run reached iteration {at}: {text}");
    (child.wait().expect("exit"), text)
}

fn kill(signal: &str, pid: &str) {
    let ok = Command::new("kill")
        .args([signal, pid])
        .status()
        .expect("kill runs");
    assert!(ok.success(), "kill {signal} {pid}");
}

fn alone(args: &[&str]) -> Output {
    Command::new(evogs())
        .env("RAYON_NUM_THREADS", "1")
        .args(args)
        .output()
        .expect("evogs starts")
}

fn text(o: &Output) -> String {
    format!(
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Iteration, parameters and Gaussian count of a run's checkpoint.
fn model_of(run: &Path) -> (u64, Vec<f32>, String) {
    let l = checkpoint::load_model(&run.join("checkpoint.safetensors")).expect("checkpoint");
    (
        l.meta.iteration,
        l.model.field.params().to_vec(),
        format!("{:?} {:?}", l.model.canonical, l.model.anchors),
    )
}

/// The log without its seconds column (wall-clock time differs between runs).
fn losses(run: &Path) -> Vec<String> {
    std::fs::read_to_string(run.join("log.csv"))
        .expect("log")
        .lines()
        .map(|l| {
            let mut f: Vec<&str> = l.split(',').collect();
            f.remove(1);
            f.join(",")
        })
        .collect()
}

#[test]
fn two_ranks_train_the_bits_of_one_process_with_a_batch_of_two() {
    let Some(mpi) = launcher() else {
        return;
    };
    let dir = common::scratch("mpi-train");
    let cfg = common::tiny_config(&dir, SCHEDULE);
    let data = evogs_cli::app::paths::shipped_scene();
    let args = |out: &Path| -> Vec<String> {
        vec![
            "train".into(),
            "--data".into(),
            data.display().to_string(),
            "--config".into(),
            cfg.display().to_string(),
            "--out".into(),
            out.display().to_string(),
        ]
    };
    let (one, two) = (dir.join("one"), dir.join("two"));
    let a: Vec<String> = args(&one);
    let o = alone(&a.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "one process: {}", text(&o));
    let b: Vec<String> = args(&two);
    let o = mpirun(&mpi, &b.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "two ranks: {}", text(&o));
    let out = text(&o);
    assert!(
        out.contains("2 processes, 1 view(s) each per step"),
        "{out}"
    );
    assert_eq!(
        out.matches("trained 50 iterations").count(),
        1,
        "rank 0 alone reports: {out}"
    );
    let (m1, m2) = (model_of(&one), model_of(&two));
    assert_eq!(m1.0, 50, "finished");
    assert_eq!(m1, m2, "the same parameters, bit for bit");
    assert_eq!(losses(&one), losses(&two), "the same log");
    assert!(two.join("metrics-test.json").is_file(), "rank 0 evaluated");

    // A batch that does not split over the ranks is refused on every rank, naming both.
    let odd = common::tiny_config(
        &dir,
        &SCHEDULE.replace("views_per_step = 2", "views_per_step = 3"),
    );
    let o = mpirun(
        &mpi,
        &[
            "train",
            "--data",
            &data.display().to_string(),
            "--config",
            &odd.display().to_string(),
            "--out",
            &dir.join("odd").display().to_string(),
        ],
    );
    assert!(!o.status.success(), "refused");
    assert!(
        text(&o).contains("views_per_step = 3 does not split over 2 processes"),
        "{}",
        text(&o)
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn two_ranks_share_the_runs_of_a_study_and_rank_0_writes_the_summary() {
    let Some(mpi) = launcher() else {
        return;
    };
    let dir = common::scratch("mpi-study");
    let cfg = common::tiny_config(
        &dir,
        "[schedule]\nwarmup_iters = 3\niterations = 6\ncurriculum_iters = 0\n",
    );
    let out = dir.join("study");
    let data = evogs_cli::app::paths::shipped_scene().display().to_string();
    let line = [
        "study",
        "--data",
        &data,
        "--config",
        &cfg.display().to_string(),
        "--out",
        &out.display().to_string(),
        "--protocols",
        "full",
        "--motions",
        "velocity,static",
    ];
    let o = mpirun(&mpi, &line);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    assert!(t.contains("rank 0 of 2: 1 of the 2 pending runs"), "{t}");
    assert!(
        out.join("study.json").is_file() && out.join("study.md").is_file(),
        "{t}"
    );
    for run in ["full-velocity-s0", "full-static-s0"] {
        assert!(
            out.join("runs").join(run).join("study-run.json").is_file(),
            "{run}"
        );
    }
    // A rerun reuses both runs.
    let o = mpirun(&mpi, &line);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("2 finished earlier"), "{}", text(&o));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_interrupt_stops_every_rank_with_a_checkpoint_and_resume_ends_bit_for_bit() {
    let Some(mpi) = launcher() else {
        return;
    };
    let dir = common::scratch("mpi-resume");
    let cfg = common::tiny_config(
        &dir,
        &SCHEDULE
            .replace("iterations = 50", "iterations = 80")
            .replace("checkpoint_every = 25", "checkpoint_every = 1000"),
    );
    let data = evogs_cli::app::paths::shipped_scene().display().to_string();
    let (one, two) = (dir.join("one"), dir.join("two"));
    let line = |out: &Path, resume: bool| -> Vec<String> {
        let mut v: Vec<String> = ["train", "--data", &data, "--config"]
            .iter()
            .map(|s| (*s).to_string())
            .collect();
        v.push(cfg.display().to_string());
        v.push("--out".into());
        v.push(out.display().to_string());
        if resume {
            v.push("--resume".into());
        }
        v
    };
    let o = alone(
        &line(&one, false)
            .iter()
            .map(String::as_str)
            .collect::<Vec<_>>(),
    );
    assert!(o.status.success(), "{}", text(&o));
    let args = line(&two, false);
    let cmd = mpirun_command(&mpi, &args.iter().map(String::as_str).collect::<Vec<_>>());
    let (status, t) = run_and_act(cmd, 30, |pid| kill("-INT", &pid.to_string()));
    assert!(!status.success(), "an interrupted run does not exit 0: {t}");
    assert!(t.contains("interrupted at iteration"), "{t}");
    let stopped = model_of(&two).0;
    assert!((30..80).contains(&stopped), "stopped at {stopped}: {t}");
    let args = line(&two, true);
    let o = mpirun(&mpi, &args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(o.status.success(), "resumed: {}", text(&o));
    assert_eq!(
        model_of(&one),
        model_of(&two),
        "resumed over MPI, bit for bit"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_rank_that_stops_answering_ends_the_job_with_an_error() {
    let Some(mpi) = launcher() else {
        return;
    };
    let dir = common::scratch("mpi-hang");
    let cfg = common::tiny_config(
        &dir,
        &SCHEDULE.replace("iterations = 50", "iterations = 2000"),
    );
    let out = dir.join("run");
    let data = evogs_cli::app::paths::shipped_scene().display().to_string();
    let args = [
        "train",
        "--data",
        &data,
        "--config",
        &cfg.display().to_string(),
        "--out",
        &out.display().to_string(),
    ];
    let mut cmd = mpirun_command(&mpi, &args);
    cmd.env("EVOGS_MPI_TIMEOUT", "3");
    let marker = out.display().to_string();
    let started = std::time::Instant::now();
    let (status, t) = run_and_act(cmd, 100, |_| {
        // Freeze one rank (the newest evogs process of this run): the other waits for it.
        let pids = Command::new("pgrep")
            .args(["-f", "-n", &format!("evogs train .*{marker}")])
            .output()
            .expect("pgrep");
        let pid = String::from_utf8_lossy(&pids.stdout).trim().to_string();
        assert!(!pid.is_empty(), "a rank's process");
        kill("-STOP", &pid);
    });
    assert!(!status.success(), "{t}");
    assert!(t.contains("did not answer within 3 s"), "{t}");
    assert!(started.elapsed().as_secs() < 90, "ended, not hung");
    Command::new("pkill")
        .args(["-9", "-f", &marker])
        .status()
        .ok();
    std::fs::remove_dir_all(&dir).ok();
}
