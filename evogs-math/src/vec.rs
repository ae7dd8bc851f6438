//! Fixed-size vectors [`Vec2`], [`Vec3`] and [`Vec6`] over any [`Real`].
//!
//! Plain `Copy` structs with public fields and inherent methods (glam's style); the
//! scalar is a type parameter so the same code runs in `f32`, `f64` and dual numbers.

use crate::Real;
use core::ops::{Add, AddAssign, Index, IndexMut, Mul, MulAssign, Neg, Sub, SubAssign};

/// A 2-vector (pixel coordinates, 2D offsets).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vec2<T> {
    /// First component.
    pub x: T,
    /// Second component.
    pub y: T,
}

/// A 3-vector (positions, rotation vectors, angular velocities, log-scales).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vec3<T> {
    /// First component.
    pub x: T,
    /// Second component.
    pub y: T,
    /// Third component.
    pub z: T,
}

/// A 6-vector as two 3-vectors: entries 0–2 are `head`, entries 3–5 are `tail`.
///
/// Used for SE(3) tangents, twists and their cotangents, ordered **ξ = (ρ, φ)**:
/// `head` = ρ (translation part), `tail` = φ (rotation part), as in sophus
/// (see [`se3`](crate::se3)).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Vec6<T> {
    /// Entries 0–2 (ρ, the translation part of an SE(3) tangent).
    pub head: Vec3<T>,
    /// Entries 3–5 (φ, the rotation part of an SE(3) tangent).
    pub tail: Vec3<T>,
}

impl<T: Real> Vec2<T> {
    /// A vector from its components.
    #[inline]
    #[must_use]
    pub const fn new(x: T, y: T) -> Self {
        Self { x, y }
    }
    /// The zero vector.
    #[inline]
    #[must_use]
    pub const fn zero() -> Self {
        Self {
            x: T::ZERO,
            y: T::ZERO,
        }
    }
    /// Dot product.
    #[inline]
    #[must_use]
    pub fn dot(self, o: Self) -> T {
        self.x * o.x + self.y * o.y
    }
    /// Squared Euclidean norm.
    #[inline]
    #[must_use]
    pub fn norm_squared(self) -> T {
        self.dot(self)
    }
    /// Euclidean norm.
    #[inline]
    #[must_use]
    pub fn norm(self) -> T {
        self.norm_squared().sqrt()
    }
    /// Components as an array.
    #[inline]
    #[must_use]
    pub const fn to_array(self) -> [T; 2] {
        [self.x, self.y]
    }
    /// A vector from an array.
    #[inline]
    #[must_use]
    pub const fn from_array(a: [T; 2]) -> Self {
        Self { x: a[0], y: a[1] }
    }
    /// Converts the scalar type (through `f64`).
    #[inline]
    #[must_use]
    pub fn cast<U: Real>(self) -> Vec2<U> {
        Vec2::new(U::from_f64(self.x.to_f64()), U::from_f64(self.y.to_f64()))
    }
}

impl<T: Real> Vec3<T> {
    /// A vector from its components.
    #[inline]
    #[must_use]
    pub const fn new(x: T, y: T, z: T) -> Self {
        Self { x, y, z }
    }
    /// The zero vector.
    #[inline]
    #[must_use]
    pub const fn zero() -> Self {
        Self {
            x: T::ZERO,
            y: T::ZERO,
            z: T::ZERO,
        }
    }
    /// All three components equal to `v`.
    #[inline]
    #[must_use]
    pub const fn splat(v: T) -> Self {
        Self { x: v, y: v, z: v }
    }
    /// The unit vector along axis `i` (0, 1 or 2).
    #[inline]
    #[must_use]
    pub fn unit(i: usize) -> Self {
        let mut v = Self::zero();
        v[i] = T::ONE;
        v
    }
    /// Dot product.
    #[inline]
    #[must_use]
    pub fn dot(self, o: Self) -> T {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    /// Cross product `self × o`.
    #[inline]
    #[must_use]
    pub fn cross(self, o: Self) -> Self {
        Self::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }
    /// Squared Euclidean norm.
    #[inline]
    #[must_use]
    pub fn norm_squared(self) -> T {
        self.dot(self)
    }
    /// Euclidean norm.
    #[inline]
    #[must_use]
    pub fn norm(self) -> T {
        self.norm_squared().sqrt()
    }
    /// Component-wise product.
    #[inline]
    #[must_use]
    pub fn mul_elem(self, o: Self) -> Self {
        Self::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
    /// Component-wise map.
    #[inline]
    #[must_use]
    pub fn map(self, f: impl Fn(T) -> T) -> Self {
        Self::new(f(self.x), f(self.y), f(self.z))
    }
    /// Largest component.
    #[inline]
    #[must_use]
    pub fn max_elem(self) -> T {
        self.x.max(self.y).max(self.z)
    }
    /// `true` if every component is finite.
    #[inline]
    #[must_use]
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
    /// Components as an array.
    #[inline]
    #[must_use]
    pub const fn to_array(self) -> [T; 3] {
        [self.x, self.y, self.z]
    }
    /// A vector from an array.
    #[inline]
    #[must_use]
    pub const fn from_array(a: [T; 3]) -> Self {
        Self {
            x: a[0],
            y: a[1],
            z: a[2],
        }
    }
    /// A vector from the first three entries of a slice.
    ///
    /// # Panics
    /// If the slice is shorter than 3.
    #[inline]
    #[must_use]
    pub fn from_slice(s: &[T]) -> Self {
        Self {
            x: s[0],
            y: s[1],
            z: s[2],
        }
    }
    /// Writes the components into the first three entries of a slice.
    ///
    /// # Panics
    /// If the slice is shorter than 3.
    #[inline]
    pub fn write_to(self, s: &mut [T]) {
        s[0] = self.x;
        s[1] = self.y;
        s[2] = self.z;
    }
    /// Adds the components into the first three entries of a slice.
    ///
    /// # Panics
    /// If the slice is shorter than 3.
    #[inline]
    pub fn add_to(self, s: &mut [T]) {
        s[0] += self.x;
        s[1] += self.y;
        s[2] += self.z;
    }
    /// Converts the scalar type (through `f64`).
    #[inline]
    #[must_use]
    pub fn cast<U: Real>(self) -> Vec3<U> {
        Vec3::new(
            U::from_f64(self.x.to_f64()),
            U::from_f64(self.y.to_f64()),
            U::from_f64(self.z.to_f64()),
        )
    }
}

impl<T: Real> Vec6<T> {
    /// A vector from its two halves.
    #[inline]
    #[must_use]
    pub const fn new(head: Vec3<T>, tail: Vec3<T>) -> Self {
        Self { head, tail }
    }
    /// The zero vector.
    #[inline]
    #[must_use]
    pub const fn zero() -> Self {
        Self::new(Vec3::zero(), Vec3::zero())
    }
    /// The unit vector along axis `i` (0–5).
    #[inline]
    #[must_use]
    pub fn unit(i: usize) -> Self {
        let mut v = Self::zero();
        v[i] = T::ONE;
        v
    }
    /// Dot product.
    #[inline]
    #[must_use]
    pub fn dot(self, o: Self) -> T {
        self.head.dot(o.head) + self.tail.dot(o.tail)
    }
    /// Squared Euclidean norm.
    #[inline]
    #[must_use]
    pub fn norm_squared(self) -> T {
        self.dot(self)
    }
    /// Euclidean norm.
    #[inline]
    #[must_use]
    pub fn norm(self) -> T {
        self.norm_squared().sqrt()
    }
    /// Largest absolute component.
    #[inline]
    #[must_use]
    pub fn max_abs(self) -> T {
        self.to_array().iter().fold(T::ZERO, |m, x| m.max(x.abs()))
    }
    /// `true` if every component is finite.
    #[inline]
    #[must_use]
    pub fn is_finite(self) -> bool {
        self.head.is_finite() && self.tail.is_finite()
    }
    /// Components as an array.
    #[inline]
    #[must_use]
    pub const fn to_array(self) -> [T; 6] {
        let (h, t) = (self.head, self.tail);
        [h.x, h.y, h.z, t.x, t.y, t.z]
    }
    /// A vector from an array.
    #[inline]
    #[must_use]
    pub const fn from_array(a: [T; 6]) -> Self {
        Self::new(Vec3::new(a[0], a[1], a[2]), Vec3::new(a[3], a[4], a[5]))
    }
    /// A vector from the first six entries of a slice.
    ///
    /// # Panics
    /// If the slice is shorter than 6.
    #[inline]
    #[must_use]
    pub fn from_slice(s: &[T]) -> Self {
        Self::new(Vec3::from_slice(s), Vec3::from_slice(&s[3..]))
    }
    /// Writes the components into the first six entries of a slice.
    ///
    /// # Panics
    /// If the slice is shorter than 6.
    #[inline]
    pub fn write_to(self, s: &mut [T]) {
        self.head.write_to(s);
        self.tail.write_to(&mut s[3..]);
    }
    /// Adds the components into the first six entries of a slice.
    ///
    /// # Panics
    /// If the slice is shorter than 6.
    #[inline]
    pub fn add_to(self, s: &mut [T]) {
        self.head.add_to(s);
        self.tail.add_to(&mut s[3..]);
    }
    /// Converts the scalar type (through `f64`).
    #[inline]
    #[must_use]
    pub fn cast<U: Real>(self) -> Vec6<U> {
        Vec6::new(self.head.cast(), self.tail.cast())
    }
}

macro_rules! impl_vec_ops {
    ($V:ident { $($f:ident),+ }) => {
        impl<T: Real> Add for $V<T> {
            type Output = Self;
            #[inline]
            fn add(self, o: Self) -> Self {
                Self { $($f: self.$f + o.$f),+ }
            }
        }
        impl<T: Real> Sub for $V<T> {
            type Output = Self;
            #[inline]
            fn sub(self, o: Self) -> Self {
                Self { $($f: self.$f - o.$f),+ }
            }
        }
        impl<T: Real> Neg for $V<T> {
            type Output = Self;
            #[inline]
            fn neg(self) -> Self {
                Self { $($f: -self.$f),+ }
            }
        }
        impl<T: Real> Mul<T> for $V<T> {
            type Output = Self;
            #[inline]
            fn mul(self, s: T) -> Self {
                Self { $($f: self.$f * s),+ }
            }
        }
        impl<T: Real> AddAssign for $V<T> {
            #[inline]
            fn add_assign(&mut self, o: Self) {
                $(self.$f += o.$f;)+
            }
        }
        impl<T: Real> SubAssign for $V<T> {
            #[inline]
            fn sub_assign(&mut self, o: Self) {
                $(self.$f -= o.$f;)+
            }
        }
        impl<T: Real> MulAssign<T> for $V<T> {
            #[inline]
            fn mul_assign(&mut self, s: T) {
                $(self.$f *= s;)+
            }
        }
    };
}

impl_vec_ops!(Vec2 { x, y });
impl_vec_ops!(Vec3 { x, y, z });
impl_vec_ops!(Vec6 { head, tail });

impl<T> Index<usize> for Vec2<T> {
    type Output = T;
    #[inline]
    fn index(&self, i: usize) -> &T {
        match i {
            0 => &self.x,
            1 => &self.y,
            _ => panic!("Vec2 index {i} out of range"),
        }
    }
}
impl<T> IndexMut<usize> for Vec2<T> {
    #[inline]
    fn index_mut(&mut self, i: usize) -> &mut T {
        match i {
            0 => &mut self.x,
            1 => &mut self.y,
            _ => panic!("Vec2 index {i} out of range"),
        }
    }
}
impl<T> Index<usize> for Vec3<T> {
    type Output = T;
    #[inline]
    fn index(&self, i: usize) -> &T {
        match i {
            0 => &self.x,
            1 => &self.y,
            2 => &self.z,
            _ => panic!("Vec3 index {i} out of range"),
        }
    }
}
impl<T> IndexMut<usize> for Vec3<T> {
    #[inline]
    fn index_mut(&mut self, i: usize) -> &mut T {
        match i {
            0 => &mut self.x,
            1 => &mut self.y,
            2 => &mut self.z,
            _ => panic!("Vec3 index {i} out of range"),
        }
    }
}

impl<T> Index<usize> for Vec6<T> {
    type Output = T;
    #[inline]
    fn index(&self, i: usize) -> &T {
        match i {
            0..3 => &self.head[i],
            3..6 => &self.tail[i - 3],
            _ => panic!("Vec6 index {i} out of range"),
        }
    }
}
impl<T> IndexMut<usize> for Vec6<T> {
    #[inline]
    fn index_mut(&mut self, i: usize) -> &mut T {
        match i {
            0..3 => &mut self.head[i],
            3..6 => &mut self.tail[i - 3],
            _ => panic!("Vec6 index {i} out of range"),
        }
    }
}

/// `f32` 3-vector.
pub type Vec3f = Vec3<f32>;
/// `f64` 3-vector.
pub type Vec3d = Vec3<f64>;
/// `f32` 2-vector.
pub type Vec2f = Vec2<f32>;
/// `f64` 2-vector.
pub type Vec2d = Vec2<f64>;
/// `f32` 6-vector.
pub type Vec6f = Vec6<f32>;
/// `f64` 6-vector.
pub type Vec6d = Vec6<f64>;

#[cfg(test)]
mod tests {
    use super::{Vec2, Vec3, Vec6};

    fn bits<const N: usize>(a: [f64; N]) -> [u64; N] {
        a.map(f64::to_bits)
    }

    #[test]
    fn components_are_reached_by_index_each_in_its_own_slot() {
        let mut a = Vec2::<f64>::new(1.5, -2.5);
        assert_eq!(
            (a[0].to_bits(), a[1].to_bits()),
            (1.5_f64.to_bits(), (-2.5_f64).to_bits())
        );
        a[0] = 7.0;
        a[1] = 8.0;
        assert_eq!(bits(a.to_array()), bits([7.0, 8.0]), "Vec2 index_mut");

        let v = Vec6::<f64>::from_array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        for i in 0..6 {
            assert_eq!(v[i].to_bits(), v.to_array()[i].to_bits(), "Vec6 index {i}");
        }
        let mut w = Vec6::<f64>::zero();
        for i in 0..6 {
            w[i] = 10.0 + f64::from(u8::try_from(i).expect("small"));
        }
        assert_eq!(
            bits(w.to_array()),
            bits([10.0, 11.0, 12.0, 13.0, 14.0, 15.0]),
            "index_mut"
        );
        for i in 0..6 {
            let mut want = [0.0; 6];
            want[i] = 1.0;
            assert_eq!(
                bits(Vec6::<f64>::unit(i).to_array()),
                bits(want),
                "unit({i})"
            );
        }
    }

    #[test]
    fn finiteness_looks_at_every_component() {
        assert!(Vec3::<f64>::new(1.0, 2.0, 3.0).is_finite(), "finite");
        for i in 0..3 {
            for bad in [f64::NAN, f64::INFINITY] {
                let mut v = Vec3::<f64>::new(1.0, 2.0, 3.0);
                v[i] = bad;
                assert!(!v.is_finite(), "component {i} = {bad}");
            }
        }
        assert!(Vec6::<f64>::unit(2).is_finite(), "finite");
        for i in [0, 5] {
            let mut v = Vec6::<f64>::unit(2);
            v[i] = f64::NAN;
            assert!(!v.is_finite(), "entry {i} = NaN");
        }
    }

    #[test]
    fn add_to_accumulates_into_the_leading_entries_only() {
        let mut s = [1.0, 2.0, 3.0, 9.0];
        Vec3::<f64>::new(10.0, 20.0, 30.0).add_to(&mut s);
        assert_eq!(bits(s), bits([11.0, 22.0, 33.0, 9.0]), "Vec3");
        let mut s = [1.0; 7];
        Vec6::<f64>::from_array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]).add_to(&mut s);
        assert_eq!(bits(s), bits([2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 1.0]), "Vec6");
    }

    #[test]
    fn vec6_max_abs_and_cast() {
        let v = Vec6::<f64>::from_array([1.0, -7.0, 3.0, 2.0, -0.5, 4.0]);
        assert_eq!(v.max_abs().to_bits(), 7.0_f64.to_bits(), "largest |entry|");
        let c: Vec6<f32> = v.cast();
        assert_eq!(
            c.to_array().map(f32::to_bits),
            [1.0_f32, -7.0, 3.0, 2.0, -0.5, 4.0].map(f32::to_bits),
            "cast to f32"
        );
    }

    #[test]
    fn vec2_dot_and_norms_are_exact_on_small_integers() {
        // Distinct products in each slot, so a swapped operator changes the value.
        let a = Vec2::<f64>::new(3.0, 4.0);
        let b = Vec2::new(2.0, 5.0);
        assert_eq!(a.dot(b).to_bits(), 26.0_f64.to_bits(), "3·2 + 4·5");
        assert_eq!(a.norm_squared().to_bits(), 25.0_f64.to_bits(), "3² + 4²");
        assert_eq!(a.norm().to_bits(), 5.0_f64.to_bits(), "√25");
    }

    #[test]
    fn cross_is_orthogonal_and_right_handed() {
        let x = Vec3::<f64>::unit(0);
        let y = Vec3::<f64>::unit(1);
        let z = x.cross(y);
        assert!((z.z - 1.0).abs() < 1e-15 && z.x.abs() < 1e-15, "x × y = z");
        let a = Vec3::<f64>::new(0.3, -1.2, 2.0);
        let b = Vec3::new(1.1, 0.4, -0.7);
        assert!(a.cross(b).dot(a).abs() < 1e-14, "a × b ⟂ a");
    }
}
