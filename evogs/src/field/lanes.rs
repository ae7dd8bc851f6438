//! Lane-parallel reductions: sums over a few dozen channels split into [`LANES`] running
//! partial sums, so the compiler keeps them in one SIMD register instead of a chain of
//! dependent additions (a plain `fold` must add in order and cannot be vectorised). The
//! lanes are combined in a fixed order, so a result depends only on the inputs.

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
}
