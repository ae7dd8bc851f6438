//! The VJP of the EWA projection, [`project_vjp`] (`docs/splatting.md` §13).
//!
//! With `dX := ∂L/∂X` and full-matrix (symmetric) adjoints of the 2×2 and 3×3 matrices:
//!
//! ```text
//! conic → B:        dB = −C Ĝ C,   Ĝ = [[g_a, g_b/2], [g_b/2, g_c]],  C = B⁻¹
//! compensation:     dA += dρ/(2ρ)·[(1 − ρ²) C − ε det(C) I]           (ρ > 0; else 0)
//! A = J Σ_c Jᵀ:     dΣ_c = Jᵀ dA J,   dJ = 2 dA J Σ_c
//! J → t:            dt_z −= fx/t_z² dJ₀₀ + fy/t_z² dJ₁₁
//!                   x row, unclamped: dt_x −= fx/t_z² dJ₀₂,  dt_z += 2 fx x̃/t_z³ dJ₀₂
//!                   x row, clamped:                          dt_z +=   fx x̃/t_z³ dJ₀₂
//! means2d:          dt_x += fx/t_z du,  dt_y += fy/t_z dv,  dt_z −= (fx t_x du + fy t_y dv)/t_z²
//! depth:            dt_z += d_depth
//! world → camera:   dμ = Rᵀ dt,  dΣ = Rᵀ dΣ_c R,  dR = dt μᵀ + 2 dΣ_c R Σ,  dt_v = dt
//! Σ → (ŝ, q):       evogs_math::covariance::covariance_vjp (stored-entry adjoint of Σ)
//! ```

use crate::camera::{CameraGrad, PinholeCamera};
use crate::project::{ProjectOptions, project_full};
use evogs_math::covariance::covariance_vjp;
use evogs_math::{Mat3, Quat, Real, Sym2, Sym3, Vec2, Vec3};

/// Cotangent of the differentiable outputs of [`project`](crate::project::project).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProjectedGrad<T> {
    /// `∂L/∂means2d`.
    pub means2d: Vec2<T>,
    /// `∂L/∂depth`.
    pub depth: T,
    /// `∂L/∂[a, b, c]` of the conic (b counted once).
    pub conic: [T; 3],
    /// `∂L/∂compensation`.
    pub compensation: T,
}

/// Gradient of a loss with respect to the inputs of [`project`](crate::project::project).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProjectInputGrad<T> {
    /// `∂L/∂μ` (world mean).
    pub mean: Vec3<T>,
    /// `∂L/∂ŝ` (log-scale).
    pub log_scale: Vec3<T>,
    /// `∂L/∂q` (raw quaternion; orthogonal to q).
    pub quat: Quat<T>,
    /// `∂L/∂(R, t)` of the camera's view matrix.
    pub camera: CameraGrad<T>,
}

/// `C G C` for symmetric 2×2 `C` and `G`.
fn sandwich<T: Real>(c: Sym2<T>, g: Sym2<T>) -> Sym2<T> {
    let (a, b, d) = (c.xx, c.xy, c.yy);
    let r00 = a * g.xx + b * g.xy;
    let r01 = a * g.xy + b * g.yy;
    let r10 = b * g.xx + d * g.xy;
    let r11 = b * g.xy + d * g.yy;
    Sym2::new(r00 * a + r01 * b, r00 * b + r01 * d, r10 * b + r11 * d)
}

/// VJP of [`project`](crate::project::project) with respect to the mean, log-scale, raw
/// quaternion and the camera's view matrix (same arguments plus the output cotangent).
///
/// Culled Gaussians get a zero gradient. The compensation gradient is exact (no `+1e-6` as
/// in gsplat's CUDA kernel); the FOV clamp uses the exact derivative of `t_z·clamp(t_x/t_z)`.
///
/// ```
/// use evogs_splat::{PinholeCamera, project, project_vjp, ProjectOptions, ProjectedGrad};
/// use evogs_math::{Quat, Vec2, Vec3};
/// use evogs_math::diff::{central_gradient, GradCheck};
/// let cam = PinholeCamera::<f64>::look_at(
///     Vec3::new(0.3, 0.2, 4.0), Vec3::zero(), Vec3::new(0.0, 1.0, 0.0), 0.7, 64, 48,
/// ).unwrap();
/// let (s, q, o) = (Vec3::new(-1.5, -2.0, -1.8), Quat::new(0.9, 0.2, -0.3, 0.1), 0.8);
/// let opts = ProjectOptions::default();
/// let d = ProjectedGrad { means2d: Vec2::new(0.3, -0.7), depth: 0.2, conic: [1.0, -2.0, 0.5], compensation: 0.4 };
/// let f = |m: &[f64]| {
///     let p = project(Vec3::from_slice(m), s, q, o, &cam, &opts);
///     p.means2d.dot(d.means2d) + p.depth * d.depth + p.compensation * d.compensation
///         + (0..3).map(|k| p.conic[k] * d.conic[k]).sum::<f64>()
/// };
/// let (mut x, mut num) = ([0.1, -0.2, 0.3], [0.0; 3]);
/// central_gradient(f, &mut x, &mut num);
/// let g = project_vjp(Vec3::from_array(x), s, q, o, &cam, &opts, &d);
/// GradCheck::new(1e-9, 1e-6).check(&g.mean.to_array(), &num).assert_passed("d mean");
/// ```
#[must_use]
pub fn project_vjp<T: Real>(
    mean: Vec3<T>,
    log_scale: Vec3<T>,
    quat: Quat<T>,
    opacity: T,
    camera: &PinholeCamera<T>,
    opts: &ProjectOptions<T>,
    d: &ProjectedGrad<T>,
) -> ProjectInputGrad<T> {
    let (p, e) = project_full(mean, log_scale, quat, opacity, camera, opts);
    let Some(e) = e.filter(|_| p.valid) else {
        return ProjectInputGrad::default();
    };
    let (fx, fy) = (camera.fx, camera.fy);
    let t = e.t;
    let z = t.z;
    let (z2, z3) = (z * z, z * z * z);

    // Conic → blurred covariance B; dB/dA = I.
    let g = Sym2::new(d.conic[0], d.conic[1] * T::HALF, d.conic[2]);
    let cgc = sandwich(e.conic, g);
    let mut da = Sym2::new(-cgc.xx, -cgc.xy, -cgc.yy);
    // Compensation ρ = sqrt(det A/det B).
    if e.comp > T::ZERO {
        let k = d.compensation / (T::TWO * e.comp);
        let one_m = T::ONE - e.comp * e.comp;
        let eps_det = opts.eps2d / e.det_b;
        da.xx += k * (one_m * e.conic.xx - eps_det);
        da.xy += k * one_m * e.conic.xy;
        da.yy += k * (one_m * e.conic.yy - eps_det);
    }

    // A = J Σ_c Jᵀ.
    let [j0, j1] = e.j;
    let sigma = e.m.mul_mat(e.m.transpose());
    let sigma_cam = e.wm.mul_mat(e.wm.transpose());
    let d_sigma_cam = Mat3::outer(j0, j0).scale(da.xx)
        + (Mat3::outer(j0, j1) + Mat3::outer(j1, j0)).scale(da.xy)
        + Mat3::outer(j1, j1).scale(da.yy);
    let sj0 = sigma_cam.mul_vec(j0);
    let sj1 = sigma_cam.mul_vec(j1);
    let dj0 = (sj0 * da.xx + sj1 * da.xy) * T::TWO;
    let dj1 = (sj0 * da.xy + sj1 * da.yy) * T::TWO;

    // J → t, with the exact derivative of the FOV clamp.
    let mut dt = Vec3::zero();
    dt.z -= fx / z2 * dj0.x + fy / z2 * dj1.y;
    if e.clamped[0] {
        dt.z += fx * e.tc[0] / z3 * dj0.z;
    } else {
        dt.x -= fx / z2 * dj0.z;
        dt.z += T::TWO * fx * e.tc[0] / z3 * dj0.z;
    }
    if e.clamped[1] {
        dt.z += fy * e.tc[1] / z3 * dj1.z;
    } else {
        dt.y -= fy / z2 * dj1.z;
        dt.z += T::TWO * fy * e.tc[1] / z3 * dj1.z;
    }

    // Mean projection and depth.
    let (du, dv) = (d.means2d.x, d.means2d.y);
    dt.x += fx / z * du;
    dt.y += fy / z * dv;
    dt.z -= (fx * t.x * du + fy * t.y * dv) / z2;
    dt.z += d.depth;

    // World → camera.
    let r = camera.rotation;
    let d_mean = r.tr_mul_vec(dt);
    let d_sigma = r.transpose().mul_mat(d_sigma_cam).mul_mat(r);
    let d_rot = Mat3::outer(dt, mean) + d_sigma_cam.mul_mat(r).mul_mat(sigma).scale(T::TWO);
    let (d_log_scale, d_quat) = covariance_vjp(log_scale, quat, Sym3::from_full_adjoint(d_sigma));
    ProjectInputGrad {
        mean: d_mean,
        log_scale: d_log_scale,
        quat: d_quat,
        camera: CameraGrad {
            rotation: d_rot,
            translation: dt,
            bottom: [T::ZERO; 4],
        },
    }
}
