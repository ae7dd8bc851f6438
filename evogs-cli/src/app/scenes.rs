//! `evogs scenes`: writes the procedural scenes with known motion (`evogs::scenes`), each in
//! a monocular and a multi-view variant: `OUT/<scene>/{monocular,multiview}/`, each a D-NeRF
//! dataset with `motion.json` and motion masks beside.

use super::Reporter;
use super::error::CommandError;
use evogs::scenes::{BuiltScene, Layout, Spacing, Variant, select, write_scene};
use evogs_math::Par;
use std::path::PathBuf;

/// The arguments of `evogs scenes`.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct ScenesArgs {
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Only these scenes, comma-separated (translate, throw, spin, orbit, pendulum, wave,
    /// pair; default: all).
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
    /// Image width and height (pixels).
    #[arg(long, default_value_t = 128)]
    pub size: usize,
    /// Generator seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

impl Default for ScenesArgs {
    fn default() -> Self {
        Self {
            out: PathBuf::from("data/scenes"),
            only: Vec::new(),
            size: Layout::default().size,
            seed: 0,
        }
    }
}

/// One dataset written by [`write_scenes`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WrittenDataset {
    /// Its folder.
    pub dir: PathBuf,
    /// Frames per split.
    pub frames: Vec<(&'static str, usize)>,
    /// Gaussians of the scene.
    pub gaussians: usize,
}

/// Runs `evogs scenes`.
///
/// # Errors
/// An unknown scene name, a size below 8 pixels, or an I/O failure.
pub fn write_scenes(
    args: &ScenesArgs,
    rep: &mut dyn Reporter,
) -> Result<Vec<WrittenDataset>, CommandError> {
    if args.size < 8 {
        return Err(CommandError::new(format!(
            "--size {}: images must be at least 8 pixels wide",
            args.size
        )));
    }
    let specs = select(&args.only).map_err(CommandError::new)?;
    let layout = Layout {
        size: args.size,
        ..Layout::default()
    };
    let mut out = Vec::new();
    for (k, spec) in specs.iter().enumerate() {
        let scene = BuiltScene::new(spec, Spacing::default(), args.seed.wrapping_add(k as u64));
        for variant in [Variant::Monocular, Variant::Multiview] {
            let dir = args.out.join(spec.name).join(variant.as_str());
            rep.start(
                &format!("{} / {}", spec.name, variant.as_str()),
                layout.frame_count(variant) as u64,
            );
            let w = write_scene(&scene, variant, &layout, &dir, Par::best(), |d, n| {
                rep.progress(d as u64, &format!("{d}/{n} frames"));
            })
            .map_err(CommandError::new)?;
            rep.finish();
            out.push(WrittenDataset {
                dir,
                frames: w.frames,
                gaussians: w.gaussians,
            });
        }
    }
    Ok(out)
}
