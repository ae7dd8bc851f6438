//! The velocity MLP of EvoGS (`docs/method.md` §4), batched over rows with GEMM kernels.
//!
//! ```text
//! trunk:  T = F·W0ᵀ + b0                     (feature_dim → W, no activation after it)
//! heads:  H = relu(T)·W1ᵀ + b1               (W → 3W: the three heads' first layers, fused)
//!         Y_h = relu(H_h)·W2_hᵀ + b2_h       (W → 3 per head: velocity, angular velocity, log-scale rate)
//! output: [s_v·Y_v, s_ω·Y_ω, s_s·Y_s]        (learnable output scales, init 10, 1, 1)
//! ```
//!
//! Parameter layout (flat, row-major `[out][in]` matrices): `W0 (W×F), b0 (W), W1 (3W×W),
//! b1 (3W), W2 (9×W: rows 3h..3h+3 belong to head h), b2 (9), scales (3)`. Xavier-uniform
//! weights (gain 1), zero biases: the initial velocity is small but not zero.

use super::gemm::{Gemm, row_major, transposed};
use super::heads::{HeadsVjp, heads_vjp};
use super::profile::{FieldProfile, GemmTimer};
use crate::aligned::CacheAligned;
use evogs_math::Real;
use evogs_math::rng::SplitMix64;

pub use super::heads::N_OUT;

/// The MLP's sizes and its parameter offsets.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Mlp {
    /// Input (feature) dimension F.
    pub input: usize,
    /// Hidden width W.
    pub width: usize,
}

/// What the backward pass needs from the forward pass of one batch (kept per stored
/// evaluation, so it holds only that: the rectified outputs, from which the masks follow, and
/// the unscaled outputs).
#[derive(Clone, Debug, Default)]
pub struct MlpActivations<T> {
    /// relu(T), the trunk's activations (rows × W).
    pub trunk: CacheAligned<T>,
    /// relu(H), the heads' hidden activations (rows × 3W).
    pub heads: CacheAligned<T>,
    /// Unscaled outputs Y (rows × 9).
    pub raw: CacheAligned<T>,
}

impl<T: Real> MlpActivations<T> {
    /// Buffers for up to `rows` rows of an MLP.
    #[must_use]
    pub fn new(mlp: &Mlp, rows: usize) -> Self {
        let w = mlp.width;
        Self {
            trunk: CacheAligned::new(rows * w, T::ZERO),
            heads: CacheAligned::new(rows * 3 * w, T::ZERO),
            raw: CacheAligned::new(rows * N_OUT, T::ZERO),
        }
    }
}

/// The backward pass's scratch for one batch (shared by every record).
#[derive(Clone, Debug, Default)]
pub struct MlpWork<T> {
    /// Gradient of the heads' pre-activations (rows × 3W).
    pub d_heads: CacheAligned<T>,
    /// Gradient of the trunk's pre-activations (rows × W).
    pub d_trunk: CacheAligned<T>,
    /// Gradient of the unscaled outputs (rows × 9).
    pub d_raw: CacheAligned<T>,
}

impl<T: Real> MlpWork<T> {
    /// Buffers for up to `rows` rows of an MLP.
    #[must_use]
    pub fn new(mlp: &Mlp, rows: usize) -> Self {
        let w = mlp.width;
        Self {
            d_heads: CacheAligned::new(rows * 3 * w, T::ZERO),
            d_trunk: CacheAligned::new(rows * w, T::ZERO),
            d_raw: CacheAligned::new(rows * N_OUT, T::ZERO),
        }
    }
}

impl Mlp {
    fn w0(&self) -> usize {
        0
    }
    fn b0(&self) -> usize {
        self.width * self.input
    }
    fn w1(&self) -> usize {
        self.b0() + self.width
    }
    fn b1(&self) -> usize {
        self.w1() + 3 * self.width * self.width
    }
    fn w2(&self) -> usize {
        self.b1() + 3 * self.width
    }
    fn b2(&self) -> usize {
        self.w2() + N_OUT * self.width
    }
    /// Offset of the three output scales.
    #[must_use]
    pub fn scales_offset(&self) -> usize {
        self.b2() + N_OUT
    }
    /// Number of parameters, including the three output scales.
    #[must_use]
    pub fn n_params(&self) -> usize {
        self.scales_offset() + 3
    }

    /// Floating-point operations of the matrix products of [`forward`](Self::forward) per
    /// row (a multiply-add counts 2): trunk `2·F·W`, fused heads `2·W·3W`, outputs
    /// `3·2·W·3`.
    #[must_use]
    pub const fn forward_flops_per_row(&self) -> u64 {
        let (f, w) = (self.input as u64, self.width as u64);
        2 * f * w + 6 * w * w + 18 * w
    }

    /// Floating-point operations of the matrix products of [`backward`](Self::backward) per
    /// row: the weight gradient and the input gradient of the fused heads (`2·3W·W` each)
    /// and of the trunk (`2·W·F` each). The heads' thin output layers (`2·3·W` each way per
    /// head) are not matrix products there: a fused kernel does them with the rectifiers
    /// (`field::heads`).
    #[must_use]
    pub const fn backward_flops_per_row(&self) -> u64 {
        let (f, w) = (self.input as u64, self.width as u64);
        12 * w * w + 4 * w * f
    }

    /// Floating-point operations of the matrix products of `forward_rows` rows forward and
    /// `backward_rows` rows backward.
    #[must_use]
    pub const fn gemm_flops(&self, forward_rows: u64, backward_rows: u64) -> u64 {
        forward_rows * self.forward_flops_per_row() + backward_rows * self.backward_flops_per_row()
    }

    /// Xavier-uniform weights, zero biases, output scales `scales`; with `zero_output` the
    /// last layer of each head starts at zero (the field is then exactly zero at first, and
    /// only the last layers receive gradient in the first step).
    pub fn init_params<T: Real>(
        &self,
        rng: &mut SplitMix64,
        scales: [f64; 3],
        zero_output: bool,
        out: &mut [T],
    ) {
        let (f, w) = (self.input, self.width);
        let mut xavier = |dst: &mut [T], fan_in: usize, fan_out: usize| {
            let a = (6.0 / (fan_in + fan_out) as f64).sqrt();
            for v in dst {
                *v = T::from_f64(rng.uniform(-a, a));
            }
        };
        xavier(&mut out[self.w0()..self.b0()], f, w);
        for h in 0..3 {
            let s = self.w1() + h * w * w;
            xavier(&mut out[s..s + w * w], w, w);
            let s = self.w2() + h * 3 * w;
            xavier(&mut out[s..s + 3 * w], w, 3);
        }
        if zero_output {
            for v in &mut out[self.w2()..self.b2()] {
                *v = T::ZERO;
            }
        }
        for v in &mut out[self.b0()..self.w1()] {
            *v = T::ZERO;
        }
        for v in &mut out[self.b1()..self.w2()] {
            *v = T::ZERO;
        }
        for v in &mut out[self.b2()..self.scales_offset()] {
            *v = T::ZERO;
        }
        for (v, s) in out[self.scales_offset()..self.n_params()]
            .iter_mut()
            .zip(scales)
        {
            *v = T::from_f64(s);
        }
    }

    /// Forward pass for `rows` rows of `features` (rows × F, row-major); writes the scaled
    /// outputs (rows × 9) and keeps the activations. With a `profile`, the time spent in the
    /// matrix products is added to it.
    pub fn forward<T: Gemm>(
        &self,
        params: &[T],
        features: &[T],
        rows: usize,
        act: &mut MlpActivations<T>,
        out: &mut [T],
        profile: Option<&FieldProfile>,
    ) {
        let (f, w) = (self.input, self.width);
        let p = params;
        let mut gemm = GemmTimer::new(profile);
        gemm.time(|| {
            T::gemm(
                T::ONE,
                row_major(&features[..rows * f], rows, f),
                transposed(&p[..self.b0()], w, f),
                T::ZERO,
                (&mut act.trunk[..rows * w], rows, w, w, 1),
            );
        });
        bias_relu(&mut act.trunk[..rows * w], &p[self.b0()..self.w1()]);
        gemm.time(|| {
            T::gemm(
                T::ONE,
                row_major(&act.trunk[..rows * w], rows, w),
                transposed(&p[self.w1()..self.b1()], 3 * w, w),
                T::ZERO,
                (&mut act.heads[..rows * 3 * w], rows, 3 * w, 3 * w, 1),
            );
        });
        bias_relu(&mut act.heads[..rows * 3 * w], &p[self.b1()..self.w2()]);
        fill_rows(
            &mut act.raw[..rows * N_OUT],
            &p[self.b2()..self.scales_offset()],
        );
        for h in 0..3 {
            let w2 = &p[self.w2() + 3 * h * w..self.w2() + 3 * (h + 1) * w];
            gemm.time(|| {
                T::gemm(
                    T::ONE,
                    (&act.heads[h * w..], rows, w, 3 * w, 1),
                    transposed(w2, 3, w),
                    T::ONE,
                    (&mut act.raw[3 * h..], rows, 3, N_OUT, 1),
                );
            });
        }
        let scales = &p[self.scales_offset()..self.n_params()];
        for (o, r) in out[..rows * N_OUT]
            .chunks_exact_mut(N_OUT)
            .zip(act.raw.chunks_exact(N_OUT))
        {
            for k in 0..N_OUT {
                o[k] = r[k] * scales[k / 3];
            }
        }
    }

    /// Backward pass after [`forward`](Self::forward) on the same rows: given `d_out`
    /// (rows × 9), **adds** the parameter gradient into `d_params` (this MLP's slice) and
    /// **writes** `d_features` (rows × F). With a `profile`, the time spent in the matrix
    /// products is added to it.
    pub fn backward<T: Gemm>(
        &self,
        params: &[T],
        features: &[T],
        rows: usize,
        act: &MlpActivations<T>,
        work: &mut MlpWork<T>,
        d_out: &[T],
        d_features: &mut [T],
        d_params: &mut [T],
        profile: Option<&FieldProfile>,
    ) {
        let (f, w) = (self.input, self.width);
        let p = params;
        let mut gemm = GemmTimer::new(profile);
        let (so, b2) = (self.scales_offset(), self.b2());
        // The output scales' and last biases' gradients summed over the rows in registers
        // (row by row from the values they had, as sums into `d_params` would add).
        let mut d_scales: [T; 3] = core::array::from_fn(|s| d_params[so + s]);
        let mut d_b2: [T; N_OUT] = core::array::from_fn(|k| d_params[b2 + k]);
        for ((dr, d), r) in work.d_raw[..rows * N_OUT]
            .chunks_exact_mut(N_OUT)
            .zip(d_out.chunks_exact(N_OUT))
            .zip(act.raw.chunks_exact(N_OUT))
        {
            for k in 0..N_OUT {
                d_scales[k / 3] += d[k] * r[k];
                dr[k] = d[k] * p[so + k / 3];
                d_b2[k] += dr[k];
            }
        }
        d_params[so..so + 3].copy_from_slice(&d_scales);
        d_params[b2..so].copy_from_slice(&d_b2);
        // The output layers, the rectifiers and the bias sums of the heads in one pass.
        let (b1, w2) = (self.b1(), self.w2());
        let (d_b1, d_w2) = d_params[b1..b2].split_at_mut(w2 - b1);
        heads_vjp(
            &mut HeadsVjp {
                w,
                x: &act.heads[..rows * 3 * w],
                d_raw: &work.d_raw[..rows * N_OUT],
                w2: &p[w2..b2],
                d_w2,
                d_b1,
                d_heads: &mut work.d_heads[..rows * 3 * w],
            },
            T::heads_vjp_lanes,
        );
        gemm.time(|| {
            T::gemm(
                T::ONE,
                transposed(&work.d_heads[..rows * 3 * w], rows, 3 * w),
                row_major(&act.trunk[..rows * w], rows, w),
                T::ONE,
                (&mut d_params[self.w1()..self.b1()], 3 * w, w, w, 1),
            );
        });
        gemm.time(|| {
            T::gemm(
                T::ONE,
                row_major(&work.d_heads[..rows * 3 * w], rows, 3 * w),
                row_major(&p[self.w1()..self.b1()], 3 * w, w),
                T::ZERO,
                (&mut work.d_trunk[..rows * w], rows, w, w, 1),
            );
        });
        relu_mask(&act.trunk[..rows * w], &mut work.d_trunk[..rows * w]);
        col_sums(
            &work.d_trunk[..rows * w],
            w,
            &mut d_params[self.b0()..self.w1()],
        );
        gemm.time(|| {
            T::gemm(
                T::ONE,
                transposed(&work.d_trunk[..rows * w], rows, w),
                row_major(&features[..rows * f], rows, f),
                T::ONE,
                (&mut d_params[..self.b0()], w, f, f, 1),
            );
        });
        gemm.time(|| {
            T::gemm(
                T::ONE,
                row_major(&work.d_trunk[..rows * w], rows, w),
                row_major(&p[..self.b0()], w, f),
                T::ZERO,
                (&mut d_features[..rows * f], rows, f, f, 1),
            );
        });
    }
}

fn fill_rows<T: Real>(dst: &mut [T], row: &[T]) {
    for r in dst.chunks_exact_mut(row.len()) {
        r.copy_from_slice(row);
    }
}

/// `x ← max(x + b, 0)` in place, `b` added to every row (NaN becomes 0): the bias and the
/// rectifier of a layer in one pass over its product.
fn bias_relu<T: Real>(x: &mut [T], bias: &[T]) {
    for row in x.chunks_exact_mut(bias.len()) {
        for (v, &b) in row.iter_mut().zip(bias) {
            let y = *v + b;
            *v = if y > T::ZERO { y } else { T::ZERO };
        }
    }
}

/// Zeroes the gradient where the rectifier was inactive, read from its output (`relu(x) > 0`
/// exactly where `x > 0`).
fn relu_mask<T: Real>(activated: &[T], grad: &mut [T]) {
    for (g, &v) in grad.iter_mut().zip(activated) {
        if v <= T::ZERO {
            *g = T::ZERO;
        }
    }
}

fn col_sums<T: Real>(m: &[T], cols: usize, out: &mut [T]) {
    for row in m.chunks_exact(cols) {
        for (o, &v) in out.iter_mut().zip(row) {
            *o += v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flop_counts_follow_the_layer_shapes() {
        // Paper size: F = 2 levels × 32 channels, W = 64. Forward: 64·64 + 64·192 + 3·64·3
        // multiply-adds per row; backward: twice those of the trunk and the fused heads
        // (weight and input gradients; the thin output layers go through `heads`).
        let m = Mlp {
            input: 64,
            width: 64,
        };
        let fwd_madds = 64 * 64 + 64 * 192 + 3 * 64 * 3;
        let bwd_madds = 2 * (64 * 64 + 64 * 192);
        assert_eq!(m.forward_flops_per_row(), 2 * fwd_madds, "forward");
        assert_eq!(m.backward_flops_per_row(), 2 * bwd_madds, "backward");
        assert_eq!(
            m.gemm_flops(3, 2),
            3 * 2 * fwd_madds + 2 * 2 * bwd_madds,
            "total"
        );
    }
}
