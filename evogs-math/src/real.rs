//! The one scalar trait of evogs: [`Real`], implemented for `f32`, `f64` and
//! [`Dual<T>`](crate::Dual).
//!
//! Every kernel in the evogs crates is written once, generic over `T: Real`:
//! `f32` for rendering and training, `f64` for gradient checks, and
//! [`Dual<f64>`](crate::Dual) for forward-mode cross-checks. The method names match the
//! inherent methods of `f32`/`f64`, so generic code reads like concrete code.
//!
//! The float functions come from `num_traits::Float`, which forwards to `std` or to
//! `libm` depending on the crate features.

use core::fmt::Debug;
use core::iter::Sum;
use core::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// A real scalar: `f32`, `f64` or a dual number over one of them.
///
/// `from_f64` is infallible (constants are written `T::from_f64(0.5)`), and every
/// transcendental function of the evogs kernels is part of the trait so that
/// [`Dual`](crate::Dual) can propagate derivatives through it.
///
/// Comparisons (`PartialOrd`) of dual numbers compare their real parts, so branches taken
/// in generic code are the same for `f64` and `Dual<f64>`.
pub trait Real:
    Copy
    + PartialEq
    + PartialOrd
    + Debug
    + Default
    + Send
    + Sync
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
    + Sum
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// 2.
    const TWO: Self;
    /// 1/2.
    const HALF: Self;
    /// π.
    const PI: Self;
    /// Machine epsilon of the underlying float type.
    const EPSILON: Self;
    /// The largest finite value of the underlying float type.
    const MAX: Self;

    /// Converts from `f64` (rounding to nearest for `f32`).
    fn from_f64(x: f64) -> Self;
    /// Converts to `f64` (the real part for dual numbers).
    fn to_f64(self) -> f64;
    /// Converts a `usize` count or index to a scalar.
    #[inline]
    fn from_usize(n: usize) -> Self {
        Self::from_f64(n as f64)
    }
    /// Square root.
    fn sqrt(self) -> Self;
    /// Cube root.
    fn cbrt(self) -> Self;
    /// e^x.
    fn exp(self) -> Self;
    /// Natural logarithm.
    fn ln(self) -> Self;
    /// Sine.
    fn sin(self) -> Self;
    /// Cosine.
    fn cos(self) -> Self;
    /// Sine and cosine together.
    #[inline]
    fn sin_cos(self) -> (Self, Self) {
        (self.sin(), self.cos())
    }
    /// Tangent.
    fn tan(self) -> Self;
    /// Four-quadrant arctangent of `self / x`.
    fn atan2(self, x: Self) -> Self;
    /// Arccosine.
    fn acos(self) -> Self;
    /// Hyperbolic tangent.
    fn tanh(self) -> Self;
    /// Integer power.
    fn powi(self, n: i32) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// Largest integer not above `self` (zero derivative).
    fn floor(self) -> Self;
    /// Smallest integer not below `self` (zero derivative).
    fn ceil(self) -> Self;
    /// `true` if neither infinite nor NaN (for dual numbers: both parts).
    fn is_finite(self) -> bool;
    /// `true` if NaN (for dual numbers: either part).
    fn is_nan(self) -> bool;

    /// The larger of two values (the first if they compare equal or are unordered).
    #[inline]
    fn max(self, other: Self) -> Self {
        if other > self { other } else { self }
    }
    /// The smaller of two values (the first if they compare equal or are unordered).
    #[inline]
    fn min(self, other: Self) -> Self {
        if other < self { other } else { self }
    }
    /// `self` clamped to `[lo, hi]`.
    #[inline]
    fn clamp(self, lo: Self, hi: Self) -> Self {
        self.max(lo).min(hi)
    }
    /// x².
    #[inline]
    fn sq(self) -> Self {
        self * self
    }
    /// 1/x.
    #[inline]
    fn recip(self) -> Self {
        Self::ONE / self
    }
}

macro_rules! impl_real_float {
    ($t:ty, $pi:expr) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const TWO: Self = 2.0;
            const HALF: Self = 0.5;
            const PI: Self = $pi;
            const EPSILON: Self = <$t>::EPSILON;
            const MAX: Self = <$t>::MAX;

            #[inline]
            fn from_f64(x: f64) -> Self {
                #[allow(
                    clippy::cast_possible_truncation,
                    reason = "f64 -> f32 rounds to nearest by design"
                )]
                {
                    x as $t
                }
            }
            #[inline]
            fn to_f64(self) -> f64 {
                f64::from(self)
            }
            #[inline]
            fn sqrt(self) -> Self {
                num_traits::Float::sqrt(self)
            }
            #[inline]
            fn cbrt(self) -> Self {
                num_traits::Float::cbrt(self)
            }
            #[inline]
            fn exp(self) -> Self {
                num_traits::Float::exp(self)
            }
            #[inline]
            fn ln(self) -> Self {
                num_traits::Float::ln(self)
            }
            #[inline]
            fn sin(self) -> Self {
                num_traits::Float::sin(self)
            }
            #[inline]
            fn cos(self) -> Self {
                num_traits::Float::cos(self)
            }
            #[inline]
            fn sin_cos(self) -> (Self, Self) {
                num_traits::Float::sin_cos(self)
            }
            #[inline]
            fn tan(self) -> Self {
                num_traits::Float::tan(self)
            }
            #[inline]
            fn atan2(self, x: Self) -> Self {
                num_traits::Float::atan2(self, x)
            }
            #[inline]
            fn acos(self) -> Self {
                num_traits::Float::acos(self)
            }
            #[inline]
            fn tanh(self) -> Self {
                num_traits::Float::tanh(self)
            }
            #[inline]
            fn powi(self, n: i32) -> Self {
                num_traits::Float::powi(self, n)
            }
            #[inline]
            fn abs(self) -> Self {
                num_traits::Float::abs(self)
            }
            #[inline]
            fn floor(self) -> Self {
                num_traits::Float::floor(self)
            }
            #[inline]
            fn ceil(self) -> Self {
                num_traits::Float::ceil(self)
            }
            #[inline]
            fn is_finite(self) -> bool {
                num_traits::Float::is_finite(self)
            }
            #[inline]
            fn is_nan(self) -> bool {
                num_traits::Float::is_nan(self)
            }
        }
    };
}

impl_real_float!(f32, core::f32::consts::PI);
impl_real_float!(f64, core::f64::consts::PI);

#[cfg(test)]
mod tests {
    use super::Real;

    #[test]
    fn the_provided_methods_of_real_through_dual_numbers() {
        // f64 has inherent methods of these names: the trait's defaults are reached through
        // a type without them.
        use crate::Dual;
        let d = |re: f64, eps: f64| Dual::new(re, eps);
        let p = |x: Dual<f64>| (x.re.to_bits(), x.eps.to_bits());
        assert_eq!(
            p(Real::max(d(1.0, 5.0), d(1.0, 7.0))),
            p(d(1.0, 5.0)),
            "ties keep the first"
        );
        assert_eq!(p(Real::max(d(1.0, 5.0), d(2.0, 7.0))), p(d(2.0, 7.0)));
        assert_eq!(
            p(Real::min(d(1.0, 5.0), d(1.0, 7.0))),
            p(d(1.0, 5.0)),
            "ties keep the first"
        );
        assert_eq!(p(Real::min(d(3.0, 5.0), d(2.0, 7.0))), p(d(2.0, 7.0)));
        assert_eq!(p(Real::min(d(1.0, 5.0), d(2.0, 7.0))), p(d(1.0, 5.0)));
        assert_eq!(
            p(Real::clamp(d(5.0, 1.0), d(0.0, 0.0), d(2.0, 3.0))),
            p(d(2.0, 3.0))
        );
        assert_eq!(p(Real::sq(d(3.0, 1.0))), p(d(9.0, 6.0)));
        assert_eq!(p(Real::recip(d(2.0, 1.0))), p(d(0.5, -0.25)));
        assert_eq!(p(<Dual<f64> as Real>::from_usize(7)), p(d(7.0, 0.0)));
    }

    fn poly<T: Real>(x: T) -> T {
        T::from_f64(0.5) * x.sq() + x.sin()
    }

    #[test]
    fn same_code_in_both_precisions() {
        let a = poly(0.3_f64);
        let b = f64::from(poly(0.3_f32));
        assert!((a - b).abs() < 1e-6, "f32 and f64 disagree: {a} vs {b}");
    }

    #[test]
    fn max_min_clamp() {
        assert!(2.0_f64.max(3.0) > 2.5, "max picks the larger");
        assert!(2.0_f64.min(3.0) < 2.5, "min picks the smaller");
        assert!((5.0_f64.clamp(0.0, 1.0) - 1.0).abs() < 1e-15, "clamp to hi");
    }
}
