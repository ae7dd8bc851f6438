//! The full differentiable chain with the reference rasterizer: [`render`] =
//! [`preprocess`] + [`rasterize_ref`], and [`render_vjp`] =
//! [`rasterize_ref_vjp`] + [`preprocess_vjp`].
//!
//! ```text
//! Splats (μ, ŝ, q, ô, SH) ──project──▶ means2d, depth, conic, ρ ─┐
//!                         ──SH─────▶ colour ─────────────────────┼─▶ composite ─▶ rgb, alpha, depth
//!                         ──sigmoid▶ o' = o (·ρ) ────────────────┘
//! backward: pixel cotangents ─▶ RasterInputGrad ─▶ SplatsGrad + CameraGrad (+ background)
//! ```

use crate::camera::{CameraGrad, PinholeCamera};
use crate::gaussians::{Splats, SplatsGrad};
use crate::preprocess::{Preprocessed, RasterInputGrad, RenderOptions, preprocess, preprocess_vjp};
use crate::raster_ref::{RasterOutput, rasterize_ref};
use crate::raster_ref_vjp::{PixelGrad, rasterize_ref_vjp};
use evogs_math::Real;

/// The result of [`render`]: the preprocessed Gaussians and the rasterizer output.
#[derive(Clone, Debug, PartialEq)]
pub struct Render<T> {
    /// Per-Gaussian rasterizer inputs (radii, validity, depth order, …).
    pub pre: Preprocessed<T>,
    /// Images: rgb, alpha, expected depth, contributor counts, final transmittance.
    pub raster: RasterOutput<T>,
}

/// The gradients returned by [`render_vjp`].
#[derive(Clone, Debug, PartialEq)]
pub struct RenderGrad<T> {
    /// `∂L/∂` every raw Gaussian parameter.
    pub splats: SplatsGrad<T>,
    /// `∂L/∂(R, t)` of the view matrix (see [`CameraGrad::to_pose_left_se3`]).
    pub camera: CameraGrad<T>,
    /// `∂L/∂` the rasterizer inputs (2D means: the densification statistic).
    pub raster: RasterInputGrad<T>,
    /// `∂L/∂background`.
    pub background: [T; 3],
}

/// Renders `splats` with `camera` through the reference rasterizer.
///
/// # Panics
/// If `splats` is inconsistent ([`Splats::check`]).
///
/// ```
/// use evogs_splat::{benchmark_scene, render, RenderOptions};
/// let (splats, cam) = benchmark_scene::<f32>(200, 24, 1);
/// let r = render(&splats, &cam, &RenderOptions::default());
/// assert_eq!(r.raster.rgb.width(), 24);
/// assert!(r.raster.alpha.iter().any(|&a| a > 0.5)); // the cube covers the centre
/// ```
#[must_use]
pub fn render<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
) -> Render<T> {
    let pre = preprocess(splats, camera, opts);
    let raster = rasterize_ref(&pre, opts.background);
    Render { pre, raster }
}

/// VJP of [`render`] given the forward result `fwd` and the pixel cotangents `d`.
///
/// # Panics
/// If the shapes disagree (`fwd` must come from `render` with the same arguments).
///
/// ```
/// use evogs_splat::{benchmark_scene, render, render_vjp, PixelGrad, RenderOptions};
/// let (splats, cam) = benchmark_scene::<f64>(50, 12, 2);
/// let opts = RenderOptions::default();
/// let fwd = render(&splats, &cam, &opts);
/// let d_rgb = vec![1.0; 12 * 12 * 3];
/// let g = render_vjp(&splats, &cam, &opts, &fwd, &PixelGrad { rgb: &d_rgb, alpha: None, depth: None });
/// assert_eq!(g.splats.len(), 50);
/// ```
#[must_use]
pub fn render_vjp<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
    fwd: &Render<T>,
    d: &PixelGrad<'_, T>,
) -> RenderGrad<T> {
    let mut raster = RasterInputGrad::zeros(splats.len());
    let background = rasterize_ref_vjp(&fwd.pre, opts.background, &fwd.raster, d, &mut raster);
    let mut grad = splats.zeros_like();
    let camera_grad = preprocess_vjp(splats, camera, opts, &fwd.pre, &raster, &mut grad);
    RenderGrad {
        splats: grad,
        camera: camera_grad,
        raster,
        background,
    }
}
