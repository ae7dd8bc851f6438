//! `evogs bench` on a tiny scene: the structure of its report (phases that add up to the
//! iteration, the field's work, GEMM rates, the one-thread run, the JSON file), never its
//! speed; and its argument errors.

use crate::common;

use common::scratch;
use evogs::field::Mlp;
use evogs::model::Motion;
use evogs_cli::app::Silent;
use evogs_cli::app::bench::{
    BenchArgs, BenchReport, FieldSize, parse_bench_motions, parse_sizes, run_bench,
};
use serde_json::Value;
use std::process::Command;

const N: usize = 500;

/// Two JSON trees are equal, numbers up to a relative 1e-12 (`serde_json` parses floats to
/// within an ulp unless its `float_roundtrip` feature is on).
fn same_json(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => match (x.as_f64(), y.as_f64()) {
            (Some(x), Some(y)) => (x - y).abs() <= 1e-12 * x.abs().max(y.abs()),
            _ => x == y,
        },
        (Value::Array(x), Value::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(x, y)| same_json(x, y))
        }
        (Value::Object(x), Value::Object(y)) => {
            x.len() == y.len()
                && x.iter()
                    .all(|(k, v)| y.get(k).is_some_and(|w| same_json(v, w)))
        }
        _ => a == b,
    }
}

#[test]
fn a_tiny_bench_reports_consistent_figures() {
    let dir = scratch("bench");
    let json = dir.join("bench.json");
    let args = BenchArgs {
        gaussians: N,
        warmup: 1,
        iters: 1,
        motions: vec![Motion::Velocity, Motion::Deformation],
        sizes: vec![FieldSize::Fast],
        threads: Some(2),
        single_thread: true,
        rounds: 1,
        json: Some(json.clone()),
        seed: 7,
        machine: false,
    };
    let report = run_bench(&args, &mut Silent).expect("the bench runs");
    assert_eq!(report.rows.len(), 2, "one row per motion");
    assert_eq!((report.gaussians, report.image), (N, [400, 400]), "scene");
    assert_eq!(report.threads, 2, "pool size");
    // The fast field: 2 levels × 16 channels into an MLP 32 wide.
    let mlp = Mlp {
        input: 32,
        width: 32,
    };
    for row in &report.rows {
        let what = format!("{} {}", row.size, row.motion.as_str());
        assert_eq!(row.samples.len(), 1, "{what}: one timed iteration");
        let s = row.samples[0];
        assert!(s.seconds > 0.0, "{what}: timed");
        let p = s.phases;
        // The named phases are disjoint stretches of the iteration measured on its calling
        // thread, so they can only add up to less than the iteration (1 ns of slack for the
        // sum in floating point); `other` is the rest, so all phases add up to the iteration.
        for (name, v) in p.entries() {
            if name != "other" {
                assert!(v > 0.0, "{what}: phase {name} measured: {p:?}");
            }
        }
        assert!(p.named_sum() <= s.seconds + 1e-9, "{what}: {p:?}");
        assert!((p.total() - s.seconds).abs() <= 1e-9, "{what}: sum");
        // What is left unnamed (ODE stepping, state packing, gradient zeroing and finiteness
        // checks) is linear in 500 Gaussians, while the named phases include per-pixel work
        // over 160 000 pixels: it measures a few percent; half the iteration leaves room for
        // a busy machine's interruptions.
        assert!(
            p.other <= 0.5 * s.seconds,
            "{what}: the named phases cover most of the iteration: {p:?}"
        );
        assert_eq!(
            row.seconds.median.to_bits(),
            s.seconds.to_bits(),
            "{what}: median of one"
        );
        assert_eq!(row.phases, p, "{what}: mean of one");
        // RK4 from 0 to 0.45 in steps of 1/8: 4 steps × 4 stages forward, whose records the
        // stage tape keeps (every stage of the frame fits the memory budget), so the adjoint
        // evaluates nothing again and its 16 VJPs read the records; the displacement is one
        // evaluation and its VJP (from its record).
        let (evals, vjps, fresh) = match row.motion {
            Motion::Velocity => (16, 16, 16),
            _ => (1, 1, 1),
        };
        let f = row.field;
        assert_eq!(
            (f.evaluations, f.vjps),
            (evals, vjps),
            "{what}: field calls"
        );
        let n = N as u64;
        assert_eq!(
            (f.forward_rows, f.backward_rows),
            (fresh * n, vjps * n),
            "{what}: MLP rows"
        );
        assert_eq!(
            row.gemm.flops,
            mlp.gemm_flops(f.forward_rows, f.backward_rows),
            "{what}: FLOPs from the layer sizes"
        );
        assert!(
            row.gemm.gflops > 0.0 && row.gemm.thread_seconds > 0.0,
            "{what}: GEMM rate"
        );
        let one = row.single_thread.expect("a one-thread run");
        assert!(
            one.speedup > 0.0 && one.gemm.gflops > 0.0,
            "{what}: {one:?}"
        );
        assert!(
            one.same_losses,
            "{what}: one thread computes the same losses"
        );
        if cfg!(target_os = "linux") {
            assert!(
                row.peak_rss_bytes.is_some_and(|b| b > 0),
                "{what}: peak RSS on Linux"
            );
        }
    }
    let table = report.table();
    assert!(
        table.contains("fast   velocity") && table.contains("fast   deformation"),
        "{table}"
    );
    let text = std::fs::read_to_string(&json).expect("JSON written");
    let back: BenchReport = serde_json::from_str(&text).expect("the JSON reads back");
    assert_eq!(back.rows.len(), 2, "rows read back");
    let (a, b) = (
        serde_json::to_value(&report).expect("to JSON"),
        serde_json::to_value(&back).expect("to JSON"),
    );
    assert!(same_json(&a, &b), "the report round-trips through JSON");
    let left: Vec<_> = std::fs::read_dir(&dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(left, vec!["bench.json"], "no temporary file left");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn rounds_alternate_the_pool_and_one_thread_and_repeat_the_same_iterations() {
    let args = BenchArgs {
        gaussians: 200,
        warmup: 0,
        iters: 2,
        motions: vec![Motion::Deformation],
        sizes: vec![FieldSize::Fast],
        threads: Some(2),
        rounds: 3,
        ..BenchArgs::default()
    };
    let report = run_bench(&args, &mut Silent).expect("the bench runs");
    assert_eq!(report.rounds, 3, "reported");
    let row = &report.rows[0];
    assert_eq!(row.samples.len(), 6, "every round's timed iterations");
    // Every round starts from the same fresh model: its losses repeat the first round's.
    assert_eq!(row.losses.len(), 6, "one loss per timed iteration");
    for (k, l) in row.losses.iter().enumerate() {
        assert_eq!(l.to_bits(), row.losses[k % 2].to_bits(), "iteration {k}");
    }
    let one = row.single_thread.expect("a one-thread run");
    assert!(
        one.same_losses,
        "one thread computes the same losses in every round"
    );
    assert!(report.table().contains("x 3 rounds"), "{}", report.table());
}

#[test]
fn bad_arguments_name_the_flag() {
    let base = BenchArgs {
        gaussians: 10,
        iters: 1,
        warmup: 0,
        sizes: vec![FieldSize::Fast],
        ..BenchArgs::default()
    };
    for (args, flag) in [
        (
            BenchArgs {
                gaussians: 0,
                ..base.clone()
            },
            "--gaussians",
        ),
        (
            BenchArgs {
                iters: 0,
                ..base.clone()
            },
            "--iters",
        ),
        (
            BenchArgs {
                threads: Some(0),
                ..base.clone()
            },
            "--threads",
        ),
        (
            BenchArgs {
                rounds: 0,
                ..base.clone()
            },
            "--rounds",
        ),
        (
            BenchArgs {
                motions: vec![Motion::Static],
                ..base.clone()
            },
            "--motions",
        ),
    ] {
        let e = run_bench(&args, &mut Silent).expect_err(flag).to_string();
        assert!(e.contains(flag) && !e.contains('\n'), "{flag}: {e}");
    }
    assert!(parse_sizes("paper,huge").is_err_and(|e| e.contains("huge")));
    assert!(parse_sizes("fast,fast").is_err_and(|e| e.contains("twice")));
    assert_eq!(
        parse_sizes(" fast , paper").expect("sizes"),
        vec![FieldSize::Fast, FieldSize::Paper]
    );
    assert!(parse_bench_motions("static").is_err_and(|e| e.contains("static")));
    assert_eq!(
        parse_bench_motions("deformation").expect("motions"),
        vec![Motion::Deformation]
    );
}

#[test]
fn the_binary_rejects_bad_flags_in_one_line() {
    for (flags, flag, code) in [
        (&["--gaussians", "-3"][..], "--gaussians", 2),
        (&["--iters", "0"][..], "--iters", 2),
        (&["--warmup", "1.5"][..], "--warmup", 2),
        (&["--threads", "0"][..], "--threads", 2),
        (&["--rounds", "0"][..], "--rounds", 2),
        // Lists are parsed with the command line too: a usage error like the counts.
        (&["--sizes", "paper,huge"][..], "--sizes", 2),
        (&["--motions", "static"][..], "--motions", 2),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_evogs"))
            .arg("bench")
            .args(flags)
            .output()
            .expect("run evogs");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(code), "{flags:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{flags:?}: one line: {err}");
        assert!(err.contains(flag), "{flags:?} names the flag: {err}");
        assert!(out.stdout.is_empty(), "{flags:?}: nothing printed");
    }
}
