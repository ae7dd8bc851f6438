//! SO(3): the exponential and logarithm, hat and vee, and the [`So3`] rotation type.
//!
//! Conventions:
//! - rotation vectors φ ∈ R³ (axis·angle), θ = |φ|;
//! - `hat(v) = [[0, −v₂, v₁], [v₂, 0, −v₀], [−v₁, v₀, 0]]`, so `hat(a)·b = a × b`;
//! - `Exp(φ)` is the rotation by θ about φ/θ (right-hand rule); as a unit quaternion
//!   `(cos(θ/2), sin(θ/2)/θ·φ)`, stored (w, x, y, z);
//! - `Log` returns the rotation vector with angle in [0, π] (the quaternion is folded to
//!   w ≥ 0 first); at exactly π both ±φ are valid and either may be returned.
//!
//! Accuracy: every map is evaluated through the coefficient functions of
//! [`so3_coeffs`](crate::so3_coeffs), each with its own small-angle series written in θ²,
//! so the f64 results are accurate to about 1e-16 relative at every angle (tested
//! against 50-digit references at 1e-12, 1e-10 … π − 1e-8 and π), and dual numbers are
//! safe at the identity.

use crate::so3_coeffs::{cos_half, one_minus_cos_over_sq, sin_half_over, sinc};
use crate::{Mat3, Quat, Real, Vec3};

/// The skew-symmetric matrix of `v`: `hat(v)·b = v × b`.
#[inline]
#[must_use]
pub fn hat<T: Real>(v: Vec3<T>) -> Mat3<T> {
    Mat3::from_rows([
        [T::ZERO, -v.z, v.y],
        [v.z, T::ZERO, -v.x],
        [-v.y, v.x, T::ZERO],
    ])
}

/// The inverse of [`hat`] on skew matrices; for a general matrix, the vee of its
/// skew part `(M − Mᵀ)/2`.
#[inline]
#[must_use]
pub fn vee<T: Real>(m: Mat3<T>) -> Vec3<T> {
    let h = T::HALF;
    Vec3::new(
        (m.m[2][1] - m.m[1][2]) * h,
        (m.m[0][2] - m.m[2][0]) * h,
        (m.m[1][0] - m.m[0][1]) * h,
    )
}

/// The exponential as a unit quaternion: `(cos(θ/2), sin(θ/2)/θ·φ)`.
///
/// No canonicalisation: for θ > π the real part is negative.
///
/// ```
/// use evogs_math::{Vec3, so3::exp_quat};
/// let q = exp_quat(Vec3::new(0.0_f64, 0.0, core::f64::consts::FRAC_PI_2));
/// assert!((q.w - q.z).abs() < 1e-15); // 90° about z: (cos 45°, 0, 0, sin 45°)
/// ```
#[inline]
#[must_use]
pub fn exp_quat<T: Real>(phi: Vec3<T>) -> Quat<T> {
    let t2 = phi.norm_squared();
    Quat::from_parts(cos_half(t2), phi * sin_half_over(t2))
}

/// The exponential as a rotation matrix (Rodrigues):
/// `Exp(φ) = I + (sin θ/θ) K + ((1 − cos θ)/θ²) K²`, `K = hat(φ)`.
#[must_use]
pub fn exp_matrix<T: Real>(phi: Vec3<T>) -> Mat3<T> {
    let t2 = phi.norm_squared();
    let k = hat(phi);
    Mat3::identity() + k.scale(sinc(t2)) + k.mul_mat(k).scale(one_minus_cos_over_sq(t2))
}

/// The logarithm of a quaternion (any non-zero norm: only the rotation `q/|q|` matters).
///
/// Folds `q` to `w ≥ 0`, then `φ = 2·atan2(|v|, w)·v/|v|`; below |v|²/w² = 1e-3 the factor
/// `2·atan(x)/x / w` (x = |v|/w) is a series in x², exact to rounding and safe at 0.
/// atan2 is well conditioned near both 0 and π, unlike acos.
///
/// ```
/// use evogs_math::{Vec3, so3::{exp_quat, log_quat}};
/// let phi = Vec3::new(0.3, -1.1, 2.0);
/// let back = log_quat(exp_quat(phi));
/// assert!((back - phi).norm() < 1e-15);
/// ```
#[must_use]
pub fn log_quat<T: Real>(q: Quat<T>) -> Vec3<T> {
    let q = if q.w < T::ZERO { -q } else { q };
    let v = q.vec();
    let n2 = v.norm_squared();
    let w = q.w;
    if w > T::ZERO && n2 < T::from_f64(1e-3) * w * w {
        // atan(x)/x = Σ (−1)^k x^{2k}/(2k+1), x² = n²/w².
        const ATAN_OVER: [f64; 6] = [1.0, -1.0 / 3.0, 0.2, -1.0 / 7.0, 1.0 / 9.0, -1.0 / 11.0];
        let x2 = n2 / (w * w);
        let mut acc = T::ZERO;
        for &c in ATAN_OVER.iter().rev() {
            acc = acc * x2 + T::from_f64(c);
        }
        v * (T::TWO * acc / w)
    } else {
        let n = n2.sqrt();
        v * (T::TWO * n.atan2(w) / n)
    }
}

/// The unit quaternion of a rotation matrix (Shepperd's method: the largest of
/// w², x², y², z² is taken from the trace or the diagonal, the others from off-diagonal
/// sums and differences), stable at every angle including π. Of the two quaternions of the
/// rotation it returns the one with `w ≥ 0`.
#[must_use]
pub fn quat_from_matrix<T: Real>(r: Mat3<T>) -> Quat<T> {
    let m = r.m;
    let tr = m[0][0] + m[1][1] + m[2][2];
    let quarter = T::from_f64(0.25);
    let q = if tr >= m[0][0] && tr >= m[1][1] && tr >= m[2][2] {
        let w = (T::ONE + tr).sqrt() * T::HALF;
        let f = quarter / w;
        Quat::new(
            w,
            (m[2][1] - m[1][2]) * f,
            (m[0][2] - m[2][0]) * f,
            (m[1][0] - m[0][1]) * f,
        )
    } else if m[0][0] >= m[1][1] && m[0][0] >= m[2][2] {
        let x = (T::ONE + m[0][0] - m[1][1] - m[2][2]).sqrt() * T::HALF;
        let f = quarter / x;
        Quat::new(
            (m[2][1] - m[1][2]) * f,
            x,
            (m[0][1] + m[1][0]) * f,
            (m[0][2] + m[2][0]) * f,
        )
    } else if m[1][1] >= m[2][2] {
        let y = (T::ONE - m[0][0] + m[1][1] - m[2][2]).sqrt() * T::HALF;
        let f = quarter / y;
        Quat::new(
            (m[0][2] - m[2][0]) * f,
            (m[0][1] + m[1][0]) * f,
            y,
            (m[1][2] + m[2][1]) * f,
        )
    } else {
        let z = (T::ONE - m[0][0] - m[1][1] + m[2][2]).sqrt() * T::HALF;
        let f = quarter / z;
        Quat::new(
            (m[1][0] - m[0][1]) * f,
            (m[0][2] + m[2][0]) * f,
            (m[1][2] + m[2][1]) * f,
            z,
        )
    };
    if q.w < T::ZERO { -q } else { q }
}

/// The logarithm of a rotation matrix, through [`quat_from_matrix`] and [`log_quat`]
/// (never acos of the trace, which loses digits near 0 and π).
#[must_use]
pub fn log_matrix<T: Real>(r: Mat3<T>) -> Vec3<T> {
    log_quat(quat_from_matrix(r))
}

/// A rotation in SO(3), stored as a unit quaternion (w, x, y, z).
///
/// Acts on vectors actively: `R·v` rotates `v`. Composition `a * b` applies `b` first.
/// Frame naming follows `a_from_b`: `world_from_body * point_in_body = point_in_world`.
///
/// ```
/// use evogs_math::{So3, Vec3};
/// let r = So3::exp(Vec3::new(0.0, 0.0, core::f64::consts::FRAC_PI_2));
/// let v = r.act(Vec3::new(1.0, 0.0, 0.0));
/// assert!((v - Vec3::new(0.0, 1.0, 0.0)).norm() < 1e-15);
/// assert!((r.log() - Vec3::new(0.0, 0.0, core::f64::consts::FRAC_PI_2)).norm() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct So3<T> {
    q: Quat<T>,
}

impl<T: Real> Default for So3<T> {
    fn default() -> Self {
        Self::identity()
    }
}

impl<T: Real> So3<T> {
    /// The identity rotation.
    #[inline]
    #[must_use]
    pub const fn identity() -> Self {
        Self {
            q: Quat::identity(),
        }
    }
    /// The rotation of a quaternion of any non-zero norm (normalised here).
    #[inline]
    #[must_use]
    pub fn from_quat(q: Quat<T>) -> Self {
        Self { q: q.normalize() }
    }
    /// The rotation of a unit quaternion, trusted as given.
    ///
    /// # Panics
    /// In debug builds, if `|q|` differs from 1 by more than 1e-4.
    #[inline]
    #[must_use]
    pub fn from_unit_quat(q: Quat<T>) -> Self {
        debug_assert!(
            (q.norm_squared() - T::ONE).abs() < T::from_f64(1e-4),
            "So3::from_unit_quat needs a unit quaternion"
        );
        Self { q }
    }
    /// The rotation of a rotation matrix.
    #[inline]
    #[must_use]
    pub fn from_matrix(m: Mat3<T>) -> Self {
        Self {
            q: quat_from_matrix(m),
        }
    }
    /// The exponential map `Exp(φ)`.
    #[inline]
    #[must_use]
    pub fn exp(phi: Vec3<T>) -> Self {
        Self { q: exp_quat(phi) }
    }
    /// The logarithm, angle in [0, π].
    #[inline]
    #[must_use]
    pub fn log(self) -> Vec3<T> {
        log_quat(self.q)
    }
    /// The unit quaternion.
    #[inline]
    #[must_use]
    pub const fn quat(self) -> Quat<T> {
        self.q
    }
    /// The rotation matrix.
    #[inline]
    #[must_use]
    pub fn matrix(self) -> Mat3<T> {
        self.q.to_rotation_matrix()
    }
    /// The inverse rotation.
    #[inline]
    #[must_use]
    pub fn inverse(self) -> Self {
        Self { q: self.q.conj() }
    }
    /// Rotates a vector.
    #[inline]
    #[must_use]
    pub fn act(self, v: Vec3<T>) -> Vec3<T> {
        self.q.rotate(v)
    }
    /// The angle of the relative rotation `Log(selfᵀ·other)`, a sign-agnostic distance.
    #[inline]
    #[must_use]
    pub fn angle_to(self, other: Self) -> T {
        (self.inverse() * other).log().norm()
    }
}

impl<T: Real> core::ops::Mul for So3<T> {
    type Output = Self;
    /// Composition: `(a * b).act(v) = a.act(b.act(v))`.
    #[inline]
    fn mul(self, o: Self) -> Self {
        Self { q: self.q * o.q }
    }
}

/// `f32` rotation.
pub type So3f = So3<f32>;
/// `f64` rotation.
pub type So3d = So3<f64>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_quat_keeps_a_half_turn_with_w_zero_as_it_is() {
        // A quaternion with w = 0 is a half turn; it is not folded, so its log points
        // along +v (folding would give the other, equally valid, −π·x).
        let phi = log_quat(Quat::new(0.0, 1.0, 0.0, 0.0));
        assert_eq!(
            [phi.x, phi.y, phi.z].map(f64::to_bits),
            [core::f64::consts::PI, 0.0, 0.0].map(f64::to_bits)
        );
    }

    #[test]
    fn log_quat_series_agrees_with_atan2_at_its_threshold() {
        // Just inside the series' range (|v|²/w² < 1e-3) its truncation is below f64
        // rounding, so it must give the closed form's value to a few ulps: a wrong
        // coefficient of the last term (x¹⁰/11, about 1e-15 there) shows.
        for &angle in &[0.063_2_f64, 0.063_21, 0.063_222] {
            let half = 0.5 * angle;
            let (w, n) = (half.cos(), half.sin());
            assert!(n * n < 1e-3 * w * w, "inside the series' range");
            let series = log_quat(Quat::new(w, n, 0.0, 0.0)).x;
            let closed = 2.0 * n.atan2(w);
            assert!(
                (series - closed).abs() <= 4.0 * f64::EPSILON * closed,
                "angle {angle}: series {series:e}, atan2 {closed:e}"
            );
        }
    }

    #[test]
    fn hat_vee_round_trip_and_cross() {
        let a = Vec3::new(0.3, -1.2, 0.7);
        let b = Vec3::new(-0.5, 0.4, 2.0);
        assert!((vee(hat(a)) - a).norm() < 1e-16, "vee(hat(a)) = a");
        assert!(
            (hat(a).mul_vec(b) - a.cross(b)).norm() < 1e-15,
            "hat(a) b = a × b"
        );
    }

    #[test]
    fn exp_quat_and_matrix_agree() {
        for phi in [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1e-9, 2e-9, -1e-9),
            Vec3::new(0.3, -2.2, 1.0),
        ] {
            let d = exp_quat(phi).to_rotation_matrix() - exp_matrix(phi);
            assert!(d.max_abs() < 1e-15, "quaternion and Rodrigues at {phi:?}");
        }
    }

    #[test]
    fn log_at_pi_returns_a_valid_axis() {
        let phi = Vec3::new(0.0, 0.0, core::f64::consts::PI);
        for l in [log_quat(exp_quat(phi)), log_matrix(exp_matrix(phi))] {
            assert!((l.norm() - core::f64::consts::PI).abs() < 1e-15, "angle π");
            assert!(
                (exp_matrix(l) - exp_matrix(phi)).max_abs() < 1e-15,
                "same rotation"
            );
        }
    }

    #[test]
    fn log_of_scaled_quaternion_ignores_the_scale() {
        let q = exp_quat(Vec3::new(0.2, 0.1, -0.4));
        let d = log_quat(q.scale(3.5)) - log_quat(q);
        assert!(d.norm() < 1e-15, "scale invariance");
    }
    #[test]
    fn half_turns_about_each_axis_take_the_branch_of_their_axis() {
        // A half turn about axis k has w = 0 and only component k non-zero: every other
        // pivot of Shepperd's method is 0, so a wrong branch divides by zero. The result
        // is exact, and w = 0 is not folded (folding would negate the axis).
        let axes = [[1.0, -1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, 1.0]];
        for (k, d) in axes.iter().enumerate() {
            let mut r = Mat3::<f64>::zero();
            for (i, &v) in d.iter().enumerate() {
                r.m[i][i] = v;
            }
            let q = quat_from_matrix(r);
            let mut want = [0.0; 4];
            want[k + 1] = 1.0;
            assert_eq!(
                [q.w, q.x, q.y, q.z].map(f64::to_bits),
                want.map(f64::to_bits),
                "half turn about axis {k}"
            );
        }
    }

    #[test]
    fn quat_from_matrix_returns_the_quaternion_with_w_at_least_zero() {
        // Angles near ±π about each axis go through the x, y and z branches, whose w
        // comes out negative for a negative angle before the fold; small angles go
        // through the trace branch.
        for axis in 0..3 {
            for angle in [3.0, -3.0, 0.4, -0.4, 2.0, -2.0] {
                let mut phi = Vec3::<f64>::zero();
                phi[axis] = angle;
                let q = quat_from_matrix(exp_matrix(phi));
                let half = 0.5 * angle;
                let want = [half.cos(), half.sin()];
                assert!(q.w >= 0.0, "w ≥ 0 for {angle} about {axis}");
                assert!(
                    (q.w - want[0]).abs() < 1e-15 && (q.vec()[axis] - want[1]).abs() < 1e-15,
                    "{angle} about {axis}: {q:?}"
                );
            }
        }
    }

    #[test]
    fn so3_from_matrix_and_angle_to_measure_what_they_say() {
        let phi = Vec3::new(0.3, -0.2, 0.9);
        let r = So3::from_matrix(exp_matrix(phi));
        assert!(
            (r.log() - phi).norm() < 1e-15,
            "from_matrix keeps the rotation"
        );
        // Two turns about one axis differ by the difference of their angles, whichever
        // comes first.
        let a = So3::exp(Vec3::new(0.0, 0.0, 0.25));
        let b = So3::exp(Vec3::new(0.0, 0.0, 1.0));
        assert!((a.angle_to(b) - 0.75).abs() < 1e-15, "{}", a.angle_to(b));
        assert!((b.angle_to(a) - 0.75).abs() < 1e-15, "{}", b.angle_to(a));
    }
}
