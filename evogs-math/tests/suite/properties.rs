//! Property tests of the SO(3) maps, exp-map updates and covariances, on the public
//! strategies (log-uniform angles from 1e-12 and angles just below π); the VJPs of the SO(3)
//! maps by the dot-product test against dual numbers. (SE(3): `se3_properties.rs`.)

use crate::common;

use common::dot_residual;
use evogs_math::covariance::covariance;
use evogs_math::so3::{exp_matrix, exp_quat, log_matrix, log_quat};
use evogs_math::so3_jacobians::{
    exp_quat_vjp, jl_inv_mul, jl_inv_mul_vjp, jl_mul, jl_mul_vjp, left_jacobian, left_jacobian_inv,
    right_jacobian, right_jacobian_inv,
};
use evogs_math::strategies::{raw_quat, so3_tangent, unit_quat, vec3};
use evogs_math::update::{
    exp_update_left, exp_update_left_vjp, exp_update_right, exp_update_right_vjp,
};
use evogs_math::{Dual, Mat3, Quat, So3, Vec3};
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

    #[test]
    fn so3_matrix_acts_as_the_rotation(a in unit_quat(), v in vec3(3.0)) {
        // The group axioms of So3 are in lie_axioms.rs; here its matrix form.
        let a = So3::from_unit_quat(a);
        prop_assert!((a.matrix().mul_vec(v) - a.act(v)).norm() < 1e-14);
    }

    #[test]
    fn so3_log_angle_is_in_zero_pi_and_exp_inverts_it(phi in so3_tangent(7.0)) {
        let r = So3::exp(phi);
        let l = r.log();
        prop_assert!(l.norm() <= core::f64::consts::PI * (1.0 + 1e-15));
        prop_assert!(So3::exp(l).angle_to(r) < 1e-14);
    }

    #[test]
    fn so3_jacobians_are_the_first_order_terms(phi in so3_tangent(3.0), d in vec3(1.0)) {
        // Exp(φ + δ) ≈ Exp(Jl δ)·Exp(φ) ≈ Exp(φ)·Exp(Jr δ), remainder O(|δ|²); Jr(φ) = Jl(−φ).
        let d = d * 1e-6;
        let e = So3::exp(phi);
        let e2 = So3::exp(phi + d);
        let l = (e2 * e.inverse()).log() - left_jacobian(phi).mul_vec(d);
        let r = (e.inverse() * e2).log() - right_jacobian(phi).mul_vec(d);
        prop_assert!(l.norm() < 1e-11 && r.norm() < 1e-11);
        prop_assert!((right_jacobian(phi) - left_jacobian(-phi)).max_abs() < 1e-16);
        prop_assert!((jl_mul(phi, d) - left_jacobian(phi).mul_vec(d)).norm() < 1e-20);
    }

    #[test]
    fn so3_exp_quat_vjp_passes_the_dot_test(phi in so3_tangent(3.1)) {
        let r = dot_residual(
            |x, y| exp_quat(Vec3::from_slice(x)).write_to(y),
            &phi.to_array(),
            |w, out| exp_quat_vjp(phi, Quat::from_slice(w)).write_to(out),
            4,
        );
        prop_assert!(r < 1e-13, "residual {}", r);
    }

    #[test]
    fn so3_jacobian_product_vjps_pass_the_dot_test(phi in so3_tangent(3.1), v in vec3(2.0)) {
        let x0 = [phi.to_array(), v.to_array()].concat();
        type F = fn(Vec3<Dual<f64>>, Vec3<Dual<f64>>) -> Vec3<Dual<f64>>;
        type G = fn(Vec3<f64>, Vec3<f64>, Vec3<f64>) -> (Vec3<f64>, Vec3<f64>);
        let pairs: [(F, G); 2] = [(jl_mul, jl_mul_vjp), (jl_inv_mul, jl_inv_mul_vjp)];
        for (f, vjp) in pairs {
            let r = dot_residual(
                |x, y| f(Vec3::from_slice(x), Vec3::from_slice(&x[3..])).write_to(y),
                &x0,
                |w, out| {
                    let (a, b) = vjp(phi, v, Vec3::from_slice(w));
                    a.write_to(out);
                    b.write_to(&mut out[3..]);
                },
                3,
            );
            prop_assert!(r < 1e-13, "residual {}", r);
        }
    }

    #[test]
    fn exp_update_vjps_pass_the_dot_test(
        q in raw_quat(), w in vec3(3.0), dt in -1.0..1.0f64,
    ) {
        let x0 = [q.to_array().as_slice(), &w.to_array(), &[dt]].concat();
        for left in [true, false] {
            let r = dot_residual(
                |x, y| {
                    let (qd, wd) = (Quat::from_slice(x), Vec3::from_slice(&x[4..]));
                    let out = if left {
                        exp_update_left(qd, wd, x[7])
                    } else {
                        exp_update_right(qd, wd, x[7])
                    };
                    out.write_to(y);
                },
                &x0,
                |g, out| {
                    let g = Quat::from_slice(g);
                    let grad = if left {
                        exp_update_left_vjp(q, w, dt, g)
                    } else {
                        exp_update_right_vjp(q, w, dt, g)
                    };
                    grad.q.write_to(out);
                    grad.omega.write_to(&mut out[4..]);
                    out[7] = grad.dt;
                },
                4,
            );
            prop_assert!(r < 1e-13, "residual {}", r);
        }
    }
}
