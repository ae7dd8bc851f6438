//! How a model's Gaussians are rendered: the options every render of a model uses
//! (training, evaluation, baselines, motion editing), for a background and an SH degree.

use evogs_math::{Par, Real};
use evogs_splat::RenderOptions;

/// The render options for a camera-independent background and an SH degree (the rest at
/// the rasterizer's defaults).
#[must_use]
pub fn render_options<T: Real>(
    background: [f32; 3],
    sh_degree: usize,
    par: Par,
) -> RenderOptions<T> {
    RenderOptions {
        sh_degree,
        background: background.map(|v| T::from_f64(f64::from(v))),
        par,
        ..RenderOptions::default()
    }
}
