//! Forward-mode dual numbers: `Dual<T> = re + eps·ε` with ε² = 0.
//!
//! Evaluating a generic kernel `f::<Dual<f64>>` at `x + v·ε` returns `f(x) + (J v)·ε`, the
//! exact Jacobian-vector product (up to rounding). That is the forward-mode half of the
//! checks in [`diff`](crate::diff): it needs no step size and is immune to the cancellation
//! of finite differences.
//!
//! Comparisons look at the real part only, so a dual evaluation takes exactly the branches
//! the `f64` evaluation takes. Functions with kinks (`abs`, `max`, `min`) differentiate the
//! branch they take; `floor` and `ceil` have zero derivative.
//!
//! ```
//! use evogs_math::{Dual, Real};
//! // d/dx sin(x²) = 2x cos(x²)
//! let x = Dual::variable(0.7_f64);
//! let y = (x * x).sin();
//! assert!((y.eps - 2.0 * 0.7 * (0.49_f64).cos()).abs() < 1e-15);
//! ```

use crate::Real;
use core::cmp::Ordering;
use core::iter::Sum;
use core::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// A dual number `re + eps·ε` (ε² = 0) over the scalar `T`.
#[derive(Clone, Copy, Debug, Default)]
pub struct Dual<T> {
    /// Real part: the value.
    pub re: T,
    /// Dual part: the directional derivative.
    pub eps: T,
}

impl<T: Real> Dual<T> {
    /// A dual number from its two parts.
    #[inline]
    #[must_use]
    pub const fn new(re: T, eps: T) -> Self {
        Self { re, eps }
    }
    /// A constant (zero derivative).
    #[inline]
    #[must_use]
    pub const fn constant(re: T) -> Self {
        Self { re, eps: T::ZERO }
    }
    /// The independent variable (unit derivative).
    #[inline]
    #[must_use]
    pub const fn variable(re: T) -> Self {
        Self { re, eps: T::ONE }
    }
    /// Chain rule for a unary function with value `f` and derivative `df` at `re`.
    #[inline]
    fn chain(self, f: T, df: T) -> Self {
        Self {
            re: f,
            eps: df * self.eps,
        }
    }
}

impl<T: Real> PartialEq for Dual<T> {
    #[inline]
    fn eq(&self, other: &Self) -> bool {
        self.re == other.re
    }
}

impl<T: Real> PartialOrd for Dual<T> {
    #[inline]
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        self.re.partial_cmp(&other.re)
    }
}

impl<T: Real> Add for Dual<T> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        Self {
            re: self.re + o.re,
            eps: self.eps + o.eps,
        }
    }
}
impl<T: Real> Sub for Dual<T> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        Self {
            re: self.re - o.re,
            eps: self.eps - o.eps,
        }
    }
}
impl<T: Real> Mul for Dual<T> {
    type Output = Self;
    #[inline]
    fn mul(self, o: Self) -> Self {
        Self {
            re: self.re * o.re,
            eps: self.re * o.eps + self.eps * o.re,
        }
    }
}
impl<T: Real> Div for Dual<T> {
    type Output = Self;
    #[inline]
    fn div(self, o: Self) -> Self {
        let inv = T::ONE / o.re;
        let re = self.re * inv;
        Self {
            re,
            eps: (self.eps - re * o.eps) * inv,
        }
    }
}
impl<T: Real> Neg for Dual<T> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        Self {
            re: -self.re,
            eps: -self.eps,
        }
    }
}
impl<T: Real> AddAssign for Dual<T> {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}
impl<T: Real> SubAssign for Dual<T> {
    #[inline]
    fn sub_assign(&mut self, o: Self) {
        *self = *self - o;
    }
}
impl<T: Real> MulAssign for Dual<T> {
    #[inline]
    fn mul_assign(&mut self, o: Self) {
        *self = *self * o;
    }
}
impl<T: Real> DivAssign for Dual<T> {
    #[inline]
    fn div_assign(&mut self, o: Self) {
        *self = *self / o;
    }
}
impl<T: Real> Sum for Dual<T> {
    fn sum<I: Iterator<Item = Self>>(iter: I) -> Self {
        iter.fold(Self::constant(T::ZERO), |a, b| a + b)
    }
}

impl<T: Real> Real for Dual<T> {
    const ZERO: Self = Self {
        re: T::ZERO,
        eps: T::ZERO,
    };
    const ONE: Self = Self {
        re: T::ONE,
        eps: T::ZERO,
    };
    const TWO: Self = Self {
        re: T::TWO,
        eps: T::ZERO,
    };
    const HALF: Self = Self {
        re: T::HALF,
        eps: T::ZERO,
    };
    const PI: Self = Self {
        re: T::PI,
        eps: T::ZERO,
    };
    const EPSILON: Self = Self {
        re: T::EPSILON,
        eps: T::ZERO,
    };
    const MAX: Self = Self {
        re: T::MAX,
        eps: T::ZERO,
    };

    #[inline]
    fn from_f64(x: f64) -> Self {
        Self::constant(T::from_f64(x))
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self.re.to_f64()
    }
    #[inline]
    fn sqrt(self) -> Self {
        let s = self.re.sqrt();
        self.chain(s, T::HALF / s)
    }
    #[inline]
    fn cbrt(self) -> Self {
        let c = self.re.cbrt();
        self.chain(c, T::ONE / (T::from_f64(3.0) * c * c))
    }
    #[inline]
    fn exp(self) -> Self {
        let e = self.re.exp();
        self.chain(e, e)
    }
    #[inline]
    fn ln(self) -> Self {
        self.chain(self.re.ln(), T::ONE / self.re)
    }
    #[inline]
    fn sin(self) -> Self {
        let (s, c) = self.re.sin_cos();
        self.chain(s, c)
    }
    #[inline]
    fn cos(self) -> Self {
        let (s, c) = self.re.sin_cos();
        self.chain(c, -s)
    }
    #[inline]
    fn tan(self) -> Self {
        let t = self.re.tan();
        self.chain(t, T::ONE + t * t)
    }
    #[inline]
    fn atan2(self, x: Self) -> Self {
        // d atan2(y, x) = (x dy - y dx) / (x² + y²)
        let r2 = self.re * self.re + x.re * x.re;
        Self {
            re: self.re.atan2(x.re),
            eps: (x.re * self.eps - self.re * x.eps) / r2,
        }
    }
    #[inline]
    fn acos(self) -> Self {
        self.chain(
            self.re.acos(),
            -T::ONE / (T::ONE - self.re * self.re).sqrt(),
        )
    }
    #[inline]
    fn tanh(self) -> Self {
        let t = self.re.tanh();
        self.chain(t, T::ONE - t * t)
    }
    #[inline]
    fn powi(self, n: i32) -> Self {
        if n == 0 {
            return Self::ONE;
        }
        let p = self.re.powi(n - 1);
        self.chain(p * self.re, T::from_f64(f64::from(n)) * p)
    }
    #[inline]
    fn abs(self) -> Self {
        if self.re < T::ZERO { -self } else { self }
    }
    #[inline]
    fn floor(self) -> Self {
        Self::constant(self.re.floor())
    }
    #[inline]
    fn ceil(self) -> Self {
        Self::constant(self.re.ceil())
    }
    #[inline]
    fn is_finite(self) -> bool {
        self.re.is_finite() && self.eps.is_finite()
    }
    #[inline]
    fn is_nan(self) -> bool {
        self.re.is_nan() || self.eps.is_nan()
    }
}

#[cfg(test)]
mod tests {
    use super::Dual;
    use crate::Real;

    #[test]
    fn negation_and_subtraction_act_on_both_parts() {
        let n = -Dual::new(1.5_f64, 2.0);
        assert_eq!(
            (n.re.to_bits(), n.eps.to_bits()),
            ((-1.5_f64).to_bits(), (-2.0_f64).to_bits())
        );
        let mut a = Dual::new(3.0_f64, 1.0);
        a -= Dual::new(1.0, 4.0);
        assert_eq!(
            (a.re.to_bits(), a.eps.to_bits()),
            (2.0_f64.to_bits(), (-3.0_f64).to_bits())
        );
        let mut b = Dual::new(3.0_f64, 1.0);
        b += Dual::new(1.0, 4.0);
        assert_eq!(
            (b.re.to_bits(), b.eps.to_bits()),
            (4.0_f64.to_bits(), 5.0_f64.to_bits())
        );
    }

    /// Both parts of a dual number, as bits.
    fn parts(d: Dual<f64>) -> (u64, u64) {
        (d.re.to_bits(), d.eps.to_bits())
    }

    /// A dual number's parts as bits, from plain values.
    fn bits(re: f64, eps: f64) -> (u64, u64) {
        (re.to_bits(), eps.to_bits())
    }

    #[test]
    fn compound_assignment_sum_and_the_real_methods_act_on_both_parts() {
        let (x, y) = (Dual::new(2.0_f64, 1.0), Dual::new(4.0, 3.0));
        let mut m = x;
        m *= y;
        assert_eq!(parts(m), bits(8.0, 1.0 * 4.0 + 2.0 * 3.0));
        let mut d = y;
        d /= x;
        assert_eq!(parts(d), bits(2.0, (3.0 * 2.0 - 4.0 * 1.0) / 4.0));
        let s: Dual<f64> = [x, y, Dual::new(1.0, -1.0)].into_iter().sum();
        assert_eq!(parts(s), bits(7.0, 3.0));
        assert_eq!(x.to_f64().to_bits(), 2.0_f64.to_bits());
        assert_eq!(parts(x.powi(3)), bits(8.0, 12.0));
        assert_eq!(parts(Dual::new(-2.0_f64, 1.0).abs()), bits(2.0, -1.0));
        assert_eq!(parts(Dual::new(2.0_f64, 1.0).abs()), bits(2.0, 1.0));
        // At the kink the derivative taken is the right one (+1).
        assert_eq!(parts(Dual::new(0.0_f64, 1.0).abs()), bits(0.0, 1.0));
        assert_eq!(parts(Dual::new(2.5_f64, 1.0).floor()), bits(2.0, 0.0));
        assert_eq!(parts(Dual::new(2.5_f64, 1.0).ceil()), bits(3.0, 0.0));
        assert!(x.is_finite() && !x.is_nan());
        assert!(!Dual::new(1.0, f64::INFINITY).is_finite());
        assert!(!Dual::new(f64::INFINITY, 1.0).is_finite());
        assert!(Dual::new(1.0, f64::NAN).is_nan() && Dual::new(f64::NAN, 1.0).is_nan());
    }

    #[test]
    fn duals_compare_by_their_real_part() {
        // Equality and order follow the value, not its derivative, so that generic code
        // branches on a dual number as it does on the plain one.
        assert!(Dual::new(1.0_f64, 2.0) == Dual::new(1.0, 5.0));
        assert!(Dual::new(1.0_f64, 0.0) != Dual::new(2.0, 0.0));
        assert!(Dual::new(1.0_f64, 9.0) < Dual::new(2.0, 0.0));
    }

    fn check(f: impl Fn(Dual<f64>) -> Dual<f64>, g: impl Fn(f64) -> f64, x: f64) {
        let d = f(Dual::variable(x)).eps;
        let h = 1e-6;
        let fd = (g(x + h) - g(x - h)) / (2.0 * h);
        assert!(
            (d - fd).abs() <= 1e-8 * (1.0 + fd.abs()),
            "dual {d} vs fd {fd} at {x}"
        );
    }

    #[test]
    fn elementary_derivatives_match_finite_differences() {
        for &x in &[0.3, 0.9, 1.7] {
            check(|v| v.sqrt(), f64::sqrt, x);
            check(|v| v.cbrt(), f64::cbrt, x);
            check(|v| v.exp(), f64::exp, x);
            check(|v| v.ln(), f64::ln, x);
            check(|v| v.sin(), f64::sin, x);
            check(|v| v.cos(), f64::cos, x);
            check(|v| v.tan(), f64::tan, x);
            check(|v| v.tanh(), f64::tanh, x);
            check(|v| v.powi(3), |u| u.powi(3), x);
            check(|v| v.atan2(Dual::constant(0.4)), |u| u.atan2(0.4), x);
            check(|v| Dual::constant(0.4).atan2(v), |u| 0.4_f64.atan2(u), x);
            check(
                |v| (v * Dual::constant(0.5)).acos(),
                |u| (0.5 * u).acos(),
                x,
            );
            check(|v| Dual::constant(2.0) / v, |u| 2.0 / u, x);
        }
    }

    #[test]
    fn nested_duals_give_second_derivatives() {
        // f(x) = x³, f'' = 6x.
        let x = Dual::new(Dual::variable(2.0_f64), Dual::constant(1.0));
        let y = x * x * x;
        assert!(
            (y.eps.eps - 12.0).abs() < 1e-12,
            "second derivative {}",
            y.eps.eps
        );
    }
}
