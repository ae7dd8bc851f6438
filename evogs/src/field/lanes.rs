//! Lane-parallel reductions: sums over a few dozen channels split into [`LANES`] running
//! partial sums, so the compiler keeps them in one SIMD register instead of a chain of
//! dependent additions (a plain `fold` must add in order and cannot be vectorised). The
//! lanes are combined in a fixed order, so a result depends only on the inputs.
//!
//! Also here: the coordinate-gradient sums of a bilinear sample ([`coord_grad_sums`]), and
//! their f32 kernel in explicit 8-lane vectors ([`coord_grad_f32x8`]), which
//! [`Gemm::coord_grad_lanes`](super::Gemm::coord_grad_lanes) chooses for f32.

use evogs_math::Real;

/// Partial sums per reduction (one AVX2 register of f32; two of f64).
pub(crate) const LANES: usize = 8;

/// The lanes' total, summed pairwise in a fixed order.
#[inline]
pub(crate) fn total<T: Real>(acc: [T; LANES]) -> T {
    let a = [
        acc[0] + acc[4],
        acc[1] + acc[5],
        acc[2] + acc[6],
        acc[3] + acc[7],
    ];
    (a[0] + a[2]) + (a[1] + a[3])
}

/// `Σ_c a_c·b_c` over the shorter of the two slices, `a_c·b_c` added to lane `c mod LANES`.
#[inline]
#[must_use]
pub(crate) fn dot<T: Real>(a: &[T], b: &[T]) -> T {
    let n = a.len().min(b.len());
    let (a, b) = (a[..n].chunks_exact(LANES), b[..n].chunks_exact(LANES));
    let (a_tail, b_tail) = (a.remainder(), b.remainder());
    let mut acc = [T::ZERO; LANES];
    for (x, y) in a.zip(b) {
        for k in 0..LANES {
            acc[k] += x[k] * y[k];
        }
    }
    for (k, (&x, &y)) in a_tail.iter().zip(b_tail).enumerate() {
        acc[k] += x * y;
    }
    total(acc)
}

/// The coordinate-gradient partial sums of one bilinear sample, channel by channel: channel
/// `c` adds to lane `c mod LANES`
/// `u += g_c·(gy·(p10_c − p00_c) + fy·(p11_c − p01_c))` and
/// `v += g_c·(gx·(p01_c − p00_c) + fx·(p11_c − p10_c))`, with `gx = 1 − fx`, `gy = 1 − fy`;
/// the corners are `[p00, p10, p01, p11]`, each as long as `g`.
#[inline]
pub(crate) fn coord_grad_sums<T: Real>(
    g: &[T],
    corners: [&[T]; 4],
    fx: T,
    fy: T,
    acc: &mut ([T; LANES], [T; LANES]),
) {
    let (gx, gy) = (T::ONE - fx, T::ONE - fy);
    let [p00, p10, p01, p11] = corners;
    for c in 0..g.len() {
        let k = c % LANES;
        acc.0[k] += g[c] * (gy * (p10[c] - p00[c]) + fy * (p11[c] - p01[c]));
        acc.1[k] += g[c] * (gx * (p01[c] - p00[c]) + fx * (p11[c] - p10[c]));
    }
}

/// [`coord_grad_sums`] over whole blocks of 8 channels (`g.len()` a multiple of 8) in
/// explicit 8-lane vectors (`wide::f32x8`: AVX where the build has it, SSE or NEON pairs
/// otherwise), the same operations per lane, so the same bits: the generic loop compiles to
/// 4-wide code with scalar loads.
#[inline]
pub(crate) fn coord_grad_f32x8(
    g: &[f32],
    corners: [&[f32]; 4],
    fx: f32,
    fy: f32,
    acc: &mut ([f32; LANES], [f32; LANES]),
) {
    use wide::f32x8;
    const _: () = assert!(LANES == 8, "one f32x8 per lane block");
    let load = |x: &[f32], c0: usize| {
        let block: [f32; 8] = x[c0..c0 + 8].try_into().expect("a block of 8 channels");
        f32x8::from(block)
    };
    let (fxv, fyv) = (f32x8::splat(fx), f32x8::splat(fy));
    let (gxv, gyv) = (f32x8::splat(1.0 - fx), f32x8::splat(1.0 - fy));
    let [p00, p10, p01, p11] = corners;
    let (mut u, mut v) = (f32x8::from(acc.0), f32x8::from(acc.1));
    for c0 in (0..g.len()).step_by(LANES) {
        let (gc, a, b) = (load(g, c0), load(p00, c0), load(p10, c0));
        let (c, d) = (load(p01, c0), load(p11, c0));
        u += gc * (gyv * (b - a) + fyv * (d - c));
        v += gc * (gxv * (c - a) + fxv * (d - b));
    }
    *acc = (u.to_array(), v.to_array());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dot_matches_the_sequential_sum_for_every_length() {
        for n in 0..40 {
            let a: Vec<f64> = (0..n).map(|i| f64::from(i) * 0.25 - 3.0).collect();
            let b: Vec<f64> = (0..n).map(|i| (f64::from(i) * 0.7).cos()).collect();
            let want: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
            let got = dot(&a, &b);
            assert!((got - want).abs() < 1e-12, "n = {n}: {got} vs {want}");
        }
    }

    #[test]
    fn lanes_are_summed_in_a_fixed_order() {
        // 1e16 + 1 − 1e16 loses the 1 in some orders and keeps it in others: the order is
        // lanes (0+4, 1+5, 2+6, 3+7), then (0+2) + (1+3).
        let mut acc = [0.0_f64; LANES];
        acc[0] = 1e16;
        acc[4] = 1.0;
        acc[2] = -1e16;
        assert!((total(acc) - 0.0).abs() < 1e-9);
        acc = [0.0; LANES];
        acc[0] = 1e16;
        acc[4] = -1e16;
        acc[1] = 1.0;
        assert!((total(acc) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn the_f32_lane_kernel_is_bitwise_the_generic_loop() {
        // The f32 override (explicit 8-lane vectors) against the documented per-lane sums,
        // written out here, over 4 blocks of channels and running sums that start non-zero.
        let mut rng = evogs_math::rng::SplitMix64::new(9);
        let mut draw = |n: usize| -> Vec<f32> {
            (0..n)
                .map(|_| {
                    f32::from(u16::try_from(rng.below(4001)).expect("below 4001")) / 1000.0 - 2.0
                })
                .collect()
        };
        let (g, p00, p10, p01, p11) = (draw(32), draw(32), draw(32), draw(32), draw(32));
        let start = (
            core::array::from_fn(|k| k as f32 * 0.25),
            core::array::from_fn(|k| 1.0 - k as f32),
        );
        for (fx, fy) in [(0.3_f32, 0.8_f32), (0.0, 1.0), (0.999, 0.001)] {
            let mut got = start;
            coord_grad_f32x8(&g, [&p00, &p10, &p01, &p11], fx, fy, &mut got);
            let mut want = start;
            let (gx, gy) = (1.0 - fx, 1.0 - fy);
            for c in 0..32 {
                let k = c % LANES;
                want.0[k] += g[c] * (gy * (p10[c] - p00[c]) + fy * (p11[c] - p01[c]));
                want.1[k] += g[c] * (gx * (p01[c] - p00[c]) + fx * (p11[c] - p10[c]));
            }
            assert_eq!(got.0.map(f32::to_bits), want.0.map(f32::to_bits), "u lanes");
            assert_eq!(got.1.map(f32::to_bits), want.1.map(f32::to_bits), "v lanes");
            assert_ne!(
                got.0.map(f32::to_bits),
                start.0.map(f32::to_bits),
                "the sums moved"
            );
        }
    }
}
