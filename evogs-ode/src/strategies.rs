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
