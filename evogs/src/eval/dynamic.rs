//! Dynamic-region metrics: PSNR and SSIM inside a frame's motion mask, and the plan that
//! decides, per held-out frame, which rule gives its mask (see `docs/losses.md`):
//!
//! 1. the dataset's own mask `X_motion.png` beside the frame `X.png` ([`MaskRule::Shipped`]);
//! 2. else, when the frame's camera pose is shared by frames at [`MEDIAN_MIN_TIMES`] or more
//!    distinct times (a fixed camera of a rig), the pixels that differ from that pose's
//!    per-pixel temporal median of the ground truth ([`MaskRule::TemporalMedian`]);
//! 3. else, when a reference model that does not move is given (a study's static run), the
//!    pixels where the ground truth differs from its render ([`MaskRule::StaticRender`]);
//! 4. else no mask, and no dynamic-region metrics for the frame.

use super::mask::{
    MEDIAN_MAX_FRAMES, MEDIAN_MIN_TIMES, MOTION_DILATION, MOTION_THRESHOLD, MotionMask,
    evenly_spaced, read_motion_mask, temporal_median,
};
use super::render_frame;
use crate::data::{RigCamera, View};
use crate::model::Model;
use evogs_math::Par;
use evogs_splat::{Image, PinholeCamera, Splats};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Where a frame's motion mask came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MaskRule {
    /// The dataset's `X_motion.png`.
    Shipped,
    /// Ground truth against its camera's temporal median.
    TemporalMedian,
    /// Ground truth against a static model's render: where a model that does not move is
    /// wrong.
    StaticRender,
}

impl MaskRule {
    /// Lowercase name (`shipped`, `temporal_median`, `static_render`).
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Shipped => "shipped",
            Self::TemporalMedian => "temporal_median",
            Self::StaticRender => "static_render",
        }
    }
}

/// A frame's motion mask and its rule.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FrameMask {
    /// The mask.
    pub mask: MotionMask,
    /// How it was made.
    pub rule: MaskRule,
}

/// MSE over the mask's pixels and channels (`None` for an empty mask).
///
/// # Panics
/// If the sizes differ.
#[must_use]
pub fn masked_mse(img: &Image<f32>, target: &Image<f32>, mask: &MotionMask) -> Option<f64> {
    assert!(img.same_size(target), "images of different sizes");
    assert_eq!(
        (mask.width(), mask.height()),
        (img.width(), img.height()),
        "mask of the wrong size"
    );
    let (mut sum, mut n) = (0.0f64, 0usize);
    for ((a, b), &on) in img
        .data()
        .chunks_exact(3)
        .zip(target.data().chunks_exact(3))
        .zip(mask.flags())
    {
        if on {
            for c in 0..3 {
                let d = f64::from(a[c]) - f64::from(b[c]);
                sum += d * d;
            }
            n += 3;
        }
    }
    (n > 0).then(|| sum / n as f64)
}

/// The mean of a per-pixel, per-channel map (an SSIM map) over the mask's pixels (`None`
/// for an empty mask).
///
/// # Panics
/// If the sizes differ.
#[must_use]
pub fn masked_mean(map: &Image<f32>, mask: &MotionMask) -> Option<f64> {
    assert_eq!(
        (mask.width(), mask.height()),
        (map.width(), map.height()),
        "mask of the wrong size"
    );
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (px, &on) in map.data().chunks_exact(3).zip(mask.flags()) {
        if on {
            sum += px.iter().map(|&v| f64::from(v)).sum::<f64>();
            n += 3;
        }
    }
    (n > 0).then(|| sum / n as f64)
}

/// PSNR inside the mask (`None` for an empty mask).
#[must_use]
pub fn masked_psnr(img: &Image<f32>, target: &Image<f32>, mask: &MotionMask) -> Option<f64> {
    masked_mse(img, target, mask).map(evogs_splat::metrics::psnr_from_mse)
}

/// A camera pose, compared bit for bit: frames of one fixed camera share it exactly.
type PoseKey = ([u64; 16], u64, usize, usize);

fn pose_key(v: &View) -> PoseKey {
    let mut m = [0u64; 16];
    for (k, x) in v.c2w.iter().flatten().enumerate() {
        m[k] = x.to_bits();
    }
    (m, v.fov_x.to_bits(), v.width, v.height)
}

/// The label of a view's camera in per-frame tables: the rig camera with its pose, else the
/// frame's file stem (a monocular frame has a camera of its own).
#[must_use]
pub fn camera_label(view: &View, rig: &[RigCamera]) -> String {
    rig.iter()
        .find(|c| c.c2w == view.c2w && c.width == view.width && c.height == view.height)
        .map_or_else(
            || {
                view.file
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default()
            },
            |c| c.name.clone(),
        )
}

/// A model that does not move, rendered as the reference of [`MaskRule::StaticRender`].
struct Reference<'m> {
    model: &'m mut Model<f32>,
    background: [f32; 3],
    par: Par,
    scratch: Splats<f32>,
}

/// Decides and computes the motion masks of held-out frames (see the module docs).
pub struct MotionMasks<'a> {
    /// Frames per camera pose (every split of the dataset), for temporal medians.
    poses: HashMap<PoseKey, Vec<&'a View>>,
    /// Medians computed so far, per pose.
    medians: HashMap<PoseKey, Image<f32>>,
    reference: Option<Reference<'a>>,
}

impl std::fmt::Debug for MotionMasks<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MotionMasks")
            .field("poses", &self.poses.len())
            .field("medians", &self.medians.len())
            .field("static_reference", &self.reference.is_some())
            .finish()
    }
}

impl<'a> MotionMasks<'a> {
    /// A plan over `pool`, every view of the dataset (the temporal median of a pose is taken
    /// over all its frames, whichever split they are in).
    #[must_use]
    pub fn new(pool: impl IntoIterator<Item = &'a View>) -> Self {
        let mut poses: HashMap<PoseKey, Vec<&'a View>> = HashMap::new();
        for v in pool {
            poses.entry(pose_key(v)).or_default().push(v);
        }
        for frames in poses.values_mut() {
            frames.sort_by(|a, b| a.time.total_cmp(&b.time));
        }
        Self {
            poses,
            medians: HashMap::new(),
            reference: None,
        }
    }

    /// Uses `model` (a model that does not move) as the reference of frames that have neither
    /// a shipped mask nor a shared pose.
    #[must_use]
    pub fn with_static_reference(
        mut self,
        model: &'a mut Model<f32>,
        background: [f32; 3],
        par: Par,
    ) -> Self {
        self.reference = Some(Reference {
            model,
            background,
            par,
            scratch: Splats::default(),
        });
        self
    }

    /// Whether `view`'s pose has frames at enough distinct times for a temporal median.
    #[must_use]
    pub fn has_shared_pose(&self, view: &View) -> bool {
        self.poses.get(&pose_key(view)).is_some_and(|f| {
            let mut times: Vec<u64> = f.iter().map(|v| v.time.to_bits()).collect();
            times.sort_unstable();
            times.dedup();
            times.len() >= MEDIAN_MIN_TIMES
        })
    }

    /// Whether a static reference is set.
    #[must_use]
    pub fn has_static_reference(&self) -> bool {
        self.reference.is_some()
    }

    /// The motion mask of `view`, whose ground truth is `target` (`None`: no rule applies).
    ///
    /// # Errors
    /// An unreadable mask or frame, or a bad camera.
    pub fn mask(&mut self, view: &View, target: &Image<f32>) -> Result<Option<FrameMask>, String> {
        if let Some(mask) = read_motion_mask(view)? {
            return Ok(Some(FrameMask {
                mask,
                rule: MaskRule::Shipped,
            }));
        }
        if self.has_shared_pose(view) {
            let key = pose_key(view);
            if !self.medians.contains_key(&key) {
                let frames = &self.poses[&key];
                let picked = evenly_spaced(frames.len(), MEDIAN_MAX_FRAMES);
                let median = temporal_median(picked.iter().map(|&i| {
                    frames[i]
                        .image_or_decode()
                        .map(std::borrow::Cow::into_owned)
                        .map_err(|e| e.to_string())
                }))?;
                self.medians.insert(key, median);
            }
            let median = &self.medians[&key];
            return Ok(Some(FrameMask {
                mask: MotionMask::from_difference(
                    target,
                    median,
                    MOTION_THRESHOLD,
                    MOTION_DILATION,
                ),
                rule: MaskRule::TemporalMedian,
            }));
        }
        if let Some(r) = self.reference.as_mut() {
            let cam: PinholeCamera<f32> = view.camera()?;
            let img = render_frame(
                r.model,
                &cam,
                view.time,
                r.background,
                r.par,
                &mut r.scratch,
            );
            return Ok(Some(FrameMask {
                mask: MotionMask::from_difference(target, &img, MOTION_THRESHOLD, MOTION_DILATION),
                rule: MaskRule::StaticRender,
            }));
        }
        Ok(None)
    }
}

/// The note of an evaluation where some frames have no motion mask.
pub const NO_MASK_NOTE: &str = "no dynamic-region metrics for frames without a motion mask: \
     a monocular frame (no camera pose shared over time) needs the dataset's X_motion.png, \
     or a static run to compare with (evogs study)";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::image_io::FrameDecode;

    const W: usize = 40;
    const H: usize = 24;
    const PATCH: usize = 4;

    fn view(file: std::path::PathBuf, time: f64, image: Image<f32>, x: f64) -> View {
        let mut c2w = [[0.0; 4]; 4];
        for (k, row) in c2w.iter_mut().enumerate() {
            row[k] = 1.0;
        }
        c2w[0][3] = x;
        c2w[2][3] = 4.0;
        View {
            file,
            time,
            c2w,
            fov_x: 0.8,
            width: W,
            height: H,
            image: Some(image),
            decode: FrameDecode {
                background: [1.0; 3],
                downscale: 1,
            },
        }
    }

    /// A textured static backdrop with a red patch at `(px, py)`.
    fn frame(px: usize, py: usize) -> Image<f32> {
        let mut img = Image::new(W, H);
        for y in 0..H {
            for x in 0..W {
                let g = 0.3 + 0.4 * (((x / 3 + y / 2) % 4) as f32) / 4.0;
                img.set(x, y, [g, g, 0.5]);
            }
        }
        for y in py..py + PATCH {
            for x in px..px + PATCH {
                img.set(x, y, [1.0, 0.0, 0.0]);
            }
        }
        img
    }

    /// The patch's top-left corner at frame `k` of `n`: a diagonal path across the frame.
    fn corner(k: usize, n: usize) -> (usize, usize) {
        (
            2 + k * (W - PATCH - 4) / (n - 1),
            2 + k * (H - PATCH - 4) / (n - 1),
        )
    }

    #[test]
    fn the_median_mask_covers_the_patch_path_and_not_the_backdrop() {
        let n = 9;
        let views: Vec<View> = (0..n)
            .map(|k| {
                let (px, py) = corner(k, n);
                let t = k as f64 / (n - 1) as f64;
                view(format!("cam00/{k:04}.png").into(), t, frame(px, py), 0.0)
            })
            .collect();
        let mut masks = MotionMasks::new(&views);
        let mut union = vec![false; W * H];
        for (k, v) in views.iter().enumerate() {
            let fm = masks
                .mask(v, v.image.as_ref().expect("in memory"))
                .expect("mask")
                .expect("a shared pose");
            assert_eq!(fm.rule, MaskRule::TemporalMedian, "fixed camera");
            let (px, py) = corner(k, n);
            for y in py..py + PATCH {
                for x in px..px + PATCH {
                    assert!(fm.mask.get(x, y), "frame {k}: patch pixel ({x}, {y})");
                }
            }
            // Only the patch and its dilation: nothing farther from it.
            for y in 0..H {
                for x in 0..W {
                    let near = x + MOTION_DILATION >= px
                        && x <= px + PATCH - 1 + MOTION_DILATION
                        && y + MOTION_DILATION >= py
                        && y <= py + PATCH - 1 + MOTION_DILATION;
                    assert!(!fm.mask.get(x, y) || near, "frame {k}: backdrop ({x}, {y})");
                }
            }
            let f = fm.mask.fraction();
            assert!(f > 0.0 && f < 0.2, "frame {k}: fraction {f}");
            for (u, &m) in union.iter_mut().zip(fm.mask.flags()) {
                *u |= m;
            }
        }
        // The path is covered; the corners away from the diagonal are not.
        assert!(!union[(H - 1) * W], "bottom-left corner");
        assert!(!union[W - 1], "top-right corner");
    }

    #[test]
    fn a_monocular_frame_has_no_mask_without_a_file_or_a_reference() {
        let views: Vec<View> = (0..3u8)
            .map(|k| {
                let x = f64::from(k);
                view(format!("r_{k}.png").into(), x / 2.0, frame(2, 2), x)
            })
            .collect();
        let mut masks = MotionMasks::new(&views);
        assert!(!masks.has_shared_pose(&views[0]), "every pose differs");
        let fm = masks
            .mask(&views[1], views[1].image.as_ref().expect("in memory"))
            .expect("no error");
        assert!(fm.is_none(), "no rule applies");
    }

    #[test]
    fn a_shipped_mask_is_read_and_wins() {
        let dir = std::env::temp_dir().join(format!("evogs-mask-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let views: Vec<View> = (0..4u8)
            .map(|k| {
                let t = f64::from(k) / 3.0;
                view(dir.join(format!("f_{k}.png")), t, frame(2, 2), 0.0)
            })
            .collect();
        // Grey-and-alpha mask: moving where both are non-zero.
        let size = |n: usize| u32::try_from(n).expect("small");
        let mut png = image::RgbaImage::new(size(W), size(H));
        png.put_pixel(5, 6, image::Rgba([255, 255, 255, 255]));
        png.put_pixel(7, 6, image::Rgba([255, 255, 255, 0]));
        png.put_pixel(9, 6, image::Rgba([0, 0, 0, 255]));
        png.save(dir.join("f_1_motion.png")).expect("mask written");
        let mut masks = MotionMasks::new(&views);
        let fm = masks
            .mask(&views[1], views[1].image.as_ref().expect("in memory"))
            .expect("readable")
            .expect("shipped");
        assert_eq!(fm.rule, MaskRule::Shipped, "the file wins over the median");
        assert_eq!(fm.mask.count(), 1, "only the opaque non-black pixel");
        assert!(fm.mask.get(5, 6), "the marked pixel");
        // A mask of the wrong size is an error naming the file.
        image::GrayImage::new(3, 3)
            .save(dir.join("f_2_motion.png"))
            .expect("written");
        let e = masks
            .mask(&views[2], views[2].image.as_ref().expect("in memory"))
            .expect_err("wrong size");
        assert!(e.contains("f_2_motion.png"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn masked_metrics_see_only_the_mask() {
        let a = Image::filled(4, 4, [0.5f32, 0.5, 0.5]);
        let mut b = a.clone();
        b.set(1, 1, [0.6, 0.6, 0.6]);
        b.set(3, 3, [0.9, 0.9, 0.9]);
        let mut on = vec![false; 16];
        on[5] = true;
        let m = MotionMask::from_flags(4, 4, on);
        let mse = masked_mse(&a, &b, &m).expect("one pixel");
        assert!((mse - 0.01).abs() < 1e-6, "{mse}");
        let empty = MotionMask::from_flags(4, 4, vec![false; 16]);
        assert!(masked_mse(&a, &b, &empty).is_none(), "empty mask");
        let mut map = Image::filled(4, 4, [1.0f32, 1.0, 1.0]);
        map.set(1, 1, [0.1, 0.2, 0.3]);
        let s = masked_mean(&map, &m).expect("one pixel");
        assert!((s - 0.2).abs() < 1e-6, "{s}");
    }
}
