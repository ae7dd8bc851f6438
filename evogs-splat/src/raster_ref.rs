//! The compositing rules, and the scalar **reference** rasterizer [`rasterize_ref`]: dense,
//! per pixel over all valid Gaussians in depth order, written to be obviously correct (its
//! backward is [`rasterize_ref_vjp`](crate::raster_ref_vjp::rasterize_ref_vjp)).
//!
//! # Compositing rules (gsplat 1.5.3 `rasterize_to_pixels`, classic 3DGS)
//!
//! These are the only definitions of the rules; every rasterizer calls [`splat_alpha`] (or
//! [`splat_alpha_cut`]) and [`should_stop`] so that the decisions are made with identical
//! floats, in both the forward and the backward pass.
//!
//! ```text
//! pixel (column j, row i) is sampled at p = (j + ½, i + ½)
//! Gaussians composite front to back in Preprocessed::order (depth, ties by index)
//! d = mean2d − p,  σ = ½(a dx² + c dy²) + b dx dy
//! skip if σ < 0
//! α = min(0.999, o'·exp(−σ));  skip if α < 1/255
//! next_T = T (1 − α);  if next_T ≤ 1e-4 the pixel stops BEFORE adding this Gaussian
//! else C += colour·α·T,  D += depth·α·T,  T = next_T
//! rgb = C + T_final·background,  alpha = 1 − T_final,
//! expected depth = D / max(1 − T_final, 1e-10)
//! ```
//!
//! The decisions are not differentiated; `min(0.999, ·)` has zero gradient where it clamps.
//!
//! **Shortcut.** [`sigma_cutoff`] gives, per Gaussian, `σ_cut = ln(255·o') + 10⁻³`: for
//! `σ > σ_cut`, `o'·exp(−σ) < e^(−10⁻³)/255`, far enough below 1/255 that the rounding of
//! `exp` and of the product cannot bring α up to the threshold, so [`splat_alpha_cut`] skips
//! without evaluating `exp`. It never changes a decision (tested), it only avoids the
//! exponential for the many far-away pairs of the dense loop.

use crate::image::Image;
use crate::preprocess::Preprocessed;
use alloc::vec;
use alloc::vec::Vec;
use evogs_math::{Real, Vec2};

/// The largest alpha of one Gaussian (gsplat 1.5.3).
pub const ALPHA_MAX: f64 = 0.999;
/// Gaussians with a smaller alpha at a pixel are skipped.
pub const ALPHA_MIN: f64 = 1.0 / 255.0;
/// A pixel stops before the Gaussian that would bring its transmittance to this or below.
pub const T_STOP: f64 = 1e-4;
/// Floor of the expected-depth denominator `1 − T_final`.
pub const DEPTH_DENOM_MIN: f64 = 1e-10;

/// One Gaussian evaluated at one pixel, when it contributes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplatHit<T> {
    /// `min(0.999, o'·G)`.
    pub alpha: T,
    /// `G = exp(−σ)`.
    pub g: T,
    /// `dx = mean2d.x − p.x`.
    pub dx: T,
    /// `dy = mean2d.y − p.y`.
    pub dy: T,
    /// `o'·G > 0.999`: alpha is clamped and has zero gradient.
    pub clamped: bool,
}

/// `σ = ½(a dx² + c dy²) + b dx dy` for a conic `[a, b, c]`.
#[inline]
#[must_use]
pub fn conic_sigma<T: Real>(conic: [T; 3], dx: T, dy: T) -> T {
    T::HALF * (conic[0] * dx * dx + conic[2] * dy * dy) + conic[1] * dx * dy
}

/// Margin of [`sigma_cutoff`] above `ln(255·o')`.
pub const SIGMA_CUTOFF_MARGIN: f64 = 1e-3;

/// `ln(255·o') + 10⁻³`: above this σ the alpha is certainly below 1/255 (see the module
/// docs); `−∞` for `o' = 0`.
#[inline]
#[must_use]
pub fn sigma_cutoff<T: Real>(opacity: T) -> T {
    (opacity / T::from_f64(ALPHA_MIN)).ln() + T::from_f64(SIGMA_CUTOFF_MARGIN)
}

/// The alpha of a Gaussian at pixel centre `(px, py)` if it contributes: `None` when
/// `σ < 0` or `α < 1/255` (the skip rules).
#[inline]
#[must_use]
pub fn splat_alpha<T: Real>(
    mean2d: Vec2<T>,
    conic: [T; 3],
    opacity: T,
    px: T,
    py: T,
) -> Option<SplatHit<T>> {
    splat_alpha_cut(mean2d, conic, opacity, T::MAX, px, py)
}

/// [`splat_alpha`] with the shortcut `σ > cutoff ⇒ skip` ([`sigma_cutoff`] of the
/// opacity); same decisions and values.
#[inline]
#[must_use]
pub fn splat_alpha_cut<T: Real>(
    mean2d: Vec2<T>,
    conic: [T; 3],
    opacity: T,
    cutoff: T,
    px: T,
    py: T,
) -> Option<SplatHit<T>> {
    let dx = mean2d.x - px;
    let dy = mean2d.y - py;
    let sigma = conic_sigma(conic, dx, dy);
    if sigma < T::ZERO || sigma > cutoff {
        return None;
    }
    let g = (-sigma).exp();
    let v = opacity * g;
    let amax = T::from_f64(ALPHA_MAX);
    let clamped = v > amax;
    let alpha = if clamped { amax } else { v };
    // `!(α >= 1/255)` also skips a NaN alpha.
    let visible = alpha >= T::from_f64(ALPHA_MIN);
    if !visible {
        return None;
    }
    Some(SplatHit {
        alpha,
        g,
        dx,
        dy,
        clamped,
    })
}

/// The stop rule: `true` if compositing a Gaussian would bring the transmittance to
/// `next_t ≤ 1e-4` (the pixel then ends without it).
#[inline]
#[must_use]
pub fn should_stop<T: Real>(next_t: T) -> bool {
    next_t <= T::from_f64(T_STOP)
}

/// The centre of pixel `(column, row)`.
#[inline]
#[must_use]
pub fn pixel_center<T: Real>(column: usize, row: usize) -> (T, T) {
    (
        T::from_usize(column) + T::HALF,
        T::from_usize(row) + T::HALF,
    )
}

/// One valid Gaussian in compositing order, packed contiguously for the dense loops (the
/// per-pixel sweep then streams memory instead of gathering through `order`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Packed<T> {
    pub(crate) mean: Vec2<T>,
    pub(crate) conic: [T; 3],
    pub(crate) opacity: T,
    pub(crate) cut: T,
}

/// The valid Gaussians of `pre` in `pre.order`, packed.
pub(crate) fn pack<T: Real>(pre: &Preprocessed<T>) -> Vec<Packed<T>> {
    pre.order
        .iter()
        .map(|&g| {
            let g = g as usize;
            Packed {
                mean: pre.means2d[g],
                conic: pre.conics[g],
                opacity: pre.opacities[g],
                cut: sigma_cutoff(pre.opacities[g]),
            }
        })
        .collect()
}

/// Output of a rasterizer; per-pixel arrays are row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct RasterOutput<T> {
    /// Composited colour plus background.
    pub rgb: Image<T>,
    /// `1 − T_final`.
    pub alpha: Vec<T>,
    /// Expected depth `Σ α T z / max(1 − T_final, 1e-10)`.
    pub depth: Vec<T>,
    /// Number of Gaussians composited.
    pub n_contrib: Vec<u32>,
    /// Final transmittance.
    pub final_t: Vec<T>,
    /// The pixel stopped on the transmittance rule.
    pub terminated: Vec<bool>,
    /// One past the position (in `Preprocessed::order`) of the last composited Gaussian;
    /// 0 if none. The backward traversal starts there.
    pub last: Vec<u32>,
}

impl<T: Real> RasterOutput<T> {
    /// An empty (transparent, background-only) output for a `width × height` image.
    #[must_use]
    pub fn new(width: usize, height: usize, background: [T; 3]) -> Self {
        let n = width * height;
        Self {
            rgb: Image::filled(width, height, background),
            alpha: vec![T::ZERO; n],
            depth: vec![T::ZERO; n],
            n_contrib: vec![0; n],
            final_t: vec![T::ONE; n],
            terminated: vec![false; n],
            last: vec![0; n],
        }
    }
}

/// The reference rasterizer: for every pixel, every valid Gaussian in
/// `pre.order`, with the rules of the module docs. O(pixels × Gaussians); for tests,
/// parity checks and small images.
///
/// ```
/// use evogs_splat::{benchmark_scene, preprocess, rasterize_ref, RenderOptions};
/// let (splats, cam) = benchmark_scene::<f64>(30, 16, 7);
/// let opts = RenderOptions::default();
/// let pre = preprocess(&splats, &cam, &opts);
/// let out = rasterize_ref(&pre, opts.background);
/// assert!(out.alpha.iter().all(|a| (0.0..1.0).contains(a)));
/// ```
#[must_use]
pub fn rasterize_ref<T: Real>(pre: &Preprocessed<T>, background: [T; 3]) -> RasterOutput<T> {
    let (w, h) = (pre.width, pre.height);
    let mut out = RasterOutput::new(w, h, background);
    let packed = pack(pre);
    for row in 0..h {
        for col in 0..w {
            let (px, py) = pixel_center::<T>(col, row);
            let mut t = T::ONE;
            let mut c = [T::ZERO; 3];
            let mut depth_sum = T::ZERO;
            let mut n = 0_u32;
            let mut last = 0_u32;
            let mut terminated = false;
            for (pos, (p, &g)) in (1_u32..).zip(packed.iter().zip(&pre.order)) {
                let Some(hit) = splat_alpha_cut(p.mean, p.conic, p.opacity, p.cut, px, py) else {
                    continue;
                };
                let g = g as usize;
                let next_t = t * (T::ONE - hit.alpha);
                if should_stop(next_t) {
                    terminated = true;
                    break;
                }
                let wgt = hit.alpha * t;
                for (acc, col) in c.iter_mut().zip(pre.colors[g]) {
                    *acc += col * wgt;
                }
                depth_sum += pre.depths[g] * wgt;
                t = next_t;
                n += 1;
                last = pos;
            }
            let p = row * w + col;
            out.rgb.set(
                col,
                row,
                core::array::from_fn(|ch| c[ch] + t * background[ch]),
            );
            out.alpha[p] = T::ONE - t;
            out.depth[p] = depth_sum / (T::ONE - t).max(T::from_f64(DEPTH_DENOM_MIN));
            out.n_contrib[p] = n;
            out.final_t[p] = t;
            out.terminated[p] = terminated;
            out.last[p] = last;
        }
    }
    out
}
