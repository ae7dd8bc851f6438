//! SE(3): the rigid transform [`Se3`] (a unit quaternion and a translation), its exponential
//! and logarithm, hat and vee, the adjoint `Ad` and the small adjoint `ad`, and the VJPs of
//! every map. The conventions and formulas are written out in `docs/se3.md`.
//!
//! Conventions:
//! - `T = (R, t)` acts on points as `p ↦ R p + t`; its 4×4 matrix is `[[R, t], [0, 1]]`
//!   (row-major `[[T; 4]; 4]`); `a * b` applies `b` first; names follow `a_from_b`;
//! - tangent vectors are [`Vec6`] **ξ = (ρ, φ)**: the translation part ρ first (`head`),
//!   the rotation part φ second (`tail`), as in sophus;
//! - `hat(ξ) = [[hat(φ), ρ], [0, 0]]` and `Exp(ξ) = expm(hat(ξ)) = (Exp(φ), Jl(φ)·ρ)` with the
//!   SO(3) left Jacobian `Jl(φ)` ([`so3_jacobians::jl_mul`](crate::so3_jacobians::jl_mul));
//! - `Log` inverts it with the rotation angle in **[0, π]** (the quaternion is folded to
//!   w ≥ 0 first, as in [`so3::log_quat`](crate::so3::log_quat)) and `ρ = Jl(φ)⁻¹·t`;
//!   beyond π the rotation part wraps to the shorter way round;
//! - `Ad(T) = [[R, hat(t)·R], [0, R]]` (`Ad(T)·ξ = vee(T·hat(ξ)·T⁻¹)`) and
//!   `ad(ξ) = [[hat(φ), hat(ρ)], [0, hat(φ)]]` (`ad(ξ)·v` is the Lie bracket `[ξ, v]`);
//! - the Jacobians `Jl`, `Jr` and their inverses are in [`se3_jacobians`](crate::se3_jacobians).
//!
//! **Cotangents of transforms** are 6-vectors with respect to the **left** perturbation
//! `T ↦ Exp(δ)·T` (world frame), as for the SE(3) blocks of evogs-ode:
//! `L(Exp(δ)·T) ≈ L(T) + ⟨∂L/∂T, δ⟩`. Vector arguments and results (points, tangents) have
//! ordinary cotangents. Each VJP follows from one identity (derivations in `docs/se3.md`):
//!
//! | map | VJP | identity |
//! |---|---|---|
//! | `Exp(ξ)` | [`exp_vjp`]: `Jl(ξ)ᵀ g` | `Exp(ξ + δ) ≈ Exp(Jl(ξ) δ)·Exp(ξ)` |
//! | `Log(T)` | [`log_vjp`]: `Jl(ξ)⁻ᵀ g` | `Log(Exp(δ)·T) ≈ ξ + Jl(ξ)⁻¹ δ` |
//! | `a·b` | [`compose_vjp`]: `(g, Ad(a)ᵀ g)` | `a·Exp(δ)·b = Exp(Ad(a) δ)·a·b` |
//! | `T⁻¹` | [`inverse_vjp`]: `−Ad(T⁻¹)ᵀ g` | `(Exp(δ)·T)⁻¹ = Exp(−Ad(T⁻¹) δ)·T⁻¹` |
//! | `T·p` | [`act_vjp`]: `((g, (T·p) × g), Rᵀ g)` | `Exp(δ)·q ≈ q + δ_ρ + δ_φ × q` |
//! | `Ad(T)·v` | [`adjoint_mul_vjp`]: `(−ad(y)ᵀ g, Ad(T)ᵀ g)` | `Ad(Exp(δ)·T) v ≈ y + ad(δ) y` |
//! | `ad(ξ)·v` | [`ad_mul_vjp`]: `(−ad(v)ᵀ g, ad(ξ)ᵀ g)` | `ad(ξ) v = −ad(v) ξ` |
//!
//! A loss written on the stored numbers (quaternion and translation) enters through
//! [`left_cotangent_from_ambient`].

use crate::se3_jacobians::{jl_inv_tr_mul, jl_tr_mul};
use crate::so3::{hat as hat3, quat_from_matrix, vee as vee3};
use crate::so3_jacobians::{jl_inv_mul, jl_mul};
use crate::{Mat3, Mat6, Quat, Real, So3, Vec3, Vec6};

/// A rigid transform in SE(3): a rotation (unit quaternion w, x, y, z) and a translation.
///
/// Acts on points as `p ↦ R p + t`; `a * b` applies `b` first, so
/// `world_from_body * point_in_body = point_in_world`.
///
/// ```
/// use evogs_math::{Se3, Vec3, Vec6};
/// use core::f64::consts::FRAC_PI_2;
/// // A quarter turn about z together with a unit translation along z (a screw motion).
/// let xi = Vec6::new(Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, FRAC_PI_2));
/// let t = Se3::exp(xi);
/// let p = t.act(Vec3::new(1.0, 0.0, 0.0));
/// assert!((p - Vec3::new(0.0, 1.0, 1.0)).norm() < 1e-15);
/// assert!((t.log() - xi).norm() < 1e-15);
/// assert!(((t * t.inverse()).log()).norm() < 1e-15);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Se3<T> {
    rotation: So3<T>,
    translation: Vec3<T>,
}

impl<T: Real> Default for Se3<T> {
    fn default() -> Self {
        Self::identity()
    }
}

impl<T: Real> Se3<T> {
    /// The identity transform.
    #[inline]
    #[must_use]
    pub const fn identity() -> Self {
        Self {
            rotation: So3::identity(),
            translation: Vec3::zero(),
        }
    }
    /// The transform `p ↦ R p + t` of a rotation and a translation.
    #[inline]
    #[must_use]
    pub const fn from_parts(rotation: So3<T>, translation: Vec3<T>) -> Self {
        Self {
            rotation,
            translation,
        }
    }
    /// A pure translation.
    #[inline]
    #[must_use]
    pub const fn from_translation(translation: Vec3<T>) -> Self {
        Self::from_parts(So3::identity(), translation)
    }
    /// The transform of a quaternion of any non-zero norm (normalised here) and a
    /// translation.
    #[inline]
    #[must_use]
    pub fn from_quat_translation(q: Quat<T>, translation: Vec3<T>) -> Self {
        Self::from_parts(So3::from_quat(q), translation)
    }
    /// The transform of a 4×4 matrix `[[R, t], [0, 1]]` (row-major; the bottom row is not
    /// read). The rotation is taken through [`quat_from_matrix`] and normalised, so a
    /// slightly non-orthogonal `R` (e.g. from `f32`) gives the nearby rotation.
    #[must_use]
    pub fn from_matrix(m: &[[T; 4]; 4]) -> Self {
        let r = Mat3::from_rows(core::array::from_fn(|i| [m[i][0], m[i][1], m[i][2]]));
        Self::from_quat_translation(quat_from_matrix(r), Vec3::new(m[0][3], m[1][3], m[2][3]))
    }
    /// The 4×4 matrix `[[R, t], [0, 1]]`, row-major.
    #[must_use]
    pub fn to_matrix(self) -> [[T; 4]; 4] {
        let r = self.rotation.matrix().m;
        let t = self.translation;
        [
            [r[0][0], r[0][1], r[0][2], t.x],
            [r[1][0], r[1][1], r[1][2], t.y],
            [r[2][0], r[2][1], r[2][2], t.z],
            [T::ZERO, T::ZERO, T::ZERO, T::ONE],
        ]
    }
    /// A transform stored as 7 numbers `[w, x, y, z, tx, ty, tz]` (the layout of an SE(3)
    /// state block in evogs-ode); the quaternion is trusted to be unit.
    ///
    /// # Panics
    /// If the slice is shorter than 7; in debug builds, if `|q|` differs from 1 by more
    /// than 1e-4.
    #[inline]
    #[must_use]
    pub fn from_slice(s: &[T]) -> Self {
        Self::from_parts(
            So3::from_unit_quat(Quat::from_slice(s)),
            Vec3::from_slice(&s[4..]),
        )
    }
    /// Writes `[w, x, y, z, tx, ty, tz]` into the first seven entries of a slice.
    ///
    /// # Panics
    /// If the slice is shorter than 7.
    #[inline]
    pub fn write_to(self, s: &mut [T]) {
        self.rotation.quat().write_to(s);
        self.translation.write_to(&mut s[4..]);
    }
    /// The exponential `Exp(ξ) = (Exp(φ), Jl(φ)·ρ)` of a tangent ξ = (ρ, φ).
    ///
    /// The quaternion is not canonicalised (its real part is negative for |φ| > π), as
    /// for [`So3::exp`].
    #[inline]
    #[must_use]
    pub fn exp(xi: Vec6<T>) -> Self {
        Self::from_parts(So3::exp(xi.tail), jl_mul(xi.tail, xi.head))
    }
    /// The logarithm: ξ = (Jl(φ)⁻¹·t, φ) with φ = Log(R), rotation angle in [0, π].
    ///
    /// At exactly π both ±φ are valid (with their own ρ), and either may be returned.
    #[inline]
    #[must_use]
    pub fn log(self) -> Vec6<T> {
        let phi = self.rotation.log();
        Vec6::new(jl_inv_mul(phi, self.translation), phi)
    }
    /// The rotation part.
    #[inline]
    #[must_use]
    pub const fn rotation(self) -> So3<T> {
        self.rotation
    }
    /// The translation part.
    #[inline]
    #[must_use]
    pub const fn translation(self) -> Vec3<T> {
        self.translation
    }
    /// The unit quaternion of the rotation (w, x, y, z), as stored.
    #[inline]
    #[must_use]
    pub const fn quat(self) -> Quat<T> {
        self.rotation.quat()
    }
    /// The inverse `(Rᵀ, −Rᵀ t)`.
    #[inline]
    #[must_use]
    pub fn inverse(self) -> Self {
        let r = self.rotation.inverse();
        Self::from_parts(r, -r.act(self.translation))
    }
    /// Transforms a point: `R p + t`.
    #[inline]
    #[must_use]
    pub fn act(self, p: Vec3<T>) -> Vec3<T> {
        self.rotation.act(p) + self.translation
    }
    /// The adjoint matrix `Ad(T) = [[R, hat(t)·R], [0, R]]`.
    #[must_use]
    pub fn adjoint(self) -> Mat6<T> {
        let r = self.rotation.matrix();
        Mat6::from_blocks(r, hat3(self.translation) * r, Mat3::zero(), r)
    }
    /// `Ad(T)·v = (R v_ρ + t × R v_φ, R v_φ)`, without forming the matrix.
    #[inline]
    #[must_use]
    pub fn adjoint_mul(self, v: Vec6<T>) -> Vec6<T> {
        let rw = self.rotation.act(v.tail);
        Vec6::new(self.rotation.act(v.head) + self.translation.cross(rw), rw)
    }
    /// `Ad(T)ᵀ·v = (Rᵀ v_ρ, Rᵀ(v_φ − t × v_ρ))`, without forming the matrix.
    #[inline]
    #[must_use]
    pub fn adjoint_tr_mul(self, v: Vec6<T>) -> Vec6<T> {
        let r = self.rotation.inverse();
        Vec6::new(
            r.act(v.head),
            r.act(v.tail - self.translation.cross(v.head)),
        )
    }
    /// The same transform with the quaternion rescaled to unit norm (removes the rounding
    /// drift of long products, as the ODE steppers do after every step).
    #[inline]
    #[must_use]
    pub fn renormalize(self) -> Self {
        Self::from_quat_translation(self.quat(), self.translation)
    }
    /// Converts the scalar type (through `f64`; the quaternion is renormalised).
    #[must_use]
    pub fn cast<U: Real>(self) -> Se3<U> {
        Se3::from_quat_translation(self.quat().cast(), self.translation.cast())
    }
}

impl<T: Real> core::ops::Mul for Se3<T> {
    type Output = Self;
    /// Composition `(R_a R_b, R_a t_b + t_a)`: `(a * b).act(p) = a.act(b.act(p))`.
    #[inline]
    fn mul(self, o: Self) -> Self {
        Self::from_parts(self.rotation * o.rotation, self.act(o.translation))
    }
}

/// The 4×4 matrix `hat(ξ) = [[hat(φ), ρ], [0, 0]]` of a tangent ξ = (ρ, φ).
#[must_use]
pub fn hat<T: Real>(xi: Vec6<T>) -> [[T; 4]; 4] {
    let p = hat3(xi.tail).m;
    let r = xi.head;
    [
        [p[0][0], p[0][1], p[0][2], r.x],
        [p[1][0], p[1][1], p[1][2], r.y],
        [p[2][0], p[2][1], p[2][2], r.z],
        [T::ZERO; 4],
    ]
}

/// The inverse of [`hat`]: `(m[0..3][3], vee of the skew part of the 3×3 block)`.
#[must_use]
pub fn vee<T: Real>(m: &[[T; 4]; 4]) -> Vec6<T> {
    let k = Mat3::from_rows(core::array::from_fn(|i| [m[i][0], m[i][1], m[i][2]]));
    Vec6::new(Vec3::new(m[0][3], m[1][3], m[2][3]), vee3(k))
}

/// The small adjoint `ad(ξ) = [[hat(φ), hat(ρ)], [0, hat(φ)]]`.
#[must_use]
pub fn ad<T: Real>(xi: Vec6<T>) -> Mat6<T> {
    let p = hat3(xi.tail);
    Mat6::from_blocks(p, hat3(xi.head), Mat3::zero(), p)
}

/// `ad(ξ)·v = (φ × v_ρ + ρ × v_φ, φ × v_φ)`, the Lie bracket `[ξ, v]`.
#[inline]
#[must_use]
pub fn ad_mul<T: Real>(xi: Vec6<T>, v: Vec6<T>) -> Vec6<T> {
    Vec6::new(
        xi.tail.cross(v.head) + xi.head.cross(v.tail),
        xi.tail.cross(v.tail),
    )
}

/// VJP of [`ad_mul`]: `(∂L/∂ξ, ∂L/∂v) = (−ad(v)ᵀ g, ad(ξ)ᵀ g)`, i.e.
/// `((v_φ × g_ρ, v_ρ × g_ρ + v_φ × g_φ), (g_ρ × φ, g_ρ × ρ + g_φ × φ))`.
#[inline]
#[must_use]
pub fn ad_mul_vjp<T: Real>(xi: Vec6<T>, v: Vec6<T>, g: Vec6<T>) -> (Vec6<T>, Vec6<T>) {
    let (gr, gp) = (g.head, g.tail);
    (
        Vec6::new(v.tail.cross(gr), v.head.cross(gr) + v.tail.cross(gp)),
        Vec6::new(gr.cross(xi.tail), gr.cross(xi.head) + gp.cross(xi.tail)),
    )
}

/// VJP of [`Se3::exp`]: given the (left) cotangent `g` of `Exp(ξ)`, returns
/// `∂L/∂ξ = Jl(ξ)ᵀ g`.
///
/// ```
/// use evogs_math::{Se3, Vec3, Vec6, se3::exp_vjp};
/// use evogs_math::diff::{central_gradient, GradCheck};
/// // L(T) = aᵀ·T·p: its left cotangent is (a, (T·p) × a).
/// let (a, p) = (Vec3::new(0.3, -1.0, 0.5), Vec3::new(1.0, 2.0, -0.5));
/// let xi = Vec6::new(Vec3::new(0.5, -0.2, 1.0), Vec3::new(0.3, 0.8, -0.4));
/// let g = Vec6::new(a, Se3::exp(xi).act(p).cross(a));
/// let mut x = xi.to_array();
/// let mut num = [0.0; 6];
/// central_gradient(|v: &[f64]| a.dot(Se3::exp(Vec6::from_slice(v)).act(p)), &mut x, &mut num);
/// assert!(GradCheck::new(1e-9, 1e-8).check(&exp_vjp(xi, g).to_array(), &num).passed());
/// ```
#[inline]
#[must_use]
pub fn exp_vjp<T: Real>(xi: Vec6<T>, g: Vec6<T>) -> Vec6<T> {
    jl_tr_mul(xi, g)
}

/// VJP of [`Se3::log`]: given the cotangent `g` of `ξ = Log(T)`, returns the left
/// cotangent `∂L/∂T = Jl(ξ)⁻ᵀ g`.
#[inline]
#[must_use]
pub fn log_vjp<T: Real>(x: Se3<T>, g: Vec6<T>) -> Vec6<T> {
    jl_inv_tr_mul(x.log(), g)
}

/// VJP of the composition `a * b`: `(∂L/∂a, ∂L/∂b) = (g, Ad(a)ᵀ g)`.
#[inline]
#[must_use]
pub fn compose_vjp<T: Real>(a: Se3<T>, _b: Se3<T>, g: Vec6<T>) -> (Vec6<T>, Vec6<T>) {
    (g, a.adjoint_tr_mul(g))
}

/// VJP of [`Se3::inverse`]: `∂L/∂T = −Ad(T⁻¹)ᵀ g`.
#[inline]
#[must_use]
pub fn inverse_vjp<T: Real>(x: Se3<T>, g: Vec6<T>) -> Vec6<T> {
    -x.inverse().adjoint_tr_mul(g)
}

/// VJP of [`Se3::act`]: with `q = T·p`, `(∂L/∂T, ∂L/∂p) = ((g, q × g), Rᵀ g)`.
#[inline]
#[must_use]
pub fn act_vjp<T: Real>(x: Se3<T>, p: Vec3<T>, g: Vec3<T>) -> (Vec6<T>, Vec3<T>) {
    (Vec6::new(g, x.act(p).cross(g)), x.rotation.inverse().act(g))
}

/// VJP of [`Se3::adjoint_mul`]: with `y = Ad(T)·v`,
/// `(∂L/∂T, ∂L/∂v) = (−ad(y)ᵀ g, Ad(T)ᵀ g)`.
#[inline]
#[must_use]
pub fn adjoint_mul_vjp<T: Real>(x: Se3<T>, v: Vec6<T>, g: Vec6<T>) -> (Vec6<T>, Vec6<T>) {
    let y = x.adjoint_mul(v);
    let d_x = Vec6::new(
        y.tail.cross(g.head),
        y.head.cross(g.head) + y.tail.cross(g.tail),
    );
    (d_x, x.adjoint_tr_mul(g))
}

/// Converts the gradient of a loss written on the stored numbers of `x` (`d_q = ∂L/∂q`
/// for the **unit** quaternion, `d_t = ∂L/∂t`) into the left cotangent
/// `(d_t, ½·vec(d_q ⊗ q*) + t × d_t)`.
///
/// (`Exp(δ)·T` moves `q` by `½(0, δ_φ) ⊗ q` and `t` by `δ_ρ + δ_φ × t`; the radial part of
/// `d_q` has no effect.)
#[inline]
#[must_use]
pub fn left_cotangent_from_ambient<T: Real>(x: Se3<T>, d_q: Quat<T>, d_t: Vec3<T>) -> Vec6<T> {
    let rot = crate::update::left_cotangent_from_ambient(x.quat(), d_q);
    Vec6::new(d_t, rot + x.translation.cross(d_t))
}

/// `f32` transform.
pub type Se3f = Se3<f32>;
/// `f64` transform.
pub type Se3d = Se3<f64>;

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Se3<f64> {
        Se3::exp(Vec6::from_array([0.4, -1.1, 0.7, 0.9, -0.3, 1.6]))
    }

    #[test]
    fn renormalize_keeps_the_transform() {
        let x = sample();
        let y = x.renormalize();
        assert!((y.log() - x.log()).norm() < 1e-15, "same transform");
        assert!((y.quat().norm() - 1.0).abs() < 1e-15, "unit quaternion");
    }

    #[test]
    fn matrix_round_trip_and_hat_vee() {
        let x = sample();
        let back = Se3::from_matrix(&x.to_matrix());
        assert!((back.log() - x.log()).norm() < 1e-14, "matrix round trip");
        let xi = Vec6::from_array([0.1, 0.2, -0.3, 1.0, -2.0, 0.5]);
        assert!(vee(&hat(xi)) == xi, "vee(hat(ξ)) = ξ");
        let mut buf = [0.0; 7];
        x.write_to(&mut buf);
        assert!(Se3::from_slice(&buf) == x, "slice round trip");
    }

    #[test]
    fn adjoint_conjugates_hat() {
        // Ad(T)·ξ = vee(T hat(ξ) T⁻¹), computed with 4×4 matrices.
        let x = sample();
        let xi = Vec6::from_array([0.3, -0.8, 0.2, -0.5, 0.4, 1.2]);
        let mul = |a: [[f64; 4]; 4], b: [[f64; 4]; 4]| -> [[f64; 4]; 4] {
            core::array::from_fn(|i| {
                core::array::from_fn(|j| (0..4).map(|k| a[i][k] * b[k][j]).sum())
            })
        };
        let conj = mul(mul(x.to_matrix(), hat(xi)), x.inverse().to_matrix());
        let want = vee(&conj);
        assert!((x.adjoint_mul(xi) - want).norm() < 1e-14, "Ad ξ");
        assert!((x.adjoint().mul_vec(xi) - want).norm() < 1e-14, "Ad matrix");
        assert!(
            (x.adjoint_tr_mul(xi) - x.adjoint().tr_mul_vec(xi)).norm() < 1e-14,
            "Adᵀ"
        );
        assert!(
            (ad_mul(xi, want) - ad(xi).mul_vec(want)).norm() < 1e-15,
            "ad"
        );
    }

    #[test]
    fn log_wraps_beyond_pi() {
        let phi = Vec3::new(0.0, 0.0, 4.0);
        let x = Se3::exp(Vec6::new(Vec3::new(1.0, 2.0, 3.0), phi));
        let l = x.log();
        assert!(
            (l.tail.norm() - (2.0 * core::f64::consts::PI - 4.0)).abs() < 1e-14,
            "angle 2π − 4"
        );
        let back = Se3::exp(l);
        assert!(
            (back.act(Vec3::new(0.3, 0.1, -0.2)) - x.act(Vec3::new(0.3, 0.1, -0.2))).norm() < 1e-14,
            "same transform"
        );
    }
}
