//! Activations of the raw Gaussian parameters, with their VJPs.
//!
//! - opacity: `o = sigmoid(ô)` from a logit ([`sigmoid`], [`sigmoid_vjp`], inverse [`logit`]);
//! - scale: `s = exp(ŝ)` from a log-scale ([`exp3`], [`exp3_vjp`]);
//! - rotation: `q̄ = q/|q|` from a raw quaternion ([`normalize_quat`], [`normalize_quat_vjp`]);
//! - directions: `d̂ = d/|d|` ([`normalize_vec3`], [`normalize_vec3_vjp`]).
//!
//! Each `foo_vjp` takes the arguments of `foo` followed by the output cotangent.

use crate::{Quat, Real, Vec3};

/// Logistic sigmoid `1/(1 + e^(−x))`, evaluated without overflow for large `|x|`.
///
/// ```
/// use evogs_math::activation::{logit, sigmoid};
/// assert!((sigmoid(logit(0.1_f64)) - 0.1).abs() < 1e-15);
/// ```
#[inline]
#[must_use]
pub fn sigmoid<T: Real>(x: T) -> T {
    if x >= T::ZERO {
        T::ONE / (T::ONE + (-x).exp())
    } else {
        let e = x.exp();
        e / (T::ONE + e)
    }
}

/// VJP of [`sigmoid`]: `d_x = o(1 − o)·d_o`.
#[inline]
#[must_use]
pub fn sigmoid_vjp<T: Real>(x: T, d_o: T) -> T {
    let o = sigmoid(x);
    o * (T::ONE - o) * d_o
}

/// Inverse of [`sigmoid`]: `ln(p/(1 − p))`.
#[inline]
#[must_use]
pub fn logit<T: Real>(p: T) -> T {
    (p / (T::ONE - p)).ln()
}

/// Component-wise `exp` of a 3-vector (log-scale → scale).
#[inline]
#[must_use]
pub fn exp3<T: Real>(v: Vec3<T>) -> Vec3<T> {
    v.map(T::exp)
}

/// VJP of [`exp3`]: `d_v = exp(v) ⊙ d_out`.
#[inline]
#[must_use]
pub fn exp3_vjp<T: Real>(v: Vec3<T>, d_out: Vec3<T>) -> Vec3<T> {
    exp3(v).mul_elem(d_out)
}

/// `q/|q|`.
#[inline]
#[must_use]
pub fn normalize_quat<T: Real>(q: Quat<T>) -> Quat<T> {
    q.normalize()
}

/// VJP of [`normalize_quat`]: `d_q = (d_u − (d_u·u) u)/|q|` with `u = q/|q|`.
///
/// The result is orthogonal to `q`: scaling a quaternion does not change its rotation.
#[inline]
#[must_use]
pub fn normalize_quat_vjp<T: Real>(q: Quat<T>, d_u: Quat<T>) -> Quat<T> {
    let inv = T::ONE / q.norm();
    let u = q.scale(inv);
    (d_u - u.scale(d_u.dot(u))).scale(inv)
}

/// `v/|v|`.
#[inline]
#[must_use]
pub fn normalize_vec3<T: Real>(v: Vec3<T>) -> Vec3<T> {
    v * (T::ONE / v.norm())
}

/// VJP of [`normalize_vec3`]: `d_v = (I − û ûᵀ) d_u / |v|`.
#[inline]
#[must_use]
pub fn normalize_vec3_vjp<T: Real>(v: Vec3<T>, d_u: Vec3<T>) -> Vec3<T> {
    let inv = T::ONE / v.norm();
    let u = v * inv;
    (d_u - u * d_u.dot(u)) * inv
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diff::{GradCheck, central_gradient, vjp_dot_test};

    #[test]
    fn sigmoid_is_stable_at_extremes() {
        assert!(
            sigmoid(-800.0_f64) >= 0.0 && sigmoid(800.0_f64) <= 1.0,
            "no overflow"
        );
        assert!((sigmoid(0.0_f64) - 0.5).abs() < 1e-16, "sigmoid(0) = 1/2");
    }

    #[test]
    fn sigmoid_vjp_matches_fd() {
        for &x in &[-3.0, -0.2, 0.0, 1.5] {
            let mut v = [x];
            let mut n = [0.0];
            central_gradient(|a: &[f64]| sigmoid(a[0]) * 1.7, &mut v, &mut n);
            let a = [sigmoid_vjp(x, 1.7)];
            assert!(
                GradCheck::new(1e-10, 1e-8).check(&a, &n).passed(),
                "sigmoid at {x}"
            );
        }
    }

    #[test]
    fn exp3_vjp_matches_fd() {
        let v0 = [0.3, -1.2, 0.05];
        let g = Vec3::new(0.7, -0.2, 1.1);
        let a = exp3_vjp(Vec3::from_array(v0), g).to_array();
        let mut x = v0;
        let mut n = [0.0; 3];
        central_gradient(|v: &[f64]| exp3(Vec3::from_slice(v)).dot(g), &mut x, &mut n);
        assert!(GradCheck::new(1e-10, 1e-8).check(&a, &n).passed(), "exp3");
    }

    #[test]
    fn normalize_quat_vjp_matches_fd_and_is_tangential() {
        let q0 = [0.4, -1.3, 0.2, 0.9];
        let g = Quat::new(0.3, 0.1, -0.8, 0.5);
        let a = normalize_quat_vjp(Quat::from_array(q0), g);
        assert!(a.dot(Quat::from_array(q0)).abs() < 1e-15, "orthogonal to q");
        let mut x = q0;
        let mut n = [0.0; 4];
        central_gradient(
            |v: &[f64]| normalize_quat(Quat::from_slice(v)).dot(g),
            &mut x,
            &mut n,
        );
        assert!(
            GradCheck::new(1e-10, 1e-8)
                .check(&a.to_array(), &n)
                .passed(),
            "normalize_quat"
        );
    }

    #[test]
    fn normalize_vec3_vjp_matches_fd_and_dot_test() {
        let v0 = [0.4, -1.3, 0.2];
        let g = Vec3::new(0.3, 0.1, -0.8);
        let a = normalize_vec3_vjp(Vec3::from_array(v0), g).to_array();
        let mut x = v0;
        let mut n = [0.0; 3];
        central_gradient(
            |v: &[f64]| normalize_vec3(Vec3::from_slice(v)).dot(g),
            &mut x,
            &mut n,
        );
        assert!(
            GradCheck::new(1e-10, 1e-8).check(&a, &n).passed(),
            "normalize_vec3"
        );
        let v = Vec3::from_array(v0);
        let r = vjp_dot_test(
            |dv: &[f64], out: &mut [f64]| {
                crate::diff::dual_jvp(
                    |x: &[crate::Dual<f64>], y: &mut [crate::Dual<f64>]| {
                        normalize_vec3(Vec3::from_slice(x)).write_to(y);
                    },
                    &v0,
                    dv,
                    out,
                );
            },
            |w: &[f64], out: &mut [f64]| normalize_vec3_vjp(v, Vec3::from_slice(w)).write_to(out),
            3,
            3,
            7,
        );
        assert!(r < 1e-14, "dot test residual {r}");
    }
}
