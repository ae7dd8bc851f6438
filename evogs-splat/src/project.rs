//! EWA projection of one 3D Gaussian to the image plane: [`project`] (its VJP is in
//! [`project_vjp`](crate::project_vjp::project_vjp)).
//!
//! The conventions are those of gsplat 1.5.3 (`_fully_fused_projection`; `docs/splatting.md`
//! §4–§9):
//!
//! ```text
//! t = R μ + t_v                              camera-space mean, depth = t_z
//! means2d = (fx t_x/t_z + cx, fy t_y/t_z + cy)  (the unclamped t)
//! Σ = R(q/|q|) diag(exp(ŝ))² R(q/|q|)ᵀ,  Σ_c = R Σ Rᵀ
//! FOV clamp (affects only J):
//!   tan_fovx = ½W/fx,  lim_x+ = (W − cx)/fx + 0.3 tan_fovx,  lim_x− = cx/fx + 0.3 tan_fovx
//!   x̃ = t_z clamp(t_x/t_z, −lim_x−, lim_x+)   (y likewise with H, cy, fy)
//! J = [[fx/t_z, 0, −fx x̃/t_z²], [0, fy/t_z, −fy ỹ/t_z²]]
//! cov2d A = J Σ_c Jᵀ,  blurred B = A + ε I  (ε = eps2d = 0.3)
//! conic = B⁻¹ = [a, b, c] (b once in σ = ½(a dx² + c dy²) + b dx dy)
//! compensation ρ = sqrt(max(0, det A / det B))
//!   (computed as det A = |t₀ × t₁|², det B = det A + ε tr A + ε², with t_a the rows of
//!    J R M, M = R(q) diag(s): the same numbers without the cancellation of ac − b²)
//! radii r = ceil(e·sqrt(B_xx)), ceil(e·sqrt(B_yy)),  e = 3.33 or min(3.33, sqrt(2 ln(255 o)))
//! valid ⇔ near < t_z < far, det B > 0, r ≠ (0, 0), mx + rx > 0, mx − rx < W, my + ry > 0,
//!          my − ry < H  (and o ≥ 1/255 for opacity-aware radii)
//! ```

use crate::camera::PinholeCamera;
use evogs_math::activation::exp3;
use evogs_math::quat::rotation_from_raw;
use evogs_math::{Mat3, Quat, Real, Sym2, Vec2, Vec3};

/// The radius extent factor, in standard deviations (gsplat).
pub const RADIUS_SIGMAS: f64 = 3.33;
/// The fraction of the half field of view added to the FOV clamp limits.
pub const FOV_CLAMP_MARGIN: f64 = 0.3;
/// The default low-pass dilation added to the 2D covariance, in pixels².
pub const DEFAULT_EPS2D: f64 = 0.3;

/// How the per-axis screen radii are chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RadiusMode {
    /// `3.33 σ` per axis (gsplat's torch reference, the oracle `radii`).
    Plain,
    /// `min(3.33, sqrt(2 ln(255 o))) σ` per axis and culling of `o < 1/255` (gsplat's CUDA
    /// projection when opacities are passed): the tightest box outside which `α < 1/255`.
    #[default]
    OpacityAware,
}

/// Options of [`project`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProjectOptions<T> {
    /// Low-pass dilation ε added to the diagonal of the 2D covariance (0.3).
    pub eps2d: T,
    /// Radius rule.
    pub radius: RadiusMode,
    /// `true` when the rasterizer multiplies opacities by the compensation (antialiased
    /// mode); then opacity-aware radii use `o·ρ`. No effect with [`RadiusMode::Plain`].
    pub antialiased: bool,
}

impl<T: Real> Default for ProjectOptions<T> {
    fn default() -> Self {
        Self {
            eps2d: T::from_f64(DEFAULT_EPS2D),
            radius: RadiusMode::default(),
            antialiased: false,
        }
    }
}

/// The projection of one Gaussian.
///
/// Every float is finite. For culled Gaussians (`valid == false`, `radii == [0, 0]`) the
/// float fields still hold the plain formulas when those are finite; if the pixel
/// coordinates, the 2D covariance, the conic or the compensation is not (`t_z = 0`, an
/// overflow), those four are zero, and the camera-space mean and depth are kept when finite.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Projected<T> {
    /// Camera-space mean `R μ + t_v`.
    pub mean_cam: Vec3<T>,
    /// Pixel coordinates of the mean.
    pub means2d: Vec2<T>,
    /// Depth `t_z`.
    pub depth: T,
    /// 2D covariance before the low-pass dilation.
    pub cov2d: Sym2<T>,
    /// Inverse of the dilated 2D covariance, `[a, b, c]` (zero when its determinant is not
    /// positive).
    pub conic: [T; 3],
    /// `sqrt(max(0, det(cov2d)/det(cov2d + εI)))` (zero when `det(cov2d + εI)` is not
    /// positive).
    pub compensation: T,
    /// Per-axis radii in pixels (`[0, 0]` if culled).
    pub radii: [u32; 2],
    /// `true` unless culled.
    pub valid: bool,
    /// Whether the FOV clamp is active on x and y (`t_z > 0` and the ratio out of limits).
    pub fov_clamped: [bool; 2],
}

impl<T: Real> Projected<T> {
    /// The dilated 2D covariance `cov2d + ε I`.
    #[must_use]
    pub fn cov2d_blurred(&self, eps2d: T) -> Sym2<T> {
        Sym2::new(self.cov2d.xx + eps2d, self.cov2d.xy, self.cov2d.yy + eps2d)
    }
}

/// Everything the projection computes between inputs and outputs, shared by [`project`] and
/// its VJP so both use the same floats.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ewa<T> {
    /// Camera-space mean.
    pub(crate) t: Vec3<T>,
    /// `M = R(q) diag(s)`: the world covariance is `Σ = M Mᵀ`.
    pub(crate) m: Mat3<T>,
    /// `W = R_v M`: the camera covariance is `Σ_c = W Wᵀ`.
    pub(crate) wm: Mat3<T>,
    /// Rows of the 2×3 Jacobian.
    pub(crate) j: [Vec3<T>; 2],
    /// Clamped numerators x̃, ỹ.
    pub(crate) tc: [T; 2],
    /// FOV clamp active on x, y.
    pub(crate) clamped: [bool; 2],
    /// Pre-blur 2D covariance.
    pub(crate) cov2d: Sym2<T>,
    /// Conic (zero if det B ≤ 0).
    pub(crate) conic: Sym2<T>,
    /// det B.
    pub(crate) det_b: T,
    /// Compensation ρ.
    pub(crate) comp: T,
}

/// The EWA chain up to the conic and compensation; `None` if `t_z` is zero or not finite.
pub(crate) fn ewa<T: Real>(
    mean: Vec3<T>,
    log_scale: Vec3<T>,
    quat: Quat<T>,
    camera: &PinholeCamera<T>,
    eps2d: T,
) -> Option<Ewa<T>> {
    let r = camera.rotation;
    let t = camera.world_to_camera(mean);
    if !(t.z.is_finite() && t.z != T::ZERO) {
        return None;
    }
    // M = R(q) diag(s), W = R_v M: Σ = M Mᵀ, Σ_c = W Wᵀ (formed only by the VJP).
    let m = rotation_from_raw(quat).mul_mat(Mat3::diag(exp3(log_scale)));
    let wm = r.mul_mat(m);
    let (w, h) = camera.size();
    let margin = T::from_f64(FOV_CLAMP_MARGIN);
    let lim = |size: T, c: T, f: T| {
        let tan_fov = T::HALF * size / f;
        ((size - c) / f + margin * tan_fov, c / f + margin * tan_fov)
    };
    let (lx_pos, lx_neg) = lim(w, camera.cx, camera.fx);
    let (ly_pos, ly_neg) = lim(h, camera.cy, camera.fy);
    let (rx, ry) = (t.x / t.z, t.y / t.z);
    let positive = t.z > T::ZERO;
    let clamped = [
        positive && (rx < -lx_neg || rx > lx_pos),
        positive && (ry < -ly_neg || ry > ly_pos),
    ];
    let tc = [
        t.z * rx.clamp(-lx_neg, lx_pos),
        t.z * ry.clamp(-ly_neg, ly_pos),
    ];
    let z2 = t.z * t.z;
    let j = [
        Vec3::new(camera.fx / t.z, T::ZERO, -camera.fx * tc[0] / z2),
        Vec3::new(T::ZERO, camera.fy / t.z, -camera.fy * tc[1] / z2),
    ];
    // A = J Σ_c Jᵀ = T Tᵀ with the rows t_a = Wᵀ j_a of T = J W; det A = |t₀ × t₁|²
    // (Cauchy–Binet) has no cancellation, so thin (needle) Gaussians keep an accurate
    // det B = det A + ε tr A + ε², conic and compensation in f32.
    let t0 = wm.tr_mul_vec(j[0]);
    let t1 = wm.tr_mul_vec(j[1]);
    let cov2d = Sym2::new(t0.norm_squared(), t0.dot(t1), t1.norm_squared());
    let det_a = t0.cross(t1).norm_squared();
    let blurred = Sym2::new(cov2d.xx + eps2d, cov2d.xy, cov2d.yy + eps2d);
    let det_b = det_a + eps2d * (cov2d.xx + cov2d.yy) + eps2d * eps2d;
    let (conic, comp) = if det_b > T::ZERO && det_b.is_finite() {
        let inv = T::ONE / det_b;
        let conic = Sym2::new(blurred.yy * inv, -blurred.xy * inv, blurred.xx * inv);
        let ratio = det_a / det_b;
        let comp = if ratio > T::ZERO {
            ratio.sqrt()
        } else {
            T::ZERO
        };
        (conic, comp)
    } else {
        (Sym2::zero(), T::ZERO)
    };
    Some(Ewa {
        t,
        m,
        wm,
        j,
        tc,
        clamped,
        cov2d,
        conic,
        det_b,
        comp,
    })
}

/// The radius extent in standard deviations for a (effective) opacity; `None` if the
/// Gaussian is culled by its opacity (`o < 1/255`, opacity-aware mode only).
fn radius_extent<T: Real>(mode: RadiusMode, opacity: T) -> Option<T> {
    let full = T::from_f64(RADIUS_SIGMAS);
    match mode {
        RadiusMode::Plain => Some(full),
        RadiusMode::OpacityAware => {
            let thr = T::from_f64(1.0 / 255.0);
            // `!(o >= thr)` also culls a NaN opacity.
            let visible = opacity >= thr;
            if !visible {
                return None;
            }
            Some(full.min((T::TWO * (opacity / thr).ln()).sqrt()))
        }
    }
}

/// `ceil(v)` as a pixel count (0 for negative or NaN, saturating).
fn ceil_px<T: Real>(v: T) -> u32 {
    let c = v.ceil().to_f64();
    #[allow(
        clippy::cast_possible_truncation,
        reason = "saturating float-to-int conversion of a pixel radius is intended"
    )]
    let r = c as u32;
    r
}

/// Projects one Gaussian (mean, log-scale, raw quaternion) with a pinhole camera.
///
/// `opacity` is the activated opacity `o = sigmoid(ô)`; it only matters for
/// [`RadiusMode::OpacityAware`] (times the compensation when `opts.antialiased`). Never
/// panics and never returns NaN for `t_z ≤ 0` or degenerate inputs: such Gaussians are culled.
///
/// ```
/// use evogs_splat::{PinholeCamera, project, ProjectOptions};
/// use evogs_math::{Quat, Vec3};
/// let cam = PinholeCamera::<f64>::look_at(
///     Vec3::new(0.0, 0.0, 4.0), Vec3::zero(), Vec3::new(0.0, 1.0, 0.0), 0.7, 64, 48,
/// ).unwrap();
/// let p = project(Vec3::zero(), Vec3::splat(-2.0), Quat::identity(), 0.8, &cam, &ProjectOptions::default());
/// assert!(p.valid && (p.means2d.x - 32.0).abs() < 1e-12 && (p.depth - 4.0).abs() < 1e-12);
/// ```
#[must_use]
pub fn project<T: Real>(
    mean: Vec3<T>,
    log_scale: Vec3<T>,
    quat: Quat<T>,
    opacity: T,
    camera: &PinholeCamera<T>,
    opts: &ProjectOptions<T>,
) -> Projected<T> {
    project_full(mean, log_scale, quat, opacity, camera, opts).0
}

/// [`project`] plus the intermediate values (when `t_z` is non-zero and finite).
pub(crate) fn project_full<T: Real>(
    mean: Vec3<T>,
    log_scale: Vec3<T>,
    quat: Quat<T>,
    opacity: T,
    camera: &PinholeCamera<T>,
    opts: &ProjectOptions<T>,
) -> (Projected<T>, Option<Ewa<T>>) {
    let mut out = Projected::default();
    let t = camera.world_to_camera(mean);
    if t.is_finite() {
        out.mean_cam = t;
        out.depth = t.z;
    }
    let Some(e) = ewa(mean, log_scale, quat, camera, opts.eps2d) else {
        return (out, None);
    };
    let means2d = Vec2::new(
        camera.fx * t.x / t.z + camera.cx,
        camera.fy * t.y / t.z + camera.cy,
    );
    let finite2 = |v: Vec2<T>| v.x.is_finite() && v.y.is_finite();
    let finite_sym = |s: Sym2<T>| s.xx.is_finite() && s.xy.is_finite() && s.yy.is_finite();
    if !(finite2(means2d) && finite_sym(e.cov2d) && finite_sym(e.conic) && e.comp.is_finite()) {
        return (out, None);
    }
    out.means2d = means2d;
    out.cov2d = e.cov2d;
    out.conic = [e.conic.xx, e.conic.xy, e.conic.yy];
    out.compensation = e.comp;
    out.fov_clamped = e.clamped;

    let in_range = t.z > camera.near && t.z < camera.far;
    if !(in_range && e.det_b > T::ZERO && e.det_b.is_finite()) {
        return (out, Some(e));
    }
    let o_eff = if opts.antialiased {
        opacity * e.comp
    } else {
        opacity
    };
    let Some(extent) = radius_extent(opts.radius, o_eff) else {
        return (out, Some(e));
    };
    let rx = ceil_px(extent * (e.cov2d.xx + opts.eps2d).sqrt());
    let ry = ceil_px(extent * (e.cov2d.yy + opts.eps2d).sqrt());
    if rx == 0 && ry == 0 {
        return (out, Some(e));
    }
    let (w, h) = camera.size();
    let (rxf, ryf) = (T::from_f64(f64::from(rx)), T::from_f64(f64::from(ry)));
    let overlaps = means2d.x + rxf > T::ZERO
        && means2d.x - rxf < w
        && means2d.y + ryf > T::ZERO
        && means2d.y - ryf < h;
    if overlaps {
        out.radii = [rx, ry];
        out.valid = true;
    }
    (out, Some(e))
}
