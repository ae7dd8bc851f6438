//! The ODE state of the Gaussians: `[p (3), q̂ (4, unit), s (3)]` per Gaussian
//! ([`gaussian_layout`](crate::field::gaussian_layout)), with the tangent/cotangent
//! `[p (3), δ (3, world-frame rotation), s (3)]`.

use crate::field::neural::STATE_STRIDE;
use evogs_math::{Quat, Real, Vec3};

/// Tangent entries per Gaussian.
pub const TANGENT: usize = 9;

/// Packs positions, log-scales and raw quaternions into ODE states (quaternions
/// normalised).
pub fn pack_state<T: Real>(
    means: &[Vec3<T>],
    log_scales: &[Vec3<T>],
    quats: &[Quat<T>],
    y: &mut Vec<T>,
) {
    y.clear();
    for i in 0..means.len() {
        let q = quats[i].normalize();
        y.extend_from_slice(&[means[i].x, means[i].y, means[i].z, q.w, q.x, q.y, q.z]);
        y.extend_from_slice(&[log_scales[i].x, log_scales[i].y, log_scales[i].z]);
    }
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
