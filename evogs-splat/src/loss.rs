//! Photometric losses: L1, L2 (the MSE) and the 3DGS training loss L1 + SSIM, with VJPs.
//!
//! All losses are means over the `N = 3·H·W` values of two same-size images `a`
//! (the render, the argument we differentiate) and `b` (the target):
//!
//! ```text
//! L1(a, b) = (1/N) Σ |a_i − b_i|            ∂L1/∂a_i = sign(a_i − b_i)/N   (sign(0) = 0)
//! L2(a, b) = (1/N) Σ (a_i − b_i)²  (MSE)    ∂L2/∂a_i = 2(a_i − b_i)/N
//! ```
//!
//! At `a_i = b_i` the absolute value has a kink; [`l1_vjp`] uses the subgradient 0 there
//! (as `torch.abs` does), so the gradient of a perfect pixel is exactly zero.
//!
//! **Gradient convention:** every `*_vjp` and `*_and_grad` function *adds*
//! `g·∂L/∂a` into a caller-provided gradient image (`g` is the output cotangent, the
//! weight of this loss). Zero the buffer first; several losses then compose by summing
//! into the same buffer, without temporaries:
//!
//! ```
//! use evogs_splat::Image;
//! use evogs_splat::loss::{l1_and_grad, l2_and_grad};
//! let a = Image::<f64>::filled(4, 4, [0.5, 0.2, 0.9]);
//! let b = Image::filled(4, 4, [0.4, 0.2, 1.0]);
//! let mut d_a = Image::new(4, 4);
//! let l = 0.8 * l1_and_grad(&a, &b, 0.8, &mut d_a) + 0.2 * l2_and_grad(&a, &b, 0.2, &mut d_a);
//! assert!((l - (0.8 * 0.2 / 3.0 + 0.2 * 0.02 / 3.0)).abs() < 1e-12);
//! ```
//!
//! Sums are accumulated in 8 independent lanes over fixed 1024-value chunks, and the chunk
//! sums are added in order: the result does not depend on threads, is vectorisable, and the
//! f32 rounding error grows with the chunk count rather than with `N`.
//!
//! [`photometric_loss_and_grad`] is the 3DGS training loss `(1 − λ)·L1 + λ·(1 − SSIM)`
//! (3DGS and 4DGS use λ = 0.2; the EvoGS anchor stage uses 0.3). Note the factor: 3DGS
//! calls `1 − SSIM` its "D-SSIM" term, while the structural dissimilarity reported as
//! D-SSIM in tables is `(1 − SSIM)/2` ([`d_ssim`](crate::ssim::d_ssim)).

use crate::Image;
use crate::ssim::SsimWorkspace;
use crate::sum::{CHUNK, chunked_sum};
use alloc::vec::Vec;
use evogs_math::{Par, Real};

/// `sign(d)` with `sign(0) = 0` (the subgradient used at the kink of `|d|`).
#[inline]
fn sign<T: Real>(d: T) -> T {
    if d > T::ZERO {
        T::ONE
    } else if d < T::ZERO {
        -T::ONE
    } else {
        T::ZERO
    }
}

/// Checks sizes and returns `N = 3·H·W`.
fn value_count<T: Real>(a: &Image<T>, b: &Image<T>) -> usize {
    assert!(
        a.same_size(b),
        "images differ in size: {}x{} vs {}x{}",
        a.width(),
        a.height(),
        b.width(),
        b.height()
    );
    let n = a.data().len();
    assert!(n > 0, "losses of an empty image are undefined");
    n
}

/// Checks that the gradient image matches the input size.
fn check_grad<T: Real>(a: &Image<T>, d_a: &Image<T>) {
    assert!(
        a.same_size(d_a),
        "gradient image is {}x{}, input is {}x{}",
        d_a.width(),
        d_a.height(),
        a.width(),
        a.height()
    );
}

/// Adds `grad(a_i − b_i)` into `d_a` and returns `Σ value(a_i − b_i)`, summed in the order
/// of [`chunked_sum`](crate::sum::chunked_sum).
///
/// Per chunk, the gradient is a plain element-wise loop (branch-free selects after
/// vectorisation) and the value a lane sum over the same, cache-resident chunk.
#[inline]
fn fused<T: Real>(
    a: &[T],
    b: &[T],
    d_a: &mut [T],
    value: impl Fn(T) -> T,
    grad: impl Fn(T) -> T,
) -> T {
    let mut total = T::ZERO;
    for ((ca, cb), cg) in a
        .chunks(CHUNK)
        .zip(b.chunks(CHUNK))
        .zip(d_a.chunks_mut(CHUNK))
    {
        for ((g, &x), &y) in cg.iter_mut().zip(ca).zip(cb) {
            *g += grad(x - y);
        }
        total += chunked_sum(ca, cb, |x, y| value(x - y));
    }
    total
}

/// Mean absolute error `(1/N) Σ |a_i − b_i|` over all `N = 3·H·W` values.
///
/// # Panics
/// If the images differ in size or are empty.
#[must_use]
pub fn l1<T: Real>(a: &Image<T>, b: &Image<T>) -> T {
    let n = value_count(a, b);
    chunked_sum(a.data(), b.data(), |x, y| (x - y).abs()) / T::from_usize(n)
}

/// VJP of [`l1`] with respect to `a`: adds `g·sign(a_i − b_i)/N` into `d_a`
/// (subgradient 0 where `a_i = b_i`).
///
/// ```
/// use evogs_math::diff::{central_gradient, GradCheck};
/// use evogs_splat::{Image, loss::{l1, l1_vjp}};
/// let a = Image::from_vec(2, 1, vec![0.1, 0.5, 0.9, 0.3, 0.7, 0.2]).unwrap();
/// let b = Image::from_vec(2, 1, vec![0.2, 0.4, 0.6, 0.6, 0.5, 0.4]).unwrap();
/// let mut d_a = Image::new(2, 1);
/// l1_vjp(&a, &b, 1.0, &mut d_a);
/// let mut x = a.data().to_vec();
/// let mut num = vec![0.0; 6];
/// central_gradient(|v: &[f64]| l1(&Image::from_vec(2, 1, v.to_vec()).unwrap(), &b), &mut x, &mut num);
/// GradCheck::new(1e-10, 1e-8).check(d_a.data(), &num).assert_passed("l1_vjp");
/// ```
///
/// # Panics
/// If the sizes of `a`, `b` and `d_a` differ or the images are empty.
pub fn l1_vjp<T: Real>(a: &Image<T>, b: &Image<T>, g: T, d_a: &mut Image<T>) {
    l1_and_grad(a, b, g, d_a);
}

/// [`l1`] and its VJP in one pass: returns `L1(a, b)` and adds `g·∂L1/∂a` into `d_a`.
///
/// # Panics
/// If the sizes of `a`, `b` and `d_a` differ or the images are empty.
pub fn l1_and_grad<T: Real>(a: &Image<T>, b: &Image<T>, g: T, d_a: &mut Image<T>) -> T {
    l1_and_grad_with_mse(a, b, g, d_a, Par::Seq).0
}

/// Mean squared error `(1/N) Σ (a_i − b_i)²` over all `N = 3·H·W` values (the L2 loss).
///
/// # Panics
/// If the images differ in size or are empty.
#[must_use]
pub fn l2<T: Real>(a: &Image<T>, b: &Image<T>) -> T {
    let n = value_count(a, b);
    chunked_sum(a.data(), b.data(), |x, y| (x - y).sq()) / T::from_usize(n)
}

/// VJP of [`l2`] with respect to `a`: adds `g·2(a_i − b_i)/N` into `d_a`.
///
/// ```
/// use evogs_math::diff::{central_gradient, GradCheck};
/// use evogs_splat::{Image, loss::{l2, l2_vjp}};
/// let a = Image::from_vec(2, 1, vec![0.1, 0.5, 0.9, 0.3, 0.7, 0.2]).unwrap();
/// let b = Image::from_vec(2, 1, vec![0.2, 0.4, 0.6, 0.6, 0.5, 0.4]).unwrap();
/// let mut d_a = Image::new(2, 1);
/// l2_vjp(&a, &b, 1.0, &mut d_a);
/// let mut x = a.data().to_vec();
/// let mut num = vec![0.0; 6];
/// central_gradient(|v: &[f64]| l2(&Image::from_vec(2, 1, v.to_vec()).unwrap(), &b), &mut x, &mut num);
/// GradCheck::new(1e-10, 1e-8).check(d_a.data(), &num).assert_passed("l2_vjp");
/// ```
///
/// # Panics
/// If the sizes of `a`, `b` and `d_a` differ or the images are empty.
pub fn l2_vjp<T: Real>(a: &Image<T>, b: &Image<T>, g: T, d_a: &mut Image<T>) {
    l2_and_grad(a, b, g, d_a);
}

/// [`l2`] and its VJP in one pass: returns `L2(a, b)` and adds `g·∂L2/∂a` into `d_a`.
///
/// # Panics
/// If the sizes of `a`, `b` and `d_a` differ or the images are empty.
pub fn l2_and_grad<T: Real>(a: &Image<T>, b: &Image<T>, g: T, d_a: &mut Image<T>) -> T {
    let n = value_count(a, b);
    check_grad(a, d_a);
    let nt = T::from_usize(n);
    let s = (g + g) / nt;
    fused(a.data(), b.data(), d_a.data_mut(), T::sq, |d| s * d) / nt
}

/// The terms of the 3DGS photometric loss `total = (1 − λ)·L1 + λ·(1 − SSIM)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotometricLoss<T> {
    /// `(1 − λ)·L1 + λ·(1 − SSIM)`.
    pub total: T,
    /// The L1 term (mean absolute error).
    pub l1: T,
    /// The SSIM (3DGS variant, [`crate::ssim`]).
    pub ssim: T,
    /// The mean squared error ([`l2`], bitwise), for a PSNR; not part of `total`.
    pub mse: T,
}

/// The 3DGS photometric loss `(1 − λ)·L1(render, target) + λ·(1 − SSIM(render, target))`
/// and its VJP: adds `g·∂total/∂render` into `d_render` (`g` weighs this view, e.g.
/// `1/n_views` for a batch mean). `λ = lambda_ssim` (0.2 in 3DGS).
///
/// # Panics
/// If the sizes of the three images differ or they are empty.
pub fn photometric_loss_and_grad<T: Real>(
    ws: &mut SsimWorkspace<T>,
    render: &Image<T>,
    target: &Image<T>,
    lambda_ssim: T,
    g: T,
    d_render: &mut Image<T>,
    par: Par,
) -> PhotometricLoss<T> {
    let w1 = T::ONE - lambda_ssim;
    let (l1, mse) = l1_and_grad_with_mse(render, target, g * w1, d_render, par);
    let ssim = ws.ssim_and_grad(render, target, -(g * lambda_ssim), d_render, par);
    PhotometricLoss {
        total: w1 * l1 + lambda_ssim * (T::ONE - ssim),
        l1,
        ssim,
        mse,
    }
}

/// [`l1_and_grad`] and [`l2`] in one pass over the values, its fixed 1024-value chunks on
/// `par`'s pool: each chunk adds its gradient and returns its two sums, which are then
/// added in chunk order, as the sequential functions add them (the same bits).
fn l1_and_grad_with_mse<T: Real>(
    a: &Image<T>,
    b: &Image<T>,
    g: T,
    d_a: &mut Image<T>,
    par: Par,
) -> (T, T) {
    let n = value_count(a, b);
    check_grad(a, d_a);
    let nt = T::from_usize(n);
    let s = g / nt;
    let chunk = |((ca, cb), cg): ((&[T], &[T]), &mut [T])| {
        for ((g, &x), &y) in cg.iter_mut().zip(ca).zip(cb) {
            *g += s * sign(x - y);
        }
        (
            chunked_sum(ca, cb, |x, y| (x - y).abs()),
            chunked_sum(ca, cb, |x, y| (x - y).sq()),
        )
    };
    let (ad, bd) = (a.data(), b.data());
    let sums: Vec<(T, T)> = match par {
        Par::Seq => ad
            .chunks(CHUNK)
            .zip(bd.chunks(CHUNK))
            .zip(d_a.data_mut().chunks_mut(CHUNK))
            .map(chunk)
            .collect(),
        #[cfg(feature = "rayon")]
        Par::Rayon => {
            use rayon::prelude::*;
            ad.par_chunks(CHUNK)
                .zip(bd.par_chunks(CHUNK))
                .zip(d_a.data_mut().par_chunks_mut(CHUNK))
                .map(chunk)
                .collect()
        }
    };
    let (l1, sq) = sums
        .into_iter()
        .fold((T::ZERO, T::ZERO), |(l, q), (cl, cq)| (l + cl, q + cq));
    (l1 / nt, sq / nt)
}

/// The 3DGS photometric loss alone (no gradient); see [`photometric_loss_and_grad`].
///
/// # Panics
/// If the images differ in size or are empty.
pub fn photometric_loss<T: Real>(
    ws: &mut SsimWorkspace<T>,
    render: &Image<T>,
    target: &Image<T>,
    lambda_ssim: T,
    par: Par,
) -> PhotometricLoss<T> {
    let w1 = T::ONE - lambda_ssim;
    let l1 = l1(render, target);
    let ssim = ws.ssim(render, target, par);
    PhotometricLoss {
        total: w1 * l1 + lambda_ssim * (T::ONE - ssim),
        l1,
        ssim,
        mse: l2(render, target),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pair() -> (Image<f64>, Image<f64>) {
        let a = Image::from_vec(2, 1, vec![0.1, 0.5, 0.9, 0.3, 0.7, 0.2]).expect("image");
        let b = Image::from_vec(2, 1, vec![0.2, 0.4, 0.6, 0.6, 0.5, 0.4]).expect("image");
        (a, b)
    }

    #[test]
    fn the_training_loss_has_the_l1_and_mse_and_gradient_of_the_separate_functions_bitwise() {
        // More values than a few chunks (and a ragged last chunk), on one thread and on the
        // pool: the fused pass gives the separate functions' bits.
        let (w, h) = (37, 29);
        let wave = |k: f64| -> Vec<f32> {
            (0..3 * w * h)
                .map(|i| {
                    #[allow(clippy::cast_possible_truncation, reason = "test values")]
                    let v = (0.5 + 0.45 * (i as f64 * k).sin()) as f32;
                    v
                })
                .collect()
        };
        let a = Image::from_vec(w, h, wave(0.37)).expect("image");
        let b = Image::from_vec(w, h, wave(0.11)).expect("image");
        let (lambda, g) = (0.2_f32, 0.7_f32);
        let mut want = Image::new(w, h);
        let l1_want = l1_and_grad(&a, &b, g * (1.0 - lambda), &mut want);
        let ssim_want =
            SsimWorkspace::new().ssim_and_grad(&a, &b, -(g * lambda), &mut want, Par::Seq);
        let bits = |x: &[f32]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for par in [Par::Seq, Par::best()] {
            let mut got = Image::new(w, h);
            let loss = photometric_loss_and_grad(
                &mut SsimWorkspace::new(),
                &a,
                &b,
                lambda,
                g,
                &mut got,
                par,
            );
            assert_eq!(loss.l1.to_bits(), l1_want.to_bits(), "{par:?}: L1");
            assert_eq!(loss.ssim.to_bits(), ssim_want.to_bits(), "{par:?}: SSIM");
            assert_eq!(loss.mse.to_bits(), l2(&a, &b).to_bits(), "{par:?}: MSE");
            assert_eq!(bits(got.data()), bits(want.data()), "{par:?}: gradient");
            let plain = photometric_loss(&mut SsimWorkspace::new(), &a, &b, lambda, par);
            assert_eq!(
                plain.mse.to_bits(),
                loss.mse.to_bits(),
                "{par:?}: MSE without gradient"
            );
        }
    }

    #[test]
    #[should_panic(expected = "gradient image is 1x1, input is 2x1")]
    fn l1_refuses_a_gradient_image_of_another_size() {
        // Without the check the fused loop would stop at the shorter image and leave part
        // of the gradient unwritten.
        let (a, b) = pair();
        let _ = l1_and_grad(&a, &b, 1.0, &mut Image::new(1, 1));
    }

    #[test]
    #[should_panic(expected = "gradient image is 3x1, input is 2x1")]
    fn l2_refuses_a_gradient_image_of_another_size() {
        let (a, b) = pair();
        let _ = l2_and_grad(&a, &b, 1.0, &mut Image::new(3, 1));
    }
}
