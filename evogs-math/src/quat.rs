//! Quaternions [`Quat`], stored **(w, x, y, z)** with the Hamilton product.
//!
//! Conventions (as in gsplat, 3DGS and the standard `.ply` `rot_0..rot_3`):
//! - storage order w, x, y, z (real part first); nalgebra also puts w first, glam puts
//!   w last, and the interop modules convert explicitly;
//! - Hamilton product `(p⊗q)_w = p_w q_w − p_v·q_v`, `(p⊗q)_v = p_w q_v + q_w p_v + p_v × q_v`;
//! - a unit quaternion acts as an *active* rotation `v ↦ q ⊗ (0, v) ⊗ q*`, with matrix
//!   [`Quat::to_rotation_matrix`];
//! - trainable quaternions are raw (not unit): [`rotation_from_raw`] normalises first, and
//!   its VJP [`rotation_from_raw_vjp`] includes the normalisation, so the gradient is
//!   orthogonal to `q`.

use crate::{Mat3, Real, Vec3};
use core::ops::{Add, Mul, Neg, Sub};

/// A quaternion `w + x i + y j + z k`, stored (w, x, y, z).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Quat<T> {
    /// Real part.
    pub w: T,
    /// i component.
    pub x: T,
    /// j component.
    pub y: T,
    /// k component.
    pub z: T,
}

impl<T: Real> Quat<T> {
    /// A quaternion from its components, real part first.
    #[inline]
    #[must_use]
    pub const fn new(w: T, x: T, y: T, z: T) -> Self {
        Self { w, x, y, z }
    }
    /// The identity rotation `(1, 0, 0, 0)`.
    #[inline]
    #[must_use]
    pub const fn identity() -> Self {
        Self::new(T::ONE, T::ZERO, T::ZERO, T::ZERO)
    }
    /// The zero quaternion.
    #[inline]
    #[must_use]
    pub const fn zero() -> Self {
        Self::new(T::ZERO, T::ZERO, T::ZERO, T::ZERO)
    }
    /// A quaternion from its real part and vector part.
    #[inline]
    #[must_use]
    pub const fn from_parts(w: T, v: Vec3<T>) -> Self {
        Self::new(w, v.x, v.y, v.z)
    }
    /// The pure quaternion `(0, v)`.
    #[inline]
    #[must_use]
    pub const fn pure(v: Vec3<T>) -> Self {
        Self::new(T::ZERO, v.x, v.y, v.z)
    }
    /// The vector part `(x, y, z)`.
    #[inline]
    #[must_use]
    pub const fn vec(self) -> Vec3<T> {
        Vec3::new(self.x, self.y, self.z)
    }
    /// Components as `[w, x, y, z]`.
    #[inline]
    #[must_use]
    pub const fn to_array(self) -> [T; 4] {
        [self.w, self.x, self.y, self.z]
    }
    /// From `[w, x, y, z]`.
    #[inline]
    #[must_use]
    pub const fn from_array(a: [T; 4]) -> Self {
        Self::new(a[0], a[1], a[2], a[3])
    }
    /// From the first four entries of a slice, `[w, x, y, z]`.
    ///
    /// # Panics
    /// If the slice is shorter than 4.
    #[inline]
    #[must_use]
    pub fn from_slice(s: &[T]) -> Self {
        Self::new(s[0], s[1], s[2], s[3])
    }
    /// Writes `[w, x, y, z]` into the first four entries of a slice.
    ///
    /// # Panics
    /// If the slice is shorter than 4.
    #[inline]
    pub fn write_to(self, s: &mut [T]) {
        s[0] = self.w;
        s[1] = self.x;
        s[2] = self.y;
        s[3] = self.z;
    }
    /// Conjugate `(w, −x, −y, −z)` (the inverse of a unit quaternion).
    #[inline]
    #[must_use]
    pub fn conj(self) -> Self {
        Self::new(self.w, -self.x, -self.y, -self.z)
    }
    /// Four-dimensional dot product.
    #[inline]
    #[must_use]
    pub fn dot(self, o: Self) -> T {
        self.w * o.w + self.x * o.x + self.y * o.y + self.z * o.z
    }
    /// Squared norm.
    #[inline]
    #[must_use]
    pub fn norm_squared(self) -> T {
        self.dot(self)
    }
    /// Norm.
    #[inline]
    #[must_use]
    pub fn norm(self) -> T {
        self.norm_squared().sqrt()
    }
    /// Scales all four components.
    #[inline]
    #[must_use]
    pub fn scale(self, s: T) -> Self {
        Self::new(self.w * s, self.x * s, self.y * s, self.z * s)
    }
    /// `q/|q|` (NaN components for the zero quaternion).
    #[inline]
    #[must_use]
    pub fn normalize(self) -> Self {
        self.scale(T::ONE / self.norm())
    }
    /// `true` if every component is finite.
    #[inline]
    #[must_use]
    pub fn is_finite(self) -> bool {
        self.w.is_finite() && self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
    /// Hamilton product `self ⊗ o`.
    #[inline]
    #[must_use]
    pub fn mul_quat(self, o: Self) -> Self {
        Self::new(
            self.w * o.w - self.x * o.x - self.y * o.y - self.z * o.z,
            self.w * o.x + self.x * o.w + self.y * o.z - self.z * o.y,
            self.w * o.y - self.x * o.z + self.y * o.w + self.z * o.x,
            self.w * o.z + self.x * o.y - self.y * o.x + self.z * o.w,
        )
    }
    /// Rotates `v` by this **unit** quaternion (`q ⊗ (0, v) ⊗ q*`).
    #[inline]
    #[must_use]
    pub fn rotate(self, v: Vec3<T>) -> Vec3<T> {
        // v + 2 w (u × v) + 2 u × (u × v), u = vector part.
        let u = self.vec();
        let t = u.cross(v) * T::TWO;
        v + t * self.w + u.cross(t)
    }
    /// Rotates `v` by the inverse of this **unit** quaternion.
    #[inline]
    #[must_use]
    pub fn rotate_inv(self, v: Vec3<T>) -> Vec3<T> {
        self.conj().rotate(v)
    }
    /// The rotation matrix of this **unit** quaternion (`docs/lie-groups.md` §1).
    #[must_use]
    pub fn to_rotation_matrix(self) -> Mat3<T> {
        let (w, x, y, z) = (self.w, self.x, self.y, self.z);
        let one = T::ONE;
        let two = T::TWO;
        Mat3::from_rows([
            [
                one - two * (y * y + z * z),
                two * (x * y - w * z),
                two * (x * z + w * y),
            ],
            [
                two * (x * y + w * z),
                one - two * (x * x + z * z),
                two * (y * z - w * x),
            ],
            [
                two * (x * z - w * y),
                two * (y * z + w * x),
                one - two * (x * x + y * y),
            ],
        ])
    }
    /// Converts the scalar type (through `f64`).
    #[inline]
    #[must_use]
    pub fn cast<U: Real>(self) -> Quat<U> {
        Quat::new(
            U::from_f64(self.w.to_f64()),
            U::from_f64(self.x.to_f64()),
            U::from_f64(self.y.to_f64()),
            U::from_f64(self.z.to_f64()),
        )
    }
}

impl<T: Real> Mul for Quat<T> {
    type Output = Self;
    /// Hamilton product.
    #[inline]
    fn mul(self, o: Self) -> Self {
        self.mul_quat(o)
    }
}
impl<T: Real> Add for Quat<T> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        Self::new(self.w + o.w, self.x + o.x, self.y + o.y, self.z + o.z)
    }
}
impl<T: Real> Sub for Quat<T> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        Self::new(self.w - o.w, self.x - o.x, self.y - o.y, self.z - o.z)
    }
}
impl<T: Real> Neg for Quat<T> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        self.scale(-T::ONE)
    }
}

/// Rotation matrix of a raw (not necessarily unit) quaternion: `R(q/|q|)`.
#[inline]
#[must_use]
pub fn rotation_from_raw<T: Real>(q: Quat<T>) -> Mat3<T> {
    q.normalize().to_rotation_matrix()
}

/// VJP of [`rotation_from_raw`]: given `d_r = ∂L/∂R`, returns `∂L/∂q` for the raw `q`.
///
/// First the adjoint with respect to the unit quaternion q̄ (`docs/splatting.md` §2), then through
/// the normalisation: `dq = (dq̄ − (dq̄·q̄) q̄)/|q|`, which is orthogonal to `q`.
///
/// ```
/// use evogs_math::{Mat3, Quat, quat::{rotation_from_raw, rotation_from_raw_vjp}};
/// use evogs_math::diff::{central_gradient, GradCheck};
/// let q = [0.9, -0.3, 0.5, 1.2];
/// let g = Mat3::from_rows([[0.1, -0.4, 0.7], [0.3, 0.2, -0.5], [-0.6, 0.8, 0.05]]);
/// let dq = rotation_from_raw_vjp(Quat::from_array(q), g).to_array();
/// let mut x = q;
/// let mut num = [0.0; 4];
/// central_gradient(|v: &[f64]| rotation_from_raw(Quat::from_slice(v)).frobenius_dot(g), &mut x, &mut num);
/// assert!(GradCheck::new(1e-9, 1e-7).check(&dq, &num).passed());
/// ```
#[must_use]
pub fn rotation_from_raw_vjp<T: Real>(q: Quat<T>, d_r: Mat3<T>) -> Quat<T> {
    let n = q.norm();
    let u = q.scale(T::ONE / n);
    let (w, x, y, z) = (u.w, u.x, u.y, u.z);
    let g = d_r.m;
    let two = T::TWO;
    let dw = two * (x * (g[2][1] - g[1][2]) + y * (g[0][2] - g[2][0]) + z * (g[1][0] - g[0][1]));
    let dx = two
        * (y * (g[0][1] + g[1][0]) + z * (g[0][2] + g[2][0]) + w * (g[2][1] - g[1][2])
            - two * x * (g[1][1] + g[2][2]));
    let dy = two
        * (x * (g[0][1] + g[1][0]) + z * (g[1][2] + g[2][1]) + w * (g[0][2] - g[2][0])
            - two * y * (g[0][0] + g[2][2]));
    let dz = two
        * (x * (g[0][2] + g[2][0]) + y * (g[1][2] + g[2][1]) + w * (g[1][0] - g[0][1])
            - two * z * (g[0][0] + g[1][1]));
    crate::activation::normalize_quat_vjp(q, Quat::new(dw, dx, dy, dz))
}

/// `f32` quaternion.
pub type Quatf = Quat<f32>;
/// `f64` quaternion.
pub type Quatd = Quat<f64>;

#[cfg(test)]
mod tests {
    use super::{Quat, rotation_from_raw};
    use crate::Vec3;

    fn bits(a: [f64; 4]) -> [u64; 4] {
        a.map(f64::to_bits)
    }

    fn bits3(v: Vec3<f64>) -> [u64; 3] {
        v.to_array().map(f64::to_bits)
    }

    #[test]
    fn quaternion_algebra_matches_its_formulas_on_small_integers() {
        // Every value below is exact in f64, so each operation is compared bit for bit.
        let p = Quat::<f64>::new(2.0, 3.0, 5.0, 7.0);
        let q = Quat::new(11.0, -13.0, 17.0, 19.0);
        assert_eq!(
            bits(p.conj().to_array()),
            bits([2.0, -3.0, -5.0, -7.0]),
            "conjugate"
        );
        assert_eq!(
            p.dot(q).to_bits(),
            201.0_f64.to_bits(),
            "22 − 39 + 85 + 133"
        );
        assert_eq!(
            p.norm_squared().to_bits(),
            87.0_f64.to_bits(),
            "4 + 9 + 25 + 49"
        );
        assert_eq!(p.norm().to_bits(), 87.0_f64.sqrt().to_bits(), "√87");
        assert_eq!(
            bits(p.scale(3.0).to_array()),
            bits([6.0, 9.0, 15.0, 21.0]),
            "3 p"
        );
        assert_eq!(
            bits((p + q).to_array()),
            bits([13.0, -10.0, 22.0, 26.0]),
            "p + q"
        );
        assert_eq!(
            bits((p - q).to_array()),
            bits([-9.0, 16.0, -12.0, -12.0]),
            "p − q"
        );
        assert_eq!(bits((-p).to_array()), bits([-2.0, -3.0, -5.0, -7.0]), "−p");
        assert_eq!(
            bits(Quat::new(2.0, -2.0, 2.0, 2.0).normalize().to_array()),
            bits([0.5, -0.5, 0.5, 0.5]),
            "q/|q|"
        );
        // The Hamilton product in scalar-vector form: (a, u)(b, v) = (ab − u·v, av + bu + u × v).
        let (a, u, b, v) = (p.w, p.vec(), q.w, q.vec());
        let want = Quat::from_parts(a * b - u.dot(v), v * a + u * b + u.cross(v));
        assert_eq!(bits((p * q).to_array()), bits(want.to_array()), "p ⊗ q");
        assert_eq!(
            bits(p.mul_quat(q).to_array()),
            bits(want.to_array()),
            "mul_quat"
        );
        let mut s = [0.0; 5];
        p.write_to(&mut s);
        assert_eq!(
            bits([s[0], s[1], s[2], s[3]]),
            bits(p.to_array()),
            "w, x, y, z in order"
        );
        assert_eq!(
            bits(Quat::from_slice(&s).to_array()),
            bits(p.to_array()),
            "from_slice"
        );
        let f: Quat<f32> = q.cast();
        assert_eq!(
            bits(f.cast::<f64>().to_array()),
            bits(q.to_array()),
            "cast and back"
        );
    }

    #[test]
    fn finiteness_looks_at_every_component() {
        assert!(Quat::<f64>::identity().is_finite(), "identity");
        for i in 0..4 {
            let mut a = [1.0; 4];
            a[i] = f64::NAN;
            assert!(!Quat::from_array(a).is_finite(), "component {i} NaN");
        }
    }

    #[test]
    fn rotations_by_half_integer_quaternions_are_exact_signed_permutations() {
        // (1 + i + j + k)/2 turns x → y → z → x by 120° about (1, 1, 1).
        let q = Quat::<f64>::new(0.5, 0.5, 0.5, 0.5);
        let v = Vec3::new(3.0, -5.0, 7.0);
        assert_eq!(bits3(q.rotate(v)), bits3(Vec3::new(7.0, 3.0, -5.0)), "R v");
        assert_eq!(
            bits3(q.rotate_inv(v)),
            bits3(Vec3::new(-5.0, 7.0, 3.0)),
            "Rᵀ v"
        );
        let perm = [[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        assert_eq!(q.to_rotation_matrix().m, perm, "R");
        assert_eq!(rotation_from_raw(q.scale(4.0)).m, perm, "R of the raw 4q");
        // Every sign pattern of a half-integer unit quaternion: the matrix against its
        // action on the axes, entry by entry.
        for signs in 0..16_u8 {
            let s = |b: u8| if signs & (1 << b) == 0 { 0.5 } else { -0.5 };
            let q = Quat::<f64>::new(s(0), s(1), s(2), s(3));
            let r = q.to_rotation_matrix();
            for c in 0..3 {
                let col = q.rotate(Vec3::unit(c));
                assert_eq!(bits3(r.col(c)), bits3(col), "column {c} of R({signs:04b})");
            }
        }
    }

    #[test]
    fn rotate_agrees_with_matrix_and_sandwich() {
        let q = Quat::new(0.8, 0.1, -0.5, 0.3).normalize();
        let v = Vec3::new(0.3, 1.2, -0.4);
        let a = q.rotate(v);
        let b = q.to_rotation_matrix().mul_vec(v);
        let c = (q * Quat::pure(v) * q.conj()).vec();
        assert!(
            (a - b).norm() < 1e-15 && (a - c).norm() < 1e-15,
            "three ways to rotate"
        );
    }

    #[test]
    fn product_is_associative_and_matrix_homomorphic() {
        let p = Quat::new(0.2, 0.7, -0.1, 0.4).normalize();
        let q = Quat::new(-0.6, 0.2, 0.5, 0.1).normalize();
        let r = Quat::new(0.3, -0.3, 0.2, 0.9).normalize();
        let d = (p * q) * r - p * (q * r);
        assert!(d.norm() < 1e-15, "associative");
        let m = (p * q).to_rotation_matrix() - p.to_rotation_matrix() * q.to_rotation_matrix();
        assert!(m.max_abs() < 1e-15, "R(pq) = R(p)R(q)");
    }
}
