//! Exact rational numbers for Butcher tableaux: [`Rational`].
//!
//! Tableau entries are stored as small fractions so that the order conditions can be
//! checked **exactly** (no rounding can hide a typo such as 1/3 written as 0.333), and the
//! floating-point coefficients are derived from them by one correctly rounded division.

use core::fmt;
use core::ops::{Add, Mul, Neg, Sub};

/// A fraction `num/den` in lowest terms with `den > 0`.
///
/// Arithmetic is exact: intermediate products are formed in `i128` and reduced, so only a
/// result whose lowest-terms numerator or denominator does not fit in `i64` panics
/// (tableau entries, even Dormand–Prince's, are far from that).
///
/// ```
/// use evogs_ode::Rational;
/// let third = Rational::new(1, 3);
/// assert_eq!(third + third + third, Rational::ONE);
/// assert_eq!(Rational::new(2, -4), Rational::new(-1, 2));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Rational {
    num: i64,
    den: i64,
}

const fn gcd(mut a: i64, mut b: i64) -> i64 {
    a = a.abs();
    b = b.abs();
    while b != 0 {
        let t = a % b;
        a = b;
        b = t;
    }
    a
}

impl Rational {
    /// 0.
    pub const ZERO: Self = Self { num: 0, den: 1 };
    /// 1.
    pub const ONE: Self = Self { num: 1, den: 1 };

    /// `num/den`, reduced to lowest terms with a positive denominator.
    ///
    /// # Panics
    /// If `den == 0`.
    #[must_use]
    pub const fn new(num: i64, den: i64) -> Self {
        assert!(den != 0, "a rational needs a non-zero denominator");
        let g = gcd(num, den);
        let g = if g == 0 { 1 } else { g };
        let s = if den < 0 { -1 } else { 1 };
        Self {
            num: s * num / g,
            den: s * den / g,
        }
    }

    /// The integer `n`.
    #[must_use]
    pub const fn int(n: i64) -> Self {
        Self { num: n, den: 1 }
    }

    /// Numerator (lowest terms, carries the sign).
    #[must_use]
    pub const fn num(self) -> i64 {
        self.num
    }

    /// Denominator (lowest terms, positive).
    #[must_use]
    pub const fn den(self) -> i64 {
        self.den
    }

    /// `true` for 0.
    #[must_use]
    pub const fn is_zero(self) -> bool {
        self.num == 0
    }

    /// The nearest `f64` (one correctly rounded division of two exactly representable
    /// integers).
    #[must_use]
    pub fn to_f64(self) -> f64 {
        self.num as f64 / self.den as f64
    }
}

const fn gcd128(mut a: i128, mut b: i128) -> i128 {
    a = a.abs();
    b = b.abs();
    while b != 0 {
        let t = a % b;
        a = b;
        b = t;
    }
    a
}

impl Rational {
    /// `num/den` from wide intermediates, reduced; panics if the result does not fit.
    /// `den` is a product of denominators, so it is positive and so is the gcd.
    fn from_wide(num: i128, den: i128) -> Self {
        let g = gcd128(num, den);
        let (n, d) = (num / g, den / g);
        match (i64::try_from(n), i64::try_from(d)) {
            (Ok(num), Ok(den)) => Self { num, den },
            _ => panic!("rational overflow: {n}/{d} does not fit in i64"),
        }
    }
}

impl Add for Rational {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        let (a, b, c, d) = (
            i128::from(self.num),
            i128::from(self.den),
            i128::from(o.num),
            i128::from(o.den),
        );
        Self::from_wide(a * d + c * b, b * d)
    }
}

impl Sub for Rational {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        self + (-o)
    }
}

impl Neg for Rational {
    type Output = Self;
    fn neg(self) -> Self {
        Self {
            num: -self.num,
            den: self.den,
        }
    }
}

impl Mul for Rational {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        Self::from_wide(
            i128::from(self.num) * i128::from(o.num),
            i128::from(self.den) * i128::from(o.den),
        )
    }
}

impl fmt::Display for Rational {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.den == 1 {
            write!(f, "{}", self.num)
        } else {
            write!(f, "{}/{}", self.num, self.den)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Rational;

    #[test]
    fn arithmetic_is_exact_and_reduced() {
        let a = Rational::new(1, 6);
        let b = Rational::new(1, 3);
        assert_eq!(a + b, Rational::new(1, 2), "1/6 + 1/3");
        assert_eq!(a * b, Rational::new(1, 18), "1/6 · 1/3");
        assert_eq!(a - b, Rational::new(-1, 6), "1/6 − 1/3");
        assert_eq!(Rational::new(6, -8).den(), 4, "positive denominator");
        assert_eq!(Rational::new(6, -8).num(), -3, "the sign on the numerator");
        assert_eq!(Rational::new(-14, -4).num(), 7, "lowest terms");
        assert_eq!(Rational::new(0, 5), Rational::ZERO, "zero normalised");
        assert_eq!(alloc::format!("{}", Rational::new(3, 9)), "1/3", "display");
        assert!(
            (Rational::new(1, 3).to_f64() - 1.0 / 3.0).abs() < 1e-300,
            "nearest f64"
        );
    }
}
