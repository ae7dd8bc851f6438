//! The 3D covariance of a Gaussian from its log-scale and raw quaternion, with its VJP.
//!
//! `Σ = R(q/|q|)·diag(exp(2ŝ))·R(q/|q|)ᵀ = M Mᵀ` with `M = R·diag(exp(ŝ))`
//! (`docs/splatting.md` §3). The gradient is taken with respect to the **stored** parameters:
//! the log-scale ŝ and the raw (unnormalised) quaternion q, so the quaternion gradient
//! includes the normalisation and is orthogonal to q.

use crate::activation::exp3;
use crate::quat::{rotation_from_raw, rotation_from_raw_vjp};
use crate::{Mat3, Quat, Real, Sym3, Vec3};

/// `Σ = R diag(exp(2ŝ)) Rᵀ` from a log-scale `ŝ` and a raw quaternion `q`.
///
/// ```
/// use evogs_math::{Quat, Vec3, covariance::covariance};
/// let s = covariance(Vec3::new(0.0_f64, 0.0, 0.0), Quat::new(2.0, 0.0, 0.0, 0.0));
/// assert!((s.xx - 1.0).abs() < 1e-15 && s.xy.abs() < 1e-15); // unit sphere
/// ```
#[must_use]
pub fn covariance<T: Real>(log_scale: Vec3<T>, q: Quat<T>) -> Sym3<T> {
    let r = rotation_from_raw(q);
    let s = exp3(log_scale);
    let m = r.mul_mat(Mat3::diag(s));
    let c = m.mul_mat(m.transpose());
    Sym3::new(
        c.m[0][0], c.m[0][1], c.m[0][2], c.m[1][1], c.m[1][2], c.m[2][2],
    )
}

/// VJP of [`covariance`]: given `d_sigma`, the adjoint of the six **stored** entries of Σ
/// (see [`Sym3`]), returns `(∂L/∂ŝ, ∂L/∂q)`.
///
/// With `G` the symmetric full-matrix adjoint: `dM = (G + Gᵀ) M = 2 G M`,
/// `dR = dM·diag(s)`, `ds_j = (Rᵀ dM)_jj`, `dŝ_j = s_j ds_j`, and `dR → dq` through
/// [`rotation_from_raw_vjp`].
///
/// ```
/// use evogs_math::{Quat, Sym3, Vec3, covariance::{covariance, covariance_vjp}};
/// use evogs_math::diff::{central_gradient, GradCheck};
/// let (s, q) = (Vec3::new(-0.5, 0.2, 0.1), Quat::new(0.8, 0.3, -0.4, 0.1));
/// let g = Sym3::new(0.3, -0.2, 0.5, 1.1, 0.4, -0.7);
/// let (ds, _dq) = covariance_vjp(s, q, g);
/// let mut x = s.to_array();
/// let mut num = [0.0; 3];
/// let dot = |a: Sym3<f64>| a.to_array().iter().zip(g.to_array()).map(|(u, v)| u * v).sum::<f64>();
/// central_gradient(|v: &[f64]| dot(covariance(Vec3::from_slice(v), q)), &mut x, &mut num);
/// assert!(GradCheck::new(1e-9, 1e-7).check(&ds.to_array(), &num).passed());
/// ```
#[must_use]
pub fn covariance_vjp<T: Real>(
    log_scale: Vec3<T>,
    q: Quat<T>,
    d_sigma: Sym3<T>,
) -> (Vec3<T>, Quat<T>) {
    let r = rotation_from_raw(q);
    let s = exp3(log_scale);
    let m = r.mul_mat(Mat3::diag(s));
    let g = d_sigma.to_full_adjoint();
    let dm = g.mul_mat(m).scale(T::TWO);
    let dr = dm.mul_mat(Mat3::diag(s));
    let rt_dm = r.transpose().mul_mat(dm);
    let d_log = Vec3::new(
        rt_dm.m[0][0] * s.x,
        rt_dm.m[1][1] * s.y,
        rt_dm.m[2][2] * s.z,
    );
    (d_log, rotation_from_raw_vjp(q, dr))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Dual;
    use crate::diff::{GradCheck, central_gradient, dual_jvp, vjp_dot_test};

    fn pack(s: Vec3<f64>, q: Quat<f64>) -> [f64; 7] {
        [s.x, s.y, s.z, q.w, q.x, q.y, q.z]
    }

    #[test]
    fn vjp_matches_fd_and_forward_mode() {
        let g = Sym3::new(0.3, -0.2, 0.5, 1.1, 0.4, -0.7);
        let dot = |a: Sym3<f64>| {
            a.to_array()
                .iter()
                .zip(g.to_array())
                .map(|(u, v)| u * v)
                .sum::<f64>()
        };
        for (s, q) in [
            (Vec3::new(-0.5, 0.2, 0.1), Quat::new(0.8, 0.3, -0.4, 0.1)),
            (Vec3::new(-4.0, -4.5, -3.9), Quat::new(2.0, -0.1, 0.0, 1.5)),
            (Vec3::new(0.0, 0.0, 0.0), Quat::new(0.5, 0.0, 0.0, 0.0)),
        ] {
            let (ds, dq) = covariance_vjp(s, q, g);
            let a = pack(ds, dq);
            let mut x = pack(s, q);
            let mut num = [0.0; 7];
            central_gradient(
                |v: &[f64]| dot(covariance(Vec3::from_slice(v), Quat::from_slice(&v[3..]))),
                &mut x,
                &mut num,
            );
            GradCheck::new(1e-10, 1e-7)
                .check(&a, &num)
                .assert_passed("covariance VJP");
            assert!(dq.dot(q).abs() < 1e-13, "quaternion gradient ⟂ q");
            let x0 = pack(s, q);
            let r = vjp_dot_test(
                |v: &[f64], out: &mut [f64]| {
                    dual_jvp(
                        |x: &[Dual<f64>], y: &mut [Dual<f64>]| {
                            y.copy_from_slice(
                                &covariance(Vec3::from_slice(x), Quat::from_slice(&x[3..]))
                                    .to_array(),
                            );
                        },
                        &x0,
                        v,
                        out,
                    );
                },
                |w: &[f64], out: &mut [f64]| {
                    let (ds, dq) = covariance_vjp(
                        s,
                        q,
                        Sym3::from_array([w[0], w[1], w[2], w[3], w[4], w[5]]),
                    );
                    out.copy_from_slice(&pack(ds, dq));
                },
                7,
                6,
                9,
            );
            assert!(r < 1e-13, "dot test residual {r}");
        }
    }
}
