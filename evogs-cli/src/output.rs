//! What each command prints on stdout when it succeeds: one function per command, so `run`
//! in `main.rs` only dispatches.

use evogs::eval::SplitMetrics;
use evogs_cli::app::bench::BenchReport;
use evogs_cli::app::export::SEQUENCE_FILE;
use evogs_cli::app::frame_writer::FramesWritten;
use evogs_cli::app::study::StudyOutcome;
use evogs_cli::app::train::TrainOutcome;
use evogs_verify::check::grad::GradTable;
use evogs_verify::check::order::{Expect, OrderResult};
use std::path::Path;

/// `evogs train`: the run folder, the time per iteration, the test metrics and the GIF.
pub(crate) fn train(o: &TrainOutcome) {
    println!("run: {}", o.run.dir.display());
    println!(
        "trained {} iterations in {:.1} s ({:.3} s/iteration), {} Gaussians",
        o.iterations,
        o.seconds,
        o.seconds / o.iterations.max(1) as f64,
        o.gaussians
    );
    if let Some(m) = &o.test {
        println!(
            "test: PSNR {:.2} dB, SSIM {:.4} over {} frames -> {}",
            m.psnr,
            m.ssim,
            m.frames.len(),
            o.run.metrics("test").display()
        );
    }
    if let Some(g) = &o.gif {
        println!("gif: {}", g.display());
    }
}

/// `evogs study`: the table and where the summary went.
pub(crate) fn study(o: &StudyOutcome) {
    println!("{}", o.summary.markdown());
    println!(
        "{} runs trained, {} reused -> {}, {}, {}",
        o.trained,
        o.reused,
        o.json.display(),
        o.markdown.display(),
        o.chart.display()
    );
}

/// `evogs eval`: PSNR and SSIM per frame, the mean and the metrics file.
pub(crate) fn eval(m: &SplitMetrics, path: &Path) {
    println!("{:>10} {:>8} {:>8}", "time", "PSNR", "SSIM");
    for f in &m.frames {
        println!("{:>10.4} {:>8.2} {:>8.4}", f.time, f.psnr, f.ssim);
    }
    println!(
        "{:>10} {:>8.2} {:>8.4}   ({} frames) -> {}",
        "mean",
        m.psnr,
        m.ssim,
        m.frames.len(),
        path.display()
    );
}

/// `evogs render` and `evogs inject`: the frames and the GIF.
pub(crate) fn frames(o: &FramesWritten) {
    println!("{} frames written to {}", o.count, o.dir.display());
    if let Some(g) = &o.gif {
        println!("gif: {}", g.display());
    }
}

/// `evogs bench`: the table and the JSON report.
pub(crate) fn bench(report: &BenchReport, json: Option<&Path>) {
    print!("{}", report.table());
    if let Some(p) = json {
        println!("\nreport: {}", p.display());
    }
}

/// `evogs bench --machine`: the FMA peak and the read bandwidth per level.
pub(crate) fn machine(m: &evogs_cli::app::bench::machine::MachineLimits) {
    let cpu = evogs_cli::app::bench::cpu_model().unwrap_or_else(|| "unknown CPU".into());
    println!("{cpu}; build for {}", m.isa);
    println!(
        "f32 FMA peak: {:.1} GFLOP/s on 1 thread, {:.1} GFLOP/s on {} threads",
        m.fma_one_thread, m.fma_all_threads, m.threads
    );
    println!("read bandwidth (GB/s):");
    println!(
        "  {:<8} {:>14} {:>10} {:>12}",
        "level",
        "bytes/thread",
        "1 thread",
        format!("{} threads", m.threads)
    );
    for b in &m.bandwidth {
        println!(
            "  {:<8} {:>14} {:>10.1} {:>12.1}",
            b.level, b.bytes_per_thread, b.one_thread, b.all_threads
        );
    }
}

/// `evogs export --time T`.
pub(crate) fn export_one(gaussians: usize, t: f64, out: &Path) {
    println!("{gaussians} Gaussians at t = {t} -> {}", out.display());
}

/// `evogs export --times A:B:N`.
pub(crate) fn export_sequence(files: usize, gaussians: usize, out: &Path) {
    println!(
        "{files} files of {gaussians} Gaussians -> {} ({SEQUENCE_FILE})",
        out.display()
    );
}

/// `evogs check-order`: every study, a summary line per study and the count that passed.
pub(crate) fn check_order(results: &[OrderResult]) {
    for r in results {
        println!("{r}");
    }
    let failed = results.iter().filter(|r| !r.passed).count();
    println!("check-order summary:");
    for r in results {
        let fit = match (&r.study.estimate, r.expect) {
            (_, Expect::Exact) => "exact".to_string(),
            (Some(e), _) => format!("{:.3}", e.order),
            (None, _) => "none".to_string(),
        };
        let nominal = match r.expect {
            Expect::Exact => "exact".to_string(),
            Expect::Order(p) => p.to_string(),
        };
        println!(
            "  {:<20} {:<9} nominal {:<5} fitted {:<6} {}",
            r.study.problem,
            r.study.method,
            nominal,
            fit,
            if r.passed { "pass" } else { "FAIL" }
        );
    }
    println!(
        "check-order: {} of {} studies passed",
        results.len() - failed,
        results.len()
    );
}

/// `evogs check-grad`: the table and the time it took.
pub(crate) fn check_grad(table: &GradTable, seconds: f64) {
    println!("{table}");
    println!("({seconds:.1} s)");
}

/// `evogs verify`: the legend before the first file.
pub(crate) fn verify_legend(legend: &str) {
    println!("{legend}\n");
}

/// `evogs verify`: one file's report.
pub(crate) fn verify_report(report: &impl std::fmt::Display) {
    println!("{report}\n");
}

/// `evogs verify`: a file that could not be checked (on stderr, beside the reports).
pub(crate) fn verify_error(e: &impl std::fmt::Display) {
    eprintln!("error: {e}\n");
}

/// `evogs verify`: how many files passed.
pub(crate) fn verify_summary(passed: usize, total: usize) {
    println!("verify: {passed} of {total} files passed");
}

/// `evogs scenes`: one line per dataset written.
pub(crate) fn scenes(written: &[evogs_cli::app::scenes::WrittenDataset]) {
    for d in written {
        let frames: Vec<String> = d.frames.iter().map(|(s, n)| format!("{n} {s}")).collect();
        println!(
            "{}: {} Gaussians, {} frames",
            d.dir.display(),
            d.gaussians,
            frames.join(", ")
        );
    }
}
