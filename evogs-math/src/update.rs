//! Exponential-map rotation updates and their VJPs.
//!
//! - [`exp_update_left`]: `q' = Exp(ω·dt) ⊗ q`, for a **world-frame** (spatial) angular
//!   velocity ω (`R' = ŵ R`); this is what the ODE steppers use for SO(3) blocks.
//! - [`exp_update_right`]: `q' = q ⊗ Exp(ω·dt)`, for a **body-frame** angular velocity
//!   (`R' = R ŵ`).
//!
//! Getting the side wrong is invisible to unit-norm checks; the tests compare both against
//! independent references. Both updates are exact for ω constant over the step, and keep
//! `|q| = 1` up to rounding (a product of unit quaternions).
//!
//! The VJPs take the output cotangent `g` as an ambient 4-vector and return the gradients
//! with respect to the (ambient) input quaternion, ω and dt.

use crate::so3::exp_quat;
use crate::so3_jacobians::exp_quat_vjp;
use crate::{Quat, Real, Vec3};

/// Gradients of an exp-map update with respect to its inputs.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExpUpdateGrad<T> {
    /// `∂L/∂q` (ambient, 4 components).
    pub q: Quat<T>,
    /// `∂L/∂ω`.
    pub omega: Vec3<T>,
    /// `∂L/∂dt`.
    pub dt: T,
}

/// `Exp(ω·dt) ⊗ q`: rotate by a world-frame angular velocity ω for a time dt.
///
/// ```
/// use evogs_math::{Quat, Vec3, update::exp_update_left};
/// let q = Quat::new(0.9_f64, 0.1, -0.3, 0.2).normalize();
/// let q1 = exp_update_left(q, Vec3::new(0.5, -1.0, 2.0), 0.1);
/// assert!((q1.norm() - 1.0).abs() < 1e-15);
/// ```
#[inline]
#[must_use]
pub fn exp_update_left<T: Real>(q: Quat<T>, omega: Vec3<T>, dt: T) -> Quat<T> {
    exp_quat(omega * dt).mul_quat(q)
}

/// `q ⊗ Exp(ω·dt)`: rotate by a body-frame angular velocity ω for a time dt.
#[inline]
#[must_use]
pub fn exp_update_right<T: Real>(q: Quat<T>, omega: Vec3<T>, dt: T) -> Quat<T> {
    q.mul_quat(exp_quat(omega * dt))
}

/// Chains the cotangent of `e = Exp(ω·dt)` to ω and dt.
#[inline]
fn through_exp<T: Real>(omega: Vec3<T>, dt: T, d_e: Quat<T>, d_q: Quat<T>) -> ExpUpdateGrad<T> {
    let d_phi = exp_quat_vjp(omega * dt, d_e);
    ExpUpdateGrad {
        q: d_q,
        omega: d_phi * dt,
        dt: d_phi.dot(omega),
    }
}

/// VJP of [`exp_update_left`]: with `e = Exp(ω dt)`, `∂L/∂q = e* ⊗ g`, `∂L/∂e = g ⊗ q*`,
/// then through [`exp_quat_vjp`] to `φ = ω dt`.
///
/// ```
/// use evogs_math::{Quat, Vec3, update::{exp_update_left, exp_update_left_vjp}};
/// use evogs_math::diff::{central_gradient, GradCheck};
/// let (q, w, dt) = (Quat::new(0.9, 0.1, -0.3, 0.2), Vec3::new(0.5, -1.0, 2.0), 0.3);
/// let g = Quat::new(0.2, -0.7, 0.4, 1.0);
/// let grad = exp_update_left_vjp(q, w, dt, g);
/// let mut x = [dt];
/// let mut num = [0.0];
/// central_gradient(|v: &[f64]| exp_update_left(q, w, v[0]).dot(g), &mut x, &mut num);
/// assert!(GradCheck::new(1e-10, 1e-8).check(&[grad.dt], &num).passed());
/// ```
#[must_use]
pub fn exp_update_left_vjp<T: Real>(
    q: Quat<T>,
    omega: Vec3<T>,
    dt: T,
    g: Quat<T>,
) -> ExpUpdateGrad<T> {
    let e = exp_quat(omega * dt);
    through_exp(omega, dt, g.mul_quat(q.conj()), e.conj().mul_quat(g))
}

/// VJP of [`exp_update_right`]: `∂L/∂q = g ⊗ e*`, `∂L/∂e = q* ⊗ g`.
#[must_use]
pub fn exp_update_right_vjp<T: Real>(
    q: Quat<T>,
    omega: Vec3<T>,
    dt: T,
    g: Quat<T>,
) -> ExpUpdateGrad<T> {
    let e = exp_quat(omega * dt);
    through_exp(omega, dt, q.conj().mul_quat(g), g.mul_quat(e.conj()))
}

/// Converts the ambient gradient `g = ∂L/∂q` of a **unit** quaternion into the cotangent of
/// a world-frame (left) perturbation `q ↦ Exp(δ) ⊗ q`: `∂L/∂δ = ½·vec(g ⊗ q*)`.
///
/// The radial part of `g` (along q) has no effect. This is how a renderer's quaternion
/// gradient enters an ODE adjoint whose SO(3) cotangents are left perturbations.
#[inline]
#[must_use]
pub fn left_cotangent_from_ambient<T: Real>(q: Quat<T>, g: Quat<T>) -> Vec3<T> {
    g.mul_quat(q.conj()).vec() * T::HALF
}

/// The inverse direction of [`left_cotangent_from_ambient`]: the ambient gradient, tangent
/// to the unit sphere at `q`, that a left cotangent λ represents: `2·(0, λ) ⊗ q`.
#[inline]
#[must_use]
pub fn ambient_from_left_cotangent<T: Real>(q: Quat<T>, lambda: Vec3<T>) -> Quat<T> {
    Quat::pure(lambda * T::TWO).mul_quat(q)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diff::{GradCheck, central_gradient, dual_jvp, vjp_dot_test};
    use crate::{Dual, So3};

    type Update<T> = fn(Quat<T>, Vec3<T>, T) -> Quat<T>;
    type UpdateVjp = fn(Quat<f64>, Vec3<f64>, f64, Quat<f64>) -> ExpUpdateGrad<f64>;

    fn flat(gr: ExpUpdateGrad<f64>) -> [f64; 8] {
        let q = gr.q.to_array();
        [
            q[0], q[1], q[2], q[3], gr.omega.x, gr.omega.y, gr.omega.z, gr.dt,
        ]
    }

    fn check(f: Update<f64>, fd: Update<Dual<f64>>, vjp: UpdateVjp) {
        let g = Quat::new(0.2, -0.7, 0.4, 1.0);
        for (q, w, dt) in [
            (
                Quat::new(0.9, 0.1, -0.3, 0.2),
                Vec3::new(0.5, -1.0, 2.0),
                0.3,
            ),
            (Quat::new(1.0, 0.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.0), 0.1),
            (
                Quat::new(-0.2, 0.5, 0.7, -0.1),
                Vec3::new(1e-8, 3e-8, 0.0),
                -0.5,
            ),
            (Quat::new(0.3, 0.3, 0.3, 0.3), Vec3::new(3.0, 4.0, 0.0), 0.6),
        ] {
            let a = flat(vjp(q, w, dt, g));
            let x0 = [q.w, q.x, q.y, q.z, w.x, w.y, w.z, dt];
            let eval = |v: &[f64]| f(Quat::from_slice(v), Vec3::from_slice(&v[4..]), v[7]).dot(g);
            let mut x = x0;
            let mut num = [0.0; 8];
            central_gradient(eval, &mut x, &mut num);
            GradCheck::new(1e-9, 1e-7)
                .check(&a, &num)
                .assert_passed("exp update VJP vs central differences");
            let r = vjp_dot_test(
                |v: &[f64], out: &mut [f64]| {
                    dual_jvp(
                        |x: &[Dual<f64>], y: &mut [Dual<f64>]| {
                            fd(Quat::from_slice(x), Vec3::from_slice(&x[4..]), x[7]).write_to(y);
                        },
                        &x0,
                        v,
                        out,
                    );
                },
                |gg: &[f64], out: &mut [f64]| {
                    out.copy_from_slice(&flat(vjp(q, w, dt, Quat::from_slice(gg))));
                },
                8,
                4,
                5,
            );
            assert!(r < 1e-13, "dot test residual {r}");
        }
    }

    #[test]
    fn left_update_vjp() {
        check(exp_update_left, exp_update_left, exp_update_left_vjp);
    }

    #[test]
    fn right_update_vjp() {
        check(exp_update_right, exp_update_right, exp_update_right_vjp);
    }

    #[test]
    fn cotangent_conversions_are_consistent() {
        let q = Quat::new(0.3, -0.5, 0.7, 0.2).normalize();
        let g = Quat::new(0.4, 1.0, -0.3, 0.8);
        let lambda = left_cotangent_from_ambient(q, g);
        // Directional derivative along Exp(δ)q equals λ·δ.
        let d = Vec3::new(0.2, -0.4, 0.9);
        let h = 1e-6;
        let fd = (exp_update_left(q, d, h).dot(g) - exp_update_left(q, d, -h).dot(g)) / (2.0 * h);
        assert!(
            (fd - lambda.dot(d)).abs() < 1e-9,
            "left cotangent: fd {fd} vs {}",
            lambda.dot(d)
        );
        // Round trip through the tangential ambient gradient.
        let back = left_cotangent_from_ambient(q, ambient_from_left_cotangent(q, lambda));
        assert!((back - lambda).norm() < 1e-15, "round trip");
        assert!(
            ambient_from_left_cotangent(q, lambda).dot(q).abs() < 1e-15,
            "tangent to the sphere"
        );
    }

    #[test]
    fn sides_match_spatial_and_body_rates() {
        // World-frame rate: R' = ŵ R  →  R(dt) = Exp(ω dt) R.
        let r0 = So3::exp(Vec3::new(0.3, -0.4, 0.8));
        let w = Vec3::new(0.0, 0.0, 1.0);
        let left = So3::from_unit_quat(exp_update_left(r0.quat(), w, 0.5));
        let v = Vec3::new(1.0, 0.0, 0.0);
        let want = So3::exp(w * 0.5).act(r0.act(v));
        assert!(
            (left.act(v) - want).norm() < 1e-15,
            "left update rotates in the world frame"
        );
        let right = So3::from_unit_quat(exp_update_right(r0.quat(), w, 0.5));
        let want = r0.act(So3::exp(w * 0.5).act(v));
        assert!(
            (right.act(v) - want).norm() < 1e-15,
            "right update rotates in the body frame"
        );
    }
}
