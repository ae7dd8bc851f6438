//! View-dependent colour from spherical harmonics: [`sh_color`] and [`sh_color_vjp`]
//! (`docs/splatting.md` §10).
//!
//! ```text
//! d = μ − c_cam,   d̂ = d/|d|              (c_cam = −Rᵀ t, the camera centre)
//! raw_ch = Σ_k Y_k(d̂) sh_k,ch + ½
//! colour_ch = max(0, raw_ch)
//! ```
//!
//! Backward: the clamp passes the gradient only where `raw > 0` (mask `m`); with `g = m ⊙ dc`,
//! `d sh_k = Y_k(d̂) g` and `d(d) = (I − d̂ d̂ᵀ)(Σ_k ∇Y_k (sh_k · g))/|d|`, then `dμ = d(d)` and
//! `dc_cam = −d(d)` (see [`PinholeCamera::center_vjp`](crate::PinholeCamera::center_vjp) for
//! the step to the view matrix). Degree 0 needs no direction and gives no direction gradient.

use evogs_math::sh::{sh_eval, sh_eval_vjp};
use evogs_math::{Real, Vec3};

/// The offset added to the SH sum before the clamp.
pub const SH_OFFSET: f64 = 0.5;

/// The colour of a Gaussian at `mean` seen from the camera centre `center`, with SH degree
/// `degree` (the first `(degree + 1)²` triples of `coeffs` are used).
///
/// # Panics
/// If `coeffs` is shorter than `(degree + 1)²` or `degree > 3`.
///
/// ```
/// use evogs_splat::sh_color;
/// use evogs_math::{Vec3, sh::SH_C0};
/// let c = sh_color(0, &[[1.0, -0.5, -4.0]], Vec3::zero(), Vec3::new(0.0, 0.0, 4.0));
/// assert!((c[0] - (SH_C0 + 0.5)).abs() < 1e-15 && c[2] == 0.0); // clamped at 0
/// ```
#[must_use]
pub fn sh_color<T: Real>(
    degree: usize,
    coeffs: &[[T; 3]],
    mean: Vec3<T>,
    center: Vec3<T>,
) -> [T; 3] {
    let raw = sh_eval(degree, coeffs, mean - center);
    let off = T::from_f64(SH_OFFSET);
    raw.map(|v| (v + off).max(T::ZERO))
}

/// VJP of [`sh_color`]: **adds** `∂L/∂coeffs` into `d_coeffs` (first `(degree + 1)²`
/// entries) and returns `(∂L/∂mean, ∂L/∂center)`.
///
/// # Panics
/// If `coeffs` or `d_coeffs` is shorter than `(degree + 1)²` or `degree > 3`.
///
/// ```
/// use evogs_splat::{sh_color, sh_color_vjp};
/// use evogs_math::Vec3;
/// use evogs_math::diff::{central_gradient, GradCheck};
/// let coeffs: Vec<[f64; 3]> = (0..16).map(|k| [0.3 - 0.05 * k as f64, 0.1, -0.2]).collect();
/// let (center, dc) = (Vec3::new(0.2, -0.1, 4.0), [0.7, -0.3, 1.1]);
/// let f = |m: &[f64]| {
///     let c = sh_color(3, &coeffs, Vec3::from_slice(m), center);
///     c[0] * dc[0] + c[1] * dc[1] + c[2] * dc[2]
/// };
/// let (mut x, mut num) = ([0.3, 0.1, -0.2], [0.0; 3]);
/// central_gradient(f, &mut x, &mut num);
/// let mut d_coeffs = vec![[0.0; 3]; 16];
/// let (d_mean, d_center) = sh_color_vjp(3, &coeffs, Vec3::from_array(x), center, dc, &mut d_coeffs);
/// GradCheck::new(1e-10, 1e-7).check(&d_mean.to_array(), &num).assert_passed("d mean");
/// assert!((d_mean + d_center).norm() < 1e-15);
/// ```
pub fn sh_color_vjp<T: Real>(
    degree: usize,
    coeffs: &[[T; 3]],
    mean: Vec3<T>,
    center: Vec3<T>,
    d_color: [T; 3],
    d_coeffs: &mut [[T; 3]],
) -> (Vec3<T>, Vec3<T>) {
    let dir = mean - center;
    let raw = sh_eval(degree, coeffs, dir);
    let off = T::from_f64(SH_OFFSET);
    let mut g = d_color;
    for (gc, r) in g.iter_mut().zip(raw) {
        let passes = r + off > T::ZERO;
        if !passes {
            *gc = T::ZERO;
        }
    }
    let d_dir = sh_eval_vjp(degree, coeffs, dir, g, d_coeffs);
    (d_dir, -d_dir)
}
