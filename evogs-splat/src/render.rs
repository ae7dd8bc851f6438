//! The full differentiable chain: [`render`] = [`preprocess`] + [`rasterize_ref`] and
//! [`render_vjp`] = [`rasterize_ref_vjp`] + [`preprocess_vjp`] with the reference rasterizer;
//! [`render_tiled`] / [`render_tiled_vjp`] the same chain through the fast
//! [`TiledRasterizer`] (same results: bitwise images in `f64`, gradients up to the order of
//! the sums over pixels). Training uses the tiled pair; the reference pair is the
//! obviously-correct baseline.
//!
//! ```text
//! Splats (μ, ŝ, q, ô, SH) ──project──▶ means2d, depth, conic, ρ ─┐
//!                         ──SH─────▶ colour ─────────────────────┼─▶ composite ─▶ rgb, alpha, depth
//!                         ──sigmoid▶ o' = o (·ρ) ────────────────┘
//! backward: pixel cotangents ─▶ RasterInputGrad ─▶ SplatsGrad + CameraGrad (+ background)
//! ```

use crate::camera::{CameraGrad, PinholeCamera};
use crate::gaussians::{Splats, SplatsGrad};
use crate::preprocess::{
    GradInit, Preprocessed, RasterInputGrad, RenderOptions, preprocess, preprocess_into,
    preprocess_vjp, preprocess_vjp_with,
};
use crate::raster_ref::{RasterOutput, rasterize_ref};
use crate::raster_ref_vjp::{PixelGrad, rasterize_ref_vjp};
use crate::raster_tiled::TiledRasterizer;
use crate::raster_tiled_vjp::DensifyStats;
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
    /// This view's densification statistics (2D-mean gradient norms in pixels, radii).
    pub densify: DensifyStats<T>,
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
    let densify = DensifyStats::from_grad(&fwd.pre, &raster);
    RenderGrad {
        splats: grad,
        camera: camera_grad,
        raster,
        background,
        densify,
    }
}

/// [`render`] through the tiled rasterizer `rast` (its work memory is reused; `opts.par`
/// parallelises both the preprocessing and the tiles).
///
/// # Panics
/// If `splats` is inconsistent ([`Splats::check`]).
///
/// ```
/// use evogs_splat::{benchmark_scene, render, render_tiled, RenderOptions, TiledRasterizer};
/// let (splats, cam) = benchmark_scene::<f64>(200, 24, 1);
/// let opts = RenderOptions::default();
/// let fast = render_tiled(&splats, &cam, &opts, &mut TiledRasterizer::new());
/// assert!(fast == render(&splats, &cam, &opts));
/// ```
#[must_use]
pub fn render_tiled<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
    rast: &mut TiledRasterizer<T>,
) -> Render<T> {
    let mut out = Render {
        pre: Preprocessed::default(),
        raster: RasterOutput::new(camera.width, camera.height, opts.background),
    };
    render_tiled_into(splats, camera, opts, rast, &mut out);
    out
}

/// [`render_tiled`] into an existing [`Render`] (buffers reused: the allocation-free form of
/// a training loop).
///
/// # Panics
/// If `splats` is inconsistent ([`Splats::check`]).
pub fn render_tiled_into<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
    rast: &mut TiledRasterizer<T>,
    out: &mut Render<T>,
) {
    preprocess_into(splats, camera, opts, &mut out.pre);
    rast.forward_into(&out.pre, opts.background, opts.par, &mut out.raster);
}

/// [`render_vjp`] through the tiled rasterizer: `fwd` must come from [`render_tiled`] with
/// the same arguments (and a rasterizer with the same [`ExpMode`](crate::ExpMode)).
///
/// # Panics
/// If the shapes disagree.
///
/// ```
/// use evogs_splat::{benchmark_scene, render_tiled, render_tiled_vjp, PixelGrad, RenderOptions, TiledRasterizer};
/// let (splats, cam) = benchmark_scene::<f32>(50, 12, 2);
/// let opts = RenderOptions::default();
/// let mut rast = TiledRasterizer::new();
/// let fwd = render_tiled(&splats, &cam, &opts, &mut rast);
/// let d_rgb = vec![1.0; 12 * 12 * 3];
/// let d = PixelGrad { rgb: &d_rgb, alpha: None, depth: None };
/// let g = render_tiled_vjp(&splats, &cam, &opts, &mut rast, &fwd, &d);
/// assert_eq!(g.densify.radius.len(), 50);
/// ```
#[must_use]
pub fn render_tiled_vjp<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
    rast: &mut TiledRasterizer<T>,
    fwd: &Render<T>,
    d: &PixelGrad<'_, T>,
) -> RenderGrad<T> {
    let mut grad = RenderGrad {
        splats: splats.zeros_like(),
        camera: CameraGrad::zero(),
        raster: RasterInputGrad::zeros(splats.len()),
        background: [T::ZERO; 3],
        densify: DensifyStats::default(),
    };
    render_tiled_vjp_into(splats, camera, opts, rast, fwd, d, &mut grad);
    grad
}

/// [`render_tiled_vjp`] into an existing [`RenderGrad`], which is **overwritten** (buffers
/// reused, resized if the Gaussian count changed).
///
/// # Panics
/// If the shapes disagree.
pub fn render_tiled_vjp_into<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
    rast: &mut TiledRasterizer<T>,
    fwd: &Render<T>,
    d: &PixelGrad<'_, T>,
    grad: &mut RenderGrad<T>,
) {
    render_tiled_vjp_compositing(splats.len(), opts, rast, fwd, d, grad);
    render_tiled_vjp_projection(splats, camera, opts, fwd, grad);
}

/// The first phase of [`render_tiled_vjp_into`]: the compositing VJP of `n` Gaussians into
/// `grad.raster`, `grad.background` and `grad.densify` (callers that time the phases call
/// the two halves themselves).
///
/// # Panics
/// If the shapes disagree.
pub fn render_tiled_vjp_compositing<T: Real>(
    n: usize,
    opts: &RenderOptions<T>,
    rast: &mut TiledRasterizer<T>,
    fwd: &Render<T>,
    d: &PixelGrad<'_, T>,
    grad: &mut RenderGrad<T>,
) {
    grad.raster.reset(n);
    grad.background = rast.backward(
        &fwd.pre,
        opts.background,
        &fwd.raster,
        d,
        opts.par,
        &mut grad.raster,
        &mut grad.densify,
    );
}

/// The second phase of [`render_tiled_vjp_into`]: the projection and colour VJP from
/// `grad.raster` into `grad.splats` (overwritten) and `grad.camera`.
///
/// # Panics
/// If the shapes disagree.
pub fn render_tiled_vjp_projection<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
    fwd: &Render<T>,
    grad: &mut RenderGrad<T>,
) {
    if !(grad.splats.len() == splats.len()
        && grad.splats.sh_degree == splats.sh_degree
        && grad.splats.check())
    {
        grad.splats = splats.zeros_like();
    }
    grad.camera = preprocess_vjp_with(
        splats,
        camera,
        opts,
        &fwd.pre,
        &grad.raster,
        &mut grad.splats,
        GradInit::Overwrite,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gaussians::benchmark_scene;

    /// `s` with its colours cut to SH degree `degree` (each Gaussian's first coefficients).
    fn with_degree(s: &Splats<f64>, degree: usize) -> Splats<f64> {
        let mut out = Splats::new(degree);
        for i in 0..s.len() {
            let (m, l, q, o) = (s.means[i], s.log_scales[i], s.quats[i], s.opacity_logits[i]);
            out.push(m, l, q, o, s.sh_coeffs(i));
        }
        out
    }

    #[test]
    fn a_gradient_reused_across_counts_and_degrees_is_the_fresh_one() {
        let opts = RenderOptions::default();
        let mut rast = TiledRasterizer::new();
        let (big, cam) = benchmark_scene::<f64>(40, 12, 2);
        let (small, _) = benchmark_scene::<f64>(25, 12, 3);
        let low = with_degree(&big, 1);
        let d_rgb: Vec<f64> = (0..12 * 12 * 3)
            .map(|k: i32| f64::from(k % 7) * 0.25 - 0.75)
            .collect();
        let d = PixelGrad {
            rgb: &d_rgb,
            alpha: None,
            depth: None,
        };
        let fwd = render_tiled(&big, &cam, &opts, &mut rast);
        let mut reused = render_tiled_vjp(&big, &cam, &opts, &mut rast, &fwd, &d);
        // Another count at the same degree, back, then the same count at another degree,
        // and back: the buffer is reused only when both agree.
        for (name, s) in [
            ("fewer", &small),
            ("more", &big),
            ("degree 1", &low),
            ("degree 3", &big),
        ] {
            let fwd = render_tiled(s, &cam, &opts, &mut rast);
            let fresh = render_tiled_vjp(s, &cam, &opts, &mut rast, &fwd, &d);
            render_tiled_vjp_into(s, &cam, &opts, &mut rast, &fwd, &d, &mut reused);
            assert!(reused.splats == fresh.splats, "{name}: Gaussian gradients");
            assert!(reused.camera == fresh.camera, "{name}: camera gradient");
        }
    }
}
