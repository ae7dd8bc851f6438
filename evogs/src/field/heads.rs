//! The backward pass of the MLP's three output heads (their thin output layers and their
//! rectifiers) as one fused kernel over the heads' activations.
//!
//! Per head `h` with hidden activations `x_h = relu(H_h)` (rows × W), output weights
//! `W2_h` (3 × W) and output gradient `d_raw_h` (rows × 3), the backward needs
//!
//! ```text
//! dW2_h   += d_raw_hᵀ · x_h                  (3 × W: the output layer's weight gradient)
//! d_heads  = (d_raw_h · W2_h) ⊙ [x_h > 0]    (rows × W: through the rectifier)
//! db1_h   += Σ_rows d_heads                  (W: the hidden layer's bias gradient)
//! ```
//!
//! Three thin matrix products with three outputs each, a mask pass and a column sum
//! read the activations five times; this kernel reads each once, a tile of [`TILE`] rows at a
//! time and within a tile [`LANES`] columns at a time, so that the block's nine weight-gradient
//! and bias sums stay in registers over the tile's rows and the tile stays in L1. Every sum
//! runs over the rows in order from the value it had, whatever the tiling, so the result
//! depends only on the inputs.

use super::lanes::LANES;
use evogs_math::Real;

/// Outputs per row: velocity (3), world-frame angular velocity (3), log-scale rate (3), one
/// head each.
pub const N_OUT: usize = 9;

/// Rows per tile: 32 rows of the paper MLP's heads (3W = 192) are 24 KiB of f32.
pub(crate) const TILE: usize = 32;

/// The operands of the heads' backward over some rows (see the module docs): the
/// activations and output gradients of the rows, the weights, the gradients the kernel adds
/// into, and the input gradient it writes.
#[derive(Debug)]
pub struct HeadsVjp<'a, T> {
    /// The hidden width W.
    pub(crate) w: usize,
    /// `relu(H)`, rows × 3W (head `h` in columns `h·W..(h + 1)·W`).
    pub(crate) x: &'a [T],
    /// The gradient of the unscaled outputs, rows × 9 (head `h` in `3h..3h + 3`).
    pub(crate) d_raw: &'a [T],
    /// `W2`, 9 × W, row `3h + k` for output `k` of head `h`.
    pub(crate) w2: &'a [T],
    /// The gradient of `W2` (added into).
    pub(crate) d_w2: &'a mut [T],
    /// The gradient of the hidden layers' biases, 3W (added into).
    pub(crate) d_b1: &'a mut [T],
    /// The gradient of the hidden pre-activations, rows × 3W (written).
    pub(crate) d_heads: &'a mut [T],
}

/// Runs the heads' backward over every row of `v`: tiles of [`TILE`] rows, in each the three
/// heads' columns in blocks of [`LANES`] through `lanes` (which must compute what
/// [`block`] computes for `B = LANES`), the remaining columns one at a time.
pub(crate) fn heads_vjp<T: Real>(
    v: &mut HeadsVjp<'_, T>,
    lanes: impl Fn(&mut HeadsVjp<'_, T>, usize, usize),
) {
    let wide = 3 * v.w;
    let rows = v.x.len() / wide;
    // The column blocks walk a tile's rows with a stride of 3W, which the hardware
    // prefetchers do not follow, and the activations come from memory: their lines are
    // read once in address order first (a chunk's fit in L2).
    touch(v.x);
    for r0 in (0..rows).step_by(TILE) {
        let r1 = (r0 + TILE).min(rows);
        let mut tile = HeadsVjp {
            w: v.w,
            x: &v.x[r0 * wide..r1 * wide],
            d_raw: &v.d_raw[r0 * N_OUT..r1 * N_OUT],
            w2: v.w2,
            d_w2: v.d_w2,
            d_b1: v.d_b1,
            d_heads: &mut v.d_heads[r0 * wide..r1 * wide],
        };
        for h in 0..3 {
            let mut j = 0;
            while j + LANES <= v.w {
                lanes(&mut tile, h, j);
                j += LANES;
            }
            for j in j..v.w {
                block::<T, 1>(&mut tile, h, j);
            }
        }
    }
}

/// Reads one value of every 64-byte line of `x` (as f32) in address order.
#[inline]
fn touch<T: Real>(x: &[T]) {
    let mut sum = T::ZERO;
    for line in x.chunks(16) {
        sum += line[0];
    }
    core::hint::black_box(sum);
}

/// The kernel for columns `j0..j0 + B` of head `h` over the rows of `v`: the sums
/// `dW2[3h + k][j] += d_raw[r][3h + k]·x[r][j]` and `db1[j] += g[r][j]` in row order, with
/// `g[r][j] = ((d₀·W2₀ⱼ + d₁·W2₁ⱼ) + d₂·W2₂ⱼ)` where `x[r][j] > 0` and `+0` elsewhere.
#[inline(always)]
pub(crate) fn block<T: Real, const B: usize>(v: &mut HeadsVjp<'_, T>, h: usize, j0: usize) {
    let w = v.w;
    let col = h * w + j0;
    let row_of = |m: &[T], row: usize| -> [T; B] { core::array::from_fn(|c| m[row * w + j0 + c]) };
    let wk: [[T; B]; 3] = core::array::from_fn(|k| row_of(v.w2, 3 * h + k));
    let mut acc: [[T; B]; 3] = core::array::from_fn(|k| row_of(v.d_w2, 3 * h + k));
    let mut bias: [T; B] = core::array::from_fn(|c| v.d_b1[col + c]);
    for ((xr, dr), gr) in
        v.x.chunks_exact(3 * w)
            .zip(v.d_raw.chunks_exact(N_OUT))
            .zip(v.d_heads.chunks_exact_mut(3 * w))
    {
        let d = [dr[3 * h], dr[3 * h + 1], dr[3 * h + 2]];
        for c in 0..B {
            let x = xr[col + c];
            for k in 0..3 {
                acc[k][c] += d[k] * x;
            }
            let g = d[0] * wk[0][c] + d[1] * wk[1][c] + d[2] * wk[2][c];
            let g = if x > T::ZERO { g } else { T::ZERO };
            gr[col + c] = g;
            bias[c] += g;
        }
    }
    for (k, a) in acc.iter().enumerate() {
        let at = (3 * h + k) * w + j0;
        v.d_w2[at..at + B].copy_from_slice(a);
    }
    v.d_b1[col..col + B].copy_from_slice(&bias);
}

/// [`block`] for `B = 8` in explicit 8-lane vectors (`wide::f32x8`: AVX where the build has
/// it, SSE or NEON pairs otherwise), the same operations per lane, so the same bits: the
/// generic kernel compiles to scalar code with spills.
pub(crate) fn block_f32x8(v: &mut HeadsVjp<'_, f32>, h: usize, j0: usize) {
    use wide::f32x8;
    const _: () = assert!(LANES == 8, "one f32x8 per column block");
    let w = v.w;
    let col = h * w + j0;
    let load = |m: &[f32], at: usize| {
        let lanes: [f32; 8] = m[at..at + 8].try_into().expect("a block of 8 columns");
        f32x8::from(lanes)
    };
    let wk: [f32x8; 3] = core::array::from_fn(|k| load(v.w2, (3 * h + k) * w + j0));
    let mut acc: [f32x8; 3] = core::array::from_fn(|k| load(v.d_w2, (3 * h + k) * w + j0));
    let mut bias = load(v.d_b1, col);
    let zero = f32x8::ZERO;
    for ((xr, dr), gr) in
        v.x.chunks_exact(3 * w)
            .zip(v.d_raw.chunks_exact(N_OUT))
            .zip(v.d_heads.chunks_exact_mut(3 * w))
    {
        let x = load(xr, col);
        let d = [
            f32x8::splat(dr[3 * h]),
            f32x8::splat(dr[3 * h + 1]),
            f32x8::splat(dr[3 * h + 2]),
        ];
        for k in 0..3 {
            acc[k] += d[k] * x;
        }
        let g = d[0] * wk[0] + d[1] * wk[1] + d[2] * wk[2];
        // The mask is all ones where x > 0 (false for NaN): g there, +0 elsewhere.
        let g = x.simd_gt(zero) & g;
        gr[col..col + 8].copy_from_slice(&g.to_array());
        bias += g;
    }
    for (k, a) in acc.iter().enumerate() {
        let at = (3 * h + k) * w + j0;
        v.d_w2[at..at + 8].copy_from_slice(&a.to_array());
    }
    v.d_b1[col..col + 8].copy_from_slice(&bias.to_array());
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The module's formulas, term by term in f64.
    #[allow(clippy::type_complexity, reason = "the three results")]
    fn reference(w: usize, x: &[f64], d_raw: &[f64], w2: &[f64]) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let rows = x.len() / (3 * w);
        let (mut d_w2, mut d_b1, mut d_heads) =
            (vec![0.0; 9 * w], vec![0.0; 3 * w], vec![0.0; rows * 3 * w]);
        for r in 0..rows {
            for h in 0..3 {
                for j in 0..w {
                    let xv = x[r * 3 * w + h * w + j];
                    let mut g = 0.0;
                    for k in 0..3 {
                        let d = d_raw[r * 9 + 3 * h + k];
                        d_w2[(3 * h + k) * w + j] += d * xv;
                        g += d * w2[(3 * h + k) * w + j];
                    }
                    let g = if xv > 0.0 { g } else { 0.0 };
                    d_heads[r * 3 * w + h * w + j] = g;
                    d_b1[h * w + j] += g;
                }
            }
        }
        (d_w2, d_b1, d_heads)
    }

    fn draw(rng: &mut evogs_math::rng::SplitMix64, n: usize) -> Vec<f64> {
        (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect()
    }

    #[test]
    fn the_kernel_is_the_products_the_mask_and_the_sums() {
        let mut rng = evogs_math::rng::SplitMix64::new(3);
        // Widths with and without a tail of columns; rows over several tiles and a partial one.
        for (w, rows) in [(16, 70), (13, 33), (8, 1), (3, 5)] {
            let x = draw(&mut rng, rows * 3 * w);
            let (d_raw, w2) = (draw(&mut rng, rows * 9), draw(&mut rng, 9 * w));
            let (want_w2, want_b1, want_heads) = reference(w, &x, &d_raw, &w2);
            let (mut d_w2, mut d_b1, mut d_heads) = (
                vec![0.0; 9 * w],
                vec![0.0; 3 * w],
                vec![f64::NAN; rows * 3 * w],
            );
            heads_vjp(
                &mut HeadsVjp {
                    w,
                    x: &x,
                    d_raw: &d_raw,
                    w2: &w2,
                    d_w2: &mut d_w2,
                    d_b1: &mut d_b1,
                    d_heads: &mut d_heads,
                },
                block::<f64, LANES>,
            );
            for (got, want, what) in [
                (&d_w2, &want_w2, "dW2"),
                (&d_b1, &want_b1, "db1"),
                (&d_heads, &want_heads, "d_heads"),
            ] {
                for (g, e) in got.iter().zip(want) {
                    assert!(
                        (g - e).abs() < 1e-12,
                        "w = {w}, rows = {rows}: {what} {g} vs {e}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_gradients_are_added_and_the_input_gradient_written() {
        // Run twice into the same gradients: the weight and bias gradients double, the
        // input gradient is the same.
        let mut rng = evogs_math::rng::SplitMix64::new(4);
        let (w, rows) = (8, 40);
        let x = draw(&mut rng, rows * 3 * w);
        let (d_raw, w2) = (draw(&mut rng, rows * 9), draw(&mut rng, 9 * w));
        let (mut d_w2, mut d_b1, mut d_heads) =
            (vec![0.0; 9 * w], vec![0.0; 3 * w], vec![0.0; rows * 3 * w]);
        let run = |d_w2: &mut [f64], d_b1: &mut [f64], d_heads: &mut [f64]| {
            heads_vjp(
                &mut HeadsVjp {
                    w,
                    x: &x,
                    d_raw: &d_raw,
                    w2: &w2,
                    d_w2,
                    d_b1,
                    d_heads,
                },
                block::<f64, LANES>,
            );
        };
        run(&mut d_w2, &mut d_b1, &mut d_heads);
        let once = (d_w2.clone(), d_b1.clone(), d_heads.clone());
        run(&mut d_w2, &mut d_b1, &mut d_heads);
        for (a, b) in d_w2.iter().zip(&once.0).chain(d_b1.iter().zip(&once.1)) {
            assert!((a - 2.0 * b).abs() < 1e-12, "added: {a} vs 2·{b}");
        }
        assert_eq!(d_heads, once.2, "written");
    }

    #[test]
    fn the_f32_vector_kernel_is_bitwise_the_generic_one() {
        let mut rng = evogs_math::rng::SplitMix64::new(5);
        let (w, rows) = (24, 75);
        #[allow(clippy::cast_possible_truncation, reason = "test data")]
        let mut draw32 =
            |n: usize| -> Vec<f32> { draw(&mut rng, n).iter().map(|&v| v as f32).collect() };
        let mut x = draw32(rows * 3 * w);
        // Exact zeros and a NaN take the masked branch.
        x[5] = 0.0;
        x[9] = f32::NAN;
        let (d_raw, w2) = (draw32(rows * 9), draw32(9 * w));
        let start = (draw32(9 * w), draw32(3 * w));
        let run = |lanes: &dyn Fn(&mut HeadsVjp<'_, f32>, usize, usize)| {
            let (mut d_w2, mut d_b1, mut d_heads) =
                (start.0.clone(), start.1.clone(), vec![0.0; rows * 3 * w]);
            heads_vjp(
                &mut HeadsVjp {
                    w,
                    x: &x,
                    d_raw: &d_raw,
                    w2: &w2,
                    d_w2: &mut d_w2,
                    d_b1: &mut d_b1,
                    d_heads: &mut d_heads,
                },
                lanes,
            );
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            (bits(&d_w2), bits(&d_b1), bits(&d_heads))
        };
        let generic = run(&|v, h, j| block::<f32, LANES>(v, h, j));
        let vector = run(&|v, h, j| block_f32x8(v, h, j));
        assert_eq!(generic, vector);
        assert_eq!(generic.2[5], 0, "masked at zero");
        assert_eq!(generic.2[9], 0, "masked at NaN");
    }
}
