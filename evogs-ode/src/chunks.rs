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

/// Four-buffer version of [`for_chunks2`]: `f(first_particle, particles, chunks)` with the
/// chunks of the four buffers, `per[i]` entries per particle in buffer `i`.
pub(crate) fn for_chunks4<T, F>(par: Par, count: usize, bufs: [&mut [T]; 4], per: [usize; 4], f: F)
where
    T: Send,
    F: Fn(usize, usize, [&mut [T]; 4]) + Sync,
{
    debug_assert!(
        bufs.iter().zip(per).all(|(b, w)| b.len() == count * w),
        "chunk buffers"
    );
    let [a, b, c, d] = bufs;
    #[cfg(feature = "rayon")]
    if matches!(par, Par::Rayon) && per.iter().all(|&w| w > 0) && count > CHUNK {
        use rayon::prelude::*;
        a.par_chunks_mut(CHUNK * per[0])
            .zip(b.par_chunks_mut(CHUNK * per[1]))
            .zip(c.par_chunks_mut(CHUNK * per[2]))
            .zip(d.par_chunks_mut(CHUNK * per[3]))
            .enumerate()
            .for_each(|(k, (((ca, cb), cc), cd))| {
                f(k * CHUNK, ca.len() / per[0], [ca, cb, cc, cd]);
            });
        return;
    }
    let _ = par;
    let mut p0 = 0;
    while p0 < count {
        let np = CHUNK.min(count - p0);
        let range = |w: usize| p0 * w..(p0 + np) * w;
        f(
            p0,
            np,
            [
                &mut a[range(per[0])],
                &mut b[range(per[1])],
                &mut c[range(per[2])],
                &mut d[range(per[3])],
            ],
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

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use std::sync::Mutex;
    use std::vec::Vec;

    /// Every `Par`, with the pool where the feature is on.
    fn pars() -> Vec<Par> {
        let mut p = std::vec![Par::Seq, Par::best()];
        p.dedup();
        p
    }

    /// Checks that the chunks `(first, count)` seen cover `0..count` in order of `CHUNK`.
    fn check_cover(mut seen: Vec<(usize, usize)>, count: usize, what: &str) {
        seen.sort_unstable();
        let want: Vec<(usize, usize)> = (0..count)
            .step_by(CHUNK)
            .map(|p0| (p0, CHUNK.min(count - p0)))
            .collect();
        assert_eq!(seen, want, "{what}: chunks");
    }

    #[test]
    fn chunks_cover_every_particle_once_whatever_the_widths() {
        // Widths of zero (a particle with no entries in one buffer) must not reach the
        // pool's chunking, whose chunk size would be 0.
        for par in pars() {
            for count in [0, 1, CHUNK - 1, CHUNK, CHUNK + 1, 3 * CHUNK + 5] {
                for (a_per, b_per) in [(0, 0), (0, 2), (3, 0), (1, 1), (3, 2)] {
                    let what = std::format!("{par:?}, {count} particles, widths {a_per}, {b_per}");
                    let mut a = std::vec![0_usize; count * a_per];
                    let mut b = std::vec![0_usize; count * b_per];
                    let seen = Mutex::new(Vec::new());
                    for_chunks2(
                        par,
                        count,
                        &mut a,
                        a_per,
                        &mut b,
                        b_per,
                        |p0, np, ca, cb| {
                            assert!(ca.len() == np * a_per && cb.len() == np * b_per, "{what}");
                            for (i, v) in ca.iter_mut().enumerate() {
                                *v = p0 + i / a_per;
                            }
                            for (i, v) in cb.iter_mut().enumerate() {
                                *v = p0 + i / b_per;
                            }
                            seen.lock().expect("lock").push((p0, np));
                        },
                    );
                    check_cover(seen.into_inner().expect("lock"), count, &what);
                    let owner =
                        |v: &[usize], per: usize| v.iter().enumerate().all(|(i, &p)| p == i / per);
                    assert!(
                        owner(&a, a_per.max(1)) && owner(&b, b_per.max(1)),
                        "{what}: owners"
                    );

                    let mut a = std::vec![0_usize; count * a_per];
                    let seen = Mutex::new(Vec::new());
                    for_chunks1(par, count, &mut a, a_per, |p0, np, ca| {
                        assert!(ca.len() == np * a_per, "{what}");
                        for (i, v) in ca.iter_mut().enumerate() {
                            *v = p0 + i / a_per;
                        }
                        seen.lock().expect("lock").push((p0, np));
                    });
                    check_cover(seen.into_inner().expect("lock"), count, &what);
                    assert!(owner(&a, a_per.max(1)), "{what}: owners, one buffer");

                    let per = [a_per, b_per, 1, a_per + b_per];
                    let mut bufs: [Vec<usize>; 4] =
                        core::array::from_fn(|i| std::vec![0_usize; count * per[i]]);
                    let seen = Mutex::new(Vec::new());
                    let [b0, b1, b2, b3] = &mut bufs;
                    for_chunks4(par, count, [b0, b1, b2, b3], per, |p0, np, chunks| {
                        for (c, w) in chunks.into_iter().zip(per) {
                            assert!(c.len() == np * w, "{what}");
                            for (i, v) in c.iter_mut().enumerate() {
                                *v = p0 + i / w;
                            }
                        }
                        seen.lock().expect("lock").push((p0, np));
                    });
                    check_cover(seen.into_inner().expect("lock"), count, &what);
                    for (b, w) in bufs.iter().zip(per) {
                        assert!(owner(b, w.max(1)), "{what}: owners, four buffers");
                    }
                }
            }
        }
    }
}
