//! The discrete decisions of the compositing rules, counted and measured the way the raster
//! reference files report them (`decision_counts`, `decision_margins`).
//!
//! The reference is dense: every pixel evaluates every valid Gaussian front to back until
//! it stops. With `v = o'·exp(−σ)` and `α = min(0.999, v)`:
//!
//! ```text
//! n_composited         pairs added to a pixel (= Σ n_contrib)
//! n_alpha_clamped      added pairs with v > 0.999
//! n_terminations       pixels that stopped (next_T ≤ 1e-4)
//! n_skipped_low_alpha  evaluated pairs with 0 < α < 1/255 (pairs whose exp(−σ) underflows
//!                      to 0 are not counted: this reproduces every reference file)
//! alpha_threshold_rel  min |α − 1/255|/(1/255)     over evaluated pairs
//! alpha_clamp_abs      min |v − 0.999|             over evaluated pairs
//! transmittance_rel    min |next_T − 1e-4|/1e-4    over pairs that pass the alpha test
//! sh_clamp_abs         min |SH(d̂) + ½|            over valid Gaussians and channels
//! ```
//!
//! The pixel part needs only the rasterizer inputs, so scene generators can use
//! [`pixel_decisions`] to keep test scenes away from the thresholds.

use evogs_math::sh::sh_eval;
use evogs_splat::raster_ref::{ALPHA_MAX, ALPHA_MIN, T_STOP, conic_sigma, pixel_center};
use evogs_splat::{PinholeCamera, Preprocessed, RenderOptions, Splats};

/// Counts and margins of one render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Decisions {
    /// Pairs added to a pixel.
    pub n_composited: usize,
    /// Added pairs whose alpha was clamped at 0.999.
    pub n_alpha_clamped: usize,
    /// Pixels that stopped early.
    pub n_terminations: usize,
    /// Evaluated pairs with `0 < α < 1/255`.
    pub n_skipped_low_alpha: usize,
    /// `min |α − 1/255|/(1/255)`.
    pub alpha_threshold_rel: f64,
    /// `min |o'·exp(−σ) − 0.999|`.
    pub alpha_clamp_abs: f64,
    /// `min |next_T − 1e-4|/1e-4`.
    pub transmittance_rel: f64,
    /// `min |SH + ½|` (infinite until [`sh_decisions`] fills it in).
    pub sh_clamp_abs: f64,
}

/// The per-pixel decisions of the rasterizer inputs `pre` (dense, every pixel).
#[must_use]
pub fn pixel_decisions(pre: &Preprocessed<f64>) -> Decisions {
    let mut d = Decisions {
        n_composited: 0,
        n_alpha_clamped: 0,
        n_terminations: 0,
        n_skipped_low_alpha: 0,
        alpha_threshold_rel: f64::INFINITY,
        alpha_clamp_abs: f64::INFINITY,
        transmittance_rel: f64::INFINITY,
        sh_clamp_abs: f64::INFINITY,
    };
    for row in 0..pre.height {
        for col in 0..pre.width {
            let (px, py) = pixel_center::<f64>(col, row);
            let mut t = 1.0;
            for &g in &pre.order {
                let g = g as usize;
                let m = pre.means2d[g];
                let sigma = conic_sigma(pre.conics[g], m.x - px, m.y - py);
                if sigma < 0.0 {
                    continue;
                }
                let v = pre.opacities[g] * (-sigma).exp();
                let alpha = v.min(ALPHA_MAX);
                d.alpha_threshold_rel = d
                    .alpha_threshold_rel
                    .min((alpha - ALPHA_MIN).abs() / ALPHA_MIN);
                d.alpha_clamp_abs = d.alpha_clamp_abs.min((v - ALPHA_MAX).abs());
                if alpha < ALPHA_MIN {
                    d.n_skipped_low_alpha += usize::from(alpha > 0.0);
                    continue;
                }
                let next_t = t * (1.0 - alpha);
                d.transmittance_rel = d.transmittance_rel.min((next_t - T_STOP).abs() / T_STOP);
                if next_t <= T_STOP {
                    d.n_terminations += 1;
                    break;
                }
                d.n_composited += 1;
                d.n_alpha_clamped += usize::from(v > ALPHA_MAX);
                t = next_t;
            }
        }
    }
    d
}

/// `min |SH(d̂) + ½|` over the valid Gaussians of `pre` and the colour channels.
#[must_use]
pub fn sh_decisions(
    pre: &Preprocessed<f64>,
    splats: &Splats<f64>,
    cam: &PinholeCamera<f64>,
    opts: &RenderOptions<f64>,
) -> f64 {
    let degree = opts.sh_degree.min(splats.sh_degree);
    let center = cam.center();
    let mut m = f64::INFINITY;
    for &g in &pre.order {
        let g = g as usize;
        for v in sh_eval(degree, splats.sh_coeffs(g), splats.means[g] - center) {
            m = m.min((v + 0.5).abs());
        }
    }
    m
}

/// Every decision count and margin of a render.
#[must_use]
pub fn decisions(
    pre: &Preprocessed<f64>,
    splats: &Splats<f64>,
    cam: &PinholeCamera<f64>,
    opts: &RenderOptions<f64>,
) -> Decisions {
    Decisions {
        sh_clamp_abs: sh_decisions(pre, splats, cam, opts),
        ..pixel_decisions(pre)
    }
}
