#![doc = include_str!("../README.md")]
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
mod pool;
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
    render_tiled_vjp_compositing, render_tiled_vjp_into, render_tiled_vjp_projection, render_vjp,
};
