//! SSIM in the 3DGS variant, D-SSIM, and their VJPs, by separable filtering.
//!
//! Per channel, with the normalised 11-tap Gaussian `g_i ∝ exp(−(i − 5)²/(2·1.5²))`, the
//! window `w = g gᵀ` and `⋆` the 2-D correlation with **zero padding** of 5 px and
//! same-size output (borders included; 3DGS `loss_utils.ssim`, not scikit-image's):
//!
//! ```text
//! μ1 = w ⋆ a    μ2 = w ⋆ b    e11 = w ⋆ a²    e22 = w ⋆ b²    e12 = w ⋆ (a b)
//! A = 2 μ1 μ2 + C1              B = 2 (e12 − μ1 μ2) + C2          (C1 = 0.01², C2 = 0.03²)
//! C = μ1² + μ2² + C1            D = (e11 − μ1²) + (e22 − μ2²) + C2
//! map = A B / (C D)             SSIM = (1/N) Σ map   over all N = 3·H·W pixels and channels
//! ```
//!
//! **Gradient.** With the filtered maps held fixed, the partials of one map value are
//!
//! ```text
//! ∂map/∂μ1  = 2 [μ2 (B − A) − μ1 map (D − C)] / (C D)
//! ∂map/∂e11 = −map / D          ∂map/∂e12 = 2 A / (C D)
//! ```
//!
//! (μ2, e22 are functions of `b` only). The adjoint of `x ↦ w ⋆ x` with zero padding is the
//! correlation with the flipped window, and `w` is symmetric, so it is the same filter:
//!
//! ```text
//! ∂SSIM/∂a = (1/N) [ w ⋆ ∂map/∂μ1 + 2 a · (w ⋆ ∂map/∂e11) + b · (w ⋆ ∂map/∂e12) ]
//! ```
//!
//! Every 2-D correlation is two 1-D passes (rows, then columns), so a gradient costs eight
//! separable filterings of the image (five forward, three backward) that share one
//! [`SsimWorkspace`]. The image is filtered in its interleaved layout: a horizontal tap of
//! offset `k` pixels is an offset of `3k` values.
//!
//! **D-SSIM** is the structural dissimilarity `(1 − SSIM)/2` ([`d_ssim`]). 3DGS trains with
//! `λ·(1 − SSIM)` instead, i.e. twice D-SSIM; see
//! [`photometric_loss_and_grad`](crate::loss::photometric_loss_and_grad).
//!
//! **Parallelism.** With `Par::Rayon` the rows of each pass run on rayon's pool. Every
//! output value is computed by the same operations in the same order as with `Par::Seq`,
//! and the mean is reduced row by row in row order, so both give bitwise identical results.
//!
//! ```
//! use evogs_splat::Image;
//! use evogs_splat::ssim::{d_ssim, ssim};
//! let a = Image::<f64>::filled(16, 12, [0.3, 0.5, 0.7]);
//! assert!((ssim(&a, &a) - 1.0).abs() < 1e-14);
//! assert!(d_ssim(&a, &a).abs() < 1e-14);
//! ```

mod filter;

pub use filter::gaussian_window;

use crate::Image;
use crate::sum::lane_sum;
use alloc::vec::Vec;
use evogs_math::{Par, Real};
use filter::{hfilter, vfilter};
#[cfg(feature = "rayon")]
use rayon::prelude::*;

/// Window size of the 3DGS SSIM (11 taps).
pub const SSIM_WINDOW: usize = 11;
/// Standard deviation of the Gaussian window, in pixels.
pub const SSIM_SIGMA: f64 = 1.5;
/// `C1 = (0.01·L)²` for data range `L = 1`.
pub const SSIM_C1: f64 = 0.01 * 0.01;
/// `C2 = (0.03·L)²` for data range `L = 1`.
pub const SSIM_C2: f64 = 0.03 * 0.03;

/// Half the window: the zero padding on each side.
const RADIUS: usize = SSIM_WINDOW / 2;
/// Values per block of the vertical pass (accumulators live on the stack).
const BLOCK: usize = 128;
/// Filtered quantities per row in the forward pass: a, b, a², b², a·b.
const N_FWD: usize = 5;
/// Per-pixel maps kept after the forward pass: map, ∂μ1, 2·∂e11, ∂e12 (the last three
/// already scaled by the cotangent over N).
const N_MAPS: usize = 4;
/// Filtered quantities per row in the backward pass.
const N_BWD: usize = 3;

/// Reusable buffers for SSIM and its gradient (caller-owned; no allocation after the
/// first call at a given size or any smaller one).
///
/// Holds two row-blocked buffers, `5·3·W` and `4·3·W` values per image row (`27·W·H` values
/// in all: 17 MB at 400×400 in f32), one partial sum per row and a row of zeros. Images are RGB interleaved, row-major, row 0 at the
/// top ([`Image`]). The methods take a [`Par`]; results do not depend on it.
///
/// ```
/// use evogs_math::Par;
/// use evogs_splat::{Image, ssim::SsimWorkspace};
/// let a = Image::filled(20, 10, [0.2, 0.4, 0.6]);
/// let b = Image::filled(20, 10, [0.25, 0.4, 0.5]);
/// let mut ws = SsimWorkspace::new();
/// let mut d_a = Image::new(20, 10);
/// let s = ws.ssim_and_grad(&a, &b, 1.0, &mut d_a, Par::Seq);
/// assert_eq!(s, ws.ssim(&a, &b, Par::Seq));
/// ```
#[derive(Clone, Debug)]
pub struct SsimWorkspace<T> {
    window: [T; SSIM_WINDOW],
    /// Horizontally filtered rows: per row `N_FWD` (forward) or `N_BWD` (backward) slots of
    /// `3W` values.
    rows: Vec<T>,
    /// Per row `N_MAPS` slots of `3W`: product scratch, then the map and its partials.
    maps: Vec<T>,
    /// Sum of the map over each row.
    row_sums: Vec<T>,
    /// `3W` zeros: the rows outside the image (zero padding).
    zeros: Vec<T>,
}

impl<T: Real> Default for SsimWorkspace<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> SsimWorkspace<T> {
    /// An empty workspace; buffers grow on first use.
    #[must_use]
    pub fn new() -> Self {
        Self {
            window: gaussian_window(),
            rows: Vec::new(),
            maps: Vec::new(),
            row_sums: Vec::new(),
            zeros: Vec::new(),
        }
    }

    /// A workspace with buffers for `width × height` images already allocated.
    #[must_use]
    pub fn with_size(width: usize, height: usize) -> Self {
        let mut ws = Self::new();
        ws.resize(width, height);
        ws
    }

    fn resize(&mut self, width: usize, height: usize) {
        let rw = 3 * width;
        self.rows.resize(height * N_FWD * rw, T::ZERO);
        self.maps.resize(height * N_MAPS * rw, T::ZERO);
        self.row_sums.resize(height, T::ZERO);
        self.zeros.resize(rw, T::ZERO);
    }

    /// The 3DGS SSIM of `a` and `b` (mean of the map over pixels and channels).
    ///
    /// # Panics
    /// If the images differ in size or are empty.
    pub fn ssim(&mut self, a: &Image<T>, b: &Image<T>, par: Par) -> T {
        self.forward(a, b, None, par)
    }

    /// The SSIM map (per pixel and channel) into `map`; returns its mean, the SSIM.
    ///
    /// # Panics
    /// If the sizes of `a`, `b` and `map` differ or the images are empty.
    pub fn ssim_map(&mut self, a: &Image<T>, b: &Image<T>, map: &mut Image<T>, par: Par) -> T {
        assert!(a.same_size(map), "map image has the wrong size");
        let s = self.forward(a, b, None, par);
        let rw = 3 * a.width();
        for (out, blk) in map
            .data_mut()
            .chunks_mut(rw)
            .zip(self.maps.chunks(N_MAPS * rw))
        {
            out.copy_from_slice(&blk[..rw]);
        }
        s
    }

    /// SSIM and its VJP in one pass: returns `SSIM(a, b)` and adds `g·∂SSIM/∂a` into `d_a`.
    ///
    /// The five filtered maps of the forward pass are shared with the backward pass.
    ///
    /// # Panics
    /// If the sizes of `a`, `b` and `d_a` differ or the images are empty.
    pub fn ssim_and_grad(
        &mut self,
        a: &Image<T>,
        b: &Image<T>,
        g: T,
        d_a: &mut Image<T>,
        par: Par,
    ) -> T {
        assert!(a.same_size(d_a), "gradient image has the wrong size");
        let n = T::from_usize(a.data().len());
        let s = self.forward(a, b, Some(g / n), par);
        self.backward(a, b, d_a, par);
        s
    }

    /// Runs the forward passes; with `grad_scale = Some(g/N)` also stores the scaled
    /// partials of the map for [`Self::backward`].
    fn forward(&mut self, a: &Image<T>, b: &Image<T>, grad_scale: Option<T>, par: Par) -> T {
        assert!(
            a.same_size(b),
            "images differ in size: {}x{} vs {}x{}",
            a.width(),
            a.height(),
            b.width(),
            b.height()
        );
        assert!(!a.data().is_empty(), "SSIM of an empty image is undefined");
        let (width, height) = (a.width(), a.height());
        self.resize(width, height);
        let rw = 3 * width;
        let w = &self.window;
        let rows = &mut self.rows[..height * N_FWD * rw];
        let maps = &mut self.maps[..height * N_MAPS * rw];
        let (da, db) = (a.data(), b.data());

        // Pass 1: products of each row, then horizontal filtering of a, b, a², b², ab.
        let hpass = |y: usize, hrow: &mut [T], scratch: &mut [T]| {
            let (ar, br) = (&da[y * rw..(y + 1) * rw], &db[y * rw..(y + 1) * rw]);
            let (aa, rest) = scratch.split_at_mut(rw);
            let (bb, rest) = rest.split_at_mut(rw);
            let ab = &mut rest[..rw];
            for j in 0..rw {
                aa[j] = ar[j] * ar[j];
                bb[j] = br[j] * br[j];
                ab[j] = ar[j] * br[j];
            }
            let srcs: [&[T]; N_FWD] = [ar, br, aa, bb, ab];
            for (src, dst) in srcs.iter().zip(hrow.chunks_exact_mut(rw)) {
                hfilter(src, dst, w);
            }
        };
        for_rows2(par, rows, N_FWD * rw, maps, N_MAPS * rw, hpass);

        // Pass 2: vertical filtering, then the map (and its partials) per value.
        let filtered = Filtered {
            rows,
            height,
            rw,
            zeros: &self.zeros[..rw],
            w,
        };
        let vpass = |y: usize, mrow: &mut [T]| {
            vertical_map_row(&filtered, y, grad_scale, mrow);
        };
        for_rows(par, maps, N_MAPS * rw, vpass);

        // Mean: per-row sums, added in row order.
        let maps = &*maps;
        let sums = &mut self.row_sums[..height];
        for_rows(par, sums, 1, |y, s: &mut [T]| {
            s[0] = lane_sum(&maps[y * N_MAPS * rw..][..rw]);
        });
        let total = sums.iter().fold(T::ZERO, |acc, &s| acc + s);
        total / T::from_usize(3 * width * height)
    }

    /// Backward passes after a forward pass with a gradient scale: filters the three
    /// partial maps and adds the chain rule into `d_a`.
    fn backward(&mut self, a: &Image<T>, b: &Image<T>, d_a: &mut Image<T>, par: Par) {
        let (width, height) = (a.width(), a.height());
        let rw = 3 * width;
        let w = &self.window;
        let maps = &self.maps[..height * N_MAPS * rw];
        // Reuse the first N_BWD slots of each row block of `rows`.
        let rows = &mut self.rows[..height * N_FWD * rw];
        let hpass = |y: usize, hrow: &mut [T]| {
            let mrow = &maps[y * N_MAPS * rw..][..N_MAPS * rw];
            for (src, dst) in mrow.chunks_exact(rw).skip(1).zip(hrow.chunks_exact_mut(rw)) {
                hfilter(src, dst, w);
            }
        };
        for_rows(par, rows, N_FWD * rw, hpass);

        let filtered = Filtered {
            rows,
            height,
            rw,
            zeros: &self.zeros[..rw],
            w,
        };
        let (da, db) = (a.data(), b.data());
        let vpass = |y: usize, grow: &mut [T]| {
            let ar = &da[y * rw..(y + 1) * rw];
            let br = &db[y * rw..(y + 1) * rw];
            vertical_grad_row(&filtered, y, ar, br, grow);
        };
        for_rows(par, d_a.data_mut(), rw, vpass);
    }
}

/// The factors of one SSIM map value (module docs): `value = A·B·inv`, `inv = 1/(C·D)`.
struct MapTerms<T> {
    a: T,
    b: T,
    c: T,
    d: T,
    inv: T,
    value: T,
}

impl<T: Real> MapTerms<T> {
    /// The factors from the filtered maps μ1, μ2, e11, e22, e12 at one value.
    #[inline]
    fn new(mu1: T, mu2: T, e11: T, e22: T, e12: T, c1: T, c2: T) -> Self {
        let m12 = mu1 * mu2;
        let a = m12 + m12 + c1;
        let b = (e12 - m12) * T::TWO + c2;
        let c = mu1 * mu1 + mu2 * mu2 + c1;
        let d = (e11 - mu1 * mu1) + (e22 - mu2 * mu2) + c2;
        let inv = T::ONE / (c * d);
        Self {
            a,
            b,
            c,
            d,
            inv,
            value: a * b * inv,
        }
    }
}

/// The horizontally filtered rows, ready for the vertical pass.
struct Filtered<'a, T> {
    /// Row blocks of `N_FWD` slots of `rw` values.
    rows: &'a [T],
    height: usize,
    /// Values per row, `3W`.
    rw: usize,
    /// `rw` zeros (rows outside the image).
    zeros: &'a [T],
    w: &'a [T; SSIM_WINDOW],
}

impl<T: Real> Filtered<'_, T> {
    /// Vertical filtering of the first `NQ` slots of the values `j0..j0 + len` of output row
    /// `y` into `acc[slot][..len]`.
    #[inline]
    fn block<const NQ: usize>(&self, y: usize, j0: usize, len: usize, acc: &mut [[T; BLOCK]; NQ]) {
        let stride = N_FWD * self.rw;
        for (q, accq) in acc.iter_mut().enumerate() {
            let offset = q * self.rw + j0;
            vfilter(
                self.rows,
                stride,
                self.height,
                y,
                offset,
                self.zeros,
                self.w,
                &mut accq[..len],
            );
        }
    }
}

/// Pass 2 for row `y`: vertical filtering of the five horizontally filtered quantities,
/// then per value the map (slot 0) and, with `grad_scale = Some(s)`, the scaled partials
/// `s·∂map/∂μ1`, `2s·∂map/∂e11`, `s·∂map/∂e12` (slots 1–3).
fn vertical_map_row<T: Real>(f: &Filtered<'_, T>, y: usize, grad_scale: Option<T>, mrow: &mut [T]) {
    let rw = f.rw;
    let c1 = T::from_f64(SSIM_C1);
    let c2 = T::from_f64(SSIM_C2);
    let (map, rest) = mrow.split_at_mut(rw);
    let (g_mu, rest) = rest.split_at_mut(rw);
    let (g_e11, rest) = rest.split_at_mut(rw);
    let g_e12 = &mut rest[..rw];
    for j0 in (0..rw).step_by(BLOCK) {
        let len = BLOCK.min(rw - j0);
        let mut acc = [[T::ZERO; BLOCK]; N_FWD];
        f.block(y, j0, len, &mut acc);
        let [mu1, mu2, e11, e22, e12] = &acc;
        let out = j0..j0 + len;
        match grad_scale {
            None => {
                for (i, m) in map[out].iter_mut().enumerate() {
                    *m = MapTerms::new(mu1[i], mu2[i], e11[i], e22[i], e12[i], c1, c2).value;
                }
            }
            Some(s) => {
                let it = map[out.clone()].iter_mut().zip(&mut g_mu[out.clone()]);
                let it = it.zip(&mut g_e11[out.clone()]).zip(&mut g_e12[out]);
                for (i, (((m, gm), g11), g12)) in it.enumerate() {
                    let (m1, m2) = (mu1[i], mu2[i]);
                    let t = MapTerms::new(m1, m2, e11[i], e22[i], e12[i], c1, c2);
                    let (big_a, big_b, big_c, big_d, val) = (t.a, t.b, t.c, t.d, t.value);
                    let s2inv = (s + s) * t.inv;
                    *m = val;
                    *gm = s2inv * (m2 * (big_b - big_a) - m1 * val * (big_d - big_c));
                    *g11 = -(s2inv * val * big_c);
                    *g12 = s2inv * big_a;
                }
            }
        }
    }
}

/// Pass 4 for row `y`: vertical filtering of the three horizontally filtered partial maps
/// and `d_a += w⋆∂μ1 + a·(w⋆2∂e11) + b·(w⋆∂e12)`.
fn vertical_grad_row<T: Real>(f: &Filtered<'_, T>, y: usize, ar: &[T], br: &[T], grow: &mut [T]) {
    let rw = f.rw;
    for j0 in (0..rw).step_by(BLOCK) {
        let len = BLOCK.min(rw - j0);
        let mut acc = [[T::ZERO; BLOCK]; N_BWD];
        f.block(y, j0, len, &mut acc);
        let [f_mu, f_e11, f_e12] = &acc;
        let it = grow[j0..j0 + len]
            .iter_mut()
            .zip(&ar[j0..j0 + len])
            .zip(&br[j0..j0 + len]);
        for (i, ((g, &av), &bv)) in it.enumerate() {
            *g += f_mu[i] + av * f_e11[i] + bv * f_e12[i];
        }
    }
}

/// Runs `f(y, chunk_y)` for every row `y`, `chunk_y = buf[y·len..(y + 1)·len]`.
fn for_rows<T: Real>(par: Par, buf: &mut [T], len: usize, f: impl Fn(usize, &mut [T]) + Sync) {
    #[cfg(feature = "rayon")]
    if !par.is_seq() {
        buf.par_chunks_mut(len)
            .enumerate()
            .for_each(|(y, c)| f(y, c));
        return;
    }
    let _ = par;
    for (y, c) in buf.chunks_mut(len).enumerate() {
        f(y, c);
    }
}

/// [`for_rows`] over two row-blocked buffers at once.
fn for_rows2<T: Real>(
    par: Par,
    buf1: &mut [T],
    len1: usize,
    buf2: &mut [T],
    len2: usize,
    f: impl Fn(usize, &mut [T], &mut [T]) + Sync,
) {
    #[cfg(feature = "rayon")]
    if !par.is_seq() {
        buf1.par_chunks_mut(len1)
            .zip(buf2.par_chunks_mut(len2))
            .enumerate()
            .for_each(|(y, (c1, c2))| f(y, c1, c2));
        return;
    }
    let _ = par;
    for (y, (c1, c2)) in buf1.chunks_mut(len1).zip(buf2.chunks_mut(len2)).enumerate() {
        f(y, c1, c2);
    }
}

/// The 3DGS SSIM of `a` and `b` (allocates a temporary [`SsimWorkspace`]; reuse one in
/// loops).
///
/// # Panics
/// If the images differ in size or are empty.
#[must_use]
pub fn ssim<T: Real>(a: &Image<T>, b: &Image<T>) -> T {
    SsimWorkspace::new().ssim(a, b, Par::Seq)
}

/// The per-pixel, per-channel SSIM map (its mean is [`ssim`]).
///
/// # Panics
/// If the images differ in size or are empty.
#[must_use]
pub fn ssim_map<T: Real>(a: &Image<T>, b: &Image<T>) -> Image<T> {
    let mut map = Image::new(a.width(), a.height());
    SsimWorkspace::new().ssim_map(a, b, &mut map, Par::Seq);
    map
}

/// VJP of [`ssim`] with respect to `a`: adds `g·∂SSIM/∂a` into `d_a`.
///
/// ```
/// use evogs_math::{diff::{central_gradient, GradCheck}, rng::SplitMix64};
/// use evogs_splat::{Image, ssim::{ssim, ssim_vjp}};
/// let mut r = SplitMix64::new(3);
/// let mut img = || Image::from_vec(4, 3, (0..36).map(|_| r.next_f64()).collect()).unwrap();
/// let (a, b) = (img(), img());
/// let mut d_a = Image::new(4, 3);
/// ssim_vjp(&a, &b, 1.0, &mut d_a);
/// let mut x = a.data().to_vec();
/// let mut num = vec![0.0; 36];
/// central_gradient(|v: &[f64]| ssim(&Image::from_vec(4, 3, v.to_vec()).unwrap(), &b), &mut x, &mut num);
/// GradCheck::new(1e-9, 1e-6).check(d_a.data(), &num).assert_passed("ssim_vjp");
/// ```
///
/// # Panics
/// If the sizes of `a`, `b` and `d_a` differ or the images are empty.
pub fn ssim_vjp<T: Real>(a: &Image<T>, b: &Image<T>, g: T, d_a: &mut Image<T>) {
    SsimWorkspace::new().ssim_and_grad(a, b, g, d_a, Par::Seq);
}

/// D-SSIM, the structural dissimilarity `(1 − SSIM(a, b))/2`, in [0, 1].
///
/// # Panics
/// If the images differ in size or are empty.
#[must_use]
pub fn d_ssim<T: Real>(a: &Image<T>, b: &Image<T>) -> T {
    (T::ONE - ssim(a, b)) * T::HALF
}

/// VJP of [`d_ssim`] with respect to `a`: adds `g·∂D-SSIM/∂a = −(g/2)·∂SSIM/∂a` into `d_a`.
///
/// # Panics
/// If the sizes of `a`, `b` and `d_a` differ or the images are empty.
pub fn d_ssim_vjp<T: Real>(a: &Image<T>, b: &Image<T>, g: T, d_a: &mut Image<T>) {
    ssim_vjp(a, b, -(g * T::HALF), d_a);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buffers_are_reused_for_equal_and_smaller_images() {
        let a = Image::filled(30, 20, [0.2, 0.4, 0.6]);
        let b = Image::filled(30, 20, [0.3, 0.4, 0.5]);
        let mut ws = SsimWorkspace::<f64>::new();
        let mut d_a = Image::new(30, 20);
        ws.ssim_and_grad(&a, &b, 1.0, &mut d_a, Par::Seq);
        let ptrs = (ws.rows.as_ptr(), ws.maps.as_ptr(), ws.row_sums.as_ptr());
        ws.ssim_and_grad(&a, &b, 1.0, &mut d_a, Par::Seq);
        let small = Image::filled(7, 5, [0.1, 0.2, 0.3]);
        let _ = ws.ssim(&small, &small, Par::Seq);
        let after = (ws.rows.as_ptr(), ws.maps.as_ptr(), ws.row_sums.as_ptr());
        assert_eq!(ptrs, after, "no reallocation after the first call");
    }

    #[test]
    fn window_is_symmetric_and_normalised() {
        let g = gaussian_window::<f64>();
        for i in 0..SSIM_WINDOW {
            assert!(
                (g[i] - g[SSIM_WINDOW - 1 - i]).abs() <= 0.0,
                "tap {i} is not symmetric"
            );
        }
        assert!(
            (g.iter().sum::<f64>() - 1.0).abs() < 1e-15,
            "window sums to 1"
        );
    }
}
