//! The render half of a training step with the time of each phase: the phases of
//! [`render_tiled_into`] (projection, then rasterization) and [`render_tiled_vjp_into`]
//! (the compositing VJP, then the projection VJP, which evogs-splat exposes as two calls),
//! with a clock read between them. Results are those of the two library functions, bit for
//! bit.
//!
//! [`render_tiled_into`]: evogs_splat::render_tiled_into
//! [`render_tiled_vjp_into`]: evogs_splat::render_tiled_vjp_into

use evogs_math::Real;
use evogs_splat::{
    PinholeCamera, PixelGrad, Render, RenderGrad, RenderOptions, Splats, TiledRasterizer,
    preprocess_into, render_tiled_vjp_compositing, render_tiled_vjp_projection,
};
use std::time::Instant;

/// Seconds spent in the phases of one render and its VJP.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderTimes {
    /// Projection and SH colours (preprocessing), forward and VJP.
    pub projection: f64,
    /// Tile binning, sorting and compositing.
    pub raster_forward: f64,
    /// The compositing VJP.
    pub raster_backward: f64,
}

impl RenderTimes {
    /// Adds another render's times.
    pub fn add(&mut self, o: &Self) {
        self.projection += o.projection;
        self.raster_forward += o.raster_forward;
        self.raster_backward += o.raster_backward;
    }
}

/// [`render_tiled_into`](evogs_splat::render_tiled_into), adding the time of its phases
/// into `times`.
pub fn render_forward<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
    rast: &mut TiledRasterizer<T>,
    out: &mut Render<T>,
    times: &mut RenderTimes,
) {
    let start = Instant::now();
    preprocess_into(splats, camera, opts, &mut out.pre);
    let projected = Instant::now();
    rast.forward_into(&out.pre, opts.background, opts.par, &mut out.raster);
    times.projection += (projected - start).as_secs_f64();
    times.raster_forward += projected.elapsed().as_secs_f64();
}

/// [`render_tiled_vjp_into`](evogs_splat::render_tiled_vjp_into) (`grad` overwritten),
/// adding the time of its phases into `times`.
pub fn render_backward<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
    rast: &mut TiledRasterizer<T>,
    fwd: &Render<T>,
    d: &PixelGrad<'_, T>,
    grad: &mut RenderGrad<T>,
    times: &mut RenderTimes,
) {
    let start = Instant::now();
    render_tiled_vjp_compositing(splats.len(), opts, rast, fwd, d, grad);
    let rasterized = Instant::now();
    render_tiled_vjp_projection(splats, camera, opts, fwd, grad);
    times.raster_backward += (rasterized - start).as_secs_f64();
    times.projection += rasterized.elapsed().as_secs_f64();
}

#[cfg(test)]
mod tests {
    use super::*;
    use evogs_math::Par;
    use evogs_splat::{random_scene, render_tiled, render_tiled_vjp};

    #[test]
    fn phases_give_the_library_results_bit_for_bit() {
        let (splats, camera) = random_scene::<f32>(300, 48, 5, [0.01, 0.05], [0.3, 0.9]);
        let opts = RenderOptions {
            sh_degree: 3,
            ..RenderOptions::default()
        };
        let mut rast = TiledRasterizer::new();
        let reference = render_tiled(&splats, &camera, &opts, &mut rast);
        let d_rgb: Vec<f32> = (0..48 * 48 * 3)
            .map(|i| f32::from(u16::try_from(i % 7).expect("small")) - 3.0)
            .collect();
        let d = PixelGrad {
            rgb: &d_rgb,
            alpha: None,
            depth: None,
        };
        let reference_grad = render_tiled_vjp(&splats, &camera, &opts, &mut rast, &reference, &d);
        let mut times = RenderTimes::default();
        let mut out = render_tiled(&splats, &camera, &opts, &mut TiledRasterizer::new());
        out.raster.rgb.data_mut().fill(0.0);
        render_forward(&splats, &camera, &opts, &mut rast, &mut out, &mut times);
        assert!(out == reference, "forward");
        let mut grad = reference_grad.clone();
        grad.splats.fill_zero(Par::Seq);
        render_backward(
            &splats, &camera, &opts, &mut rast, &out, &d, &mut grad, &mut times,
        );
        assert!(grad == reference_grad, "backward");
        assert!(
            times.projection > 0.0 && times.raster_forward > 0.0 && times.raster_backward > 0.0,
            "every phase timed: {times:?}"
        );
    }
}
