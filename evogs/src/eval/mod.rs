//! Evaluation: render held-out views at their times and compare with PSNR and SSIM (the 3DGS
//! SSIM: 11×11 Gaussian window, σ = 1.5, zero padding). Renders are clamped to [0, 1] first.
//! LPIPS needs a pretrained network that is out of reach offline, and is not reported.
//!
//! Besides the whole image, each frame is measured inside its motion mask ([`dynamic`],
//! [`mask`]): whole-image PSNR is decided by the static background when the moving parts
//! cover a few percent of the pixels. [`table`] writes the per-frame CSV.

pub mod dynamic;
pub mod mask;
pub mod table;

use dynamic::{FrameMask, MaskRule, camera_label, masked_mean, masked_psnr};

use crate::data::{RigCamera, SplitName, View};
use crate::model::Model;
use crate::model::render_options;
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
    /// The camera (a rig camera's name, else the frame's file stem).
    #[serde(default)]
    pub camera: String,
    /// PSNR inside the motion mask (dB; `None`: no mask, or an empty one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dynamic_psnr: Option<f64>,
    /// Mean of the SSIM map inside the motion mask.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dynamic_ssim: Option<f64>,
    /// Fraction of the frame's pixels in the motion mask (`None`: no mask).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mask_fraction: Option<f64>,
    /// The rule that made the mask.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mask_rule: Option<MaskRule>,
}

/// Dynamic-region means of a split: over the frames whose motion mask is not empty.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DynamicMetrics {
    /// Mean PSNR inside the masks (dB).
    pub psnr: f64,
    /// Mean masked SSIM.
    pub ssim: f64,
    /// Frames with a non-empty mask (the means are over these).
    pub frames: usize,
    /// Mean mask fraction over the frames that have a mask (empty ones count as 0).
    pub mask_fraction: f64,
    /// The rules that made the masks, in first-use order.
    pub rules: Vec<MaskRule>,
}

impl DynamicMetrics {
    /// The means of `frames` (`None` when no frame has a non-empty mask).
    #[must_use]
    pub fn of(frames: &[FrameMetrics]) -> Option<Self> {
        let with: Vec<(f64, f64)> = frames
            .iter()
            .filter_map(|f| Some((f.dynamic_psnr?, f.dynamic_ssim?)))
            .collect();
        if with.is_empty() {
            return None;
        }
        let fractions: Vec<f64> = frames.iter().filter_map(|f| f.mask_fraction).collect();
        let mut rules = Vec::new();
        for r in frames.iter().filter_map(|f| f.mask_rule) {
            if !rules.contains(&r) {
                rules.push(r);
            }
        }
        Some(Self {
            psnr: mean(with.iter().map(|w| w.0)),
            ssim: mean(with.iter().map(|w| w.1)),
            frames: with.len(),
            mask_fraction: mean(fractions.iter().copied()),
            rules,
        })
    }
}

/// The mean of `xs` (0 when empty).
fn mean(xs: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = xs.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    s / n.max(1) as f64
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
    /// Dynamic-region means (`None`: no frame had a non-empty motion mask).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dynamic: Option<DynamicMetrics>,
    /// Why some or all frames have no dynamic-region metrics, if so.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dynamic_note: Option<String>,
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

/// Evaluates the given views (any selection, e.g. a study's held-out set), in order, on the
/// whole image only. Views loaded without their image are decoded one at a time, so a split
/// larger than memory is evaluated in the memory of one frame.
///
/// # Errors
/// An image that cannot be decoded, or a bad camera.
pub fn evaluate_views(
    model: &mut Model<f32>,
    selected: &[&View],
    split: SplitName,
    background: [f32; 3],
    par: Par,
    progress: impl FnMut(usize, usize),
) -> Result<SplitMetrics, String> {
    let mut no_masks = |_: &View, _: &Image<f32>| Ok(None);
    let mut m = evaluate_views_masked(
        model,
        selected,
        split,
        &[],
        background,
        par,
        &mut no_masks,
        progress,
    )?;
    m.dynamic_note = None;
    Ok(m)
}

/// Gives a frame's motion mask from its view and ground truth (`None`: no mask).
pub type MaskSource<'f> = dyn FnMut(&View, &Image<f32>) -> Result<Option<FrameMask>, String> + 'f;

/// Evaluates the given views in order, on the whole image and inside each frame's motion
/// mask (`masks` gives it from the view and its ground truth; `None`: no mask). `rig` names
/// the cameras of the per-frame values. Views loaded without their image are decoded one at
/// a time.
///
/// # Errors
/// An image that cannot be decoded, a bad camera, or a mask that cannot be made.
pub fn evaluate_views_masked(
    model: &mut Model<f32>,
    selected: &[&View],
    split: SplitName,
    rig: &[RigCamera],
    background: [f32; 3],
    par: Par,
    masks: &mut MaskSource<'_>,
    progress: impl FnMut(usize, usize),
) -> Result<SplitMetrics, String> {
    let n_gaussians = model.len();
    let mut scratch = Splats::default();
    let render = |cam: &PinholeCamera<f32>, t: f64| {
        render_frame(model, cam, t, background, par, &mut scratch)
    };
    evaluate_renders(
        selected,
        split,
        rig,
        par,
        masks,
        n_gaussians,
        render,
        progress,
    )
}

/// The metrics of the images `render` makes (values in [0, 1]) for the cameras and times of
/// `selected`, whole and inside the masks `masks` gives: the loop shared by a model
/// ([`evaluate_views_masked`]) and the no-training baselines (`crate::extrapolate`).
///
/// # Errors
/// An image that cannot be decoded, a bad camera, or a mask that cannot be made.
pub fn evaluate_renders(
    selected: &[&View],
    split: SplitName,
    rig: &[RigCamera],
    par: Par,
    masks: &mut MaskSource<'_>,
    n_gaussians: usize,
    mut render: impl FnMut(&PinholeCamera<f32>, f64) -> Image<f32>,
    mut progress: impl FnMut(usize, usize),
) -> Result<SplitMetrics, String> {
    let mut frames = Vec::with_capacity(selected.len());
    let mut ws = SsimWorkspace::default();
    let mut map = Image::new(0, 0);
    let mut unmasked = 0usize;
    for (i, v) in selected.iter().enumerate() {
        let target = v.image_or_decode().map_err(|e| e.to_string())?;
        let target = target.as_ref();
        let cam: PinholeCamera<f32> = v.camera()?;
        let img = render(&cam, v.time);
        let m = f64::from(mse(&img, target));
        if !map.same_size(&img) {
            map = Image::new(img.width(), img.height());
        }
        let s = f64::from(ws.ssim_map(&img, target, &mut map, par));
        let fm = masks(v, target)?;
        unmasked += usize::from(fm.is_none());
        frames.push(FrameMetrics {
            file: v.file.display().to_string(),
            time: v.time,
            psnr: evogs_splat::metrics::psnr_from_mse(m),
            ssim: s,
            camera: camera_label(v, rig),
            dynamic_psnr: fm.as_ref().and_then(|f| masked_psnr(&img, target, &f.mask)),
            dynamic_ssim: fm.as_ref().and_then(|f| masked_mean(&map, &f.mask)),
            mask_fraction: fm.as_ref().map(|f| f.mask.fraction()),
            mask_rule: fm.as_ref().map(|f| f.rule),
        });
        progress(i + 1, selected.len());
    }
    Ok(SplitMetrics {
        split,
        psnr: mean(frames.iter().map(|f| f.psnr)),
        ssim: mean(frames.iter().map(|f| f.ssim)),
        dynamic: DynamicMetrics::of(&frames),
        dynamic_note: (unmasked > 0).then(|| {
            format!(
                "{unmasked} of {} frames: {}",
                frames.len(),
                dynamic::NO_MASK_NOTE
            )
        }),
        frames,
        n_gaussians,
        iterations: 0,
        train_seconds: 0.0,
        time_range: None,
    })
}
