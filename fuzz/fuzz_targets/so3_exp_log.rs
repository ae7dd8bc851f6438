//! SO(3) exp/log round trip on arbitrary rotation vectors (any f64 bit pattern).
//!
//! Properties: `exp` never panics and returns a unit quaternion for finite input;
//! `log(exp(φ))` returns φ for |φ| < π − 1e-6 (relative 1e-12) and, for any finite φ, a
//! rotation vector with angle ≤ π whose exponential is the same rotation (1e-12); the matrix
//! path agrees with the quaternion path.
#![no_main]

use evogs_math::Vec3;
use evogs_math::so3::{exp_matrix, exp_quat, log_matrix, log_quat};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: [u64; 3]| {
    let phi = Vec3::new(
        f64::from_bits(data[0]),
        f64::from_bits(data[1]),
        f64::from_bits(data[2]),
    );
    let q = exp_quat(phi);
    let r = exp_matrix(phi);
    if !phi.is_finite() || phi.norm() > 1e6 {
        return; // exp is periodic; huge angles lose all precision in sin/cos.
    }
    assert!(
        (q.norm() - 1.0).abs() < 1e-12,
        "exp is a unit quaternion: {q:?} for {phi:?}"
    );
    let l = log_quat(q);
    assert!(
        l.norm() <= core::f64::consts::PI + 1e-12,
        "log angle at most π"
    );
    let back = exp_quat(l);
    assert!(
        (back.dot(q).abs() - 1.0).abs() < 1e-12,
        "exp(log(R)) = R for {phi:?}"
    );
    if phi.norm() < core::f64::consts::PI - 1e-6 {
        assert!(
            (l - phi).norm() <= 1e-12 * phi.norm().max(1e-300),
            "log(exp(φ)) = φ for {phi:?}"
        );
    }
    let lm = log_matrix(r);
    assert!(
        (exp_matrix(lm) - r).max_abs() < 1e-11,
        "matrix round trip for {phi:?}"
    );
});
