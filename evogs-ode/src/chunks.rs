//! Fixed-size particle chunks, run sequentially or on rayon.
//!
//! The per-particle updates of the steppers have no reductions: each chunk writes only its
//! own particles, so a [`Par::Rayon`](evogs_math::Par) run performs exactly the same
//! floating-point operations as a sequential one and gives bitwise identical results.

use evogs_math::Par;

/// Particles per chunk (independent of the thread count).
pub(crate) const CHUNK: usize = 512;

/// Calls `f(first_particle, particles, a_chunk, b_chunk)` for consecutive chunks of
/// [`CHUNK`] particles; `a` holds `a_per` entries per particle and `b` holds `b_per`.
pub(crate) fn for_chunks2<T, F>(
    par: Par,
    count: usize,
    a: &mut [T],
    a_per: usize,
    b: &mut [T],
    b_per: usize,
    f: F,
) where
    T: Send,
    F: Fn(usize, usize, &mut [T], &mut [T]) + Sync,
{
    debug_assert!(
        a.len() == count * a_per && b.len() == count * b_per,
        "chunk buffers"
    );
    #[cfg(feature = "rayon")]
    if matches!(par, Par::Rayon) && a_per > 0 && b_per > 0 && count > CHUNK {
        use rayon::prelude::*;
        a.par_chunks_mut(CHUNK * a_per)
            .zip(b.par_chunks_mut(CHUNK * b_per))
            .enumerate()
            .for_each(|(c, (ca, cb))| f(c * CHUNK, ca.len() / a_per, ca, cb));
        return;
    }
    let _ = par;
    let mut p0 = 0;
    while p0 < count {
        let np = CHUNK.min(count - p0);
        f(
            p0,
            np,
            &mut a[p0 * a_per..(p0 + np) * a_per],
            &mut b[p0 * b_per..(p0 + np) * b_per],
        );
        p0 += np;
    }
}

/// One-buffer version of [`for_chunks2`].
pub(crate) fn for_chunks1<T, F>(par: Par, count: usize, a: &mut [T], a_per: usize, f: F)
where
    T: Send,
    F: Fn(usize, usize, &mut [T]) + Sync,
{
    debug_assert!(a.len() == count * a_per, "chunk buffer");
    #[cfg(feature = "rayon")]
    if matches!(par, Par::Rayon) && a_per > 0 && count > CHUNK {
        use rayon::prelude::*;
        a.par_chunks_mut(CHUNK * a_per)
            .enumerate()
            .for_each(|(c, ca)| f(c * CHUNK, ca.len() / a_per, ca));
        return;
    }
    let _ = par;
    let mut p0 = 0;
    while p0 < count {
        let np = CHUNK.min(count - p0);
        f(p0, np, &mut a[p0 * a_per..(p0 + np) * a_per]);
        p0 += np;
    }
}
