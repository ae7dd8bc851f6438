//! # evogs-splat
//!
//! Differentiable 3D Gaussian splatting on the CPU, forward and backward, every derivative
//! written by hand and checked against central differences, dual numbers and reference
//! vectors from gsplat. `no_std` + `alloc`.
//!
//! | stage | forward | backward |
//! |---|---|---|
//! | camera | [`PinholeCamera`] (`camera_from_world`, OpenCV axes, from D-NeRF/OpenGL matrices) | [`CameraGrad`] (view matrix, left se(3)) |
//! | projection (EWA) | [`project`]: means2d, depth, conic, radii, compensation | [`project_vjp`] |
//! | colour | [`sh_color`]: SH + ½, clamped at 0 | [`sh_color_vjp`] (into the mean and the camera) |
//! | all Gaussians | [`preprocess`] → [`Preprocessed`] | [`preprocess_vjp`] |
//! | compositing | [`rasterize_ref`] (dense, obviously correct), [`rasterize_tiled`] (16×16 tiles) | [`rasterize_ref_vjp`], [`rasterize_tiled_vjp`] |
//! | whole chain | [`render`], [`render_tiled`] | [`render_vjp`], [`render_tiled_vjp`] |
//! | losses, metrics | [`loss`] (L1, L2, 3DGS loss), [`ssim`] (3DGS SSIM, D-SSIM), [`metrics`] (PSNR) | the `*_vjp` beside each |
//!
//! Conventions: Gaussians are stored in their raw training parameterisation ([`Splats`]:
//! mean, log-scale, raw quaternion (w, x, y, z), opacity logit, SH coefficients DC first);
//! cameras use OpenCV axes (x right, y down, z forward), pixel centres at `(j + ½, i + ½)`;
//! images are RGB, row-major, row 0 at the top ([`Image`]). Compositing follows gsplat 1.5.3
//! exactly: `α = min(0.999, o·e^(−σ))`, skip `σ < 0` or `α < 1/255`, stop before adding when
//! the next transmittance would be ≤ 1e-4, background times the final transmittance.
//!
//! The reference rasterizer is a per-pixel loop over every Gaussian in depth order, written
//! to be read; the tiled rasterizer bins Gaussians into 16×16 tiles (a stable counting sort
//! by tile then depth), evaluates 4×4 pixel groups in loops the compiler vectorises, and
//! reduces per-Gaussian gradients in a fixed order (no atomics), so sequential and rayon runs
//! are bitwise identical. Both make exactly the same decisions and their images agree bitwise
//! (in `f32` with [`ExpMode::Exact`]; the default fast `f32` exponential can move a value by an
//! ulp).
//!
//! ```
//! use evogs_splat::{benchmark_scene, render_tiled, render_tiled_vjp, PixelGrad, RenderOptions, TiledRasterizer};
//! let (splats, camera) = benchmark_scene::<f32>(500, 64, 1);
//! let opts = RenderOptions::default();
//! let mut rast = TiledRasterizer::new();
//! let fwd = render_tiled(&splats, &camera, &opts, &mut rast);
//! let d_rgb = vec![1.0; 64 * 64 * 3]; // ∂L/∂pixel for L = Σ pixels
//! let grad = render_tiled_vjp(&splats, &camera, &opts, &mut rast, &fwd, &PixelGrad { rgb: &d_rgb, alpha: None, depth: None });
//! assert_eq!(grad.splats.len(), 500);
//! ```
#![cfg_attr(not(feature = "std"), no_std)]

#[cfg(not(any(feature = "std", feature = "libm")))]
compile_error!(
    "evogs-splat needs a float backend: enable the `std` (default) or the `libm` feature"
);

extern crate alloc;

mod binning;
mod camera;
mod color;
mod fast_exp;
mod gaussians;
mod image;
pub mod loss;
pub mod metrics;
pub mod preprocess;
pub mod project;
pub mod project_vjp;
pub mod raster_ref;
mod raster_ref_vjp;
mod raster_tiled;
mod raster_tiled_vjp;
mod render;
pub mod ssim;
#[cfg(feature = "proptest")]
pub mod strategies;
mod sum;
mod tile_lanes;

pub use binning::{Binning, Rect, TILE_SIZE, TileGrid};
pub use camera::{CameraError, CameraGrad, DEFAULT_FAR, DEFAULT_NEAR, PinholeCamera};
pub use color::{SH_OFFSET, sh_color, sh_color_vjp};
pub use gaussians::{Splats, SplatsGrad, benchmark_scene, random_scene};
pub use image::Image;
pub use preprocess::{
    Preprocessed, RasterInputGrad, RasterMode, RenderOptions, preprocess, preprocess_into,
    preprocess_vjp,
};
pub use project::{ProjectOptions, Projected, RadiusMode, project};
pub use project_vjp::{ProjectInputGrad, ProjectedGrad, project_vjp};
pub use raster_ref::{RasterOutput, SplatHit, rasterize_ref, splat_alpha, splat_alpha_cut};
pub use raster_ref_vjp::{PixelGrad, rasterize_ref_vjp};
pub use raster_tiled::{ExpMode, TiledRasterizer, rasterize_tiled};
pub use raster_tiled_vjp::{DensifyStats, rasterize_tiled_vjp};
pub use render::{
    Render, RenderGrad, render, render_tiled, render_tiled_into, render_tiled_vjp,
    render_tiled_vjp_into, render_vjp,
};
