//! The backward pass of the reference rasterizer, [`rasterize_ref_vjp`] (`docs/splatting.md`
//! §12).
//!
//! Per pixel with contributors i = 1…n (front to back), `T_i = Π_{j<i}(1 − α_j)`,
//! `C = Σ c_i α_i T_i + T_f·bg`, `A = 1 − T_f`, `D = Σ z_i α_i T_i`, `E = D/max(1 − T_f, 1e-10)`,
//! and pixel cotangents `dC`, `dA`, `dE`:
//!
//! ```text
//! dD   = dE / max(1 − T_f, 1e-10)
//! g_T  = dC·bg − dA + dE·D/(1 − T_f)²   (last term only where the floor is inactive)
//! dc_i = α_i T_i dC,   dz_i = α_i T_i dD
//! dα_i = dC·(c_i T_i − S_i/(1 − α_i)) + dD (z_i T_i − S^z_i/(1 − α_i)) − g_T T_f/(1 − α_i)
//!        with S_i = Σ_{j>i} c_j α_j T_j (and S^z_i likewise with z_j)
//! d bg = T_f dC
//! ```
//!
//! Through `α = o'·G`, `G = exp(−σ)` (zero where α was clamped at 0.999):
//! `do' = G dα`, `dσ = −α dα`, `d[a, b, c] = (½dx², dx dy, ½dy²) dσ`,
//! `d mean2d = dσ (a dx + b dy, b dx + c dy)`.
//!
//! `T_i` is recovered by reverse traversal from the stored `T_f`: walking back from the
//! last contributor, every Gaussian that passes the same skip rules (same floats, same
//! [`splat_alpha_cut`]) divides `T ← T/(1 − α)`.

use crate::preprocess::{Preprocessed, RasterInputGrad};
use crate::raster_ref::{DEPTH_DENOM_MIN, RasterOutput, pack, pixel_center, splat_alpha_cut};
use evogs_math::{Real, Vec2};

/// Per-pixel cotangents of a rasterizer's outputs (row-major, row 0 at the top).
#[derive(Clone, Copy, Debug)]
pub struct PixelGrad<'a, T> {
    /// `∂L/∂rgb`, interleaved like [`Image`](crate::Image) (3 per pixel).
    pub rgb: &'a [T],
    /// `∂L/∂alpha` (one per pixel), if the loss uses the alpha output.
    pub alpha: Option<&'a [T]>,
    /// `∂L/∂(expected depth)` (one per pixel), if the loss uses the depth output.
    pub depth: Option<&'a [T]>,
}

impl<T> PixelGrad<'_, T> {
    /// Panics unless every cotangent covers `np` pixels (the shape check both rasterizers'
    /// backward passes start with).
    pub(crate) fn assert_pixels(&self, np: usize) {
        assert_eq!(self.rgb.len(), 3 * np, "rgb cotangent length");
        assert!(
            self.alpha.is_none_or(|a| a.len() == np),
            "alpha cotangent length"
        );
        assert!(
            self.depth.is_none_or(|a| a.len() == np),
            "depth cotangent length"
        );
    }
}

/// VJP of [`rasterize_ref`](crate::raster_ref::rasterize_ref): **adds** the gradients with
/// respect to every Gaussian's 2D mean, conic, colour, effective opacity and depth into
/// `grad` and returns the gradient with respect to the background colour.
///
/// `out` must be the forward output for the same `pre` and `background`.
///
/// # Panics
/// If the cotangent or gradient lengths do not match the image and `pre`.
///
/// ```
/// use evogs_splat::{benchmark_scene, preprocess, rasterize_ref, rasterize_ref_vjp, PixelGrad, RasterInputGrad, RenderOptions};
/// let (splats, cam) = benchmark_scene::<f64>(20, 8, 3);
/// let opts = RenderOptions::default();
/// let pre = preprocess(&splats, &cam, &opts);
/// let out = rasterize_ref(&pre, opts.background);
/// let d_rgb = vec![1.0; 8 * 8 * 3];
/// let mut grad = RasterInputGrad::zeros(splats.len());
/// let d_bg = rasterize_ref_vjp(&pre, opts.background, &out, &PixelGrad { rgb: &d_rgb, alpha: None, depth: None }, &mut grad);
/// // ∂(Σ rgb)/∂bg = Σ T_final.
/// assert!((d_bg[0] - out.final_t.iter().sum::<f64>()).abs() < 1e-12);
/// ```
pub fn rasterize_ref_vjp<T: Real>(
    pre: &Preprocessed<T>,
    background: [T; 3],
    out: &RasterOutput<T>,
    d: &PixelGrad<'_, T>,
    grad: &mut RasterInputGrad<T>,
) -> [T; 3] {
    let (w, h) = (pre.width, pre.height);
    let np = w * h;
    d.assert_pixels(np);
    assert!(out.final_t.len() == np, "forward output size");
    assert_eq!(grad.len(), pre.means2d.len(), "gradient length");
    let floor = T::from_f64(DEPTH_DENOM_MIN);
    let packed = pack(pre);
    let mut d_bg = [T::ZERO; 3];
    for row in 0..h {
        for col in 0..w {
            let p = row * w + col;
            let (px, py) = pixel_center::<T>(col, row);
            let tf = out.final_t[p];
            let dc = [d.rgb[3 * p], d.rgb[3 * p + 1], d.rgb[3 * p + 2]];
            let da = d.alpha.map_or(T::ZERO, |a| a[p]);
            let de = d.depth.map_or(T::ZERO, |a| a[p]);
            let one_minus_tf = T::ONE - tf;
            let denom = one_minus_tf.max(floor);
            let dd = de / denom;
            let mut g_t =
                dc[0] * background[0] + dc[1] * background[1] + dc[2] * background[2] - da;
            if one_minus_tf > floor {
                let depth_sum = out.depth[p] * denom;
                g_t += de * depth_sum / (denom * denom);
            }
            for ch in 0..3 {
                d_bg[ch] += tf * dc[ch];
            }

            let mut t = tf;
            let mut s = [T::ZERO; 3];
            let mut sz = T::ZERO;
            for pos in (0..out.last[p] as usize).rev() {
                let p = &packed[pos];
                let Some(hit) = splat_alpha_cut(p.mean, p.conic, p.opacity, p.cut, px, py) else {
                    continue;
                };
                let g = pre.order[pos] as usize;
                let om = T::ONE - hit.alpha;
                t /= om;
                let wgt = hit.alpha * t;
                let color = pre.colors[g];
                let z = pre.depths[g];
                let mut d_alpha = dd * (z * t - sz / om) - g_t * tf / om;
                for ch in 0..3 {
                    grad.colors[g][ch] += wgt * dc[ch];
                    d_alpha += dc[ch] * (color[ch] * t - s[ch] / om);
                    s[ch] += color[ch] * wgt;
                }
                grad.depths[g] += wgt * dd;
                sz += z * wgt;
                if hit.clamped {
                    continue;
                }
                grad.opacities[g] += hit.g * d_alpha;
                let d_sigma = -hit.alpha * d_alpha;
                let (dx, dy) = (hit.dx, hit.dy);
                let conic = pre.conics[g];
                let dcon = &mut grad.conics[g];
                dcon[0] += T::HALF * dx * dx * d_sigma;
                dcon[1] += dx * dy * d_sigma;
                dcon[2] += T::HALF * dy * dy * d_sigma;
                grad.means2d[g] += Vec2::new(
                    d_sigma * (conic[0] * dx + conic[1] * dy),
                    d_sigma * (conic[1] * dx + conic[2] * dy),
                );
            }
        }
    }
    d_bg
}

#[cfg(test)]
mod tests {
    use super::*;

    const RGB: [f64; 6] = [0.0; 6];
    const ONE: [f64; 2] = [0.0; 2];
    const SHORT: [f64; 1] = [0.0];

    /// The shape check of these cotangents for two pixels.
    fn check_two_pixels(rgb: &[f64], alpha: Option<&[f64]>, depth: Option<&[f64]>) {
        PixelGrad { rgb, alpha, depth }.assert_pixels(2);
    }

    #[test]
    fn cotangents_covering_every_pixel_pass() {
        check_two_pixels(&RGB, Some(&ONE), None);
    }

    #[test]
    #[should_panic(expected = "rgb cotangent length")]
    fn a_short_colour_cotangent_is_refused() {
        check_two_pixels(&RGB[..5], None, None);
    }

    #[test]
    #[should_panic(expected = "alpha cotangent length")]
    fn a_short_alpha_cotangent_is_refused() {
        check_two_pixels(&RGB, Some(&SHORT), Some(&ONE));
    }

    #[test]
    #[should_panic(expected = "depth cotangent length")]
    fn a_short_depth_cotangent_is_refused() {
        check_two_pixels(&RGB, Some(&ONE), Some(&SHORT));
    }
}
