//! Fixed-size matrices [`Mat2`], [`Mat3`] and [`Mat6`] over any [`Real`].
//!
//! Storage is **row-major**: `m[r][c]` is the entry in row `r`, column `c`, exactly as the
//! formulas in the docs are written. (glam is column-major and nalgebra's storage is
//! column-major too; the interop modules convert explicitly.)

use crate::{Real, Vec2, Vec3, Vec6};
use core::ops::{Add, AddAssign, Mul, Neg, Sub};

/// A 2×2 matrix, row-major (`m[row][col]`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Mat2<T> {
    /// Entries, `m[row][col]`.
    pub m: [[T; 2]; 2],
}

/// A 3×3 matrix, row-major (`m[row][col]`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Mat3<T> {
    /// Entries, `m[row][col]`.
    pub m: [[T; 3]; 3],
}

/// A 6×6 matrix, row-major (`m[row][col]`): the SE(3) adjoints and Jacobians, which act
/// on [`Vec6`] tangents ξ = (ρ, φ). Usually built from four 3×3 blocks
/// ([`Mat6::from_blocks`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Mat6<T> {
    /// Entries, `m[row][col]`.
    pub m: [[T; 6]; 6],
}

impl<T: Real> Mat2<T> {
    /// A matrix from its rows.
    #[inline]
    #[must_use]
    pub const fn from_rows(m: [[T; 2]; 2]) -> Self {
        Self { m }
    }
    /// The zero matrix.
    #[inline]
    #[must_use]
    pub const fn zero() -> Self {
        Self {
            m: [[T::ZERO; 2]; 2],
        }
    }
    /// The identity.
    #[inline]
    #[must_use]
    pub const fn identity() -> Self {
        Self {
            m: [[T::ONE, T::ZERO], [T::ZERO, T::ONE]],
        }
    }
    /// Transpose.
    #[inline]
    #[must_use]
    pub fn transpose(self) -> Self {
        let m = self.m;
        Self {
            m: [[m[0][0], m[1][0]], [m[0][1], m[1][1]]],
        }
    }
    /// Determinant.
    #[inline]
    #[must_use]
    pub fn det(self) -> T {
        self.m[0][0] * self.m[1][1] - self.m[0][1] * self.m[1][0]
    }
    /// Matrix-vector product.
    #[inline]
    #[must_use]
    pub fn mul_vec(self, v: Vec2<T>) -> Vec2<T> {
        Vec2::new(
            self.m[0][0] * v.x + self.m[0][1] * v.y,
            self.m[1][0] * v.x + self.m[1][1] * v.y,
        )
    }
}

impl<T: Real> Mat3<T> {
    /// A matrix from its rows.
    #[inline]
    #[must_use]
    pub const fn from_rows(m: [[T; 3]; 3]) -> Self {
        Self { m }
    }
    /// A matrix from three column vectors.
    #[inline]
    #[must_use]
    pub const fn from_cols(c0: Vec3<T>, c1: Vec3<T>, c2: Vec3<T>) -> Self {
        Self {
            m: [[c0.x, c1.x, c2.x], [c0.y, c1.y, c2.y], [c0.z, c1.z, c2.z]],
        }
    }
    /// The zero matrix.
    #[inline]
    #[must_use]
    pub const fn zero() -> Self {
        Self {
            m: [[T::ZERO; 3]; 3],
        }
    }
    /// The identity.
    #[inline]
    #[must_use]
    pub const fn identity() -> Self {
        Self::diag(Vec3::new(T::ONE, T::ONE, T::ONE))
    }
    /// A diagonal matrix.
    #[inline]
    #[must_use]
    pub const fn diag(d: Vec3<T>) -> Self {
        Self {
            m: [
                [d.x, T::ZERO, T::ZERO],
                [T::ZERO, d.y, T::ZERO],
                [T::ZERO, T::ZERO, d.z],
            ],
        }
    }
    /// The outer product `a bᵀ`.
    #[inline]
    #[must_use]
    pub fn outer(a: Vec3<T>, b: Vec3<T>) -> Self {
        Self {
            m: [
                [a.x * b.x, a.x * b.y, a.x * b.z],
                [a.y * b.x, a.y * b.y, a.y * b.z],
                [a.z * b.x, a.z * b.y, a.z * b.z],
            ],
        }
    }
    /// Row `r` as a vector.
    #[inline]
    #[must_use]
    pub fn row(self, r: usize) -> Vec3<T> {
        Vec3::from_array(self.m[r])
    }
    /// Column `c` as a vector.
    #[inline]
    #[must_use]
    pub fn col(self, c: usize) -> Vec3<T> {
        Vec3::new(self.m[0][c], self.m[1][c], self.m[2][c])
    }
    /// Transpose.
    #[inline]
    #[must_use]
    pub fn transpose(self) -> Self {
        let m = self.m;
        Self {
            m: [
                [m[0][0], m[1][0], m[2][0]],
                [m[0][1], m[1][1], m[2][1]],
                [m[0][2], m[1][2], m[2][2]],
            ],
        }
    }
    /// Trace.
    #[inline]
    #[must_use]
    pub fn trace(self) -> T {
        self.m[0][0] + self.m[1][1] + self.m[2][2]
    }
    /// Determinant.
    #[inline]
    #[must_use]
    pub fn det(self) -> T {
        let m = self.m;
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    }
    /// Inverse by the adjugate; `None` if the determinant is zero or not finite.
    #[must_use]
    pub fn inverse(self) -> Option<Self> {
        let d = self.det();
        if d == T::ZERO || !d.is_finite() {
            return None;
        }
        let m = self.m;
        let inv = T::ONE / d;
        let c = |r0: usize, c0: usize, r1: usize, c1: usize| {
            m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]
        };
        Some(Self {
            m: [
                [
                    c(1, 1, 2, 2) * inv,
                    -c(0, 1, 2, 2) * inv,
                    c(0, 1, 1, 2) * inv,
                ],
                [
                    -c(1, 0, 2, 2) * inv,
                    c(0, 0, 2, 2) * inv,
                    -c(0, 0, 1, 2) * inv,
                ],
                [
                    c(1, 0, 2, 1) * inv,
                    -c(0, 0, 2, 1) * inv,
                    c(0, 0, 1, 1) * inv,
                ],
            ],
        })
    }
    /// Matrix-vector product `M v`.
    #[inline]
    #[must_use]
    pub fn mul_vec(self, v: Vec3<T>) -> Vec3<T> {
        Vec3::new(self.row(0).dot(v), self.row(1).dot(v), self.row(2).dot(v))
    }
    /// Transposed product `Mᵀ v`.
    #[inline]
    #[must_use]
    pub fn tr_mul_vec(self, v: Vec3<T>) -> Vec3<T> {
        self.row(0) * v.x + self.row(1) * v.y + self.row(2) * v.z
    }
    /// Matrix product `self · o`.
    #[inline]
    #[must_use]
    pub fn mul_mat(self, o: Self) -> Self {
        let mut r = Self::zero();
        for i in 0..3 {
            for j in 0..3 {
                r.m[i][j] =
                    self.m[i][0] * o.m[0][j] + self.m[i][1] * o.m[1][j] + self.m[i][2] * o.m[2][j];
            }
        }
        r
    }
    /// Scales every entry.
    #[inline]
    #[must_use]
    pub fn scale(self, s: T) -> Self {
        let mut r = self;
        for row in &mut r.m {
            for e in row {
                *e *= s;
            }
        }
        r
    }
    /// Frobenius inner product `Σ_ij A_ij B_ij`.
    #[inline]
    #[must_use]
    pub fn frobenius_dot(self, o: Self) -> T {
        let mut s = T::ZERO;
        for i in 0..3 {
            for j in 0..3 {
                s += self.m[i][j] * o.m[i][j];
            }
        }
        s
    }
    /// Largest absolute entry.
    #[must_use]
    pub fn max_abs(self) -> T {
        let mut s = T::ZERO;
        for row in self.m {
            for e in row {
                s = s.max(e.abs());
            }
        }
        s
    }
    /// Entries as a flat row-major array.
    #[inline]
    #[must_use]
    pub fn to_flat(self) -> [T; 9] {
        let m = self.m;
        [
            m[0][0], m[0][1], m[0][2], m[1][0], m[1][1], m[1][2], m[2][0], m[2][1], m[2][2],
        ]
    }
    /// A matrix from a flat row-major array.
    #[inline]
    #[must_use]
    pub fn from_flat(a: [T; 9]) -> Self {
        Self {
            m: [[a[0], a[1], a[2]], [a[3], a[4], a[5]], [a[6], a[7], a[8]]],
        }
    }
    /// Converts the scalar type (through `f64`).
    #[must_use]
    pub fn cast<U: Real>(self) -> Mat3<U> {
        let mut r = Mat3::<U>::zero();
        for i in 0..3 {
            for j in 0..3 {
                r.m[i][j] = U::from_f64(self.m[i][j].to_f64());
            }
        }
        r
    }
}

impl<T: Real> Add for Mat3<T> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        let mut r = self;
        r += o;
        r
    }
}
impl<T: Real> AddAssign for Mat3<T> {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        for i in 0..3 {
            for j in 0..3 {
                self.m[i][j] += o.m[i][j];
            }
        }
    }
}
impl<T: Real> Sub for Mat3<T> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        self + (-o)
    }
}
impl<T: Real> Neg for Mat3<T> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        self.scale(-T::ONE)
    }
}
impl<T: Real> Mul for Mat3<T> {
    type Output = Self;
    #[inline]
    fn mul(self, o: Self) -> Self {
        self.mul_mat(o)
    }
}
impl<T: Real> Mul<Vec3<T>> for Mat3<T> {
    type Output = Vec3<T>;
    #[inline]
    fn mul(self, v: Vec3<T>) -> Vec3<T> {
        self.mul_vec(v)
    }
}

impl<T: Real> Mat6<T> {
    /// The zero matrix.
    #[inline]
    #[must_use]
    pub const fn zero() -> Self {
        Self {
            m: [[T::ZERO; 6]; 6],
        }
    }
    /// The identity.
    #[must_use]
    pub fn identity() -> Self {
        let mut r = Self::zero();
        for i in 0..6 {
            r.m[i][i] = T::ONE;
        }
        r
    }
    /// A matrix from its rows.
    #[inline]
    #[must_use]
    pub const fn from_rows(m: [[T; 6]; 6]) -> Self {
        Self { m }
    }
    /// The block matrix `[[a, b], [c, d]]` of four 3×3 blocks.
    #[must_use]
    pub fn from_blocks(a: Mat3<T>, b: Mat3<T>, c: Mat3<T>, d: Mat3<T>) -> Self {
        let mut r = Self::zero();
        for i in 0..3 {
            for j in 0..3 {
                r.m[i][j] = a.m[i][j];
                r.m[i][j + 3] = b.m[i][j];
                r.m[i + 3][j] = c.m[i][j];
                r.m[i + 3][j + 3] = d.m[i][j];
            }
        }
        r
    }
    /// The 3×3 block in block row `br` and block column `bc` (each 0 or 1).
    #[must_use]
    pub fn block(self, br: usize, bc: usize) -> Mat3<T> {
        let mut r = Mat3::zero();
        for i in 0..3 {
            for j in 0..3 {
                r.m[i][j] = self.m[3 * br + i][3 * bc + j];
            }
        }
        r
    }
    /// Transpose.
    #[must_use]
    pub fn transpose(self) -> Self {
        let mut r = Self::zero();
        for i in 0..6 {
            for j in 0..6 {
                r.m[i][j] = self.m[j][i];
            }
        }
        r
    }
    /// Matrix-vector product `M v`.
    #[must_use]
    pub fn mul_vec(self, v: Vec6<T>) -> Vec6<T> {
        let v = v.to_array();
        Vec6::from_array(core::array::from_fn(|i| {
            (0..6).map(|j| self.m[i][j] * v[j]).sum()
        }))
    }
    /// Transposed product `Mᵀ v`.
    #[must_use]
    pub fn tr_mul_vec(self, v: Vec6<T>) -> Vec6<T> {
        let v = v.to_array();
        Vec6::from_array(core::array::from_fn(|j| {
            (0..6).map(|i| self.m[i][j] * v[i]).sum()
        }))
    }
    /// Matrix product `self · o`.
    #[must_use]
    pub fn mul_mat(self, o: Self) -> Self {
        let mut r = Self::zero();
        for i in 0..6 {
            for j in 0..6 {
                r.m[i][j] = (0..6).map(|k| self.m[i][k] * o.m[k][j]).sum();
            }
        }
        r
    }
    /// Scales every entry.
    #[must_use]
    pub fn scale(self, s: T) -> Self {
        let mut r = self;
        for e in r.m.as_flattened_mut() {
            *e *= s;
        }
        r
    }
    /// Largest absolute entry.
    #[must_use]
    pub fn max_abs(self) -> T {
        self.m
            .as_flattened()
            .iter()
            .fold(T::ZERO, |s, e| s.max(e.abs()))
    }
    /// Converts the scalar type (through `f64`).
    #[must_use]
    pub fn cast<U: Real>(self) -> Mat6<U> {
        Mat6 {
            m: self.m.map(|row| row.map(|e| U::from_f64(e.to_f64()))),
        }
    }
}

impl<T: Real> Add for Mat6<T> {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        let mut r = self;
        for (a, b) in r.m.as_flattened_mut().iter_mut().zip(o.m.as_flattened()) {
            *a += *b;
        }
        r
    }
}
impl<T: Real> Sub for Mat6<T> {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        self + (-o)
    }
}
impl<T: Real> Neg for Mat6<T> {
    type Output = Self;
    fn neg(self) -> Self {
        self.scale(-T::ONE)
    }
}
impl<T: Real> Mul for Mat6<T> {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        self.mul_mat(o)
    }
}
impl<T: Real> Mul<Vec6<T>> for Mat6<T> {
    type Output = Vec6<T>;
    fn mul(self, v: Vec6<T>) -> Vec6<T> {
        self.mul_vec(v)
    }
}

/// `f32` 3×3 matrix.
pub type Mat3f = Mat3<f32>;
/// `f64` 3×3 matrix.
pub type Mat3d = Mat3<f64>;
/// `f32` 6×6 matrix.
pub type Mat6f = Mat6<f32>;
/// `f64` 6×6 matrix.
pub type Mat6d = Mat6<f64>;

#[cfg(test)]
mod tests {
    use super::Mat3;
    use crate::Vec3;

    #[test]
    fn inverse_times_matrix_is_identity() {
        let a = Mat3::from_rows([[2.0, 0.3, -1.0], [0.5, 1.5, 0.2], [-0.4, 0.1, 3.0]]);
        let i = a.inverse().expect("invertible") * a;
        assert!((i - Mat3::identity()).max_abs() < 1e-14, "A⁻¹A = I");
        assert!(
            Mat3::<f64>::zero().inverse().is_none(),
            "singular gives None"
        );
    }

    #[test]
    fn mat6_blocks_products_and_transpose() {
        use super::Mat6;
        use crate::Vec6;
        let a = Mat3::from_rows([[2.0, 0.3, -1.0], [0.5, 1.5, 0.2], [-0.4, 0.1, 3.0]]);
        let b = Mat3::from_rows([[0.1, -0.7, 0.4], [1.2, 0.0, -0.3], [0.6, 0.9, -1.1]]);
        let m = Mat6::from_blocks(a, b, Mat3::zero(), a.transpose());
        assert!(
            m.block(0, 1) == b && m.block(1, 1) == a.transpose(),
            "blocks"
        );
        let v = Vec6::from_array([0.3, -0.2, 0.9, 1.1, -0.4, 0.25]);
        let mv = m.mul_vec(v);
        let want_head = a.mul_vec(v.head) + b.mul_vec(v.tail);
        assert!((mv.head - want_head).norm() < 1e-15, "block product");
        assert!(
            (m.tr_mul_vec(v) - m.transpose().mul_vec(v)).norm() < 1e-15,
            "Mᵀv"
        );
        let mm = m * m;
        assert!((mm.block(0, 0) - a * a).max_abs() < 1e-15, "block of M²");
        assert!(((m * Mat6::identity()) - m).max_abs() == 0.0, "identity");
    }

    // Entry-wise references on small integers: every product and sum below is exact in
    // f64, so each operation is compared bit for bit, and the entries are distinct enough
    // that a changed operator or index changes a result.
    const A3: [[f64; 3]; 3] = [[2.0, 3.0, 1.0], [1.0, 2.0, 1.0], [1.0, 1.0, 1.0]]; // det 1
    const B3: [[f64; 3]; 3] = [[5.0, -7.0, 11.0], [-13.0, 17.0, 19.0], [23.0, -29.0, 31.0]];

    fn same<const R: usize, const C: usize>(a: [[f64; C]; R], b: [[f64; C]; R], what: &str) {
        assert_eq!(
            a.map(|r| r.map(f64::to_bits)),
            b.map(|r| r.map(f64::to_bits)),
            "{what}"
        );
    }

    fn product<const N: usize>(a: [[f64; N]; N], b: [[f64; N]; N]) -> [[f64; N]; N] {
        core::array::from_fn(|i| core::array::from_fn(|j| (0..N).map(|k| a[i][k] * b[k][j]).sum()))
    }

    fn times<const N: usize>(a: [[f64; N]; N], v: [f64; N]) -> [f64; N] {
        core::array::from_fn(|i| (0..N).map(|k| a[i][k] * v[k]).sum())
    }

    fn transposed<const N: usize>(a: [[f64; N]; N]) -> [[f64; N]; N] {
        core::array::from_fn(|i| core::array::from_fn(|j| a[j][i]))
    }

    fn entrywise<const N: usize>(
        a: [[f64; N]; N],
        b: [[f64; N]; N],
        f: impl Fn(f64, f64) -> f64,
    ) -> [[f64; N]; N] {
        core::array::from_fn(|i| core::array::from_fn(|j| f(a[i][j], b[i][j])))
    }

    #[test]
    fn mat2_operations_match_their_formulas() {
        use super::Mat2;
        use crate::Vec2;
        let a = Mat2::from_rows([[2.0, 3.0], [5.0, 7.0]]);
        same(a.transpose().m, [[2.0, 5.0], [3.0, 7.0]], "transpose");
        assert_eq!(a.det().to_bits(), (-1.0_f64).to_bits(), "2·7 − 3·5");
        let v = a.mul_vec(Vec2::new(11.0, 13.0));
        assert_eq!(
            [v.x, v.y].map(f64::to_bits),
            [61.0_f64, 146.0].map(f64::to_bits),
            "A v"
        );
        same(
            Mat2::<f64>::identity().m,
            [[1.0, 0.0], [0.0, 1.0]],
            "identity",
        );
        same(Mat2::<f64>::zero().m, [[0.0; 2]; 2], "zero");
    }

    #[test]
    fn mat3_operations_match_their_formulas() {
        let (a, b) = (Mat3::from_rows(A3), Mat3::from_rows(B3));
        let v = Vec3::new(3.0, -5.0, 7.0);
        same(a.transpose().m, transposed(A3), "transpose");
        same((a * b).m, product(A3, B3), "A B");
        same(a.mul_mat(b).m, product(A3, B3), "mul_mat");
        same([(a * v).to_array()], [times(A3, v.to_array())], "A v");
        same(
            [a.tr_mul_vec(v).to_array()],
            [times(transposed(A3), v.to_array())],
            "Aᵀ v",
        );
        same((a + b).m, entrywise(A3, B3, |x, y| x + y), "A + B");
        let mut c = a;
        c += b;
        same(c.m, entrywise(A3, B3, |x, y| x + y), "A += B");
        same((a - b).m, entrywise(A3, B3, |x, y| x - y), "A − B");
        same((-b).m, B3.map(|r| r.map(|x| -x)), "−B");
        same(b.scale(3.0).m, B3.map(|r| r.map(|x| 3.0 * x)), "3 B");
        let fro: f64 = A3
            .iter()
            .flatten()
            .zip(B3.iter().flatten())
            .map(|(x, y)| x * y)
            .sum();
        assert_eq!(a.frobenius_dot(b).to_bits(), fro.to_bits(), "⟨A, B⟩");
        assert_eq!(b.max_abs().to_bits(), 31.0_f64.to_bits(), "max |b_ij|");
        assert_eq!(a.trace().to_bits(), 5.0_f64.to_bits(), "2 + 2 + 1");
        assert_eq!(b.trace().to_bits(), 53.0_f64.to_bits(), "5 + 17 + 31");
        assert_eq!(a.det().to_bits(), 1.0_f64.to_bits(), "det A");
        // det B by the rule of Sarrus.
        let m = B3;
        let sarrus =
            m[0][0] * m[1][1] * m[2][2] + m[0][1] * m[1][2] * m[2][0] + m[0][2] * m[1][0] * m[2][1]
                - m[0][2] * m[1][1] * m[2][0]
                - m[0][0] * m[1][2] * m[2][1]
                - m[0][1] * m[1][0] * m[2][2];
        assert_eq!(b.det().to_bits(), sarrus.to_bits(), "det B");
        // det A = 1: the inverse is the adjugate, in integers (its zero cofactor is negated).
        same(
            a.inverse().expect("invertible").m,
            [[1.0, -2.0, 1.0], [-0.0, 1.0, -1.0], [-1.0, 1.0, 1.0]],
            "A⁻¹",
        );
        let w = Vec3::new(2.0, -3.0, 4.0);
        let outer: [[f64; 3]; 3] =
            core::array::from_fn(|i| core::array::from_fn(|j| v.to_array()[i] * w.to_array()[j]));
        same(Mat3::outer(v, w).m, outer, "v wᵀ");
        for k in 0..3 {
            same([b.row(k).to_array()], [B3[k]], "row");
            same([b.col(k).to_array()], [transposed(B3)[k]], "col");
        }
        same(
            Mat3::from_cols(b.col(0), b.col(1), b.col(2)).m,
            B3,
            "from_cols",
        );
        same(
            Mat3::diag(v).m,
            [[3.0, 0.0, 0.0], [0.0, -5.0, 0.0], [0.0, 0.0, 7.0]],
            "diag",
        );
        same(Mat3::from_flat(b.to_flat()).m, B3, "flat round trip");
        assert_eq!(b.to_flat()[5].to_bits(), 19.0_f64.to_bits(), "row-major");
        let f: Mat3<f32> = b.cast();
        same(f.cast::<f64>().m, B3, "cast to f32 and back");
    }

    #[test]
    fn mat6_operations_match_their_formulas() {
        use super::Mat6;
        use crate::Vec6;
        let m6: [[f64; 6]; 6] = core::array::from_fn(|i| {
            core::array::from_fn(|j| {
                let (i, j) = (i as f64, j as f64);
                (3.0 * i + 7.0 * j + i * j) % 17.0 - 8.0
            })
        });
        let n6: [[f64; 6]; 6] = core::array::from_fn(|i| {
            core::array::from_fn(|j| {
                let (i, j) = (i as f64, j as f64);
                (5.0 * i - 2.0 * j + 2.0 * i * j) % 13.0 + 1.0
            })
        });
        let (m, n) = (Mat6::from_rows(m6), Mat6::from_rows(n6));
        same(
            Mat6::<f64>::identity().m,
            core::array::from_fn(|i| core::array::from_fn(|j| if i == j { 1.0 } else { 0.0 })),
            "identity",
        );
        same(m.transpose().m, transposed(m6), "transpose");
        same((m * n).m, product(m6, n6), "M N");
        same((m + n).m, entrywise(m6, n6, |x, y| x + y), "M + N");
        same((m - n).m, entrywise(m6, n6, |x, y| x - y), "M − N");
        same((-m).m, m6.map(|r| r.map(|x| -x)), "−M");
        same(m.scale(-2.0).m, m6.map(|r| r.map(|x| -2.0 * x)), "−2 M");
        let top = m6.iter().flatten().fold(0.0_f64, |s, x| s.max(x.abs()));
        assert_eq!(m.max_abs().to_bits(), top.to_bits(), "max |m_ij|");
        let v = [1.0, -2.0, 3.0, -4.0, 5.0, -6.0];
        same(
            [(m * Vec6::from_array(v)).to_array()],
            [times(m6, v)],
            "M v",
        );
        same(
            [m.tr_mul_vec(Vec6::from_array(v)).to_array()],
            [times(transposed(m6), v)],
            "Mᵀ v",
        );
        for (br, bc) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
            let want: [[f64; 3]; 3] =
                core::array::from_fn(|i| core::array::from_fn(|j| m6[3 * br + i][3 * bc + j]));
            same(m.block(br, bc).m, want, "block");
        }
        let back = Mat6::from_blocks(m.block(0, 0), m.block(0, 1), m.block(1, 0), m.block(1, 1));
        same(back.m, m6, "from_blocks ∘ block");
        let f: Mat6<f32> = m.cast();
        same(f.cast::<f64>().m, m6, "cast to f32 and back");
    }

    #[test]
    fn transposed_product() {
        let a = Mat3::from_rows([[2.0, 0.3, -1.0], [0.5, 1.5, 0.2], [-0.4, 0.1, 3.0]]);
        let v = Vec3::new(0.2, -0.7, 1.3);
        let d = a.tr_mul_vec(v) - a.transpose().mul_vec(v);
        assert!(d.norm() < 1e-15, "Aᵀv two ways");
    }
}
