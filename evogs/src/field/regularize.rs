//! The HexPlane regularisers of EvoGS/4DGS (`docs/losses.md` §6), with gradients.
//!
//! - `smoothness(P)`: the mean over all entries of `(P[h+2] − 2P[h+1] + P[h])²`, a squared
//!   **second** difference along the rows (the plane's second coordinate: y or z for spatial
//!   planes, t for space-time planes);
//! - plane TV = Σ over levels and spatial planes of smoothness; time smoothness = the same
//!   over space-time planes; L1 time = Σ over space-time planes of mean |1 − P|.
//!
//! `total = w_tv·tv + w_time·time_smooth + w_l1·l1_time`.

use super::hexplane::{HexPlane, SPACE_PLANES, TIME_PLANES};
use evogs_math::{Par, Real};

/// Weights of the three plane regularisers.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PlaneRegWeights {
    /// Weight of the spatial-plane smoothness ("plane TV").
    pub plane_tv: f64,
    /// Weight of the space-time-plane smoothness.
    pub time_smoothness: f64,
    /// Weight of the L1 of space-time planes toward 1.
    pub l1_time: f64,
}

/// The unweighted regulariser values and the weighted total. A term whose weight is zero
/// is not evaluated: its value reads 0.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlaneRegValues {
    /// Σ smoothness over spatial planes.
    pub plane_tv: f64,
    /// Σ smoothness over space-time planes.
    pub time_smoothness: f64,
    /// Σ mean |1 − P| over space-time planes.
    pub l1_time: f64,
    /// Weighted sum.
    pub total: f64,
}

/// Rows of a plane (or entries, for the L1 term) that one task handles: a fixed number, so
/// the partial sums are the same, and reduced in the same order, on any thread count.
const RUN_ROWS: usize = 32;
const RUN_ENTRIES: usize = 16_384;

/// Runs `f` over fixed runs of `grad` (`run` entries each, `f` gets the run's offset) on
/// `par`, and sums the values it returns in run order.
fn sum_runs<T: Real>(
    grad: &mut [T],
    run: usize,
    par: Par,
    f: impl Fn(usize, &mut [T]) -> f64 + Sync,
) -> f64 {
    match par {
        Par::Seq => grad
            .chunks_mut(run)
            .enumerate()
            .map(|(i, g)| f(i * run, g))
            .fold(0.0, |a, b| a + b),
        #[cfg(feature = "rayon")]
        Par::Rayon => {
            use rayon::prelude::*;
            let parts: Vec<f64> = grad
                .par_chunks_mut(run)
                .enumerate()
                .map(|(i, g)| f(i * run, g))
                .collect();
            parts.into_iter().fold(0.0, |a, b| a + b)
        }
    }
}

/// Mean squared second difference along the rows of a plane, its weighted gradient added
/// into `grad`. Each second difference `d[h] = P[h+2] − 2P[h+1] + P[h]` adds `g·d[h]` to
/// rows h and h+2 and `−2g·d[h]` to row h+1. A run of rows takes every `d[h]` that touches
/// it, in increasing h, and adds only into its own rows: each gradient entry receives the
/// same terms in the same order as in one pass over the plane. The value of `d[h]` is
/// counted by the run that holds row h.
fn smoothness<T: Real>(
    plane: &[T],
    rows: usize,
    row_len: usize,
    weight: f64,
    grad: &mut [T],
    par: Par,
) -> f64 {
    if rows < 3 {
        return 0.0;
    }
    let count = ((rows - 2) * row_len) as f64;
    let g = T::from_f64(2.0 * weight / count);
    let acc = sum_runs(grad, RUN_ROWS * row_len, par, |offset, run| {
        let (first, end) = (offset / row_len, offset / row_len + run.len() / row_len);
        let mut acc = 0.0;
        for h in first.saturating_sub(2)..end.min(rows - 2) {
            let row = |i: usize| &plane[i * row_len..(i + 1) * row_len];
            let (p0, p1, p2) = (row(h), row(h + 1), row(h + 2));
            // Which of the three rows it touches lie in this run: all three but near the
            // run's ends, where the loop checks each.
            let own = [h >= first, h + 1 >= first && h + 1 < end, h + 2 < end];
            if own == [true; 3] {
                let base = (h - first) * row_len;
                let (r0, rest) = run[base..].split_at_mut(row_len);
                let (r1, r2) = rest.split_at_mut(row_len);
                for k in 0..row_len {
                    let d = p2[k] - T::TWO * p1[k] + p0[k];
                    let gd = g * d;
                    r2[k] += gd;
                    r1[k] -= T::TWO * gd;
                    acc += d.to_f64() * d.to_f64();
                    r0[k] += gd;
                }
                continue;
            }
            for k in 0..row_len {
                let d = p2[k] - T::TWO * p1[k] + p0[k];
                let gd = g * d;
                if own[2] {
                    run[(h + 2 - first) * row_len + k] += gd;
                }
                if own[1] {
                    run[(h + 1 - first) * row_len + k] -= T::TWO * gd;
                }
                if own[0] {
                    acc += d.to_f64() * d.to_f64();
                    run[(h - first) * row_len + k] += gd;
                }
            }
        }
        acc
    });
    acc / count
}

/// Mean `|P − 1|` over a plane, its weighted gradient (the sign) added into `grad`.
fn l1_to_one<T: Real>(plane: &[T], weight: f64, grad: &mut [T], par: Par) -> f64 {
    let count = plane.len() as f64;
    let g = T::from_f64(weight / count);
    let acc = sum_runs(grad, RUN_ENTRIES, par, |offset, run| {
        let mut acc = 0.0;
        for (p, d) in plane[offset..].iter().zip(run.iter_mut()) {
            let r = *p - T::ONE;
            acc += r.abs().to_f64();
            if r > T::ZERO {
                *d += g;
            } else if r < T::ZERO {
                *d -= g;
            }
        }
        acc
    });
    acc / count
}

/// Evaluates the regularisers on the plane parameters (`params[..hex.n_params()]`) and adds
/// the weighted gradient into `d_params`. `par` splits each plane into fixed runs of rows:
/// the same bits on any thread count. A term of weight zero is skipped (it adds nothing to
/// the total or the gradient; its unweighted value reads 0), so a training run that turns a
/// regulariser off does not pay for it.
pub fn plane_regularizers<T: Real>(
    hex: &HexPlane,
    params: &[T],
    w: &PlaneRegWeights,
    d_params: &mut [T],
    par: Par,
) -> PlaneRegValues {
    let mut v = PlaneRegValues::default();
    let ch = hex.channels();
    for l in 0..hex.levels() {
        for p in SPACE_PLANES.into_iter().filter(|_| w.plane_tv != 0.0) {
            let r = hex.plane_range(l, p);
            let (rows, cols) = hex.plane_shape(l, p);
            v.plane_tv += smoothness(
                &params[r.clone()],
                rows,
                cols * ch,
                w.plane_tv,
                &mut d_params[r],
                par,
            );
        }
        for p in TIME_PLANES {
            let r = hex.plane_range(l, p);
            let (rows, cols) = hex.plane_shape(l, p);
            if w.time_smoothness != 0.0 {
                v.time_smoothness += smoothness(
                    &params[r.clone()],
                    rows,
                    cols * ch,
                    w.time_smoothness,
                    &mut d_params[r.clone()],
                    par,
                );
            }
            if w.l1_time != 0.0 {
                v.l1_time += l1_to_one(&params[r.clone()], w.l1_time, &mut d_params[r], par);
            }
        }
    }
    v.total =
        w.plane_tv * v.plane_tv + w.time_smoothness * v.time_smoothness + w.l1_time * v.l1_time;
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::hexplane::{HexPlaneConfig, TimeMapping};
    use evogs_math::diff::{GradCheck, central_gradient};
    use evogs_math::rng::SplitMix64;

    /// A HexPlane over the box [−1, 1]³ and the times [−1, 1].
    fn unit_box(cfg: &HexPlaneConfig) -> HexPlane {
        let times = TimeMapping::Normalized {
            t_min: -1.0,
            t_max: 1.0,
        };
        HexPlane::new(cfg, [-1.0; 3], [1.0; 3], times)
    }

    #[test]
    fn gradient_matches_central_differences() {
        let cfg = HexPlaneConfig {
            channels: 2,
            resolution: [3, 4, 10, 11],
            multires: vec![1],
        };
        let hex = unit_box(&cfg);
        let mut rng = SplitMix64::new(3);
        let mut x: Vec<f64> = (0..hex.n_params()).map(|_| rng.uniform(0.0, 2.0)).collect();
        let w = PlaneRegWeights {
            plane_tv: 0.7,
            time_smoothness: 1.3,
            l1_time: 0.4,
        };
        let mut g = vec![0.0; x.len()];
        let v = plane_regularizers(&hex, &x, &w, &mut g, Par::Seq);
        assert!(v.total > 0.0, "non-trivial value");
        let mut num = vec![0.0; x.len()];
        central_gradient(
            |p: &[f64]| {
                let mut d = vec![0.0; p.len()];
                plane_regularizers(&hex, p, &w, &mut d, Par::Seq).total
            },
            &mut x,
            &mut num,
        );
        GradCheck::new(1e-8, 1e-6)
            .check(&g, &num)
            .assert_passed("plane regularisers");
    }

    #[test]
    fn runs_of_rows_add_the_terms_of_one_pass_over_the_plane() {
        // The scatter over the whole plane, one second difference after another.
        fn one_pass(plane: &[f64], rows: usize, row_len: usize, g: f64, grad: &mut [f64]) -> f64 {
            let mut acc = 0.0;
            for h in 0..rows - 2 {
                for k in 0..row_len {
                    let (a, b, c) = (
                        h * row_len + k,
                        (h + 1) * row_len + k,
                        (h + 2) * row_len + k,
                    );
                    let d = plane[c] - 2.0 * plane[b] + plane[a];
                    acc += d * d;
                    grad[c] += g * d;
                    grad[b] -= 2.0 * (g * d);
                    grad[a] += g * d;
                }
            }
            acc
        }
        let (rows, row_len) = (3 * RUN_ROWS + 5, 7);
        let mut rng = SplitMix64::new(11);
        let plane: Vec<f64> = (0..rows * row_len)
            .map(|_| rng.uniform(-1.0, 1.0))
            .collect();
        let weight = 0.3;
        let count = ((rows - 2) * row_len) as f64;
        let mut want = vec![0.5; plane.len()];
        let acc = one_pass(&plane, rows, row_len, 2.0 * weight / count, &mut want);
        for par in [Par::Seq, Par::best()] {
            let mut got = vec![0.5; plane.len()];
            let v = smoothness(&plane, rows, row_len, weight, &mut got, par);
            let bits = |g: &[f64]| g.iter().map(|e| e.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(&got),
                bits(&want),
                "the gradient, bit for bit ({par:?})"
            );
            assert!(
                (v - acc / count).abs() <= 1e-14 * v,
                "{v} against {}",
                acc / count
            );
        }
    }

    #[test]
    fn a_term_of_weight_zero_is_skipped_and_the_others_are_unchanged() {
        let cfg = HexPlaneConfig {
            channels: 2,
            resolution: [5, 6, 7, 8],
            multires: vec![1, 2],
        };
        let hex = unit_box(&cfg);
        let mut rng = SplitMix64::new(8);
        let x: Vec<f64> = (0..hex.n_params()).map(|_| rng.uniform(0.0, 2.0)).collect();
        let run = |w: PlaneRegWeights| {
            let mut g = vec![0.25; x.len()];
            let v = plane_regularizers(&hex, &x, &w, &mut g, Par::Seq);
            (v, g.iter().map(|e| e.to_bits()).collect::<Vec<_>>())
        };
        let (tv, ts, l1) = (0.7, 1.3, 0.4);
        let all = |plane_tv, time_smoothness, l1_time| PlaneRegWeights {
            plane_tv,
            time_smoothness,
            l1_time,
        };
        let (none, untouched) = run(all(0.0, 0.0, 0.0));
        assert_eq!(none, PlaneRegValues::default(), "nothing evaluated");
        assert!(
            untouched.iter().all(|&b| b == 0.25_f64.to_bits()),
            "no gradient added"
        );
        // Each term alone, then with another's weight set to zero: the same value and
        // gradient bits (the terms add into disjoint planes or in a fixed order).
        let (both, g_both) = run(all(tv, 0.0, l1));
        let (only_tv, _) = run(all(tv, 0.0, 0.0));
        let (only_l1, _) = run(all(0.0, 0.0, l1));
        assert!(both.plane_tv > 0.0 && both.l1_time > 0.0, "{both:?}");
        let bits = |v: [f64; 2]| v.map(f64::to_bits);
        assert_eq!(
            both.time_smoothness.to_bits(),
            0,
            "the skipped term reads +0"
        );
        assert_eq!(
            bits([both.plane_tv, both.l1_time]),
            bits([only_tv.plane_tv, only_l1.l1_time])
        );
        let (full, g_full) = run(all(tv, ts, l1));
        assert_eq!(
            bits([full.plane_tv, full.l1_time]),
            bits([both.plane_tv, both.l1_time])
        );
        assert!(full.time_smoothness > 0.0, "{full:?}");
        assert_ne!(
            g_full, g_both,
            "time smoothness adds gradient when weighted"
        );
    }

    #[test]
    fn the_pool_gives_the_bits_of_one_thread() {
        // Planes of more rows than one run, so the runs' partial sums and their order count.
        let cfg = HexPlaneConfig {
            channels: 3,
            resolution: [21, 19, 17, 23],
            multires: vec![1, 2],
        };
        let hex = unit_box(&cfg);
        let mut rng = SplitMix64::new(5);
        let x: Vec<f32> = (0..hex.n_params())
            .map(|_| <f32 as Real>::from_f64(rng.uniform(0.0, 2.0)))
            .collect();
        let w = PlaneRegWeights {
            plane_tv: 0.7,
            time_smoothness: 1.3,
            l1_time: 0.4,
        };
        let run = |par: Par| {
            let mut g = vec![0.25_f32; x.len()];
            let v = plane_regularizers(&hex, &x, &w, &mut g, par);
            (
                v.total.to_bits(),
                g.iter().map(|e| e.to_bits()).collect::<Vec<_>>(),
            )
        };
        let seq = run(Par::Seq);
        assert!(
            seq.1.iter().any(|&b| b != 0.25_f32.to_bits()),
            "gradients added"
        );
        assert_eq!(seq, run(Par::best()), "value and gradient");
    }
}
