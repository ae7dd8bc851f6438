//! Property tests of the SO(3) maps, exp-map updates and covariances, on the public
//! strategies (log-uniform angles from 1e-12 and angles just below π).

use evogs_math::covariance::covariance;
use evogs_math::so3::{exp_matrix, exp_quat, log_matrix, log_quat};
use evogs_math::so3_jacobians::{
    left_jacobian, left_jacobian_inv, right_jacobian, right_jacobian_inv,
};
use evogs_math::strategies::{raw_quat, so3_tangent, unit_quat, vec3};
use evogs_math::update::{exp_update_left, exp_update_right};
use evogs_math::{Mat3, So3};
use proptest::prelude::*;

proptest! {
    #[test]
    fn exp_of_log_is_identity_on_rotations(q in unit_quat()) {
        let r = q.to_rotation_matrix();
        prop_assert!((exp_matrix(log_matrix(r)) - r).max_abs() < 1e-14);
        let back = exp_quat(log_quat(q));
        // Same rotation (quaternions up to sign).
        prop_assert!((back.dot(q).abs() - 1.0).abs() < 1e-14);
    }

    #[test]
    fn log_of_exp_is_identity_below_pi(phi in so3_tangent(core::f64::consts::PI)) {
        let l = log_quat(exp_quat(phi));
        prop_assert!((l - phi).norm() <= 1e-14 * phi.norm().max(1e-300) + 1e-300);
        let lm = log_matrix(exp_matrix(phi));
        // Through the matrix the angle near π is conditioned by the rounding of R.
        prop_assert!((lm - phi).norm() <= 1e-13 * phi.norm().max(1e-300) + 1e-300);
    }

    #[test]
    fn rotations_are_orthonormal_with_unit_determinant(phi in so3_tangent(3.0)) {
        let r = exp_matrix(phi);
        prop_assert!((r * r.transpose() - Mat3::identity()).max_abs() < 1e-14);
        prop_assert!((r.det() - 1.0).abs() < 1e-14);
    }

    #[test]
    fn exp_map_updates_keep_unit_norm(q in unit_quat(), w in vec3(20.0), dt in -1.0..1.0f64) {
        let mut a = q;
        let mut b = q;
        for _ in 0..100 {
            a = exp_update_left(a, w, dt);
            b = exp_update_right(b, w, dt);
        }
        prop_assert!((a.norm() - 1.0).abs() < 1e-13);
        prop_assert!((b.norm() - 1.0).abs() < 1e-13);
    }

    #[test]
    fn left_jacobian_is_rotation_times_right_jacobian(phi in so3_tangent(3.0)) {
        let d = left_jacobian(phi) - exp_matrix(phi) * right_jacobian(phi);
        prop_assert!(d.max_abs() < 1e-14);
    }

    #[test]
    fn jacobians_times_inverses_are_identity(phi in so3_tangent(3.1)) {
        prop_assert!((left_jacobian(phi) * left_jacobian_inv(phi) - Mat3::identity()).max_abs() < 1e-13);
        prop_assert!((right_jacobian(phi) * right_jacobian_inv(phi) - Mat3::identity()).max_abs() < 1e-13);
    }

    #[test]
    fn covariance_is_symmetric_positive_definite(s in vec3(4.0), q in raw_quat()) {
        let sigma = covariance(s, q);
        let m = sigma.to_mat();
        prop_assert!((m - m.transpose()).max_abs() == 0.0);
        // Eigenvalues are exp(2 s_i): check via the quadratic form along the rotated axes.
        let r = So3::from_quat(q);
        let largest = (2.0 * s.max_elem()).exp();
        for i in 0..3 {
            let axis = r.act(evogs_math::Vec3::unit(i));
            let var = axis.dot(m.mul_vec(axis));
            let want = (2.0 * s[i]).exp();
            prop_assert!(var > 0.0 && (var - want).abs() < 1e-13 * largest);
        }
        prop_assert!(sigma.det() > 0.0);
    }
}
