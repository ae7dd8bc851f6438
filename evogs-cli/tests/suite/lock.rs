//! One writer per folder: while `evogs train` writes a run folder, a second `train`,
//! a `render` or an `export --times` into it is refused at once with the holder's process id;
//! once the holder is killed (SIGKILL, no clean-up), its stale lock file blocks nothing.

#![cfg(unix)]

use std::io::{BufRead as _, BufReader};
use std::process::{Command, Stdio};

use crate::common;

fn evogs() -> Command {
    Command::new(env!("CARGO_BIN_EXE_evogs"))
}

#[test]
fn a_folder_being_written_refuses_other_writers_and_a_killed_holder_blocks_nothing() {
    let dir = common::scratch("lock");
    let cfg = common::tiny_config(
        &dir,
        "[schedule]\nwarmup_iters = 3\niterations = 300\ncurriculum_iters = 0\ncheckpoint_every = 5\n",
    );
    let run = dir.join("run");
    let data = evogs_cli::app::paths::shipped_scene();
    let train = |extra: &[&str]| {
        let mut c = evogs();
        c.args(["train", "--data"])
            .arg(&data)
            .arg("--config")
            .arg(&cfg)
            .arg("--out")
            .arg(&run)
            .args(extra);
        c
    };
    let mut holder = train(&[])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("evogs starts");
    // Its stderr stays open (read no further) until it is killed, so that it never writes
    // into a closed pipe.
    let mut lines = BufReader::new(holder.stderr.take().expect("stderr")).lines();
    // Wait until it trains (its folder is prepared and locked), then stop it there
    // (SIGSTOP): a stopped holder keeps its lock however slow the refused commands are,
    // where a running one might finish its 300 iterations and release it first.
    for line in lines.by_ref() {
        if line.expect("utf-8").starts_with("train ")
            && run.join("checkpoint.safetensors").is_file()
        {
            break;
        }
    }
    let id = holder.id().to_string();
    let stopped = Command::new("kill")
        .args(["-STOP", &id])
        .status()
        .expect("kill runs");
    assert!(stopped.success(), "SIGSTOP sent");
    assert!(
        holder.try_wait().expect("status").is_none(),
        "the holder is still training when the others try"
    );
    let pid = format!("process {id}");
    let refused = |mut c: Command, what: &str| {
        let o = c.output().expect("evogs runs");
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(!o.status.success(), "{what}: refused");
        assert!(
            err.contains("is writing to this folder")
                && err.contains(&pid)
                && err.contains("evogs train"),
            "{what}: {err}"
        );
    };
    refused(train(&["--force"]), "a second train --force");
    refused(train(&["--resume"]), "a second train --resume");
    let mut render = evogs();
    render
        .args(["render", "--run"])
        .arg(&run)
        .arg("--out")
        .arg(&run)
        .args(["--times", "0:1:2"]);
    refused(render, "render into the run folder");
    let mut export = evogs();
    export
        .args(["export", "--run"])
        .arg(&run)
        .arg("--out")
        .arg(&run)
        .args(["--times", "0:1:2"]);
    refused(export, "export --times into the run folder");
    holder.kill().expect("SIGKILL");
    holder.wait().expect("ended");
    drop(lines);
    assert!(
        run.join(".evogs.lock").is_file(),
        "the stale lock file stays"
    );
    let o = train(&["--resume"]).output().expect("evogs runs");
    assert!(
        o.status.success(),
        "a stale lock does not block: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    std::fs::remove_dir_all(&dir).ok();
}
