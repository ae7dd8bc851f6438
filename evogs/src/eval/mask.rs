//! Motion masks: the pixels of a held-out frame where the scene moves, from the ground truth
//! alone (never from a model being judged). A mask is a per-pixel flag of the frame's size.
//!
//! * [`MotionMask::from_difference`]: pixels whose colour differs from a reference image
//!   (a camera's temporal median, or a static model's render) by more than
//!   [`MOTION_THRESHOLD`] in the largest of the three channel differences (L∞ over RGB, values
//!   in [0, 1]), then dilated by [`MOTION_DILATION`] pixels (a square window).
//! * [`read_motion_mask`]: a dataset's own mask, `X_motion.png` beside the frame `X.png`.
//! * [`temporal_median`]: the per-pixel, per-channel median of a fixed camera's frames.

use crate::data::View;
use evogs_splat::Image;
use std::path::{Path, PathBuf};

/// Colour distance above which a pixel counts as moving: the largest absolute channel
/// difference, RGB in [0, 1] (0.1 ≈ 26 of 255 levels).
pub const MOTION_THRESHOLD: f32 = 0.1;

/// Radius of the square dilation applied to a thresholded mask (pixels, at the evaluated
/// resolution): a pixel is in the mask when any pixel within this Chebyshev distance passed
/// the threshold.
pub const MOTION_DILATION: usize = 3;

/// Most frames a temporal median is taken over (evenly spaced in the camera's frame order,
/// first and last included), so a long capture's median fits in memory.
pub const MEDIAN_MAX_FRAMES: usize = 64;

/// Fewest distinct times a camera pose needs for its temporal median to be used.
pub const MEDIAN_MIN_TIMES: usize = 3;

/// A per-pixel motion flag of one frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MotionMask {
    width: usize,
    height: usize,
    on: Vec<bool>,
}

impl MotionMask {
    /// A mask from row-major flags.
    ///
    /// # Panics
    /// If `on` does not hold `width × height` flags.
    #[must_use]
    pub fn from_flags(width: usize, height: usize, on: Vec<bool>) -> Self {
        assert_eq!(on.len(), width * height, "mask of the wrong size");
        Self { width, height, on }
    }

    /// The pixels where `gt` and `reference` differ by more than `threshold` (largest
    /// absolute channel difference), dilated by `radius` pixels.
    ///
    /// # Panics
    /// If the images differ in size.
    #[must_use]
    pub fn from_difference(
        gt: &Image<f32>,
        reference: &Image<f32>,
        threshold: f32,
        radius: usize,
    ) -> Self {
        assert!(gt.same_size(reference), "images of different sizes");
        let on = gt
            .data()
            .chunks_exact(3)
            .zip(reference.data().chunks_exact(3))
            .map(|(a, b)| {
                a.iter()
                    .zip(b)
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0f32, f32::max)
                    > threshold
            })
            .collect();
        Self::from_flags(gt.width(), gt.height(), on).dilated(radius)
    }

    /// This mask dilated by a square of radius `radius` (separable: rows, then columns).
    #[must_use]
    pub fn dilated(&self, radius: usize) -> Self {
        if radius == 0 || self.on.is_empty() {
            return self.clone();
        }
        let (w, h) = (self.width, self.height);
        let mut rows = vec![false; w * h];
        for y in 0..h {
            let src = &self.on[y * w..(y + 1) * w];
            let dst = &mut rows[y * w..(y + 1) * w];
            for (x, d) in dst.iter_mut().enumerate() {
                let (a, b) = (x.saturating_sub(radius), (x + radius).min(w - 1));
                *d = src[a..=b].iter().any(|&v| v);
            }
        }
        let mut on = vec![false; w * h];
        for y in 0..h {
            let (a, b) = (y.saturating_sub(radius), (y + radius).min(h - 1));
            for x in 0..w {
                on[y * w + x] = (a..=b).any(|yy| rows[yy * w + x]);
            }
        }
        Self {
            width: w,
            height: h,
            on,
        }
    }

    /// Width in pixels.
    #[must_use]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    #[must_use]
    pub fn height(&self) -> usize {
        self.height
    }

    /// Whether pixel `(x, y)` moves.
    #[must_use]
    pub fn get(&self, x: usize, y: usize) -> bool {
        self.on[y * self.width + x]
    }

    /// The row-major flags.
    #[must_use]
    pub fn flags(&self) -> &[bool] {
        &self.on
    }

    /// Number of moving pixels.
    #[must_use]
    pub fn count(&self) -> usize {
        self.on.iter().filter(|&&v| v).count()
    }

    /// The fraction of the frame's pixels that move (0 for an empty frame).
    #[must_use]
    pub fn fraction(&self) -> f64 {
        self.count() as f64 / self.on.len().max(1) as f64
    }
}

/// The motion-mask file of the frame `file`: `X_motion.png` for `X.png` (any extension of
/// the frame; the mask is always a PNG).
#[must_use]
pub fn motion_mask_path(file: &Path) -> PathBuf {
    let stem = file
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    file.with_file_name(format!("{stem}_motion.png"))
}

/// Reads the dataset's motion mask of `view` (`None` when the file does not exist).
///
/// A pixel moves when its grey level (or any of R, G, B) is non-zero and, where the file has
/// an alpha channel, its alpha is non-zero too. The file has the frame's size before the
/// dataset's downscale; a downscaled pixel moves when any pixel of its block does.
///
/// # Errors
/// An unreadable file, or one whose size is not the frame's.
pub fn read_motion_mask(view: &View) -> Result<Option<MotionMask>, String> {
    let path = motion_mask_path(&view.file);
    if !crate::bounded::present(&path) {
        return Ok(None);
    }
    crate::bounded::regular_file_size(&path, "a motion mask").map_err(|e| e.to_string())?;
    let img = image::open(&path)
        .map_err(|e| format!("{}: cannot read the motion mask: {e}", path.display()))?
        .to_rgba8();
    let f = view.decode.downscale.max(1);
    let (fw, fh) = (img.width() as usize, img.height() as usize);
    if fw / f != view.width || fh / f != view.height {
        return Err(format!(
            "{}: the motion mask is {fw}x{fh}, its frame {} is {}x{} at downscale {f}",
            path.display(),
            view.file.display(),
            view.width * f,
            view.height * f
        ));
    }
    let mut on = vec![false; view.width * view.height];
    for (x, y, p) in img.enumerate_pixels() {
        let (x, y) = (x as usize / f, y as usize / f);
        if x < view.width && y < view.height && p.0[3] != 0 && p.0[..3].iter().any(|&c| c != 0) {
            on[y * view.width + x] = true;
        }
    }
    Ok(Some(MotionMask::from_flags(view.width, view.height, on)))
}

/// The per-pixel, per-channel median of `frames` (at least one, all of one size), taken one
/// frame at a time: each is kept as 16-bit levels of [0, 1] (a step of 1/65535, far below
/// [`MOTION_THRESHOLD`]), so the median of `k` frames of `n` values takes `2kn` bytes. An even
/// count takes the mean of the two middle values.
///
/// # Errors
/// The first frame that fails to load, or no frame at all, or frames of different sizes.
pub fn temporal_median(
    frames: impl IntoIterator<Item = Result<Image<f32>, String>>,
) -> Result<Image<f32>, String> {
    let mut levels: Vec<u16> = Vec::new();
    let mut size = None;
    let mut k = 0usize;
    for f in frames {
        let f = f?;
        let s = *size.get_or_insert((f.width(), f.height()));
        if s != (f.width(), f.height()) {
            return Err(format!(
                "frames of different sizes for one camera: {}x{} and {}x{}",
                s.0,
                s.1,
                f.width(),
                f.height()
            ));
        }
        #[allow(
            clippy::cast_possible_truncation,
            reason = "clamped to [0, 65535] first"
        )]
        levels.extend(
            f.data()
                .iter()
                .map(|v| (v.clamp(0.0, 1.0) * 65535.0).round() as u16),
        );
        k += 1;
    }
    let (w, h) = size.ok_or_else(|| "no frame to take a median of".to_string())?;
    let n = 3 * w * h;
    let mut out = Image::new(w, h);
    let mut column = vec![0u16; k];
    for (i, o) in out.data_mut().iter_mut().enumerate() {
        for (f, c) in column.iter_mut().enumerate() {
            *c = levels[f * n + i];
        }
        column.sort_unstable();
        let level = if k % 2 == 1 {
            f32::from(column[k / 2])
        } else {
            0.5 * (f32::from(column[k / 2 - 1]) + f32::from(column[k / 2]))
        };
        *o = level / 65535.0;
    }
    Ok(out)
}

/// Up to `max` indices of `0..n`, evenly spaced, first and last included (all of them when
/// `n ≤ max`).
#[must_use]
pub fn evenly_spaced(n: usize, max: usize) -> Vec<usize> {
    if n <= max {
        return (0..n).collect();
    }
    if max < 2 {
        return (0..max).collect();
    }
    (0..max).map(|k| k * (n - 1) / (max - 1)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_difference_mask_thresholds_the_largest_channel_and_dilates() {
        let a = Image::filled(9, 7, [0.5f32, 0.5, 0.5]);
        let mut b = a.clone();
        b.set(4, 3, [0.5, 0.5 + 2.0 * MOTION_THRESHOLD, 0.5]);
        b.set(0, 0, [0.5 + 0.5 * MOTION_THRESHOLD, 0.5, 0.5]);
        let m = MotionMask::from_difference(&a, &b, MOTION_THRESHOLD, 0);
        assert_eq!(m.count(), 1, "one pixel above the threshold");
        assert!(m.get(4, 3), "the changed pixel");
        let d = MotionMask::from_difference(&a, &b, MOTION_THRESHOLD, 2);
        for y in 0..7_usize {
            for x in 0..9_usize {
                let inside = x.abs_diff(4) <= 2 && y.abs_diff(3) <= 2;
                assert_eq!(d.get(x, y), inside, "({x}, {y})");
            }
        }
        assert!(
            (d.fraction() - 25.0 / 63.0).abs() < 1e-12,
            "{}",
            d.fraction()
        );
    }

    #[test]
    fn the_median_ignores_a_minority_of_frames() {
        let back = Image::filled(4, 3, [0.2f32, 0.4, 0.6]);
        let mut odd = back.clone();
        odd.set(1, 1, [1.0, 1.0, 1.0]);
        let m = temporal_median([back.clone(), odd.clone(), back.clone()].map(Ok)).expect("median");
        for (a, b) in m.data().iter().zip(back.data()) {
            assert!(
                (a - b).abs() <= 0.5 / 65535.0,
                "two of three frames: {a} vs {b}"
            );
        }
        let even = temporal_median([back.clone(), odd].map(Ok)).expect("median");
        let p = even.get(1, 1);
        assert!((p[0] - 0.6).abs() < 1e-4, "mean of the middle two: {p:?}");
        let e = temporal_median([Ok(back), Ok(Image::new(2, 2))]).expect_err("sizes");
        assert!(e.contains("different sizes"), "{e}");
        assert!(temporal_median([]).is_err(), "no frame");
    }

    #[test]
    fn evenly_spaced_indices_keep_both_ends() {
        assert_eq!(evenly_spaced(5, 64), vec![0, 1, 2, 3, 4]);
        assert_eq!(evenly_spaced(100, 4), vec![0, 33, 66, 99]);
        assert_eq!(evenly_spaced(0, 4), Vec::<usize>::new());
    }

    #[test]
    fn the_mask_file_sits_beside_the_frame() {
        assert_eq!(
            motion_mask_path(Path::new("d/train/r_007.png")),
            PathBuf::from("d/train/r_007_motion.png")
        );
    }
}
