//! Evaluation: render held-out views at their times and compare with PSNR and SSIM (the 3DGS
//! SSIM: 11×11 Gaussian window, σ = 1.5, zero padding). Renders are clamped to [0, 1] first.
//! LPIPS needs a pretrained network that is out of reach offline, and is not reported.

use crate::data::{SplitName, View};
use crate::model::Model;
use crate::train::step::render_options;
use crate::train::trainer::psnr_of_mse;
use crate::train::views::view_camera;
use evogs_math::Par;
use evogs_splat::metrics::mse;
use evogs_splat::ssim::SsimWorkspace;
use evogs_splat::{Image, PinholeCamera, Splats, TiledRasterizer, render_tiled};
use serde::{Deserialize, Serialize};

/// Metrics of one frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameMetrics {
    /// Image file of the ground truth.
    pub file: String,
    /// Frame time.
    pub time: f64,
    /// PSNR (dB).
    pub psnr: f64,
    /// SSIM (3DGS variant).
    pub ssim: f64,
}

/// Metrics of a split: `RUN/metrics-<split>.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SplitMetrics {
    /// The split.
    pub split: SplitName,
    /// Mean PSNR over the frames.
    pub psnr: f64,
    /// Mean SSIM over the frames.
    pub ssim: f64,
    /// Per-frame values.
    pub frames: Vec<FrameMetrics>,
    /// Number of Gaussians of the model.
    pub n_gaussians: usize,
    /// Training iterations of the model.
    pub iterations: u64,
    /// Training time (seconds).
    pub train_seconds: f64,
    /// The time range the frames were restricted to (`evogs eval --time-range A:B`), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_range: Option<[f64; 2]>,
}

/// Renders the model at time `t` from `camera` (values clamped to [0, 1]).
pub fn render_frame(
    model: &mut Model<f32>,
    camera: &PinholeCamera<f32>,
    t: f64,
    background: [f32; 3],
    par: Par,
    scratch: &mut Splats<f32>,
) -> Image<f32> {
    let mut stepper = None;
    let _tape = model.splats_at(t, &mut stepper, scratch);
    let opts = render_options(background, model.canonical.sh_degree, par);
    let mut img = render_tiled(scratch, camera, &opts, &mut TiledRasterizer::new())
        .raster
        .rgb;
    for v in img.data_mut() {
        *v = v.clamp(0.0, 1.0);
    }
    img
}

/// Evaluates `views` (optionally only those with `t` in `range`).
///
/// # Errors
/// An image that cannot be decoded, or a bad camera.
pub fn evaluate(
    model: &mut Model<f32>,
    views: &[View],
    split: SplitName,
    range: Option<(f64, f64)>,
    background: [f32; 3],
    par: Par,
    progress: impl FnMut(usize, usize),
) -> Result<SplitMetrics, String> {
    let selected: Vec<&View> = views
        .iter()
        .filter(|v| range.is_none_or(|(a, b)| v.time >= a && v.time <= b))
        .collect();
    evaluate_views(model, &selected, split, background, par, progress)
}

/// Evaluates the given views (any selection, e.g. a study's held-out set), in order. Views
/// loaded without their image are decoded one at a time, so a split larger than memory is
/// evaluated in the memory of one frame.
///
/// # Errors
/// An image that cannot be decoded, or a bad camera.
pub fn evaluate_views(
    model: &mut Model<f32>,
    selected: &[&View],
    split: SplitName,
    background: [f32; 3],
    par: Par,
    mut progress: impl FnMut(usize, usize),
) -> Result<SplitMetrics, String> {
    let mut frames = Vec::with_capacity(selected.len());
    let mut ws = SsimWorkspace::default();
    let mut scratch = Splats::default();
    for (i, v) in selected.iter().enumerate() {
        let target = v.image_or_decode().map_err(|e| e.to_string())?;
        let target = target.as_ref();
        let cam: PinholeCamera<f32> = view_camera(v)?;
        let img = render_frame(model, &cam, v.time, background, par, &mut scratch);
        let m = f64::from(mse(&img, target));
        let s = f64::from(ws.ssim(&img, target, par));
        frames.push(FrameMetrics {
            file: v.file.display().to_string(),
            time: v.time,
            psnr: psnr_of_mse(m),
            ssim: s,
        });
        progress(i + 1, selected.len());
    }
    #[allow(clippy::cast_precision_loss, reason = "frame counts are small")]
    let n = frames.len().max(1) as f64;
    Ok(SplitMetrics {
        split,
        psnr: frames.iter().map(|f| f.psnr).sum::<f64>() / n,
        ssim: frames.iter().map(|f| f.ssim).sum::<f64>() / n,
        frames,
        n_gaussians: model.len(),
        iterations: 0,
        train_seconds: 0.0,
        time_range: None,
    })
}
