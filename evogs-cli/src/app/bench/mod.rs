//! `evogs bench`: the cost of one training iteration on a synthetic scene, per field size
//! and motion, with a breakdown by phase, peak memory, the rate of the field's matrix
//! products and the speed-up of the thread pool over one thread (docs/performance.md).
//!
//! Every configuration builds the same seeded scene ([`BenchScene`]) and a fresh model
//! ([`BenchRun`]), runs `warmup` untimed and `iters` timed iterations on a pool of the chosen
//! size, then the same on a one-thread pool (results are bitwise the same for any thread
//! count, which the report checks through the losses).

mod iteration;
pub mod machine;
mod report;
pub mod scene;
mod system;
mod threads;

pub use iteration::{BenchRun, IterationSample, MAX_STEP, VIEW_TIME};
pub use report::{
    BenchReport, BenchRow, FieldWork, GemmFigures, Phases, Sample, SingleThread, Summary,
};
pub use scene::BenchScene;
pub use system::{cpu_model, current_rss_bytes, peak_rss_bytes, reset_peak_rss};
pub use threads::Threads;

use super::Reporter;
use super::counts::{positive_count, positive_size, whole_count};
use super::error::CommandError;
use super::interrupt;
use evogs::config::TrainConfig;
use evogs::model::Motion;
use std::path::PathBuf;

/// The largest scene the bench builds.
pub const MAX_GAUSSIANS: usize = 10_000_000;

/// A field size: the field of a training preset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldSize {
    /// [`TrainConfig::paper`]'s field: HexPlane 2 levels × 32 channels at [64, 64, 64, 25],
    /// MLP 64 wide.
    Paper,
    /// [`TrainConfig::fast`]'s field: 2 levels × 16 channels at [32, 32, 32, 16], MLP 32
    /// wide.
    Fast,
}

impl FieldSize {
    /// `paper` or `fast`.
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Paper => "paper",
            Self::Fast => "fast",
        }
    }

    /// The preset whose field, loss weight and optimiser settings the bench uses.
    #[must_use]
    pub fn config(self) -> TrainConfig {
        match self {
            Self::Paper => TrainConfig::paper(),
            Self::Fast => TrainConfig::fast(),
        }
    }
}

/// A comma-separated list of field sizes (`paper`, `fast`), each at most once.
///
/// # Errors
/// An unknown or repeated size, or an empty list.
pub fn parse_sizes(s: &str) -> Result<Vec<FieldSize>, String> {
    let mut out = Vec::new();
    for part in s.split(',') {
        let size = match part.trim() {
            "paper" => FieldSize::Paper,
            "fast" => FieldSize::Fast,
            other => return Err(format!("unknown field size `{other}` (paper, fast)")),
        };
        if out.contains(&size) {
            return Err(format!("field size `{}` is listed twice", size.as_str()));
        }
        out.push(size);
    }
    Ok(out)
}

/// A comma-separated list of motions the bench can time (`velocity`, `deformation`; static
/// motion has no field), each at most once.
///
/// # Errors
/// An unknown, static or repeated motion.
pub fn parse_bench_motions(s: &str) -> Result<Vec<Motion>, String> {
    let motions = super::study::parse_motions(s)?;
    if motions.contains(&Motion::Static) {
        return Err("static motion has no field to time (velocity, deformation)".into());
    }
    Ok(motions)
}

/// The arguments of `evogs bench`: the command line's flags (clap), each list parsed into
/// its values when the line is read.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct BenchArgs {
    /// Gaussians in the scene.
    #[arg(long, default_value_t = 20_000, allow_negative_numbers = true, value_parser = positive_size)]
    pub gaussians: usize,
    /// Untimed iterations before the timed ones (per configuration and thread count).
    #[arg(long, default_value_t = 2, allow_negative_numbers = true, value_parser = whole_count)]
    pub warmup: u64,
    /// Timed iterations (per configuration and thread count).
    #[arg(long, default_value_t = 5, allow_negative_numbers = true, value_parser = positive_count)]
    pub iters: u64,
    /// Motions, comma-separated: velocity, deformation.
    #[arg(long, default_value = "velocity,deformation", value_parser = parse_bench_motions)]
    pub motions: std::vec::Vec<Motion>,
    /// Field sizes, comma-separated: paper (HexPlane 2 levels x 32 channels at 64^3 x 25,
    /// MLP 64 wide), fast (2 levels x 16 channels at 32^3 x 16, MLP 32 wide).
    #[arg(long, default_value = "paper,fast", value_parser = parse_sizes)]
    pub sizes: std::vec::Vec<FieldSize>,
    /// Threads of the pool (default: `RAYON_NUM_THREADS` or the logical CPUs).
    #[arg(long, allow_negative_numbers = true, value_parser = positive_size)]
    pub threads: Option<usize>,
    /// Also run every configuration on one thread when the pool has more (for the speed-up
    /// column); the flag `--no-single-thread` turns it off.
    #[arg(
        long = "no-single-thread",
        action = clap::ArgAction::SetFalse,
        help = "Skip the one-thread runs (no speed-up column)"
    )]
    pub single_thread: bool,
    /// Rounds per configuration: each runs the warm-up and timed iterations on the pool and
    /// then on one thread, so that a drift of the machine's speed during the bench falls on
    /// both sides of the speed-up alike (the figures are over every round's iterations).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true, value_parser = positive_count)]
    pub rounds: u64,
    /// Also write every figure to this JSON file.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Scene seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Measure this machine's limits instead (the f32 FMA peak, and the read bandwidth of
    /// data in L1, L2, L3 and memory, with one thread and with --threads).
    #[arg(long)]
    pub machine: bool,
}

impl Default for BenchArgs {
    fn default() -> Self {
        Self {
            gaussians: 20_000,
            warmup: 2,
            iters: 5,
            motions: vec![Motion::Velocity, Motion::Deformation],
            sizes: vec![FieldSize::Paper, FieldSize::Fast],
            threads: None,
            single_thread: true,
            rounds: 1,
            json: None,
            seed: 0,
            machine: false,
        }
    }
}

/// What one pool measured for one configuration.
struct PoolRun {
    samples: Vec<IterationSample>,
    gemm_flops: u64,
    field_params: usize,
    peak_rss: Option<u64>,
}

/// Builds the configuration and runs its warm-up and timed iterations on `threads`,
/// reporting each iteration.
fn run_pool(
    scene: &BenchScene,
    size: FieldSize,
    motion: Motion,
    args: &BenchArgs,
    threads: &Threads,
    rep: &mut dyn Reporter,
) -> Result<PoolRun, CommandError> {
    let phase = format!("{}/{} x{}", size.as_str(), motion.as_str(), threads.count());
    let mut run = threads.run(|| BenchRun::new(scene, size.config(), motion));
    let total = args.warmup + args.iters;
    rep.start(&phase, total);
    let mut samples = Vec::with_capacity(usize::try_from(args.iters).unwrap_or(0));
    let mut gemm_flops = 0;
    for i in 0..total {
        if interrupt::requested() {
            rep.finish();
            return Err(CommandError::new("bench interrupted; nothing written"));
        }
        let sample = threads
            .run(|| run.step())
            .map_err(|e| CommandError::new(format!("{phase}: {e}")))?;
        rep.progress(i + 1, &format!("{:.3} s", sample.seconds));
        if i >= args.warmup {
            gemm_flops = run.gemm_flops(&sample.field);
            samples.push(sample);
        }
    }
    rep.finish();
    let field_params = run.field_params();
    drop(run);
    Ok(PoolRun {
        samples,
        gemm_flops,
        field_params,
        peak_rss: peak_rss_bytes(),
    })
}

/// The GEMM figures of a pool's samples.
fn gemm_figures(p: &PoolRun) -> GemmFigures {
    let (flops, k) = (p.gemm_flops as f64, p.samples.len() as f64);
    let thread_seconds = p
        .samples
        .iter()
        .map(|s| s.field.gemm_thread_seconds)
        .sum::<f64>()
        / k.max(1.0);
    GemmFigures {
        flops: p.gemm_flops,
        thread_seconds,
        gflops: if thread_seconds > 0.0 {
            flops / thread_seconds * 1e-9
        } else {
            0.0
        },
    }
}

/// Runs the bench: every (size, motion) on the pool, then on one thread; writes the JSON if
/// asked for and returns the report (the binary prints [`BenchReport::table`]).
///
/// # Errors
/// Bad arguments (naming the flag), a pool that cannot start, a non-finite step, an
/// interrupt, or the JSON file cannot be written.
pub fn run_bench(args: &BenchArgs, rep: &mut dyn Reporter) -> Result<BenchReport, CommandError> {
    if args.gaussians == 0 || args.gaussians > MAX_GAUSSIANS {
        return Err(CommandError::new(format!(
            "--gaussians: {} is not between 1 and {MAX_GAUSSIANS}",
            args.gaussians
        )));
    }
    if args.iters == 0 {
        return Err(CommandError::new("--iters: at least 1 timed iteration"));
    }
    if args.rounds == 0 {
        return Err(CommandError::new("--rounds: at least 1 round"));
    }
    if args.sizes.is_empty() || args.motions.is_empty() {
        return Err(CommandError::new(
            "the bench needs at least one size (--sizes) and one motion (--motions)",
        ));
    }
    if args.motions.contains(&Motion::Static) {
        return Err(CommandError::new(
            "--motions: static motion has no field to time",
        ));
    }
    if args.threads == Some(0) {
        return Err(CommandError::new("--threads: at least 1"));
    }
    let pool = Threads::new(args.threads).map_err(|e| e.context("--threads"))?;
    let single = if args.single_thread && pool.count() > 1 {
        Some(Threads::new(Some(1))?)
    } else {
        None
    };
    rep.info(&format!(
        "bench: {} Gaussians, {} threads; building the scene",
        args.gaussians,
        pool.count()
    ));
    let scene = BenchScene::new(args.gaussians, args.seed)
        .map_err(|e| CommandError::new(format!("bench camera: {e}")))?;
    let mut peak_rss_reset = true;
    let mut rows = Vec::new();
    for &size in &args.sizes {
        for &motion in &args.motions {
            peak_rss_reset &= reset_peak_rss();
            let rss_at_start_bytes = current_rss_bytes();
            // Round 1 gives the peak memory (the pool's, before the one-thread run).
            let mut main = run_pool(&scene, size, motion, args, &pool, rep)?;
            let mut one = match &single {
                Some(t) => Some(run_pool(&scene, size, motion, args, t, rep)?),
                None => None,
            };
            for _ in 1..args.rounds {
                let more = run_pool(&scene, size, motion, args, &pool, rep)?;
                main.samples.extend(more.samples);
                if let (Some(o), Some(t)) = (&mut one, &single) {
                    o.samples
                        .extend(run_pool(&scene, size, motion, args, t, rep)?.samples);
                }
            }
            let threads = pool.count();
            let seconds: Vec<f64> = main.samples.iter().map(|s| s.seconds).collect();
            let losses: Vec<f64> = main.samples.iter().map(|s| s.loss).collect();
            let summary = Summary::of(&seconds);
            let single_thread = match one {
                Some(o) => {
                    let secs: Vec<f64> = o.samples.iter().map(|s| s.seconds).collect();
                    let s = Summary::of(&secs);
                    #[allow(clippy::float_cmp, reason = "bitwise equality is the claim")]
                    let same_losses = o.samples.len() == losses.len()
                        && o.samples.iter().zip(&losses).all(|(a, &b)| a.loss == b);
                    Some(SingleThread {
                        seconds: s,
                        phases: Phases::mean(o.samples.iter().map(|x| &x.phases)),
                        gemm: gemm_figures(&o),
                        speedup: if summary.median > 0.0 {
                            s.median / summary.median
                        } else {
                            0.0
                        },
                        same_losses,
                    })
                }
                None => None,
            };
            let last = main.samples.last().map(|s| s.field).unwrap_or_default();
            rows.push(BenchRow {
                size: size.as_str().into(),
                motion,
                field_params: main.field_params,
                threads,
                seconds: summary,
                phases: Phases::mean(main.samples.iter().map(|s| &s.phases)),
                samples: main
                    .samples
                    .iter()
                    .map(|s| Sample {
                        seconds: s.seconds,
                        phases: s.phases,
                    })
                    .collect(),
                losses,
                field: FieldWork {
                    evaluations: last.evaluations,
                    vjps: last.vjps,
                    forward_rows: last.forward_rows,
                    backward_rows: last.backward_rows,
                },
                gemm: gemm_figures(&main),
                peak_rss_bytes: main.peak_rss,
                rss_at_start_bytes,
                single_thread,
            });
        }
    }
    let report = BenchReport {
        version: env!("CARGO_PKG_VERSION").into(),
        cpu: cpu_model(),
        logical_cpus: std::thread::available_parallelism().map_or(1, std::num::NonZero::get),
        threads: pool.count(),
        gaussians: args.gaussians,
        image: [scene.camera.width, scene.camera.height],
        warmup: args.warmup,
        iters: args.iters,
        rounds: args.rounds,
        seed: args.seed,
        peak_rss_reset,
        rows,
    };
    if let Some(path) = &args.json {
        let text = serde_json::to_string_pretty(&report).map_err(CommandError::new)?;
        evogs::atomic::write_atomic_named(path, text.as_bytes()).map_err(CommandError::new)?;
    }
    Ok(report)
}
