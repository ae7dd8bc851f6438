//! The separable, zero-padded Gaussian correlation of the SSIM, in 1-D passes.
//!
//! Both passes evaluate the symmetric 11-tap sum in one fixed order,
//!
//! ```text
//! out = [w₀(t₀ + t₁₀) + w₁(t₁ + t₉)] + [w₂(t₂ + t₈) + w₃(t₃ + t₇)] + [w₄(t₄ + t₆) + w₅ t₅]
//! ```
//!
//! (three independent partial sums, then added left to right), where `t_k` is the input at offset `k − 5` and 0 outside the
//! image (zero padding). Using `w_k = w₁₀₋ₖ` halves the multiplications, and computing each
//! output in registers from eleven shifted input slices (instead of eleven read-modify-write
//! sweeps) lets the compiler vectorise across outputs. Taps outside the image read a zero
//! row (vertical) or a zero value (horizontal borders), so every output, border or not,
//! follows the same formula.

use super::{RADIUS, SSIM_SIGMA, SSIM_WINDOW};
use evogs_math::Real;

/// The normalised 1-D Gaussian window `g_i = exp(−(i − 5)²/(2σ²)) / Σ_j exp(…)`,
/// `i = 0..11`, `σ = 1.5`, computed in `f64` and rounded once to `T`. It is exactly
/// symmetric (`g_i = g_{10−i}`), which the filter relies on.
///
/// ```
/// let g = evogs_splat::ssim::gaussian_window::<f64>();
/// assert!((g.iter().sum::<f64>() - 1.0).abs() < 1e-15);
/// assert_eq!(g[0], g[10]);
/// ```
#[must_use]
pub fn gaussian_window<T: Real>() -> [T; SSIM_WINDOW] {
    let mut g = [0.0_f64; SSIM_WINDOW];
    let two_var = 2.0 * SSIM_SIGMA * SSIM_SIGMA;
    for (i, gi) in g.iter_mut().enumerate() {
        let x = f64::from_usize(i) - f64::from_usize(RADIUS);
        *gi = Real::exp(-(x * x) / two_var);
    }
    let sum: f64 = g.iter().sum();
    g.map(|gi| T::from_f64(gi / sum))
}

/// The symmetric 11-tap sum of one output (module docs).
#[inline(always)]
fn sym_sum<T: Real>(w: &[T; SSIM_WINDOW], t: &[T; SSIM_WINDOW]) -> T {
    let outer = w[0] * (t[0] + t[10]) + w[1] * (t[1] + t[9]);
    let middle = w[2] * (t[2] + t[8]) + w[3] * (t[3] + t[7]);
    let inner = w[4] * (t[4] + t[6]) + w[5] * t[5];
    outer + middle + inner
}

/// `out[i] = sym_sum(taps[0][i], …, taps[10][i])` for `i < out.len()`.
#[inline]
fn sym_filter<T: Real>(taps: &[&[T]; SSIM_WINDOW], w: &[T; SSIM_WINDOW], out: &mut [T]) {
    let n = out.len();
    let [t0, t1, t2, t3, t4, t5, t6, t7, t8, t9, t10] = taps.map(|s| &s[..n]);
    for i in 0..n {
        let t = [
            t0[i], t1[i], t2[i], t3[i], t4[i], t5[i], t6[i], t7[i], t8[i], t9[i], t10[i],
        ];
        out[i] = sym_sum(w, &t);
    }
}

/// Zero-padded horizontal correlation of one interleaved RGB row: `dst[3x + c] =
/// Σ_k w_k src[3(x + k − 5) + c]`.
pub(super) fn hfilter<T: Real>(src: &[T], dst: &mut [T], w: &[T; SSIM_WINDOW]) {
    let rw = src.len();
    let pad = 3 * RADIUS;
    // Interior: every tap inside the row.
    let interior = rw.saturating_sub(2 * pad);
    if interior > 0 {
        let taps: [&[T]; SSIM_WINDOW] = core::array::from_fn(|k| &src[3 * k..3 * k + interior]);
        sym_filter(&taps, w, &mut dst[pad..pad + interior]);
    }
    // Borders (or the whole row if it is narrower than the window): zero outside.
    let tap = |j: usize, k: usize| {
        (j + 3 * k)
            .checked_sub(pad)
            .filter(|&i| i < rw)
            .map_or(T::ZERO, |i| src[i])
    };
    let border = |j: usize| -> T {
        let t: [T; SSIM_WINDOW] = core::array::from_fn(|k| tap(j, k));
        sym_sum(w, &t)
    };
    let left = if interior > 0 { pad } else { rw };
    for j in 0..left {
        dst[j] = border(j);
    }
    for j in (pad + interior).max(left)..rw {
        dst[j] = border(j);
    }
}

/// Zero-padded vertical correlation of one slot: `out[i] = Σ_k w_k row_{y+k−5}[offset + i]`,
/// where row `r` starts at `rows[r·stride]` and rows outside `0..height` read `zeros`.
pub(super) fn vfilter<T: Real>(
    rows: &[T],
    stride: usize,
    height: usize,
    y: usize,
    offset: usize,
    zeros: &[T],
    w: &[T; SSIM_WINDOW],
    out: &mut [T],
) {
    let n = out.len();
    let taps: [&[T]; SSIM_WINDOW] =
        core::array::from_fn(
            |k| match (y + k).checked_sub(RADIUS).filter(|&r| r < height) {
                Some(r) => &rows[r * stride + offset..][..n],
                None => &zeros[..n],
            },
        );
    sym_filter(&taps, w, out);
}
