//! The pinhole camera [`PinholeCamera`] and the gradient of a loss with respect to its pose,
//! [`CameraGrad`].
//!
//! ```text
//! x_cam = R x_world + t                      (camera_from_world; OpenCV axes)
//! u = fx x_cam/z_cam + cx,  v = fy y_cam/z_cam + cy
//! pixel (column j, row i) is sampled at (j + ½, i + ½)
//! camera centre c = −Rᵀ t
//! ```
//!
//! Pose gradients are kept as the gradient of the 16 **entries** of the 4×4 world-to-camera
//! matrix `V = [[R, t], [0, 1]]` (what gsplat calls `v_viewmats`), with the camera centre
//! taken as `inverse(V)[:3, 3]` of the general 4×4 inverse, as gsplat's autograd does.
//! Off the rigid manifold that extension is a convention (it is why the centre path reaches
//! the bottom row); [`CameraGrad::to_pose_left_se3`] gives the convention-free gradient of a
//! left se(3) perturbation `V' = Exp(ξ^) V`, ξ = (ρ, φ):
//!
//! ```text
//! dL/dρ = G_t,   dL/dφ = Σ_j R_{:,j} × G_{R,:,j} + t × G_t
//! ```
//!
//! VJP of the centre through the 4×4 inverse `M = V⁻¹` (`dM = −M dV M`), with `ĝ = (d_c, 0)`:
//! `G_V = −(Mᵀ ĝ)(M e₃)ᵀ`; with `c = −R⁻¹ t` and `u = R⁻ᵀ d_c` (`= R d_c` for a rotation):
//!
//! ```text
//! G_R = −u cᵀ,   G_t = −u,   G_bottom = −(c·d_c) (cᵀ, 1)
//! ```

use core::fmt;
use evogs_math::{Mat3, Real, Vec3};

/// Tolerance on `|RᵀR − I|` (largest entry) and on the bottom row when a 4×4 matrix is
/// accepted as a rigid transform.
const RIGID_TOL: f64 = 1e-4;

/// Why a camera could not be built.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraError {
    /// A matrix entry, the field of view or an intrinsic is NaN or infinite.
    NonFinite,
    /// The rotation block is not orthonormal with determinant +1, or the bottom row is not
    /// `[0, 0, 0, 1]` (within 1e-4).
    NotRigid,
    /// The field of view is not in (0, π), or a focal length is not positive.
    BadIntrinsics,
    /// Width or height is zero.
    EmptyImage,
    /// `0 < near < far` does not hold.
    BadClipRange,
    /// `look_at` with `eye == target` or `up` parallel to the viewing direction.
    DegenerateLookAt,
}

impl fmt::Display for CameraError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let s = match self {
            Self::NonFinite => "camera parameters contain NaN or infinity",
            Self::NotRigid => "camera matrix is not a rigid transform",
            Self::BadIntrinsics => "field of view or focal length out of range",
            Self::EmptyImage => "image width or height is zero",
            Self::BadClipRange => "near and far planes must satisfy 0 < near < far",
            Self::DegenerateLookAt => "look-at eye equals target or up is parallel to the view",
        };
        f.write_str(s)
    }
}

impl core::error::Error for CameraError {}

/// A pinhole camera: a rigid `camera_from_world` transform, intrinsics, image size and clip
/// planes.
///
/// Conventions:
/// - **OpenCV axes**: x right, y down, z forward; depth is the camera-space z;
/// - `x_cam = rotation · x_world + translation` (the world-to-camera "view matrix" `[R | t]`);
/// - pixel (column j, row i) covers `[j, j + 1) × [i, i + 1)` and is sampled at its centre
///   `(j + ½, i + ½)`;
/// - Gaussians are culled unless `near < depth < far` (strict).
///
/// ```
/// use evogs_splat::PinholeCamera;
/// use evogs_math::Vec3;
/// let cam = PinholeCamera::<f64>::look_at(
///     Vec3::new(0.0, 0.0, 4.0), Vec3::zero(), Vec3::new(0.0, 1.0, 0.0), 0.7, 64, 48,
/// ).unwrap();
/// assert!((cam.center() - Vec3::new(0.0, 0.0, 4.0)).norm() < 1e-12);
/// // The target projects to the principal point.
/// let p = cam.world_to_camera(Vec3::zero());
/// assert!((p.z - 4.0).abs() < 1e-12 && p.x.abs() < 1e-12);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinholeCamera<T> {
    /// Rotation of `camera_from_world` (row-major), `x_cam = R x_world + t`.
    pub rotation: Mat3<T>,
    /// Translation of `camera_from_world`.
    pub translation: Vec3<T>,
    /// Focal length in pixels along x.
    pub fx: T,
    /// Focal length in pixels along y.
    pub fy: T,
    /// Principal point x, in pixels (image left edge = 0).
    pub cx: T,
    /// Principal point y, in pixels (image top edge = 0).
    pub cy: T,
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// Near clip plane (depth).
    pub near: T,
    /// Far clip plane (depth).
    pub far: T,
}

/// Default near plane (gsplat's default).
pub const DEFAULT_NEAR: f64 = 0.01;
/// Default far plane (gsplat's default).
pub const DEFAULT_FAR: f64 = 1e10;

fn check_rigid(r: &Mat3<f64>) -> Result<(), CameraError> {
    let e = r.transpose().mul_mat(*r) - Mat3::identity();
    if e.max_abs() > RIGID_TOL || (r.det() - 1.0).abs() > RIGID_TOL {
        return Err(CameraError::NotRigid);
    }
    Ok(())
}

fn focal_from_fov(width: usize, fov_x: f64) -> Result<f64, CameraError> {
    if !fov_x.is_finite() {
        return Err(CameraError::NonFinite);
    }
    if !(fov_x > 0.0 && fov_x < core::f64::consts::PI) {
        return Err(CameraError::BadIntrinsics);
    }
    let w = f64::from(u32::try_from(width).map_err(|_| CameraError::BadIntrinsics)?);
    Ok(w / (2.0 * Real::tan(0.5 * fov_x)))
}

impl<T: Real> PinholeCamera<T> {
    /// A camera from a D-NeRF / NeRF-synthetic `transform_matrix` (camera-to-world, OpenGL /
    /// Blender axes: x right, y up, looking along −z) and the horizontal field of view
    /// `camera_angle_x` in radians.
    ///
    /// Negates the 2nd and 3rd columns of `c2w` (OpenGL → OpenCV camera axes), then inverts
    /// the rigid transform: `R = R_c2wᵀ`, `t = −R_c2wᵀ p`. Intrinsics:
    /// `fx = fy = W/(2 tan(fov_x/2))`, `cx = W/2`, `cy = H/2`; near 0.01, far 1e10.
    ///
    /// # Errors
    /// [`CameraError`] if the matrix is not finite or not rigid, the field of view is not in
    /// (0, π), or the image is empty.
    ///
    /// ```
    /// use evogs_splat::PinholeCamera;
    /// // Blender camera at (0, 0, 4) looking down −z towards the origin.
    /// let c2w = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 4.0], [0.0, 0.0, 0.0, 1.0]];
    /// let cam = PinholeCamera::<f64>::from_dnerf(c2w, 0.69, 800, 800).unwrap();
    /// let p = cam.world_to_camera(evogs_math::Vec3::new(0.0, 1.0, 0.0));
    /// assert!((p.z - 4.0).abs() < 1e-12 && (p.y + 1.0).abs() < 1e-12); // world up = image up
    /// ```
    pub fn from_dnerf(
        c2w: [[f64; 4]; 4],
        camera_angle_x: f64,
        width: usize,
        height: usize,
    ) -> Result<Self, CameraError> {
        if c2w.iter().flatten().any(|v| !v.is_finite()) {
            return Err(CameraError::NonFinite);
        }
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage);
        }
        let bottom = c2w[3];
        if bottom[0].abs() > RIGID_TOL
            || bottom[1].abs() > RIGID_TOL
            || bottom[2].abs() > RIGID_TOL
            || (bottom[3] - 1.0).abs() > RIGID_TOL
        {
            return Err(CameraError::NotRigid);
        }
        // Camera axes in world coordinates, OpenCV convention: x = +col0, y = −col1, z = −col2.
        let col = |j: usize| Vec3::new(c2w[0][j], c2w[1][j], c2w[2][j]);
        let r_c2w = Mat3::from_cols(col(0), -col(1), -col(2));
        check_rigid(&r_c2w)?;
        let pos = col(3);
        let rot = r_c2w.transpose();
        let trans = -rot.mul_vec(pos);
        let f = focal_from_fov(width, camera_angle_x)?;
        let (w, h) = (
            f64::from(u32::try_from(width).map_err(|_| CameraError::BadIntrinsics)?),
            f64::from(u32::try_from(height).map_err(|_| CameraError::BadIntrinsics)?),
        );
        Ok(Self {
            rotation: rot.cast(),
            translation: trans.cast(),
            fx: T::from_f64(f),
            fy: T::from_f64(f),
            cx: T::from_f64(0.5 * w),
            cy: T::from_f64(0.5 * h),
            width,
            height,
            near: T::from_f64(DEFAULT_NEAR),
            far: T::from_f64(DEFAULT_FAR),
        })
    }

    /// A camera from a 4×4 world-to-camera view matrix `[[R, t], [0, 0, 0, 1]]` and the
    /// intrinsic matrix `K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]` (the gsplat / oracle
    /// layout). Only `K[0][0]`, `K[1][1]`, `K[0][2]`, `K[1][2]` are read.
    ///
    /// # Errors
    /// [`CameraError`] if an entry is not finite, the matrix is not rigid (within 1e-4), a
    /// focal length is not positive, the image is empty or `0 < near < far` fails.
    pub fn from_viewmat(
        viewmat: [[T; 4]; 4],
        k: [[T; 3]; 3],
        width: usize,
        height: usize,
        near: T,
        far: T,
    ) -> Result<Self, CameraError> {
        let finite = viewmat.iter().flatten().all(|v| v.is_finite())
            && k.iter().flatten().all(|v| v.is_finite())
            && near.is_finite();
        if !finite || far.is_nan() {
            return Err(CameraError::NonFinite);
        }
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage);
        }
        if !(near > T::ZERO && far > near) {
            return Err(CameraError::BadClipRange);
        }
        let rot = Mat3::from_rows([
            [viewmat[0][0], viewmat[0][1], viewmat[0][2]],
            [viewmat[1][0], viewmat[1][1], viewmat[1][2]],
            [viewmat[2][0], viewmat[2][1], viewmat[2][2]],
        ]);
        check_rigid(&rot.cast())?;
        let b = viewmat[3];
        let tol = T::from_f64(RIGID_TOL);
        if b[0].abs() > tol || b[1].abs() > tol || b[2].abs() > tol || (b[3] - T::ONE).abs() > tol {
            return Err(CameraError::NotRigid);
        }
        if !(k[0][0] > T::ZERO && k[1][1] > T::ZERO) {
            return Err(CameraError::BadIntrinsics);
        }
        Ok(Self {
            rotation: rot,
            translation: Vec3::new(viewmat[0][3], viewmat[1][3], viewmat[2][3]),
            fx: k[0][0],
            fy: k[1][1],
            cx: k[0][2],
            cy: k[1][2],
            width,
            height,
            near,
            far,
        })
    }

    /// A camera at `eye` looking at `target`, with `up` pointing up in the image, horizontal
    /// field of view `fov_x` (radians), square pixels and the principal point at the image
    /// centre; near 0.01, far 1e10.
    ///
    /// The camera axes are z = (target − eye)/|·|, x = z × up/|·| (right), y = z × x (down).
    ///
    /// # Errors
    /// [`CameraError`] for non-finite input, `eye == target`, `up` parallel to the viewing
    /// direction, a field of view outside (0, π) or an empty image.
    pub fn look_at(
        eye: Vec3<f64>,
        target: Vec3<f64>,
        up: Vec3<f64>,
        fov_x: f64,
        width: usize,
        height: usize,
    ) -> Result<Self, CameraError> {
        if !(eye.is_finite() && target.is_finite() && up.is_finite()) {
            return Err(CameraError::NonFinite);
        }
        if width == 0 || height == 0 {
            return Err(CameraError::EmptyImage);
        }
        let fwd = target - eye;
        let right = fwd.cross(up);
        let (nf, nr) = (fwd.norm(), right.norm());
        if nf <= 0.0 || nr <= 1e-12 * nf * up.norm() {
            return Err(CameraError::DegenerateLookAt);
        }
        let z = fwd * (1.0 / nf);
        let x = right * (1.0 / nr);
        let y = z.cross(x);
        let rot = Mat3::from_rows([x.to_array(), y.to_array(), z.to_array()]);
        let trans = -rot.mul_vec(eye);
        let f = focal_from_fov(width, fov_x)?;
        let (w, h) = (
            f64::from(u32::try_from(width).map_err(|_| CameraError::BadIntrinsics)?),
            f64::from(u32::try_from(height).map_err(|_| CameraError::BadIntrinsics)?),
        );
        Ok(Self {
            rotation: rot.cast(),
            translation: trans.cast(),
            fx: T::from_f64(f),
            fy: T::from_f64(f),
            cx: T::from_f64(0.5 * w),
            cy: T::from_f64(0.5 * h),
            width,
            height,
            near: T::from_f64(DEFAULT_NEAR),
            far: T::from_f64(DEFAULT_FAR),
        })
    }

    /// The camera centre in world coordinates, `inverse(V)[:3, 3] = −R⁻¹ t` (`= −Rᵀ t` for a
    /// rotation; the general inverse defines the gradient convention of [`CameraGrad`], and
    /// `−Rᵀ t` is the fallback for a singular `R`).
    #[inline]
    #[must_use]
    pub fn center(&self) -> Vec3<T> {
        match self.rotation.inverse() {
            Some(inv) => -inv.mul_vec(self.translation),
            None => -self.rotation.tr_mul_vec(self.translation),
        }
    }

    /// `R x + t`: a world point in camera coordinates.
    #[inline]
    #[must_use]
    pub fn world_to_camera(&self, x: Vec3<T>) -> Vec3<T> {
        self.rotation.mul_vec(x) + self.translation
    }

    /// The 4×4 world-to-camera matrix `[[R, t], [0, 0, 0, 1]]`.
    #[must_use]
    pub fn viewmat(&self) -> [[T; 4]; 4] {
        let (r, t) = (self.rotation.m, self.translation);
        [
            [r[0][0], r[0][1], r[0][2], t.x],
            [r[1][0], r[1][1], r[1][2], t.y],
            [r[2][0], r[2][1], r[2][2], t.z],
            [T::ZERO, T::ZERO, T::ZERO, T::ONE],
        ]
    }

    /// Width and height as scalars.
    #[inline]
    #[must_use]
    pub fn size(&self) -> (T, T) {
        (T::from_usize(self.width), T::from_usize(self.height))
    }

    /// Converts the scalar type (through `f64`).
    #[must_use]
    pub fn cast<U: Real>(&self) -> PinholeCamera<U> {
        let c = |v: T| U::from_f64(v.to_f64());
        PinholeCamera {
            rotation: self.rotation.cast(),
            translation: self.translation.cast(),
            fx: c(self.fx),
            fy: c(self.fy),
            cx: c(self.cx),
            cy: c(self.cy),
            width: self.width,
            height: self.height,
            near: c(self.near),
            far: c(self.far),
        }
    }

    /// VJP of [`center`](Self::center) with the centre read from the general 4×4 inverse of
    /// the view matrix (gsplat's convention, see the module docs): with `u = R⁻ᵀ d_c`
    /// (`= R d_c` for a rotation), `G_R = −u cᵀ`, `G_t = −u`, `G_bottom = −(c·d_c)(cᵀ, 1)`.
    #[must_use]
    pub fn center_vjp(&self, d_center: Vec3<T>) -> CameraGrad<T> {
        let c = self.center();
        let u = match self.rotation.inverse() {
            Some(inv) => inv.tr_mul_vec(d_center),
            None => self.rotation.mul_vec(d_center),
        };
        let s = -c.dot(d_center);
        CameraGrad {
            rotation: -Mat3::outer(u, c),
            translation: -u,
            bottom: [s * c.x, s * c.y, s * c.z, s],
        }
    }
}

/// Gradient of a loss with respect to the 16 entries of a camera's 4×4 view matrix
/// `V = [[R, t], [0, 0, 0, 1]]`: `rotation[i][j] = ∂L/∂R_ij`, `translation[i] = ∂L/∂t_i`,
/// `bottom[j] = ∂L/∂V_3j`.
///
/// The entries are treated as independent numbers (no rigidity constraint), as gsplat's
/// `v_viewmats`; the camera centre is `inverse(V)[:3, 3]` (see the module docs), which is the
/// only path into `bottom`. Use [`to_pose_left_se3`](Self::to_pose_left_se3) for the gradient
/// on the manifold.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraGrad<T> {
    /// `∂L/∂R` (row-major).
    pub rotation: Mat3<T>,
    /// `∂L/∂t`.
    pub translation: Vec3<T>,
    /// `∂L/∂` the bottom row `[0, 0, 0, 1]` of the view matrix.
    pub bottom: [T; 4],
}

impl<T: Real> CameraGrad<T> {
    /// The zero gradient.
    #[must_use]
    pub const fn zero() -> Self {
        Self {
            rotation: Mat3::zero(),
            translation: Vec3::zero(),
            bottom: [T::ZERO; 4],
        }
    }

    /// Adds another gradient.
    #[inline]
    pub fn add(&mut self, o: &Self) {
        self.rotation += o.rotation;
        self.translation += o.translation;
        for (a, b) in self.bottom.iter_mut().zip(o.bottom) {
            *a += b;
        }
    }

    /// The gradient as a 4×4 matrix laid out like the view matrix.
    #[must_use]
    pub fn to_viewmat(&self) -> [[T; 4]; 4] {
        let (r, t) = (self.rotation.m, self.translation);
        [
            [r[0][0], r[0][1], r[0][2], t.x],
            [r[1][0], r[1][1], r[1][2], t.y],
            [r[2][0], r[2][1], r[2][2], t.z],
            self.bottom,
        ]
    }

    /// The gradient with respect to a left se(3) perturbation of the view matrix,
    /// `V' = Exp(ξ^) V` at ξ = 0, ξ = (ρx, ρy, ρz, φx, φy, φz):
    /// `dL/dρ = G_t`, `dL/dφ = Σ_j R_{:,j} × G_{R,:,j} + t × G_t` (the perturbation keeps the
    /// bottom row, so `bottom` does not enter).
    #[must_use]
    pub fn to_pose_left_se3(&self, camera: &PinholeCamera<T>) -> [T; 6] {
        let r = camera.rotation;
        let mut phi = camera.translation.cross(self.translation);
        for j in 0..3 {
            phi += r.col(j).cross(self.rotation.col(j));
        }
        let rho = self.translation;
        [rho.x, rho.y, rho.z, phi.x, phi.y, phi.z]
    }
}
