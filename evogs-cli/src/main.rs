//! The `evogs` command line: a thin clap front end over `evogs_cli::app`.
#![allow(
    rustdoc::broken_intra_doc_links,
    rustdoc::invalid_html_tags,
    reason = "the doc comments here are the command line's help text (`A:B:N`, `<split>`), not rustdoc"
)]

use anyhow::Result;
use clap::{Parser, Subcommand};
use evogs::config::Preset;
use evogs::data::{DataFormat, SplitName};
use evogs_cli::app::Reporter;
use evogs_cli::app::bench::{BenchArgs, parse_bench_motions, parse_sizes, run_bench};
use evogs_cli::app::evaluate::{evaluate_run, parse_range};
use evogs_cli::app::export::{SEQUENCE_FILE, export, export_sequence};
use evogs_cli::app::inject::{InjectArgs, inject, parse_field, parse_mask};
use evogs_cli::app::render::{CameraPath, RenderArgs, parse_times, render_sequence};
use evogs_cli::app::scenes::{ScenesArgs, write_scenes};
use evogs_cli::app::study::{StudyArgs, StudyProtocol, parse_motions, run_study};
use evogs_cli::app::train::{TrainArgs, positive_count, train};
use evogs_ode::Method;
use evogs_verify::check::grad::check_grad;
use evogs_verify::check::order::{Expect, check_order};
use evogs_verify::verify::{LEGEND, verify_file};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal as _;
use std::path::PathBuf;

/// EvoGS on the CPU: 4D Gaussian splatting as a learned dynamical system.
#[derive(Parser, Debug)]
#[command(name = "evogs", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand, Debug)]
enum Cmd {
    /// Train a dynamic scene (default: the shipped toys-mini scene) and end with test metrics
    /// and a GIF.
    Train(TrainArgs),
    /// Run the paper's protocols for several motions with one preset, budget and dataset:
    /// a run per (protocol, motion, seed), each evaluated on its protocol's held-out sets,
    /// summarised in OUT/study.json, OUT/study.md (table) and OUT/study.png (bars).
    /// Resumable: finished runs are reused, interrupted runs continue from their checkpoint.
    Study {
        /// Dataset folder (default: data/toys-mini shipped with evogs).
        #[arg(long)]
        data: Option<PathBuf>,
        /// Study folder (runs in OUT/runs/, the summary in OUT/study.*).
        #[arg(long, default_value = "runs/study")]
        out: PathBuf,
        /// Protocols, comma-separated: full, sparse:K (K >= 2), future:TAU, backward:TAU
        /// (0 < TAU < 1).
        #[arg(long, default_value = "full,sparse:4,future:0.75")]
        protocols: String,
        /// Motions, comma-separated: velocity, deformation, static.
        #[arg(long, default_value = "velocity,deformation,static")]
        motions: String,
        /// Preset of every run: fast (default) or paper.
        #[arg(long)]
        preset: Option<Preset>,
        /// TOML file overlaid on the preset for every run.
        #[arg(long)]
        config: Option<PathBuf>,
        /// Iterations per run (default: the preset's; shortens warm-up and curriculum to fit).
        #[arg(long, allow_negative_numbers = true, value_parser = positive_count)]
        iters: Option<u64>,
        /// Repeats per protocol and motion, with seeds seed, seed+1, ...; the table reports
        /// mean and standard deviation.
        #[arg(long, default_value_t = 1, allow_negative_numbers = true, value_parser = positive_count)]
        seeds: u64,
        /// Runs at once; the threads are divided among them.
        #[arg(long, default_value_t = 1, allow_negative_numbers = true, value_parser = positive_count)]
        jobs: u64,
        /// Retrain every run, finished or interrupted.
        #[arg(long)]
        force: bool,
    },
    /// Evaluate a run: PSNR and SSIM per frame and mean -> RUN/metrics-<split>.json.
    Eval {
        /// Run folder.
        #[arg(long)]
        run: PathBuf,
        /// Split: test, val, train or future.
        #[arg(long, default_value = "test")]
        split: SplitName,
        /// Only frames with time in A:B.
        #[arg(long, allow_hyphen_values = true)]
        time_range: Option<String>,
        /// Dataset folder (default: the run's).
        #[arg(long)]
        data: Option<PathBuf>,
        /// Dataset layout: auto, dnerf or n3dv (default: the run's, recognised from the
        /// folder).
        #[arg(long)]
        format: Option<DataFormat>,
    },
    /// Render PNG frames at any times (also beyond [0, 1] and negative) and a GIF.
    Render {
        /// Run folder.
        #[arg(long)]
        run: PathBuf,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        #[command(flatten)]
        frames: FrameArgs,
    },
    /// Edit the motion: inside a mask, replace the learned velocity by an injected field
    /// (rigid rotation or translation) and render the result.
    Inject {
        /// Run folder (velocity motion).
        #[arg(long)]
        run: PathBuf,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Mask: sphere:CX,CY,CZ,R or box:X0,Y0,Z0,X1,Y1,Z1, optionally ",soft=W".
        #[arg(long)]
        mask: String,
        /// Field: rotate:AX,AY,AZ,RATE[,CX,CY,CZ] (rad per unit time) or translate:UX,UY,UZ.
        #[arg(long)]
        field: String,
        #[command(flatten)]
        frames: FrameArgs,
    },
    /// Recompute reference-vector files (projection, raster, ode, ode adaptive, so3,
    /// metrics) in f64 and print, per file, every quantity's largest error against its
    /// tolerance (adaptive files: per problem, pair and tolerance, with the field
    /// evaluations beside scipy's RK45).
    Verify {
        /// Reference files (JSON); the kind is recognised from the content.
        #[arg(required = true)]
        files: Vec<PathBuf>,
    },
    /// Measure the convergence order of every stepper on the ODE test problems: error table
    /// over the step sequence and the fitted order.
    CheckOrder {
        /// Only this stepper (euler, midpoint, heun, rk4, rk38).
        #[arg(long)]
        stepper: Option<Method>,
        /// Only this problem (logistic, cos-growth, harmonic-oscillator, rotating-decay,
        /// so3-constant-rate, problem-k, symmetric-top, asymmetric-top, se3-constant-twist,
        /// se3-screw-pair, se3-propelled-top).
        #[arg(long)]
        problem: Option<String>,
    },
    /// Check every VJP of the stack and the end-to-end training step against central
    /// differences in f64; print the worst errors per group.
    CheckGrad,
    /// Time training iterations on a synthetic scene (seeded random Gaussians, one 400x400
    /// view at t = 0.45, RK4 from t = 0 in steps of 1/8): per field size and motion the
    /// seconds per iteration, a breakdown by phase, peak memory, the GFLOP/s of the field's
    /// matrix products and the speed-up over one thread (docs/performance.md).
    Bench {
        /// Gaussians in the scene.
        #[arg(long, default_value_t = 20_000, allow_negative_numbers = true, value_parser = positive_count)]
        gaussians: u64,
        /// Untimed iterations before the timed ones (per configuration and thread count).
        #[arg(long, default_value_t = 2, allow_negative_numbers = true, value_parser = whole_count)]
        warmup: u64,
        /// Timed iterations (per configuration and thread count).
        #[arg(long, default_value_t = 5, allow_negative_numbers = true, value_parser = positive_count)]
        iters: u64,
        /// Motions, comma-separated: velocity, deformation.
        #[arg(long, default_value = "velocity,deformation")]
        motions: String,
        /// Field sizes, comma-separated: paper (HexPlane 2 levels x 32 channels at 64^3 x 25,
        /// MLP 64 wide), fast (2 levels x 16 channels at 32^3 x 16, MLP 32 wide).
        #[arg(long, default_value = "paper,fast")]
        sizes: String,
        /// Threads of the pool (default: `RAYON_NUM_THREADS` or the logical CPUs).
        #[arg(long, allow_negative_numbers = true, value_parser = positive_count)]
        threads: Option<u64>,
        /// Skip the one-thread runs (no speed-up column).
        #[arg(long)]
        no_single_thread: bool,
        /// Also write every figure to this JSON file.
        #[arg(long)]
        json: Option<PathBuf>,
        /// Scene seed.
        #[arg(long, default_value_t = 0)]
        seed: u64,
    },
    /// Write the procedural scenes with known motion (D-NeRF layout, motion.json and motion
    /// masks beside): OUT/<scene>/monocular and OUT/<scene>/multiview (docs/scenes.md).
    Scenes {
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
        /// Only these scenes, comma-separated (translate, throw, spin, orbit, pendulum,
        /// wave, pair).
        #[arg(long)]
        only: Option<String>,
        /// Image width and height (pixels).
        #[arg(long, default_value_t = 128)]
        size: usize,
        /// Generator seed.
        #[arg(long, default_value_t = 0)]
        seed: u64,
    },
    /// Export the Gaussians at time T as a standard 3DGS .ply, or a sequence of them at
    /// times A:B:N (a folder of .ply files and sequence.json).
    Export {
        /// Run folder.
        #[arg(long)]
        run: PathBuf,
        /// One time (any, negative too): write the Gaussians at it into the `.ply` file --out.
        #[arg(
            long,
            allow_hyphen_values = true,
            required_unless_present = "times",
            conflicts_with = "times"
        )]
        time: Option<f64>,
        /// Times A:B:N: write N `.ply` files and `sequence.json` into the folder --out.
        #[arg(long, allow_hyphen_values = true)]
        times: Option<String>,
        /// Output `.ply` file (--time) or folder (--times).
        #[arg(long)]
        out: PathBuf,
    },
}

/// A whole number of at least 0 (warm-up iterations), with a message that says so for `-1`
/// or `1.5`.
fn whole_count(s: &str) -> Result<u64, String> {
    s.trim()
        .parse::<u64>()
        .map_err(|_| format!("`{s}` is not a whole number of at least 0"))
}

/// The frame options `render` and `inject` share.
#[derive(clap::Args, Debug)]
struct FrameArgs {
    /// Times A:B:N (N frames from A to B); A may be negative (`--times -0.5:1.5:40`).
    #[arg(long, default_value = "0:1:40", allow_hyphen_values = true)]
    times: String,
    /// Cameras: orbit, test, rig (a multi-view rig's cameras in turn) or one rig camera
    /// (cam03).
    #[arg(long, default_value = "orbit")]
    camera: CameraPath,
    /// Also write a GIF: OUT/render.gif (render) or OUT/inject.gif (inject).
    #[arg(long)]
    gif: bool,
    /// Dataset folder (default: the run's).
    #[arg(long)]
    data: Option<PathBuf>,
    /// Dataset layout: auto, dnerf or n3dv (default: the run's, recognised from the folder).
    #[arg(long)]
    format: Option<DataFormat>,
}

/// Progress bars and messages on the terminal; when stderr is not a terminal (logs, CI), a
/// progress line every 5% of a phase instead of a bar.
struct Terminal {
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

/// Parses the command line; a usage error is printed as one line (clap's first paragraph,
/// which names the flag or value at fault) with a pointer to `--help`, exit code 2.
fn parse_cli() -> Cli {
    use clap::error::ErrorKind;
    match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e)
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) =>
        {
            e.exit()
        }
        Err(e) => {
            let text = e.render().to_string();
            let first: Vec<&str> = text
                .lines()
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect();
            let tip = text
                .lines()
                .map(str::trim)
                .find(|l| l.starts_with("tip:"))
                .map(|t| format!(" ({t})"))
                .unwrap_or_default();
            eprintln!("{}{tip}; see `evogs --help`", first.join(" "));
            std::process::exit(2);
        }
    }
}

/// Runs the command; an error is printed as one line (`Error: ...`, its causes joined with
/// `: `, never a backtrace) with exit code 1.
fn main() {
    if let Err(e) = run(parse_cli()) {
        eprintln!("Error: {e:#}");
        std::process::exit(1);
    }
}

fn run(cli: Cli) -> Result<()> {
    evogs_cli::app::interrupt::install().map_err(anyhow::Error::msg)?;
    let mut term = Terminal {
        bar: None,
        phase: String::new(),
        total: 0,
        next_line: 0,
        started: std::time::Instant::now(),
    };
    match cli.cmd {
        Cmd::Train(args) => {
            let o = train(&args, &mut term)?;
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
        Cmd::Study {
            data,
            out,
            protocols,
            motions,
            preset,
            config,
            iters,
            seeds,
            jobs,
            force,
        } => {
            let args = StudyArgs {
                data,
                out,
                protocols: StudyProtocol::parse_list(&protocols)
                    .map_err(|e| anyhow::anyhow!("--protocols: {e}"))?,
                motions: parse_motions(&motions).map_err(|e| anyhow::anyhow!("--motions: {e}"))?,
                preset,
                config,
                iters,
                seeds: usize::try_from(seeds)?,
                jobs: usize::try_from(jobs)?,
                force,
                command: std::env::args().collect::<Vec<_>>().join(" "),
            };
            let o = run_study(&args, &mut term)?;
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
        Cmd::Eval {
            run,
            split,
            time_range,
            data,
            format,
        } => {
            let range = time_range
                .as_deref()
                .map(parse_range)
                .transpose()
                .map_err(|e| anyhow::anyhow!("--time-range: {e}"))?;
            let (m, path) = evaluate_run(&run, split, range, data.as_deref(), format, &mut term)?;
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
        Cmd::Render { run, out, frames } => {
            let o = render_sequence(
                &RenderArgs {
                    run,
                    out,
                    times: parse_times(&frames.times)
                        .map_err(|e| anyhow::anyhow!("--times: {e}"))?,
                    camera: frames.camera,
                    gif: frames.gif,
                    data: frames.data,
                    format: frames.format,
                },
                None,
                &mut term,
            )?;
            println!("{} frames written to {}", o.count, o.dir.display());
            if let Some(g) = o.gif {
                println!("gif: {}", g.display());
            }
        }
        Cmd::Inject {
            run,
            out,
            mask,
            field,
            frames,
        } => {
            let args = InjectArgs {
                run,
                out,
                mask: parse_mask(&mask).map_err(|e| anyhow::anyhow!("--mask: {e}"))?,
                field: parse_field(&field).map_err(|e| anyhow::anyhow!("--field: {e}"))?,
                times: parse_times(&frames.times).map_err(|e| anyhow::anyhow!("--times: {e}"))?,
                camera: frames.camera,
                gif: frames.gif,
                data: frames.data,
                format: frames.format,
            };
            let o = inject(&args, &mut term)?;
            println!("{} frames written to {}", o.count, o.dir.display());
            if let Some(g) = o.gif {
                println!("gif: {}", g.display());
            }
        }
        Cmd::Bench {
            gaussians,
            warmup,
            iters,
            motions,
            sizes,
            threads,
            no_single_thread,
            json,
            seed,
        } => {
            let args = BenchArgs {
                gaussians: usize::try_from(gaussians)
                    .map_err(|_| anyhow::anyhow!("--gaussians: {gaussians} is too large"))?,
                warmup,
                iters,
                motions: parse_bench_motions(&motions)
                    .map_err(|e| anyhow::anyhow!("--motions: {e}"))?,
                sizes: parse_sizes(&sizes).map_err(|e| anyhow::anyhow!("--sizes: {e}"))?,
                threads: threads
                    .map(usize::try_from)
                    .transpose()
                    .map_err(|_| anyhow::anyhow!("--threads: too large"))?,
                single_thread: !no_single_thread,
                json,
                seed,
            };
            let report = run_bench(&args, &mut term)?;
            print!("{}", report.table());
            if let Some(p) = &args.json {
                println!("\nreport: {}", p.display());
            }
        }
        Cmd::Scenes {
            out,
            only,
            size,
            seed,
        } => {
            let args = ScenesArgs {
                out,
                only: only
                    .map(|s| s.split(',').map(|n| n.trim().to_string()).collect())
                    .unwrap_or_default(),
                size,
                seed,
            };
            for d in write_scenes(&args, &mut term)? {
                let frames: Vec<String> =
                    d.frames.iter().map(|(s, n)| format!("{n} {s}")).collect();
                println!(
                    "{}: {} Gaussians, {} frames",
                    d.dir.display(),
                    d.gaussians,
                    frames.join(", ")
                );
            }
        }
        Cmd::Export {
            run,
            time,
            times,
            out,
        } => match (time, times) {
            (Some(t), _) => {
                let n = export(&run, t, &out)?;
                println!("{n} Gaussians at t = {t} -> {}", out.display());
            }
            (None, Some(spec)) => {
                let times = parse_times(&spec).map_err(|e| anyhow::anyhow!("--times: {e}"))?;
                let seq = export_sequence(&run, times, &out, &mut term)?;
                println!(
                    "{} files of {} Gaussians -> {} ({})",
                    seq.files.len(),
                    seq.gaussians,
                    out.display(),
                    SEQUENCE_FILE
                );
            }
            (None, None) => anyhow::bail!("export needs --time T or --times A:B:N"),
        },
        Cmd::CheckOrder { stepper, problem } => {
            let results = check_order(stepper, problem.as_deref())?;
            for r in &results {
                println!("{r}");
            }
            let failed = results.iter().filter(|r| !r.passed).count();
            println!("check-order summary:");
            for r in &results {
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
            if failed > 0 {
                std::process::exit(1);
            }
        }
        Cmd::CheckGrad => {
            let start = std::time::Instant::now();
            let table = check_grad(usize::MAX);
            println!("{table}");
            println!("({:.1} s)", start.elapsed().as_secs_f64());
            if !table.passed() {
                std::process::exit(1);
            }
        }
        Cmd::Verify { files } => {
            let mut bad = 0_usize;
            println!("{LEGEND}\n");
            for f in &files {
                match verify_file(f) {
                    Ok(r) => {
                        println!("{r}\n");
                        bad += usize::from(!r.passed());
                    }
                    Err(e) => {
                        eprintln!("error: {e}\n");
                        bad += 1;
                    }
                }
            }
            println!(
                "verify: {} of {} files passed",
                files.len() - bad,
                files.len()
            );
            if bad > 0 {
                std::process::exit(1);
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::{Cli, Cmd};
    use clap::{CommandFactory, Parser};
    use evogs_cli::app::render::CameraPath;

    #[test]
    fn command_line_definition_is_consistent() {
        Cli::command().debug_assert();
    }

    /// Parses a command line given as one string (arguments split at spaces).
    fn parse(line: &str) -> Cmd {
        Cli::try_parse_from(std::iter::once("evogs").chain(line.split(' ')))
            .unwrap_or_else(|e| panic!("`{line}` does not parse: {e}"))
            .cmd
    }

    #[test]
    fn render_and_inject_read_the_shared_frame_options() {
        let Cmd::Render { frames, .. } =
            parse("render --run r --out o --times -1:2:5 --camera test --gif")
        else {
            panic!("not render")
        };
        assert_eq!(frames.times, "-1:2:5");
        assert_eq!(frames.camera, CameraPath::Test);
        assert!(frames.gif && frames.data.is_none());
        let Cmd::Inject { frames, .. } =
            parse("inject --run r --out o --mask sphere:0,0,0,1 --field translate:1,0,0 --data d")
        else {
            panic!("not inject")
        };
        assert_eq!(frames.times, "0:1:40");
        assert_eq!(frames.camera, CameraPath::Orbit);
        assert!(!frames.gif);
        assert_eq!(frames.data.as_deref(), Some(std::path::Path::new("d")));
    }

    #[test]
    fn counts_must_be_whole_and_positive() {
        for bad in ["-5", "0", "1.5", "x"] {
            let e = Cli::try_parse_from(["evogs", "train", "--iters", bad])
                .expect_err(bad)
                .to_string();
            assert!(
                e.contains("whole number of at least 1"),
                "--iters {bad}: {e}"
            );
            let e = Cli::try_parse_from(["evogs", "study", "--jobs", bad])
                .expect_err(bad)
                .to_string();
            assert!(
                e.contains("whole number of at least 1"),
                "--jobs {bad}: {e}"
            );
        }
        let Cmd::Study {
            iters, seeds, jobs, ..
        } = parse("study --iters 30 --seeds 3 --jobs 2")
        else {
            panic!("not study")
        };
        assert_eq!((iters, seeds, jobs), (Some(30), 3, 2), "parsed");
    }

    #[test]
    fn negative_times_parse_without_an_equals_sign() {
        let Cmd::Export { time, .. } = parse("export --run r --time -0.5 --out o.ply") else {
            panic!("not export")
        };
        assert_eq!(time, Some(-0.5), "parsed");
        let Cmd::Eval { time_range, .. } = parse("eval --run r --time-range -1:0.5") else {
            panic!("not eval")
        };
        assert_eq!(time_range.as_deref(), Some("-1:0.5"));
        // The price of accepting a leading hyphen: a forgotten value swallows the next flag,
        // which the times parser then rejects with a message.
        assert!(evogs_cli::app::render::parse_times("--gif").is_err());
    }
}
