//! Property tests of SE(3) on the public strategies (rotation angles log-uniform from 1e-12,
//! just below π, and beyond π where `Log` wraps): exp/log round trips through matrices, the
//! Jacobian identities, the adjoints, and every VJP of `se3` and `se3_jacobians` by the
//! dot-product test against forward-mode dual numbers.
//!
//! The VJPs take and return cotangents of transforms with respect to the left perturbation
//! `T ↦ Exp(δ)·T`, so each map is differentiated here in those coordinates: a transform
//! input `T` becomes `Exp(δ)·T` with δ among the dual inputs (at δ = 0), and a transform
//! output `Y` is read as `Log(Y·Y₀⁻¹)`.

use crate::common;

use common::{d3, dot_residual, dse3, mat4_diff};
use evogs_math::se3::{
    act_vjp, ad, ad_mul, ad_mul_vjp, adjoint_mul_vjp, compose_vjp, exp_vjp, inverse_vjp,
    left_cotangent_from_ambient, log_vjp,
};
use evogs_math::se3_jacobians::{
    jl_inv_mul, jl_inv_mul_vjp, jl_mul, jl_mul_vjp, left_jacobian, left_jacobian_inv,
    right_jacobian, right_jacobian_inv,
};
use evogs_math::strategies::{se3, se3_perturbation, se3_tangent, vec3, vec6};
use evogs_math::{Dual, Mat6, Quat, Se3, Vec3, Vec6};
use proptest::prelude::*;

const PI: f64 = core::f64::consts::PI;

/// Distance of two transforms: `|Log(a·b⁻¹)|`.
fn dist(a: Se3<f64>, b: Se3<f64>) -> f64 {
    (a * b.inverse()).log().norm()
}

/// `Exp(δ)·x` with δ the first six dual inputs.
fn perturbed(x: Se3<f64>, d: &[Dual<f64>]) -> Se3<Dual<f64>> {
    Se3::exp(Vec6::from_slice(d)) * dse3(x)
}

/// Writes `Log(y·y0⁻¹)`, the left tangent coordinates of a transform output.
fn write_left(y: Se3<Dual<f64>>, y0: Se3<f64>, out: &mut [Dual<f64>]) {
    (y * dse3(y0).inverse()).log().write_to(out);
}

/// Writes a pair of 6-vectors.
fn write2(a: Vec6<f64>, b: Vec6<f64>, out: &mut [f64]) {
    a.write_to(out);
    b.write_to(&mut out[6..]);
}

proptest! {
    #[test]
    fn exp_of_log_is_identity_on_transforms(x in se3(10.0)) {
        let back = Se3::exp(x.log());
        prop_assert!(mat4_diff(back.to_matrix(), x.to_matrix()) < 1e-13);
        prop_assert!(mat4_diff(Se3::from_matrix(&x.to_matrix()).to_matrix(), x.to_matrix()) < 1e-14);
    }

    #[test]
    fn log_of_exp_is_identity_below_pi(xi in se3_tangent(PI, 10.0)) {
        let l = Se3::exp(xi).log();
        prop_assert!((l - xi).norm() <= 1e-13 * xi.norm().max(1.0), "{:?} vs {:?}", l, xi);
        // Through the 4×4 matrix too.
        let lm = Se3::from_matrix(&Se3::exp(xi).to_matrix()).log();
        prop_assert!((lm - xi).norm() <= 1e-12 * xi.norm().max(1.0));
    }

    #[test]
    fn log_angle_is_in_zero_pi_beyond_pi(xi in se3_tangent(12.0, 5.0)) {
        let x = Se3::exp(xi);
        let l = x.log();
        prop_assert!(l.tail.norm() <= PI * (1.0 + 1e-15));
        prop_assert!(dist(Se3::exp(l), x) < 1e-12 * xi.norm().max(1.0));
    }

    #[test]
    fn left_jacobian_is_adjoint_times_right_jacobian(xi in se3_tangent(3.1, 5.0)) {
        let d = left_jacobian(xi) - Se3::exp(xi).adjoint() * right_jacobian(xi);
        prop_assert!(d.max_abs() < 1e-13 * xi.norm().max(1.0));
    }

    #[test]
    fn jacobians_times_inverses_are_identity(xi in se3_tangent(3.1, 5.0)) {
        let s = xi.norm().max(1.0).powi(2);
        let l = left_jacobian(xi) * left_jacobian_inv(xi) - Mat6::identity();
        let r = right_jacobian(xi) * right_jacobian_inv(xi) - Mat6::identity();
        prop_assert!(l.max_abs() < 1e-13 * s && r.max_abs() < 1e-13 * s);
        let v = Vec6::from_array([0.3, -0.2, 0.9, 1.1, -0.4, 0.25]);
        prop_assert!((jl_mul(xi, jl_inv_mul(xi, v)) - v).norm() < 1e-13 * s);
    }

    #[test]
    fn jacobians_are_the_first_order_terms_of_exp(
        xi in se3_tangent(3.0, 3.0), d in se3_perturbation(1e-6),
    ) {
        // Exp(ξ + δ) ≈ Exp(Jl(ξ) δ)·Exp(ξ) ≈ Exp(ξ)·Exp(Jr(ξ) δ), remainder O(|δ|²).
        let (e, e2) = (Se3::exp(xi), Se3::exp(xi + d));
        let s = xi.norm().max(1.0);
        let l = (e2 * e.inverse()).log() - left_jacobian(xi).mul_vec(d);
        let r = (e.inverse() * e2).log() - right_jacobian(xi).mul_vec(d);
        prop_assert!(l.norm() < 1e-11 * s && r.norm() < 1e-11 * s, "{} {}", l.norm(), r.norm());
        prop_assert!((right_jacobian(xi) - left_jacobian(-xi)).max_abs() == 0.0);
    }

    #[test]
    fn adjoint_is_a_homomorphism(a in se3(5.0), b in se3(5.0)) {
        let d = (a * b).adjoint() - a.adjoint() * b.adjoint();
        prop_assert!(d.max_abs() < 1e-13 * (1.0 + a.translation().norm() + b.translation().norm()));
    }

    #[test]
    fn adjoint_of_the_inverse_is_the_inverse(x in se3(5.0), v in vec6(2.0)) {
        let s = 1.0 + x.translation().norm();
        prop_assert!((x.inverse().adjoint() * x.adjoint() - Mat6::identity()).max_abs() < 1e-13 * s * s);
        prop_assert!((x.inverse().adjoint_mul(x.adjoint_mul(v)) - v).norm() < 1e-13 * s * s);
        prop_assert!((x.adjoint_tr_mul(v) - x.adjoint().tr_mul_vec(v)).norm() < 1e-13 * s);
    }

    #[test]
    fn ad_of_a_twist_annihilates_it(xi in se3_tangent(3.0, 2.0)) {
        // Exp(Ad(T) ξ) = T·Exp(ξ)·T⁻¹ is in lie_axioms.rs; here ad(ξ) ξ = 0, in both forms.
        prop_assert!(ad_mul(xi, xi).norm() < 1e-14 * xi.norm().max(1.0).powi(2));
        prop_assert!((ad(xi).mul_vec(xi) - ad_mul(xi, xi)).norm() < 1e-14 * xi.norm().max(1.0).powi(2));
    }

    #[test]
    fn action_is_the_matrix_product(a in se3(5.0), p in vec3(4.0)) {
        // Composition and inverses of the action are in lie_axioms.rs; here the matrix form.
        let s = 1.0 + p.norm() + a.translation().norm();
        let m = a.to_matrix();
        let mp = Vec3::new(
            m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
            m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
            m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3],
        );
        prop_assert!((mp - a.act(p)).norm() < 1e-13 * s);
    }

    #[test]
    fn exp_vjp_passes_the_dot_test(xi in se3_tangent(3.1, 3.0)) {
        let y0 = Se3::exp(xi);
        let r = dot_residual(
            |x, y| write_left(Se3::exp(Vec6::from_slice(x)), y0, y),
            &xi.to_array(),
            |g, out| exp_vjp(xi, Vec6::from_slice(g)).write_to(out),
            6,
        );
        prop_assert!(r < 1e-12, "residual {}", r);
    }

    #[test]
    fn log_vjp_passes_the_dot_test(x in se3(5.0)) {
        let r = dot_residual(
            |d, y| perturbed(x, d).log().write_to(y),
            &[0.0; 6],
            |g, out| log_vjp(x, Vec6::from_slice(g)).write_to(out),
            6,
        );
        prop_assert!(r < 1e-12, "residual {}", r);
    }

    #[test]
    fn compose_vjp_passes_the_dot_test(a in se3(5.0), b in se3(5.0)) {
        let y0 = a * b;
        let r = dot_residual(
            |d, y| write_left(perturbed(a, d) * perturbed(b, &d[6..]), y0, y),
            &[0.0; 12],
            |g, out| {
                let (da, db) = compose_vjp(a, b, Vec6::from_slice(g));
                write2(da, db, out);
            },
            6,
        );
        prop_assert!(r < 1e-12, "residual {}", r);
    }

    #[test]
    fn inverse_vjp_passes_the_dot_test(x in se3(5.0)) {
        let y0 = x.inverse();
        let r = dot_residual(
            |d, y| write_left(perturbed(x, d).inverse(), y0, y),
            &[0.0; 6],
            |g, out| inverse_vjp(x, Vec6::from_slice(g)).write_to(out),
            6,
        );
        prop_assert!(r < 1e-12, "residual {}", r);
    }

    #[test]
    fn act_vjp_passes_the_dot_test(x in se3(5.0), p in vec3(4.0)) {
        let x0 = [[0.0; 6].as_slice(), &p.to_array()].concat();
        let r = dot_residual(
            |d, y| perturbed(x, d).act(Vec3::from_slice(&d[6..])).write_to(y),
            &x0,
            |g, out| {
                let (dx, dp) = act_vjp(x, p, Vec3::from_slice(g));
                dx.write_to(out);
                dp.write_to(&mut out[6..]);
            },
            3,
        );
        prop_assert!(r < 1e-12, "residual {}", r);
    }

    #[test]
    fn adjoint_mul_vjp_passes_the_dot_test(x in se3(5.0), v in vec6(2.0)) {
        let x0 = [[0.0; 6], v.to_array()].concat();
        let r = dot_residual(
            |d, y| perturbed(x, d).adjoint_mul(Vec6::from_slice(&d[6..])).write_to(y),
            &x0,
            |g, out| {
                let (dx, dv) = adjoint_mul_vjp(x, v, Vec6::from_slice(g));
                write2(dx, dv, out);
            },
            6,
        );
        prop_assert!(r < 1e-12, "residual {}", r);
    }

    #[test]
    fn ad_mul_vjp_passes_the_dot_test(xi in vec6(3.0), v in vec6(3.0)) {
        let x0 = [xi.to_array(), v.to_array()].concat();
        let r = dot_residual(
            |x, y| ad_mul(Vec6::from_slice(x), Vec6::from_slice(&x[6..])).write_to(y),
            &x0,
            |g, out| {
                let (a, b) = ad_mul_vjp(xi, v, Vec6::from_slice(g));
                write2(a, b, out);
            },
            6,
        );
        prop_assert!(r < 1e-13, "residual {}", r);
    }

    #[test]
    fn jacobian_product_vjps_pass_the_dot_test(xi in se3_tangent(3.1, 3.0), v in vec6(2.0)) {
        let x0 = [xi.to_array(), v.to_array()].concat();
        type F = fn(Vec6<Dual<f64>>, Vec6<Dual<f64>>) -> Vec6<Dual<f64>>;
        type G = fn(Vec6<f64>, Vec6<f64>, Vec6<f64>) -> (Vec6<f64>, Vec6<f64>);
        let pairs: [(F, G); 2] = [(jl_mul, jl_mul_vjp), (jl_inv_mul, jl_inv_mul_vjp)];
        for (f, vjp) in pairs {
            let r = dot_residual(
                |x, y| f(Vec6::from_slice(x), Vec6::from_slice(&x[6..])).write_to(y),
                &x0,
                |g, out| {
                    let (a, b) = vjp(xi, v, Vec6::from_slice(g));
                    write2(a, b, out);
                },
                6,
            );
            prop_assert!(r < 1e-12, "residual {}", r);
        }
    }

    #[test]
    fn ambient_gradients_become_left_cotangents(
        x in se3(5.0), dq_ in vec3(1.0), dw in -1.0..1.0f64, dt in vec3(1.0),
    ) {
        // L = ⟨d_q, q⟩ + ⟨d_t, t⟩ on the stored numbers; its left cotangent by duals.
        let d_q = Quat::from_parts(dw, dq_);
        let grad = left_cotangent_from_ambient(x, d_q, dt);
        let r = dot_residual(
            |d, y| {
                let p = perturbed(x, d);
                let (qd, td) = (p.quat(), p.translation());
                let dqd = Quat::from_parts(Dual::constant(dw), d3(dq_));
                y[0] = qd.dot(dqd) + td.dot(d3(dt));
            },
            &[0.0; 6],
            |g, out| (grad * g[0]).write_to(out),
            1,
        );
        prop_assert!(r < 1e-13, "residual {}", r);
    }
}
