//! Deterministic sums over images: 8 independent lanes over fixed 1024-value chunks, the
//! chunk sums added in order. The result does not depend on threads, the loop vectorises,
//! and the f32 rounding error grows with the chunk count rather than with the length.

use evogs_math::Real;

/// Values per chunk of the two-level summation.
pub(crate) const CHUNK: usize = 1024;
/// Independent accumulators inside a chunk.
const LANES: usize = 8;

/// `Σ f(a_i, b_i)` in lanes of 8 over chunks of 1024, chunks added in order.
#[inline]
pub(crate) fn chunked_sum<T: Real>(a: &[T], b: &[T], f: impl Fn(T, T) -> T) -> T {
    let mut total = T::ZERO;
    for (ca, cb) in a.chunks(CHUNK).zip(b.chunks(CHUNK)) {
        let mut acc = [T::ZERO; LANES];
        let mut ia = ca.chunks_exact(LANES);
        let mut ib = cb.chunks_exact(LANES);
        for (xa, xb) in (&mut ia).zip(&mut ib) {
            for l in 0..LANES {
                acc[l] += f(xa[l], xb[l]);
            }
        }
        let mut s = reduce_lanes(&acc);
        for (&x, &y) in ia.remainder().iter().zip(ib.remainder()) {
            s += f(x, y);
        }
        total += s;
    }
    total
}

/// `Σ x_i` with the same lane and chunk order as [`chunked_sum`].
#[inline]
pub(crate) fn lane_sum<T: Real>(xs: &[T]) -> T {
    chunked_sum(xs, xs, |x, _| x)
}

/// Pairwise sum of the eight lanes.
#[inline]
fn reduce_lanes<T: Real>(acc: &[T; LANES]) -> T {
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
}
