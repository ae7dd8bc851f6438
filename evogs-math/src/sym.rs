//! Symmetric matrices [`Sym2`] and [`Sym3`], stored as their unique entries.
//!
//! **Cotangent convention.** A gradient "with respect to a `Sym3`" is the gradient with
//! respect to the six *stored* numbers, where each off-diagonal number appears twice in the
//! full matrix. If `G` is the adjoint of the full 3×3 matrix, the stored adjoint is
//! `xx = G₀₀`, `xy = G₀₁ + G₁₀`, … ([`Sym3::from_full_adjoint`]). Mixing this up with the
//! per-entry convention is the classic factor-2 bug of splatting code (`docs/splatting.md` §3
//! and §8).

use crate::{Mat2, Mat3, Real, Vec2, Vec3};

/// A symmetric 2×2 matrix `[[xx, xy], [xy, yy]]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sym2<T> {
    /// Entry (0, 0).
    pub xx: T,
    /// Entries (0, 1) and (1, 0).
    pub xy: T,
    /// Entry (1, 1).
    pub yy: T,
}

/// A symmetric 3×3 matrix `[[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Sym3<T> {
    /// Entry (0, 0).
    pub xx: T,
    /// Entries (0, 1) and (1, 0).
    pub xy: T,
    /// Entries (0, 2) and (2, 0).
    pub xz: T,
    /// Entry (1, 1).
    pub yy: T,
    /// Entries (1, 2) and (2, 1).
    pub yz: T,
    /// Entry (2, 2).
    pub zz: T,
}

impl<T: Real> Sym2<T> {
    /// A symmetric matrix from its unique entries.
    #[inline]
    #[must_use]
    pub const fn new(xx: T, xy: T, yy: T) -> Self {
        Self { xx, xy, yy }
    }
    /// The zero matrix.
    #[inline]
    #[must_use]
    pub const fn zero() -> Self {
        Self {
            xx: T::ZERO,
            xy: T::ZERO,
            yy: T::ZERO,
        }
    }
    /// Determinant `xx·yy − xy²`.
    #[inline]
    #[must_use]
    pub fn det(self) -> T {
        self.xx * self.yy - self.xy * self.xy
    }
    /// Inverse; `None` unless the determinant is positive and finite (a covariance).
    #[inline]
    #[must_use]
    pub fn inverse(self) -> Option<Self> {
        let d = self.det();
        if d > T::ZERO && d.is_finite() {
            let inv = T::ONE / d;
            Some(Self::new(self.yy * inv, -self.xy * inv, self.xx * inv))
        } else {
            None
        }
    }
    /// Matrix-vector product.
    #[inline]
    #[must_use]
    pub fn mul_vec(self, v: Vec2<T>) -> Vec2<T> {
        Vec2::new(self.xx * v.x + self.xy * v.y, self.xy * v.x + self.yy * v.y)
    }
    /// The full matrix.
    #[inline]
    #[must_use]
    pub fn to_mat(self) -> Mat2<T> {
        Mat2::from_rows([[self.xx, self.xy], [self.xy, self.yy]])
    }
    /// Stored-entry adjoint from the adjoint `g` of the full matrix (off-diagonals summed).
    #[inline]
    #[must_use]
    pub fn from_full_adjoint(g: Mat2<T>) -> Self {
        Self::new(g.m[0][0], g.m[0][1] + g.m[1][0], g.m[1][1])
    }
    /// Full-matrix adjoint (symmetric, off-diagonals halved) from a stored-entry adjoint.
    #[inline]
    #[must_use]
    pub fn to_full_adjoint(self) -> Mat2<T> {
        let h = self.xy * T::HALF;
        Mat2::from_rows([[self.xx, h], [h, self.yy]])
    }
}

impl<T: Real> Sym3<T> {
    /// A symmetric matrix from its unique entries.
    #[inline]
    #[must_use]
    pub const fn new(xx: T, xy: T, xz: T, yy: T, yz: T, zz: T) -> Self {
        Self {
            xx,
            xy,
            xz,
            yy,
            yz,
            zz,
        }
    }
    /// The zero matrix.
    #[inline]
    #[must_use]
    pub const fn zero() -> Self {
        Self {
            xx: T::ZERO,
            xy: T::ZERO,
            xz: T::ZERO,
            yy: T::ZERO,
            yz: T::ZERO,
            zz: T::ZERO,
        }
    }
    /// The full matrix.
    #[inline]
    #[must_use]
    pub fn to_mat(self) -> Mat3<T> {
        Mat3::from_rows([
            [self.xx, self.xy, self.xz],
            [self.xy, self.yy, self.yz],
            [self.xz, self.yz, self.zz],
        ])
    }
    /// The symmetric part `(M + Mᵀ)/2` of a full matrix.
    #[inline]
    #[must_use]
    pub fn from_mat_sym(m: Mat3<T>) -> Self {
        let h = T::HALF;
        let m = m.m;
        Self::new(
            m[0][0],
            (m[0][1] + m[1][0]) * h,
            (m[0][2] + m[2][0]) * h,
            m[1][1],
            (m[1][2] + m[2][1]) * h,
            m[2][2],
        )
    }
    /// Stored-entry adjoint from the adjoint `g` of the full matrix (off-diagonals summed).
    #[inline]
    #[must_use]
    pub fn from_full_adjoint(g: Mat3<T>) -> Self {
        let m = g.m;
        Self::new(
            m[0][0],
            m[0][1] + m[1][0],
            m[0][2] + m[2][0],
            m[1][1],
            m[1][2] + m[2][1],
            m[2][2],
        )
    }
    /// Full-matrix adjoint (symmetric, off-diagonals halved) from a stored-entry adjoint.
    #[inline]
    #[must_use]
    pub fn to_full_adjoint(self) -> Mat3<T> {
        let h = T::HALF;
        Self::new(
            self.xx,
            self.xy * h,
            self.xz * h,
            self.yy,
            self.yz * h,
            self.zz,
        )
        .to_mat()
    }
    /// Matrix-vector product.
    #[inline]
    #[must_use]
    pub fn mul_vec(self, v: Vec3<T>) -> Vec3<T> {
        self.to_mat().mul_vec(v)
    }
    /// Determinant.
    #[inline]
    #[must_use]
    pub fn det(self) -> T {
        self.to_mat().det()
    }
    /// The congruence `A Σ Aᵀ` (a change of frame for a covariance).
    #[inline]
    #[must_use]
    pub fn congruence(self, a: Mat3<T>) -> Self {
        let m = a.mul_mat(self.to_mat()).mul_mat(a.transpose());
        Self::new(
            m.m[0][0], m.m[0][1], m.m[0][2], m.m[1][1], m.m[1][2], m.m[2][2],
        )
    }
    /// The unique entries as an array `[xx, xy, xz, yy, yz, zz]`.
    #[inline]
    #[must_use]
    pub const fn to_array(self) -> [T; 6] {
        [self.xx, self.xy, self.xz, self.yy, self.yz, self.zz]
    }
    /// From the unique entries `[xx, xy, xz, yy, yz, zz]`.
    #[inline]
    #[must_use]
    pub const fn from_array(a: [T; 6]) -> Self {
        Self::new(a[0], a[1], a[2], a[3], a[4], a[5])
    }
}

#[cfg(test)]
mod tests {
    use super::{Sym2, Sym3};
    use crate::Mat3;

    #[test]
    fn stored_adjoint_round_trip() {
        let s = Sym3::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0);
        let back = Sym3::from_full_adjoint(s.to_full_adjoint());
        assert_eq!(back, s, "stored -> full -> stored");
    }

    #[test]
    fn stored_adjoint_is_gradient_of_stored_entries() {
        // L = <G, S> with S built from stored entries: dL/dxy = G01 + G10.
        let g = Mat3::<f64>::from_rows([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]]);
        let a = Sym3::from_full_adjoint(g);
        assert!(
            (a.xy - 6.0).abs() < 1e-15 && (a.yz - 14.0).abs() < 1e-15,
            "off-diagonals summed"
        );
    }

    #[test]
    fn sym2_operations_match_their_formulas_on_small_integers() {
        let s = Sym2::<f64>::new(3.0, 2.0, 5.0);
        assert_eq!(s.det().to_bits(), 11.0_f64.to_bits(), "3·5 − 2²");
        // Exactly singular (det 0): no inverse, even though 1/0 is a number in floating
        // point.
        assert!(Sym2::<f64>::new(2.0, 2.0, 2.0).inverse().is_none(), "det 0");
        let inv = Sym2::<f64>::new(2.0, 1.0, 1.0).inverse().expect("det 1");
        assert_eq!(inv, Sym2::new(1.0, -1.0, 2.0), "the adjugate over det 1");
        let g = crate::Mat2::from_rows([[1.0, 2.0], [3.0, 4.0]]);
        assert_eq!(
            Sym2::from_full_adjoint(g),
            Sym2::new(1.0, 5.0, 4.0),
            "off-diagonals summed"
        );
        let full = Sym2::<f64>::new(1.0, 6.0, 4.0).to_full_adjoint();
        assert_eq!(full.m, [[1.0, 3.0], [3.0, 4.0]], "off-diagonals halved");
    }

    #[test]
    fn sym3_symmetric_part_and_congruence_match_their_formulas_on_small_integers() {
        let m = Mat3::<f64>::from_rows([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0], [7.0, 8.0, 9.0]]);
        assert_eq!(
            Sym3::from_mat_sym(m),
            Sym3::new(1.0, 3.0, 5.0, 5.0, 7.0, 9.0),
            "(M + Mᵀ)/2"
        );
        // A Σ Aᵀ with A a shear: entry by entry from the product written out.
        let s = Sym3::<f64>::new(1.0, 2.0, 3.0, 4.0, 5.0, 6.0);
        let a = Mat3::from_rows([[1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]]);
        // A Σ = [[3, 6, 8], [2, 4, 5], [6, 10, 12]]; (A Σ) Aᵀ:
        assert_eq!(
            s.congruence(a),
            Sym3::new(9.0, 6.0, 16.0, 4.0, 10.0, 24.0),
            "A Σ Aᵀ"
        );
    }

    #[test]
    fn sym2_inverse() {
        let s = Sym2::<f64>::new(2.0, 0.5, 1.0);
        let i = s.inverse().expect("positive definite");
        let p = s.to_mat().mul_vec(i.mul_vec(crate::Vec2::new(0.3, -0.2)));
        assert!(
            (p.x - 0.3).abs() < 1e-15 && (p.y + 0.2).abs() < 1e-15,
            "S S⁻¹ = I"
        );
        assert!(
            Sym2::new(1.0, 2.0, 1.0).inverse().is_none(),
            "indefinite gives None"
        );
    }
}
