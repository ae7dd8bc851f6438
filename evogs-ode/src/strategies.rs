//! Public proptest strategies for evogs-ode (feature `proptest`): methods and pairs,
//! log-uniform tolerances, random linear systems, states of any block layout (unit
//! quaternions on SO(3) and SE(3) blocks), output times and step sequences.

use crate::adaptive::{Pair, StepSequence};
use crate::{Block, Method, StateLayout};
use alloc::vec::Vec;
use evogs_math::strategies::unit_quat;
use proptest::prelude::*;

/// One of the built-in fixed-step methods.
pub fn method() -> impl Strategy<Value = Method> {
    proptest::sample::select(Method::ALL.to_vec())
}

/// One of the adaptive pairs.
pub fn pair() -> impl Strategy<Value = Pair> {
    proptest::sample::select(Pair::ALL.to_vec())
}

/// `10^e` for `e` uniform in `[lo_exp, hi_exp]` (tolerances, scales).
pub fn log_uniform(lo_exp: f64, hi_exp: f64) -> impl Strategy<Value = f64> {
    (lo_exp..=hi_exp).prop_map(|e: f64| evogs_math::Real::exp(e * core::f64::consts::LN_10))
}

/// An `n × n` matrix (row-major) `M − s·I` with entries of `M` in `[−r, r]` and a shift
/// `s ∈ [0, r]`: linear systems `y' = Ay` whose solutions stay moderate over a few time
/// units (growth at most `e^{(n−1)r t}`).
pub fn linear_system(n: usize, r: f64) -> impl Strategy<Value = Vec<f64>> {
    (proptest::collection::vec(-r..=r, n * n), 0.0..=r).prop_map(move |(mut m, s)| {
        for i in 0..n {
            m[i * n + i] -= s;
        }
        m
    })
}

/// A Euclidean state of dimension `n` with entries in `[−r, r]`.
pub fn euclidean_state(n: usize, r: f64) -> impl Strategy<Value = Vec<f64>> {
    proptest::collection::vec(-r..=r, n)
}

/// A state of `layout`: Euclidean entries in `[−r, r]`, unit quaternions on SO(3) blocks and
/// on the rotation of SE(3) blocks (their translations in `[−r, r]`).
pub fn state(layout: StateLayout, r: f64) -> impl Strategy<Value = Vec<f64>> {
    let n_rot = layout.count()
        * layout
            .pattern()
            .iter()
            .filter(|b| matches!(b, Block::So3 | Block::Se3))
            .count();
    (
        proptest::collection::vec(-r..=r, layout.ambient_len()),
        proptest::collection::vec(unit_quat(), n_rot),
    )
        .prop_map(move |(mut y, qs)| {
            let pa = layout.particle_ambient_len();
            let mut next = qs.iter();
            for p in 0..layout.count() {
                for sp in layout.spans() {
                    if matches!(sp.block, Block::So3 | Block::Se3)
                        && let Some(q) = next.next()
                    {
                        q.write_to(&mut y[p * pa + sp.ambient..]);
                    }
                }
            }
            y
        })
}

/// `m` output times in `[t0, t1]` (either direction), ordered from `t0` to `t1`, the last
/// one `t1`.
pub fn output_times(t0: f64, t1: f64, m: usize) -> impl Strategy<Value = Vec<f64>> {
    proptest::collection::vec(0.0..1.0f64, m.saturating_sub(1)).prop_map(move |mut u| {
        u.sort_by(f64::total_cmp);
        let mut v: Vec<f64> = u.iter().map(|s| t0 + s * (t1 - t0)).collect();
        v.push(t1);
        v
    })
}

/// `n` steps from `t0` with sizes in `[h_lo, h_hi]` (negative for `backward`).
pub fn step_sequence(
    t0: f64,
    n: usize,
    h_lo: f64,
    h_hi: f64,
    backward: bool,
) -> impl Strategy<Value = StepSequence<f64>> {
    proptest::collection::vec(h_lo..=h_hi, n).prop_map(move |hs| {
        let sign = if backward { -1.0 } else { 1.0 };
        let hs: Vec<f64> = hs.iter().map(|h| sign * h).collect();
        StepSequence::from_sizes(t0, &hs)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use evogs_math::strategies::sample;

    /// The smallest and largest of some values.
    fn range(v: impl IntoIterator<Item = f64>) -> (f64, f64) {
        v.into_iter()
            .fold((f64::MAX, f64::MIN), |(lo, hi), x| (lo.min(x), hi.max(x)))
    }

    #[test]
    fn log_uniform_spans_its_decades() {
        let (lo, hi) = range(sample(&log_uniform(-8.0, -2.0), 400));
        assert!(lo >= 1e-8 * (1.0 - 1e-12) && hi <= 1e-2 * (1.0 + 1e-12));
        assert!(lo < 2e-8 && hi > 5e-3, "[{lo:e}, {hi:e}]");
    }

    #[test]
    fn linear_systems_shift_the_diagonal_only() {
        let (n, r) = (3, 2.0);
        let systems = sample(&linear_system(n, r), 400);
        let diagonal = |m: &Vec<f64>| (0..n).map(|i| m[i * n + i]).collect::<Vec<_>>();
        let off = |m: &Vec<f64>| {
            (0..n * n)
                .filter(|k| k % (n + 1) != 0)
                .map(|k| m[k])
                .collect::<Vec<_>>()
        };
        let (dlo, dhi) = range(systems.iter().flat_map(diagonal));
        let (olo, ohi) = range(systems.iter().flat_map(off));
        assert!(
            olo >= -r && ohi <= r && olo < -1.5 && ohi > 1.5,
            "[{olo}, {ohi}]"
        );
        // M_ii − s with s ∈ [0, r]: in [−2r, r], below −r a quarter of the time.
        assert!(
            dlo >= -2.0 * r && dhi <= r && dlo < -3.0 && dhi > 1.0,
            "[{dlo}, {dhi}]"
        );
    }

    #[test]
    fn states_put_unit_quaternions_on_rotations_and_fill_the_rest() {
        let r = 3.0;
        let (lo, hi) = range(sample(&euclidean_state(4, r), 100).into_iter().flatten());
        assert!(lo >= -r && hi <= r && lo < -2.5 && hi > 2.5, "[{lo}, {hi}]");

        let layout = StateLayout::particles(&[Block::Euclidean(2), Block::So3, Block::Se3], 3);
        let pa = layout.particle_ambient_len();
        let mut free = Vec::new();
        for y in sample(&state(layout, r), 100) {
            assert_eq!(y.len(), layout.ambient_len());
            for p in 0..layout.count() {
                for sp in layout.spans() {
                    let at = &y[p * pa + sp.ambient..];
                    let (quat, rest) = match sp.block {
                        Block::So3 => (true, 0),
                        Block::Se3 => (true, 3),
                        Block::Euclidean(k) => (false, k),
                    };
                    let skip = if quat {
                        let norm2: f64 = at[..4].iter().map(|v| v * v).sum();
                        assert!((norm2 - 1.0).abs() < 1e-12, "particle {p}: |q|² = {norm2}");
                        4
                    } else {
                        0
                    };
                    free.extend_from_slice(&at[skip..skip + rest]);
                }
            }
        }
        let (lo, hi) = range(free);
        assert!(lo >= -r && hi <= r && lo < -2.5 && hi > 2.5, "[{lo}, {hi}]");
    }

    #[test]
    fn step_sequences_run_either_way() {
        for backward in [false, true] {
            let sign = if backward { -1.0 } else { 1.0 };
            for seq in sample(&step_sequence(0.5, 6, 0.01, 0.2, backward), 50) {
                assert_eq!(seq.len(), 6);
                assert!(
                    seq.sizes()
                        .iter()
                        .all(|h| (0.01..=0.2).contains(&(sign * h))),
                    "{:?}",
                    seq.sizes()
                );
            }
        }
    }
}
