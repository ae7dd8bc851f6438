//! Per-Gaussian passes in runs on the pool: [`for_each_gaussian`] over one per-Gaussian
//! buffer (an ODE state, a cotangent), [`for_each_gaussian3`] over three (means, rotations,
//! scales), [`all_gaussian_runs`] a check of every run. Each Gaussian's entries are written
//! by one call of `f` and nothing is reduced, so `Par::Rayon` gives bitwise the results of
//! `Par::Seq`; the runs have a fixed length.

use evogs_math::Par;
use std::ops::Range;

/// Gaussians per run.
pub const RUN: usize = 2048;

/// `true` if `ok` holds for every run `[k·RUN, (k + 1)·RUN) ∩ [0, n)` of `n` Gaussians;
/// `Par::Rayon` checks the runs in parallel.
pub fn all_gaussian_runs(
    par: Par,
    n: usize,
    ok: impl Fn(Range<usize>) -> bool + Sync + Send,
) -> bool {
    let range = |k: usize| k * RUN..((k + 1) * RUN).min(n);
    match par {
        Par::Seq => (0..n.div_ceil(RUN)).all(|k| ok(range(k))),
        #[cfg(feature = "rayon")]
        Par::Rayon => {
            use rayon::prelude::*;
            (0..n.div_ceil(RUN)).into_par_iter().all(|k| ok(range(k)))
        }
    }
}

/// Calls `f(i, entries)` for every Gaussian `i`, with `entries` its `width` consecutive
/// values of `buf` (`buf.len()` a multiple of `width`).
pub fn for_each_gaussian<T: Send>(
    par: Par,
    buf: &mut [T],
    width: usize,
    f: impl Fn(usize, &mut [T]) + Sync + Send,
) {
    if width == 0 {
        return;
    }
    debug_assert_eq!(buf.len() % width, 0, "whole Gaussians");
    let run = |(r, chunk): (usize, &mut [T])| {
        for (j, entries) in chunk.chunks_exact_mut(width).enumerate() {
            f(r * RUN + j, entries);
        }
    };
    match par {
        Par::Seq => buf.chunks_mut(RUN * width).enumerate().for_each(run),
        #[cfg(feature = "rayon")]
        Par::Rayon => {
            use rayon::prelude::*;
            buf.par_chunks_mut(RUN * width).enumerate().for_each(run);
        }
    }
}

/// Calls `f(i, a_i, b_i, c_i)` for every Gaussian `i` of three per-Gaussian arrays of one
/// length.
///
/// # Panics
/// If the lengths differ.
pub fn for_each_gaussian3<A: Send, B: Send, C: Send>(
    par: Par,
    a: &mut [A],
    b: &mut [B],
    c: &mut [C],
    f: impl Fn(usize, &mut A, &mut B, &mut C) + Sync + Send,
) {
    assert!(
        a.len() == b.len() && b.len() == c.len(),
        "per-Gaussian arrays of different lengths"
    );
    let run = |r: usize, ca: &mut [A], cb: &mut [B], cc: &mut [C]| {
        for (j, ((x, y), z)) in ca
            .iter_mut()
            .zip(cb.iter_mut())
            .zip(cc.iter_mut())
            .enumerate()
        {
            f(r * RUN + j, x, y, z);
        }
    };
    match par {
        Par::Seq => a
            .chunks_mut(RUN)
            .zip(b.chunks_mut(RUN))
            .zip(c.chunks_mut(RUN))
            .enumerate()
            .for_each(|(r, ((ca, cb), cc))| run(r, ca, cb, cc)),
        #[cfg(feature = "rayon")]
        Par::Rayon => {
            use rayon::prelude::*;
            a.par_chunks_mut(RUN)
                .zip(b.par_chunks_mut(RUN))
                .zip(c.par_chunks_mut(RUN))
                .enumerate()
                .for_each(|(r, ((ca, cb), cc))| run(r, ca, cb, cc));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_gaussian_is_visited_once_with_its_index_on_any_par() {
        for par in [Par::Seq, Par::best()] {
            for n in [0, 1, RUN - 1, RUN, 2 * RUN + 3] {
                let mut buf = vec![0_usize; 3 * n];
                for_each_gaussian(par, &mut buf, 3, |i, e| {
                    for (k, v) in e.iter_mut().enumerate() {
                        *v += 3 * i + k + 1;
                    }
                });
                assert!(
                    buf.iter().enumerate().all(|(k, &v)| v == k + 1),
                    "{n} Gaussians, {par:?}"
                );
                let (mut a, mut b, mut c) = (vec![0; n], vec![0_u8; n], vec![0_u16; n]);
                for_each_gaussian3(par, &mut a, &mut b, &mut c, |i, x, y, z| {
                    *x += i + 1;
                    *y += 1;
                    *z += 2;
                });
                assert!(a.iter().enumerate().all(|(i, &x)| x == i + 1), "{n}: first");
                assert!(
                    b.iter().all(|&y| y == 1) && c.iter().all(|&z| z == 2),
                    "{n}"
                );
            }
        }
    }
}
