//! Image quality metrics: MSE, PSNR (with VJP) and the 3DGS SSIM, per image.
//!
//! With the data range 1 (images in [0, 1]) and `N = 3·H·W` values:
//!
//! ```text
//! MSE  = (1/N) Σ (a_i − b_i)²
//! PSNR = 10 log10(1/MSE) = −(10/ln 10)·ln MSE       (dB; +∞ for identical images)
//! ∂PSNR/∂a_i = −(10/ln 10)·(1/MSE)·2(a_i − b_i)/N
//! ```
//!
//! This is 3DGS's `20·log10(1/√MSE)` and scikit-image's `peak_signal_noise_ratio` with
//! `data_range = 1`. SSIM is the 3DGS variant of [`crate::ssim`] (zero padding, no crop),
//! not scikit-image's. Renders are usually clamped to [0, 1] (and quantised to 8 bits when
//! read back from PNG) before evaluation; that is the caller's business. Per-image values
//! are averaged over the evaluation set by the caller.
//!
//! ```
//! use evogs_splat::{Image, metrics::{psnr, psnr_from_mse}};
//! let a = Image::<f64>::filled(8, 8, [0.5, 0.5, 0.5]);
//! let b = Image::filled(8, 8, [0.6, 0.5, 0.4]);
//! // MSE = (0.01 + 0 + 0.01)/3
//! assert!((psnr(&a, &b) - psnr_from_mse(0.02 / 3.0)).abs() < 1e-12);
//! assert!((psnr_from_mse(0.01_f64) - 20.0).abs() < 1e-12);
//! ```

use crate::Image;
use crate::loss::{l2, l2_vjp};
use crate::ssim::SsimWorkspace;
use evogs_math::{Par, Real};

/// `10/ln 10`: decibels per neper of power.
const DB_PER_LN: f64 = 10.0 / core::f64::consts::LN_10;

/// Mean squared error over all values (the same function as [`l2`]).
///
/// # Panics
/// If the images differ in size or are empty.
#[must_use]
pub fn mse<T: Real>(a: &Image<T>, b: &Image<T>) -> T {
    l2(a, b)
}

/// PSNR in dB for data range 1 from a mean squared error: `10 log10(1/mse)`
/// (`+∞` for `mse = 0`).
#[must_use]
pub fn psnr_from_mse<T: Real>(mse: T) -> T {
    -(T::from_f64(DB_PER_LN) * mse.ln())
}

/// Derivative of [`psnr_from_mse`]: `−(10/ln 10)/mse`.
#[must_use]
pub fn psnr_from_mse_vjp<T: Real>(mse: T, g: T) -> T {
    -(g * T::from_f64(DB_PER_LN) / mse)
}

/// PSNR of `a` against `b` in dB (data range 1).
///
/// # Panics
/// If the images differ in size or are empty.
#[must_use]
pub fn psnr<T: Real>(a: &Image<T>, b: &Image<T>) -> T {
    psnr_from_mse(mse(a, b))
}

/// VJP of [`psnr`] with respect to `a`: adds `g·∂PSNR/∂a` into `d_a`.
///
/// PSNR is not differentiable at `a = b` (it is `+∞` there); for identical images nothing
/// is added.
///
/// ```
/// use evogs_math::diff::{central_gradient, GradCheck};
/// use evogs_splat::{Image, metrics::{psnr, psnr_vjp}};
/// let a = Image::from_vec(2, 1, vec![0.1, 0.5, 0.9, 0.3, 0.7, 0.2]).unwrap();
/// let b = Image::from_vec(2, 1, vec![0.2, 0.4, 0.6, 0.6, 0.5, 0.4]).unwrap();
/// let mut d_a = Image::new(2, 1);
/// psnr_vjp(&a, &b, 1.0, &mut d_a);
/// let mut x = a.data().to_vec();
/// let mut num = vec![0.0; 6];
/// central_gradient(|v: &[f64]| psnr(&Image::from_vec(2, 1, v.to_vec()).unwrap(), &b), &mut x, &mut num);
/// GradCheck::new(1e-8, 1e-7).check(d_a.data(), &num).assert_passed("psnr_vjp");
/// ```
///
/// # Panics
/// If the sizes of `a`, `b` and `d_a` differ or the images are empty.
pub fn psnr_vjp<T: Real>(a: &Image<T>, b: &Image<T>, g: T, d_a: &mut Image<T>) {
    let m = mse(a, b);
    if m > T::ZERO {
        l2_vjp(a, b, psnr_from_mse_vjp(m, g), d_a);
    }
}

/// The per-image metrics of an evaluation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageMetrics<T> {
    /// Mean squared error.
    pub mse: T,
    /// PSNR in dB (data range 1).
    pub psnr: T,
    /// SSIM, 3DGS variant.
    pub ssim: T,
}

/// MSE, PSNR and SSIM of a render `a` against the ground truth `b`.
///
/// ```
/// use evogs_math::Par;
/// use evogs_splat::{Image, metrics::image_metrics, ssim::SsimWorkspace};
/// let a = Image::<f64>::filled(12, 12, [0.5, 0.5, 0.5]);
/// let m = image_metrics(&mut SsimWorkspace::new(), &a, &a, Par::Seq);
/// assert!(m.psnr.is_infinite() && (m.ssim - 1.0).abs() < 1e-14);
/// ```
///
/// # Panics
/// If the images differ in size or are empty.
pub fn image_metrics<T: Real>(
    ws: &mut SsimWorkspace<T>,
    a: &Image<T>,
    b: &Image<T>,
    par: Par,
) -> ImageMetrics<T> {
    let mse = mse(a, b);
    ImageMetrics {
        mse,
        psnr: psnr_from_mse(mse),
        ssim: ws.ssim(a, b, par),
    }
}
