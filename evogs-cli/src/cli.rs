//! The command line's definition: one clap struct per command. Every specification (times,
//! ranges, masks, fields, protocols, motions, sizes, counts) is parsed into its value by a
//! `value_parser` while the line is read, so a bad one is a usage error naming the flag.

use clap::{Parser, Subcommand};
use evogs::data::{DataFormat, SplitName};
use evogs_cli::app::bench::BenchArgs;
use evogs_cli::app::evaluate::parse_range;
use evogs_cli::app::inject::{FieldSpec, InjectArgs, parse_field, parse_mask};
use evogs_cli::app::render::{CameraPath, RenderArgs, parse_times};
use evogs_cli::app::study::StudyArgs;
use evogs_cli::app::train::TrainArgs;
use evogs_ode::Method;
use evogs_ode::algebra::Mask;
use std::path::PathBuf;

/// EvoGS on the CPU: 4D Gaussian splatting as a learned dynamical system.
#[derive(Parser, Debug)]
#[command(name = "evogs", version, about, long_about = None)]
pub(crate) struct Cli {
    /// The command.
    #[command(subcommand)]
    pub(crate) cmd: Cmd,
}

/// The commands.
#[derive(Subcommand, Debug)]
pub(crate) enum Cmd {
    /// Train a dynamic scene (default: the shipped toys-mini scene) and end with test metrics
    /// and a GIF.
    Train(TrainArgs),
    /// Run the paper's protocols for several motions with one preset, budget and dataset:
    /// a run per (protocol, motion, seed), each evaluated on its protocol's held-out sets,
    /// summarised in OUT/study.json, OUT/study.md (table) and OUT/study.png (bars).
    /// Resumable: finished runs are reused, interrupted runs continue from their checkpoint.
    Study(StudyArgs),
    /// Evaluate a run: PSNR and SSIM per frame and mean -> RUN/metrics-<split>.json.
    Eval(EvalCmd),
    /// Render PNG frames at any times (also beyond [0, 1] and negative) and a GIF.
    Render(RenderCmd),
    /// Edit the motion: inside a mask, replace the learned velocity by an injected field
    /// (rigid rotation or translation) and render the result.
    Inject(InjectCmd),
    /// Recompute reference-vector files (projection, raster, ode, ode adaptive, so3,
    /// metrics) in f64 and print, per file, every quantity's largest error against its
    /// tolerance (adaptive files: per problem, pair and tolerance, with the field
    /// evaluations beside scipy's RK45).
    Verify(VerifyCmd),
    /// Measure the convergence order of every stepper on the ODE test problems: error table
    /// over the step sequence and the fitted order.
    CheckOrder(CheckOrderCmd),
    /// Check every VJP of the stack and the end-to-end training step against central
    /// differences in f64; print the worst errors per group.
    CheckGrad,
    /// Time training iterations on a synthetic scene (seeded random Gaussians, one 400x400
    /// view at t = 0.45, RK4 from t = 0 in steps of 1/8): per field size and motion the
    /// seconds per iteration, a breakdown by phase, peak memory, the GFLOP/s of the field's
    /// matrix products and the speed-up over one thread (docs/performance.md).
    Bench(BenchArgs),
    /// Write the procedural scenes with known motion (D-NeRF layout, motion.json and motion
    /// masks beside): OUT/<scene>/monocular and OUT/<scene>/multiview (docs/scenes.md).
    Scenes(evogs_cli::app::scenes::ScenesArgs),
    /// Show a run in the browser: a local server on 127.0.0.1 computes the Gaussians at
    /// each time the page asks for (prints the address), or --export writes a static page.
    View(evogs_cli::app::view::ViewArgs),
    /// Export the Gaussians at time T as a standard 3DGS .ply, or a sequence of them at
    /// times A:B:N (a folder of .ply files and sequence.json).
    Export(ExportCmd),
}

/// `evogs eval`.
#[derive(clap::Args, Debug)]
pub(crate) struct EvalCmd {
    /// Run folder.
    #[arg(long)]
    pub(crate) run: PathBuf,
    /// Split: test, val, train or future.
    #[arg(long, default_value = "test")]
    pub(crate) split: SplitName,
    /// Only frames with time in A:B.
    #[arg(long, allow_hyphen_values = true, value_parser = parse_range)]
    pub(crate) time_range: Option<(f64, f64)>,
    /// Dataset folder (default: the run's).
    #[arg(long)]
    pub(crate) data: Option<PathBuf>,
    /// Dataset layout: auto, dnerf or n3dv (default: the run's, recognised from the
    /// folder).
    #[arg(long)]
    pub(crate) format: Option<DataFormat>,
}

/// The frame options `render` and `inject` share.
#[derive(clap::Args, Debug)]
pub(crate) struct FrameArgs {
    /// Times A:B:N (N frames from A to B); A may be negative (`--times -0.5:1.5:40`).
    #[arg(long, default_value = "0:1:40", allow_hyphen_values = true, value_parser = parse_times)]
    pub(crate) times: (f64, f64, usize),
    /// Cameras: orbit, test, rig (a multi-view rig's cameras in turn) or one rig camera
    /// (cam03).
    #[arg(long, default_value = "orbit")]
    pub(crate) camera: CameraPath,
    /// Also write a GIF: OUT/render.gif (render) or OUT/inject.gif (inject).
    #[arg(long)]
    pub(crate) gif: bool,
    /// Dataset folder (default: the run's).
    #[arg(long)]
    pub(crate) data: Option<PathBuf>,
    /// Dataset layout: auto, dnerf or n3dv (default: the run's, recognised from the folder).
    #[arg(long)]
    pub(crate) format: Option<DataFormat>,
    /// Replace the frames of an earlier sequence in the output folder (without it, a folder
    /// holding `frame_NNNN.png`, `frames.json` or a GIF is refused).
    #[arg(long)]
    pub(crate) force: bool,
}

/// `evogs render`.
#[derive(clap::Args, Debug)]
pub(crate) struct RenderCmd {
    /// Run folder.
    #[arg(long)]
    pub(crate) run: PathBuf,
    /// Output folder.
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Times, cameras, GIF and dataset.
    #[command(flatten)]
    pub(crate) frames: FrameArgs,
}

impl From<RenderCmd> for RenderArgs {
    fn from(c: RenderCmd) -> Self {
        Self {
            run: c.run,
            out: c.out,
            times: c.frames.times,
            camera: c.frames.camera,
            gif: c.frames.gif,
            data: c.frames.data,
            format: c.frames.format,
            force: c.frames.force,
        }
    }
}

/// `evogs inject`.
#[derive(clap::Args, Debug)]
pub(crate) struct InjectCmd {
    /// Run folder (velocity motion).
    #[arg(long)]
    pub(crate) run: PathBuf,
    /// Output folder.
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// Mask: sphere:CX,CY,CZ,R or box:X0,Y0,Z0,X1,Y1,Z1, optionally ",soft=W".
    #[arg(long, value_parser = parse_mask)]
    pub(crate) mask: Mask<f32>,
    /// Field: rotate:AX,AY,AZ,RATE[,CX,CY,CZ] (rad per unit time) or translate:UX,UY,UZ.
    #[arg(long, value_parser = parse_field)]
    pub(crate) field: FieldSpec,
    /// Times, cameras, GIF and dataset.
    #[command(flatten)]
    pub(crate) frames: FrameArgs,
}

impl From<InjectCmd> for InjectArgs {
    fn from(c: InjectCmd) -> Self {
        Self {
            run: c.run,
            out: c.out,
            mask: c.mask,
            field: c.field,
            times: c.frames.times,
            camera: c.frames.camera,
            gif: c.frames.gif,
            data: c.frames.data,
            format: c.frames.format,
            force: c.frames.force,
        }
    }
}

/// `evogs verify`.
#[derive(clap::Args, Debug)]
pub(crate) struct VerifyCmd {
    /// Reference files (JSON); the kind is recognised from the content.
    #[arg(required = true)]
    pub(crate) files: Vec<PathBuf>,
}

/// `evogs check-order`.
#[derive(clap::Args, Debug)]
pub(crate) struct CheckOrderCmd {
    /// Only this stepper (euler, midpoint, heun, rk4, rk38).
    #[arg(long)]
    pub(crate) stepper: Option<Method>,
    /// Only this problem (logistic, cos-growth, harmonic-oscillator, rotating-decay,
    /// so3-constant-rate, problem-k, symmetric-top, asymmetric-top, se3-constant-twist,
    /// se3-screw-pair, se3-propelled-top).
    #[arg(long)]
    pub(crate) problem: Option<String>,
}

/// `evogs export`: one time or a sequence of times.
#[derive(clap::Args, Debug)]
pub(crate) struct ExportCmd {
    /// Run folder.
    #[arg(long)]
    pub(crate) run: PathBuf,
    /// One time (any, negative too): write the Gaussians at it into the `.ply` file --out.
    #[arg(
        long,
        allow_hyphen_values = true,
        required_unless_present = "times",
        conflicts_with = "times"
    )]
    pub(crate) time: Option<f64>,
    /// Times A:B:N: write N `.ply` files and `sequence.json` into the folder --out.
    #[arg(long, allow_hyphen_values = true, value_parser = parse_times)]
    pub(crate) times: Option<(f64, f64, usize)>,
    /// Output `.ply` file (--time) or folder (--times).
    #[arg(long)]
    pub(crate) out: PathBuf,
    /// With --times: replace the files of an earlier sequence in the folder (without it, a
    /// folder holding `frame_NNNN.ply` or `sequence.json` is refused).
    #[arg(long)]
    pub(crate) force: bool,
}

/// Parses the command line; a usage error is one line (clap's first paragraph, which names
/// the flag or value at fault) with a pointer to `--help`, returned with clap's exit code.
/// Help and version requests are printed here and returned with exit code 0.
///
/// # Errors
/// The exit code for `main`: 0 after help or version, 2 after a usage error.
pub(crate) fn parse() -> Result<Cli, i32> {
    use clap::error::ErrorKind;
    match Cli::try_parse() {
        Ok(cli) => Ok(cli),
        Err(e)
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) =>
        {
            // Printing help can only fail on a closed stdout/stderr, which leaves nothing to
            // report to.
            let _ = e.print();
            Err(e.exit_code())
        }
        Err(e) => {
            eprintln!("{}", usage_line(&e));
            Err(2)
        }
    }
}

/// A clap error as one line: its first paragraph, a `tip:` if it gives one, and a pointer to
/// `--help`.
fn usage_line(e: &clap::Error) -> String {
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
    format!("{}{tip}; see `evogs --help`", first.join(" "))
}
