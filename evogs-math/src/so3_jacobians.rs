//! The Jacobians of the SO(3) exponential, their inverses, and the VJPs built on them.
//!
//! Definitions (micro-Lie-theory conventions; `K = hat(φ)`, θ = |φ|):
//!
//! ```text
//! Exp(φ + δ) ≈ Exp(φ)·Exp(Jr(φ) δ) ≈ Exp(Jl(φ) δ)·Exp(φ)
//! Jl = I + A K + B K²       Jr = I − A K + B K² = Jlᵀ = Jl(−φ)
//! Jl⁻¹ = I − K/2 + D K²     Jr⁻¹ = I + K/2 + D K²
//! A = (1 − cos θ)/θ²,  B = (θ − sin θ)/θ³,  D = 1/θ² − cot(θ/2)/(2θ)
//! ```
//!
//! `Jl(φ) = Exp(φ)·Jr(φ)`. [`jl_mul`] applies `Jl` without forming it (the translation of
//! the SE(3) exponential is `Jl(φ)·ρ`). `Jl⁻¹` is the closed-form `dexp⁻¹` of left-trivialised
//! Lie-group integrators (RKMK): with `R(t) = Exp(Ω(t))·Rₙ` and a world-frame rate ω,
//! `Ω' = Jl⁻¹(Ω)·ω` ([`jl_inv_mul`], with its VJP [`jl_inv_mul_vjp`]).

use crate::so3::{exp_quat, hat};
use crate::so3_coeffs::{jinv_coeff, one_minus_cos_over_sq, theta_minus_sin_over_cube};
use crate::{Dual, Mat3, Quat, Real, Vec3};

/// `I + a K + b K²` for `K = hat(φ)`.
#[inline]
fn poly_k<T: Real>(phi: Vec3<T>, a: T, b: T) -> Mat3<T> {
    let k = hat(phi);
    Mat3::identity() + k.scale(a) + k.mul_mat(k).scale(b)
}

/// The left Jacobian `Jl(φ) = I + A K + B K²`.
#[must_use]
pub fn left_jacobian<T: Real>(phi: Vec3<T>) -> Mat3<T> {
    let t2 = phi.norm_squared();
    poly_k(
        phi,
        one_minus_cos_over_sq(t2),
        theta_minus_sin_over_cube(t2),
    )
}

/// The right Jacobian `Jr(φ) = I − A K + B K² = Jl(−φ)`.
#[must_use]
pub fn right_jacobian<T: Real>(phi: Vec3<T>) -> Mat3<T> {
    left_jacobian(-phi)
}

/// The inverse left Jacobian `Jl⁻¹(φ) = I − K/2 + D K²` (finite for θ < 2π).
#[must_use]
pub fn left_jacobian_inv<T: Real>(phi: Vec3<T>) -> Mat3<T> {
    poly_k(phi, -T::HALF, jinv_coeff(phi.norm_squared()))
}

/// The inverse right Jacobian `Jr⁻¹(φ) = I + K/2 + D K² = Jl⁻¹(−φ)`.
#[must_use]
pub fn right_jacobian_inv<T: Real>(phi: Vec3<T>) -> Mat3<T> {
    left_jacobian_inv(-phi)
}

/// `Jl(φ)·v = v + A φ×v + B φ×(φ×v)`, without forming the matrix (`Jl(φ)ᵀ·v` is
/// `jl_mul(−φ, v)`).
///
/// This is also the translation of the SE(3) exponential, `t = Jl(φ)·ρ`
/// ([`Se3::exp`](crate::Se3::exp)).
#[inline]
#[must_use]
pub fn jl_mul<T: Real>(phi: Vec3<T>, v: Vec3<T>) -> Vec3<T> {
    let t2 = phi.norm_squared();
    let c = phi.cross(v);
    v + c * one_minus_cos_over_sq(t2) + phi.cross(c) * theta_minus_sin_over_cube(t2)
}

/// VJP of [`jl_mul`]: given the cotangent `g` of the output, returns `(∂L/∂φ, ∂L/∂v)`.
///
/// `∂L/∂v = Jl(φ)ᵀ·g`. For φ, with `u = φ×(φ×v)`:
/// `A·v×g + B·[(φ·v) g + (g·φ) v − 2(g·v) φ] + 2 [A'·g·(φ×v) + B'·g·u] φ`, where
/// `A' = dA/d(θ²)` and `B' = dB/d(θ²)` come from dual-number evaluations of the coefficient
/// functions (exact to rounding in both of their branches), as in [`jl_inv_mul_vjp`].
///
/// ```
/// use evogs_math::{Vec3, so3_jacobians::{jl_mul, jl_mul_vjp}};
/// use evogs_math::diff::{central_gradient, GradCheck};
/// let (phi, v, g) = (Vec3::new(0.4, -0.9, 0.3), Vec3::new(1.0, 0.2, -0.5), Vec3::new(0.3, 0.7, -1.1));
/// let (d_phi, _) = jl_mul_vjp(phi, v, g);
/// let mut x = phi.to_array();
/// let mut num = [0.0; 3];
/// central_gradient(|p: &[f64]| jl_mul(Vec3::from_slice(p), v).dot(g), &mut x, &mut num);
/// assert!(GradCheck::new(1e-10, 1e-8).check(&d_phi.to_array(), &num).passed());
/// ```
#[must_use]
pub fn jl_mul_vjp<T: Real>(phi: Vec3<T>, v: Vec3<T>, g: Vec3<T>) -> (Vec3<T>, Vec3<T>) {
    let t2 = Dual::variable(phi.norm_squared());
    let (a, b) = (one_minus_cos_over_sq(t2), theta_minus_sin_over_cube(t2));
    let c = phi.cross(v);
    let u = phi.cross(c);
    let d_phi = v.cross(g) * a.re
        + (g * phi.dot(v) + v * g.dot(phi) - phi * (T::TWO * g.dot(v))) * b.re
        + phi * (T::TWO * (a.eps * g.dot(c) + b.eps * g.dot(u)));
    (d_phi, jl_mul(-phi, g))
}

/// `Jl⁻¹(Ω)·ω = ω − ½ Ω×ω + D(θ) Ω×(Ω×ω)`, without forming the matrix.
#[inline]
#[must_use]
pub fn jl_inv_mul<T: Real>(big_omega: Vec3<T>, omega: Vec3<T>) -> Vec3<T> {
    let d = jinv_coeff(big_omega.norm_squared());
    let c = big_omega.cross(omega);
    omega - c * T::HALF + big_omega.cross(c) * d
}

/// VJP of [`jl_inv_mul`]: given the cotangent `g` of the output, returns
/// `(∂L/∂Ω, ∂L/∂ω)`.
///
/// `∂L/∂ω = Jr⁻¹(Ω)·g` (the transpose of `Jl⁻¹`). For Ω, with `u = Ω×(Ω×ω)
/// = Ω(Ω·ω) − ω|Ω|²`: `−½ ω×g + D·[(Ω·ω) g + (g·Ω) ω − 2(g·ω) Ω] + 2 D'(θ²)(g·u) Ω`,
/// where `D' = dD/d(θ²)` comes from a dual-number evaluation of the same coefficient
/// function (exact to rounding in both of its branches).
///
/// ```
/// use evogs_math::{Vec3, so3_jacobians::{jl_inv_mul, jl_inv_mul_vjp}};
/// use evogs_math::diff::{central_gradient, GradCheck};
/// let (big, w, g) = (Vec3::new(0.4, -0.9, 0.3), Vec3::new(1.0, 0.2, -0.5), Vec3::new(0.3, 0.7, -1.1));
/// let (d_big, _) = jl_inv_mul_vjp(big, w, g);
/// let mut x = big.to_array();
/// let mut num = [0.0; 3];
/// central_gradient(|v: &[f64]| jl_inv_mul(Vec3::from_slice(v), w).dot(g), &mut x, &mut num);
/// assert!(GradCheck::new(1e-10, 1e-8).check(&d_big.to_array(), &num).passed());
/// ```
#[must_use]
pub fn jl_inv_mul_vjp<T: Real>(
    big_omega: Vec3<T>,
    omega: Vec3<T>,
    g: Vec3<T>,
) -> (Vec3<T>, Vec3<T>) {
    let t2 = big_omega.norm_squared();
    let dd = jinv_coeff(Dual::variable(t2));
    let (d, d_prime) = (dd.re, dd.eps);
    let c = big_omega.cross(omega);
    let u = big_omega.cross(c);
    let om_dot_w = big_omega.dot(omega);
    let d_big = omega.cross(g) * (-T::HALF)
        + (g * om_dot_w + omega * g.dot(big_omega) - big_omega * (T::TWO * g.dot(omega))) * d
        + big_omega * (T::TWO * d_prime * g.dot(u));
    let d_omega = g + big_omega.cross(g) * T::HALF + big_omega.cross(big_omega.cross(g)) * d;
    (d_big, d_omega)
}

/// VJP of [`exp_quat`]: given the cotangent `g` of the quaternion `Exp(φ)` (4 ambient
/// components), returns `∂L/∂φ = ½·Jr(φ)ᵀ·vec(Exp(φ)* ⊗ g)`.
///
/// Exact because `Exp(φ + δ) = Exp(φ) ⊗ (1, Jr(φ)δ/2) + O(δ²)` as quaternions.
#[must_use]
pub fn exp_quat_vjp<T: Real>(phi: Vec3<T>, g: Quat<T>) -> Vec3<T> {
    let q = exp_quat(phi);
    let local = q.conj().mul_quat(g).vec() * T::HALF;
    right_jacobian(phi).tr_mul_vec(local)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diff::{GradCheck, central_gradient, dual_jvp, vjp_dot_test};
    use crate::so3::{exp_matrix, log_matrix};

    fn samples() -> [Vec3<f64>; 6] {
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1e-7, -2e-7, 5e-8),
            Vec3::new(0.02, 0.05, -0.01),
            Vec3::new(0.4, -0.9, 0.3),
            Vec3::new(-1.5, 2.0, 0.7),
            Vec3::new(0.0, 3.1, 0.0),
        ]
    }

    #[test]
    fn jacobians_relate_and_invert() {
        for phi in samples() {
            let jl = left_jacobian(phi);
            let jr = right_jacobian(phi);
            assert!(
                (jl - exp_matrix(phi) * jr).max_abs() < 1e-15,
                "Jl = Exp Jr at {phi:?}"
            );
            assert!(
                (jl * left_jacobian_inv(phi) - Mat3::identity()).max_abs() < 1e-14,
                "Jl Jl⁻¹ = I"
            );
            assert!(
                (jr * right_jacobian_inv(phi) - Mat3::identity()).max_abs() < 1e-14,
                "Jr Jr⁻¹ = I"
            );
        }
    }

    #[test]
    fn left_jacobian_is_the_derivative_of_exp() {
        // Log(Exp(φ + h e_j) Exp(φ)ᵀ)/h → Jl e_j (central difference).
        for phi in samples() {
            let jl = left_jacobian(phi);
            for j in 0..3 {
                let h = 1e-6;
                let e = Vec3::<f64>::unit(j) * h;
                let p = log_matrix(exp_matrix(phi + e) * exp_matrix(phi).transpose());
                let m = log_matrix(exp_matrix(phi - e) * exp_matrix(phi).transpose());
                let col = (p - m) * (0.5 / h);
                assert!(
                    (col - jl.col(j)).norm() < 1e-9,
                    "column {j} of Jl at {phi:?}"
                );
            }
        }
    }

    #[test]
    fn jl_inv_mul_vjp_matches_fd_dual_and_dot_test() {
        let w = Vec3::new(1.0, 0.2, -0.5);
        let g = Vec3::new(0.3, 0.7, -1.1);
        for big in samples() {
            let (d_big, d_w) = jl_inv_mul_vjp(big, w, g);
            let mut x = big.to_array();
            let mut num = [0.0; 3];
            central_gradient(
                |v: &[f64]| jl_inv_mul(Vec3::from_slice(v), w).dot(g),
                &mut x,
                &mut num,
            );
            GradCheck::new(1e-9, 1e-7)
                .check(&d_big.to_array(), &num)
                .assert_passed("d Ω");
            let mut x = w.to_array();
            central_gradient(
                |v: &[f64]| jl_inv_mul(big, Vec3::from_slice(v)).dot(g),
                &mut x,
                &mut num,
            );
            GradCheck::new(1e-9, 1e-7)
                .check(&d_w.to_array(), &num)
                .assert_passed("d ω");
            // Forward mode with duals, through the dot-product test (exact).
            let x0 = [big.x, big.y, big.z, w.x, w.y, w.z];
            let r = vjp_dot_test(
                |v: &[f64], out: &mut [f64]| {
                    dual_jvp(
                        |x: &[crate::Dual<f64>], y: &mut [crate::Dual<f64>]| {
                            jl_inv_mul(Vec3::from_slice(x), Vec3::from_slice(&x[3..])).write_to(y);
                        },
                        &x0,
                        v,
                        out,
                    );
                },
                |gg: &[f64], out: &mut [f64]| {
                    let (a, b) = jl_inv_mul_vjp(big, w, Vec3::from_slice(gg));
                    a.write_to(out);
                    b.write_to(&mut out[3..]);
                },
                6,
                3,
                11,
            );
            assert!(r < 1e-13, "dot test residual {r} at {big:?}");
        }
    }

    #[test]
    fn jl_mul_matches_the_matrix_and_its_vjp_the_fd_and_dual_numbers() {
        let v = Vec3::new(1.0, 0.2, -0.5);
        let g = Vec3::new(0.3, 0.7, -1.1);
        for phi in samples() {
            let d = jl_mul(phi, v) - left_jacobian(phi).mul_vec(v);
            assert!(d.norm() < 1e-15, "Jl v at {phi:?}");
            let (d_phi, d_v) = jl_mul_vjp(phi, v, g);
            let mut x = phi.to_array();
            let mut num = [0.0; 3];
            central_gradient(
                |p: &[f64]| jl_mul(Vec3::from_slice(p), v).dot(g),
                &mut x,
                &mut num,
            );
            GradCheck::new(1e-9, 1e-7)
                .check(&d_phi.to_array(), &num)
                .assert_passed("jl_mul d φ");
            let want_v = left_jacobian(phi).tr_mul_vec(g);
            assert!((d_v - want_v).norm() < 1e-15, "d v = Jlᵀ g");
            let x0 = [phi.x, phi.y, phi.z, v.x, v.y, v.z];
            let r = vjp_dot_test(
                |dir: &[f64], out: &mut [f64]| {
                    dual_jvp(
                        |x: &[crate::Dual<f64>], y: &mut [crate::Dual<f64>]| {
                            jl_mul(Vec3::from_slice(x), Vec3::from_slice(&x[3..])).write_to(y);
                        },
                        &x0,
                        dir,
                        out,
                    );
                },
                |gg: &[f64], out: &mut [f64]| {
                    let (a, b) = jl_mul_vjp(phi, v, Vec3::from_slice(gg));
                    a.write_to(out);
                    b.write_to(&mut out[3..]);
                },
                6,
                3,
                13,
            );
            assert!(r < 1e-13, "dot test residual {r} at {phi:?}");
        }
    }

    #[test]
    fn exp_quat_vjp_matches_fd() {
        let g = Quat::new(0.3, -0.2, 0.9, 0.4);
        for phi in samples() {
            let a = exp_quat_vjp(phi, g).to_array();
            let mut x = phi.to_array();
            let mut num = [0.0; 3];
            central_gradient(
                |v: &[f64]| exp_quat(Vec3::from_slice(v)).dot(g),
                &mut x,
                &mut num,
            );
            GradCheck::new(1e-9, 1e-7)
                .check(&a, &num)
                .assert_passed("exp_quat_vjp");
        }
    }
}
