//! The ODE state of the Gaussians: `[p (3), q̂ (4, unit), s (3)]` per Gaussian
//! ([`gaussian_layout`](crate::field::gaussian_layout)), with the tangent/cotangent
//! `[p (3), δ (3, world-frame rotation), s (3)]`.

use super::gaussian_runs::{for_each_gaussian, for_each_gaussian3};
use crate::field::neural::STATE_STRIDE;
use evogs_math::{Par, Quat, Real, Vec3};

/// Tangent entries per Gaussian.
pub const TANGENT: usize = 9;

/// Packs positions, log-scales and raw quaternions into ODE states (quaternions
/// normalised), in runs of Gaussians on the pool with `par`.
pub fn pack_state<T: Real>(
    means: &[Vec3<T>],
    log_scales: &[Vec3<T>],
    quats: &[Quat<T>],
    y: &mut Vec<T>,
    par: Par,
) {
    y.resize(means.len() * STATE_STRIDE, T::ZERO);
    for_each_gaussian(par, y, STATE_STRIDE, |i, s| {
        let (m, q, l) = (means[i], quats[i].normalize(), log_scales[i]);
        s.copy_from_slice(&[m.x, m.y, m.z, q.w, q.x, q.y, q.z, l.x, l.y, l.z]);
    });
}

/// Writes the positions, rotations and log-scales of the ODE state `y` into `means`,
/// `quats` and `log_scales` (one entry per Gaussian of `y`), in runs on the pool with `par`.
///
/// # Panics
/// If the arrays differ in length from each other or from the state's Gaussians.
pub fn unpack_into<T: Real>(
    y: &[T],
    means: &mut [Vec3<T>],
    quats: &mut [Quat<T>],
    log_scales: &mut [Vec3<T>],
    par: Par,
) {
    assert_eq!(y.len(), means.len() * STATE_STRIDE, "state length");
    for_each_gaussian3(par, means, quats, log_scales, |i, m, q, s| {
        (*m, *q, *s) = unpack(y, i);
    });
}

/// Gaussian `i` of an ODE state.
pub fn unpack<T: Real>(y: &[T], i: usize) -> (Vec3<T>, Quat<T>, Vec3<T>) {
    let s = &y[i * STATE_STRIDE..(i + 1) * STATE_STRIDE];
    (
        Vec3::from_slice(s),
        Quat::from_slice(&s[3..]),
        Vec3::from_slice(&s[7..]),
    )
}
