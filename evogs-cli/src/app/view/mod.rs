//! `evogs view`: a trained run's Gaussians in the browser (`docs/viewer.md`). A local server
//! on 127.0.0.1 computes the Gaussians at each time the page asks for with the run's own
//! model; or, with `--export DIR`, the page and precomputed frames are written as static
//! files for any web server. The page renders with Spark on three.js, vendored from npm and
//! embedded in the binary (`assets/viewer/PROVENANCE.md`).

pub mod assets;
pub mod frames;
pub mod scene;
pub mod server;
pub mod wire;

use super::error::CommandError;
use super::load::load_dataset;
use super::paths::RunFolder;
use super::render::{frame_time, parse_times};
use super::{Reporter, interrupt};
use evogs::model::Model;
use evogs::run::checkpoint;
use frames::{DEFAULT_CACHE_FRAMES, FrameSource};
use scene::{SceneFrames, SceneInfo};
use server::ViewServer;
use std::path::{Path, PathBuf};

/// The options of `evogs view`.
#[derive(Clone, Debug, Default, PartialEq, Eq, clap::Args)]
pub struct ViewArgs {
    /// Run folder.
    #[arg(long)]
    pub run: PathBuf,
    /// Port on 127.0.0.1 (default: a free one).
    #[arg(long, conflicts_with = "export")]
    pub port: Option<u16>,
    /// Dataset folder for the cameras (default: the one recorded in the run).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Write the page and precomputed frames into this folder instead of serving.
    #[arg(long)]
    pub export: Option<PathBuf>,
    /// Times A:B:N of the exported frames (default: the page's slider range, 61 frames).
    #[arg(long, allow_hyphen_values = true, requires = "export")]
    pub times: Option<String>,
}

/// Frames of an export when `--times` is not given.
pub const DEFAULT_EXPORT_FRAMES: usize = 61;

/// A run opened for viewing: its model, the page's scene description and the colours.
#[derive(Debug)]
pub struct Viewer {
    /// What the page is told first.
    pub scene: SceneInfo,
    /// The colours and opacities ([`wire::encode_static`]).
    pub static_bin: Vec<u8>,
    /// The model, evaluated per time.
    pub frames: FrameSource,
}

impl Viewer {
    /// Loads the run's model and its dataset's cameras (no images).
    ///
    /// # Errors
    /// An unreadable run, checkpoint or dataset.
    pub fn open(run: &Path, data: Option<&Path>) -> Result<Self, CommandError> {
        let folder = RunFolder::new(run);
        let l = checkpoint::load_model(&folder.checkpoint()).map_err(CommandError::new)?;
        let dir = match data {
            Some(d) => d.to_path_buf(),
            None => folder.data_dir()?,
        };
        let ds = load_dataset(&dir, &l.cfg, false)?;
        let model: Model<f32> = l.model;
        let scene = SceneInfo::new(&model, &ds);
        let static_bin = wire::encode_static(&model.canonical);
        Ok(Self {
            scene,
            static_bin,
            frames: FrameSource::new(model, DEFAULT_CACHE_FRAMES),
        })
    }

    /// Writes the page, `scene.json` (listing the frames), `static.bin` and one
    /// `frames/NNNN.bin` per time into `dir`; returns the number of frames. An interrupt stops
    /// before the next frame.
    ///
    /// # Errors
    /// A time out of the model's reach (the text `evogs render` gives), an unwritable folder,
    /// or an interrupt.
    pub fn export(
        mut self,
        dir: &Path,
        times: (f64, f64, usize),
        rep: &mut dyn Reporter,
    ) -> Result<usize, CommandError> {
        for t in [times.0, times.1] {
            self.frames
                .model()
                .check_time(t)
                .map_err(|e| CommandError::new(format!("--times: {e}")))?;
        }
        let write = |rel: &str, bytes: &[u8]| -> Result<(), CommandError> {
            let p = dir.join(rel);
            if let Some(parent) = p.parent() {
                std::fs::create_dir_all(parent).map_err(|e| {
                    CommandError::new(format!("{}: cannot create: {e}", parent.display()))
                })?;
            }
            evogs::atomic::write_atomic_named(&p, bytes).map_err(CommandError::new)
        };
        for f in assets::all_assets() {
            write(&f.path().to_string_lossy(), f.contents())?;
        }
        write("static.bin", &self.static_bin)?;
        let n = times.2;
        let mut listed = SceneFrames {
            times: Vec::with_capacity(n),
            files: Vec::with_capacity(n),
        };
        rep.start("view export", n as u64);
        for i in 0..n {
            if interrupt::take() {
                return Err(CommandError::new(format!(
                    "interrupted: {i} of {n} frames written to {}; no scene.json",
                    dir.display()
                )));
            }
            let t = frame_time(times, i);
            let name = format!("frames/{i:04}.bin");
            write(&name, self.frames.frame(t).map_err(CommandError::new)?)?;
            listed.times.push(t);
            listed.files.push(name);
            rep.progress(i as u64 + 1, &format!("t = {t:.3}"));
        }
        rep.finish();
        // Frames in increasing time for the page's nearest-frame search.
        if times.0 > times.1 {
            listed.times.reverse();
            listed.files.reverse();
        }
        self.scene.frames = Some(listed);
        let json = serde_json::to_vec_pretty(&self.scene).unwrap_or_default();
        // Last, so a folder with a scene.json holds every frame it lists.
        write("scene.json", &json)?;
        Ok(n)
    }
}

/// Runs `evogs view`: serves the run until Ctrl-C (the address is reported through `rep`
/// first), or with `--export` writes the static page and frames.
///
/// # Errors
/// An unreadable run or dataset, a malformed `--times`, a port that cannot be bound, an
/// unwritable export folder.
pub fn view(args: &ViewArgs, rep: &mut dyn Reporter) -> Result<(), CommandError> {
    let viewer = Viewer::open(&args.run, args.data.as_deref())?;
    if let Some(dir) = &args.export {
        let [a, b] = viewer.scene.slider_range;
        let times = match &args.times {
            Some(s) => parse_times(s).map_err(|e| CommandError::new(format!("--times: {e}")))?,
            None => (a, b, DEFAULT_EXPORT_FRAMES),
        };
        let n = viewer.export(dir, times, rep)?;
        rep.info(&format!(
            "{n} frames and the page -> {} (serve the folder with any static web server)",
            dir.display()
        ));
        return Ok(());
    }
    let server = ViewServer::bind(args.port, &viewer.scene, viewer.static_bin, viewer.frames)?;
    rep.info(&format!("evogs view: {} (Ctrl-C to stop)", server.url()));
    server.serve(rep)
}
