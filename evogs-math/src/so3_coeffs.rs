//! The scalar coefficient functions of the SO(3) maps, each with its own small-angle branch.
//!
//! All take **θ² = |φ|²**, never θ: the derivative of √(θ²) is infinite at 0, so a branch
//! written in θ would give NaN derivatives with dual numbers at the identity. Each
//! function switches to a truncated Taylor series below a threshold chosen for *that*
//! function (`docs/lie-groups.md` §6), such that both branches are accurate to about 1e-16 relative
//! in f64 at the switch:
//!
//! | function | closed form | series below | terms | cancellation of the closed form |
//! |---|---|---|---|---|
//! | [`sinc`] | sin θ/θ | θ² < 1e-2 | 5 | none |
//! | [`cos_half`] | cos(θ/2) | θ² < 1e-2 | 5 | none |
//! | [`one_minus_cos_over_sq`] | 2 sin²(θ/2)/θ² | θ² < 1e-2 | 5 | none (half-angle form) |
//! | [`theta_minus_sin_over_cube`] | (θ − sin θ)/θ³ | θ² < 1 | 9 | ~ε/θ² |
//! | [`jinv_coeff`] | 1/θ² − cot(θ/2)/(2θ) | θ² < 1 | 10 | ~ε/θ² |
//! | [`q_coeff_c`] | (θ² + 2 cos θ − 2)/(2θ⁴) | θ² < 2.25 | 10 | ~ε/θ² (half-angle form) |
//! | [`q_coeff_e`] | (2θ − 3 sin θ + θ cos θ)/(2θ⁵) | θ² < 2.25 | 10 | ~ε/θ⁴ |
//!
//! Names follow the oracle's Jacobian conventions: `Jl = I + A K + B K²` with
//! `A = (1 − cos θ)/θ²` and `B = (θ − sin θ)/θ³`, `Jl⁻¹ = I − K/2 + D K²`. The last two
//! are the angle-only coefficients `C` and `E` of the `Q(ρ, φ)` block of the SE(3) left
//! Jacobian (Barfoot; see [`se3_jacobians`](crate::se3_jacobians)), whose closed forms
//! cancel worse than the SO(3) ones (measured against 50-digit values: `E` loses 1.7e-6
//! relative at θ = 1e-2 and 1.7e-14 at θ = 1); at θ = 1.5 both closed forms are within
//! 6e-16 of the 50-digit values and the 10-term series within 2e-17.

use crate::Real;

/// Evaluates `Σ_k c[k]·x^k` by Horner's rule.
#[inline]
pub(crate) fn horner<T: Real>(x: T, c: &[f64]) -> T {
    let mut acc = T::ZERO;
    for &ck in c.iter().rev() {
        acc = acc * x + T::from_f64(ck);
    }
    acc
}

/// sin θ/θ, Taylor coefficients in θ²: (−1)^k/(2k+1)!.
const SINC: [f64; 5] = [
    1.0,
    -0.16666666666666666,
    0.008333333333333333,
    -0.0001984126984126984,
    2.7557319223985893e-06,
];
/// cos(θ/2) in powers of θ²: (−1)^k/(4^k (2k)!).
const COS_HALF: [f64; 5] = [
    1.0,
    -0.125,
    0.0026041666666666665,
    -2.170138888888889e-05,
    9.68812003968254e-08,
];
/// (1 − cos θ)/θ² in powers of θ²: (−1)^k/(2k+2)!.
const ONE_MINUS_COS: [f64; 5] = [
    0.5,
    -0.041666666666666664,
    0.001388888888888889,
    -2.48015873015873e-05,
    2.755731922398589e-07,
];
/// (θ − sin θ)/θ³ in powers of θ²: (−1)^k/(2k+3)!.
const THETA_MINUS_SIN: [f64; 9] = [
    0.16666666666666666,
    -0.008333333333333333,
    0.0001984126984126984,
    -2.7557319223985893e-06,
    2.505210838544172e-08,
    -1.6059043836821613e-10,
    7.647163731819816e-13,
    -2.8114572543455206e-15,
    8.22063524662433e-18,
];
/// D(θ) = 1/θ² − cot(θ/2)/(2θ) in powers of θ²: |B₂ₙ|/(2n)! (Bernoulli numbers).
const JINV: [f64; 10] = [
    0.08333333333333333,
    0.001388888888888889,
    3.306878306878307e-05,
    8.267195767195768e-07,
    2.08767569878681e-08,
    5.284190138687493e-10,
    1.3382536530684679e-11,
    3.3896802963225827e-13,
    8.586062056277845e-15,
    2.174868698558062e-16,
];

/// C = (θ² + 2 cos θ − 2)/(2θ⁴) in powers of θ²: (−1)^k/(2k+4)!.
const Q_C: [f64; 10] = [
    0.041666666666666664,
    -0.001388888888888889,
    2.48015873015873e-05,
    -2.755731922398589e-07,
    2.08767569878681e-09,
    -1.1470745597729725e-11,
    4.779477332387385e-14,
    -1.5619206968586225e-16,
    4.110317623312165e-19,
    -8.896791392450574e-22,
];
/// E = (2θ − 3 sin θ + θ cos θ)/(2θ⁵) in powers of θ²: (−1)^k (k+1)/(2k+5)!.
const Q_E: [f64; 10] = [
    0.008333333333333333,
    -0.0003968253968253968,
    8.267195767195768e-06,
    -1.0020843354176688e-07,
    8.029521918410807e-10,
    -4.58829823909189e-12,
    1.9680200780418645e-14,
    -6.576508197299464e-17,
    1.7615646957052136e-19,
    -3.868170170630684e-22,
];

/// Threshold on θ² below which the short (5-term) series are used.
pub const SMALL_SERIES_THRESHOLD: f64 = 1e-2;
/// Threshold on θ² below which the long series of the cancelling coefficients are used.
pub const LONG_SERIES_THRESHOLD: f64 = 1.0;
/// Threshold on θ² below which the series of the SE(3) `Q`-block coefficients
/// [`q_coeff_c`] and [`q_coeff_e`] are used (θ < 1.5).
pub const Q_SERIES_THRESHOLD: f64 = 2.25;

// Each coefficient is a pair of plain functions (series, closed form) and a threshold; the
// public function picks one. Plain `fn` items (not function pointers) so both branches inline.

#[inline]
fn sinc_series<T: Real>(x: T) -> T {
    horner(x, &SINC)
}
#[inline]
fn sinc_closed<T: Real>(x: T) -> T {
    let t = x.sqrt();
    t.sin() / t
}
#[inline]
fn cos_half_series<T: Real>(x: T) -> T {
    horner(x, &COS_HALF)
}
#[inline]
fn cos_half_closed<T: Real>(x: T) -> T {
    (x.sqrt() * T::HALF).cos()
}
#[inline]
fn one_minus_cos_series<T: Real>(x: T) -> T {
    horner(x, &ONE_MINUS_COS)
}
#[inline]
fn one_minus_cos_closed<T: Real>(x: T) -> T {
    let s = sin_half_over(x);
    T::TWO * s * s
}
#[inline]
fn theta_minus_sin_series<T: Real>(x: T) -> T {
    horner(x, &THETA_MINUS_SIN)
}
#[inline]
fn theta_minus_sin_closed<T: Real>(x: T) -> T {
    let t = x.sqrt();
    (t - t.sin()) / (x * t)
}
#[inline]
fn jinv_series<T: Real>(x: T) -> T {
    horner(x, &JINV)
}
#[inline]
fn jinv_closed<T: Real>(x: T) -> T {
    let t = x.sqrt();
    let (s, c) = (t * T::HALF).sin_cos();
    T::ONE / x - c / (s * T::TWO * t)
}

#[inline]
fn q_c_series<T: Real>(x: T) -> T {
    horner(x, &Q_C)
}
#[inline]
fn q_c_closed<T: Real>(x: T) -> T {
    // θ² + 2 cos θ − 2 = θ² − 4 sin²(θ/2) = θ²(1 − 4 s²) with s = sin(θ/2)/θ.
    let s = sin_half_over(x);
    (T::ONE - T::from_f64(4.0) * s * s) / (T::TWO * x)
}
#[inline]
fn q_e_series<T: Real>(x: T) -> T {
    horner(x, &Q_E)
}
#[inline]
fn q_e_closed<T: Real>(x: T) -> T {
    let t = x.sqrt();
    let (s, c) = t.sin_cos();
    (T::TWO * t - T::from_f64(3.0) * s + t * c) / (T::TWO * x * x * t)
}

/// sin θ/θ as a function of θ² (limit 1 at 0).
#[inline]
#[must_use]
pub fn sinc<T: Real>(theta_sq: T) -> T {
    if theta_sq < T::from_f64(SMALL_SERIES_THRESHOLD) {
        sinc_series(theta_sq)
    } else {
        sinc_closed(theta_sq)
    }
}

/// cos(θ/2) as a function of θ².
#[inline]
#[must_use]
pub fn cos_half<T: Real>(theta_sq: T) -> T {
    if theta_sq < T::from_f64(SMALL_SERIES_THRESHOLD) {
        cos_half_series(theta_sq)
    } else {
        cos_half_closed(theta_sq)
    }
}

/// sin(θ/2)/θ as a function of θ² (limit 1/2): the vector-part factor of the quaternion
/// exponential `(cos(θ/2), sin(θ/2)/θ · φ)`.
#[inline]
#[must_use]
pub fn sin_half_over<T: Real>(theta_sq: T) -> T {
    sinc(theta_sq * T::from_f64(0.25)) * T::HALF
}

/// A = (1 − cos θ)/θ² as a function of θ² (limit 1/2), via the cancellation-free
/// 2 sin²(θ/2)/θ².
#[inline]
#[must_use]
pub fn one_minus_cos_over_sq<T: Real>(theta_sq: T) -> T {
    if theta_sq < T::from_f64(SMALL_SERIES_THRESHOLD) {
        one_minus_cos_series(theta_sq)
    } else {
        one_minus_cos_closed(theta_sq)
    }
}

/// B = (θ − sin θ)/θ³ as a function of θ² (limit 1/6).
#[inline]
#[must_use]
pub fn theta_minus_sin_over_cube<T: Real>(theta_sq: T) -> T {
    if theta_sq < T::from_f64(LONG_SERIES_THRESHOLD) {
        theta_minus_sin_series(theta_sq)
    } else {
        theta_minus_sin_closed(theta_sq)
    }
}

/// D = 1/θ² − cot(θ/2)/(2θ) = (1 − (θ/2)·cot(θ/2))/θ² as a function of θ² (limit 1/12).
///
/// Finite on [0, 2π), equal to 1/π² at π; singular at 2π, which a shortest-path log never
/// reaches.
#[inline]
#[must_use]
pub fn jinv_coeff<T: Real>(theta_sq: T) -> T {
    if theta_sq < T::from_f64(LONG_SERIES_THRESHOLD) {
        jinv_series(theta_sq)
    } else {
        jinv_closed(theta_sq)
    }
}

/// C = (θ² + 2 cos θ − 2)/(2θ⁴) as a function of θ² (limit 1/24): a coefficient of the
/// `Q(ρ, φ)` block of the SE(3) left Jacobian.
#[inline]
#[must_use]
pub fn q_coeff_c<T: Real>(theta_sq: T) -> T {
    if theta_sq < T::from_f64(Q_SERIES_THRESHOLD) {
        q_c_series(theta_sq)
    } else {
        q_c_closed(theta_sq)
    }
}

/// E = (2θ − 3 sin θ + θ cos θ)/(2θ⁵) as a function of θ² (limit 1/120): a coefficient of
/// the `Q(ρ, φ)` block of the SE(3) left Jacobian.
#[inline]
#[must_use]
pub fn q_coeff_e<T: Real>(theta_sq: T) -> T {
    if theta_sq < T::from_f64(Q_SERIES_THRESHOLD) {
        q_e_series(theta_sq)
    } else {
        q_e_closed(theta_sq)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Dual;

    #[test]
    fn both_branches_agree_at_each_threshold() {
        type Pair = (&'static str, fn(f64) -> f64, fn(f64) -> f64, f64);
        let all: [Pair; 7] = [
            ("sinc", sinc_series, sinc_closed, SMALL_SERIES_THRESHOLD),
            (
                "cos_half",
                cos_half_series,
                cos_half_closed,
                SMALL_SERIES_THRESHOLD,
            ),
            (
                "one_minus_cos",
                one_minus_cos_series,
                one_minus_cos_closed,
                SMALL_SERIES_THRESHOLD,
            ),
            (
                "theta_minus_sin",
                theta_minus_sin_series,
                theta_minus_sin_closed,
                LONG_SERIES_THRESHOLD,
            ),
            ("jinv", jinv_series, jinv_closed, LONG_SERIES_THRESHOLD),
            ("q_c", q_c_series, q_c_closed, Q_SERIES_THRESHOLD),
            ("q_e", q_e_series, q_e_closed, Q_SERIES_THRESHOLD),
        ];
        for (name, series, closed, thr) in all {
            for x in [thr, thr * 0.5] {
                let s = series(x);
                let k = closed(x);
                assert!(
                    (s - k).abs() <= 5e-15 * s.abs(),
                    "{name}: series {s} vs closed {k} at θ² = {x}"
                );
            }
        }
    }

    #[test]
    fn dual_derivatives_are_finite_at_zero_and_match_series() {
        // d/d(θ²) at 0 is the second series coefficient.
        let want = [
            -1.0 / 6.0,
            -0.125,
            -1.0 / 24.0,
            -1.0 / 120.0,
            1.0 / 720.0,
            -1.0 / 720.0,
            -2.0 / 5040.0,
        ];
        let fs: [fn(Dual<f64>) -> Dual<f64>; 7] = [
            sinc::<Dual<f64>>,
            cos_half::<Dual<f64>>,
            one_minus_cos_over_sq::<Dual<f64>>,
            theta_minus_sin_over_cube::<Dual<f64>>,
            jinv_coeff::<Dual<f64>>,
            q_coeff_c::<Dual<f64>>,
            q_coeff_e::<Dual<f64>>,
        ];
        for (f, w) in fs.iter().zip(want) {
            let d = f(Dual::variable(0.0)).eps;
            assert!((d - w).abs() < 1e-15, "derivative at 0: {d} vs {w}");
        }
    }

    #[test]
    fn q_coefficients_match_high_precision_values() {
        // (θ, C, E) from mpmath at 150 digits (θ as written, an f64), rounded to f64.
        let refs = [
            (1e-12, 0.041666666666666664, 0.008333333333333333),
            (1e-8, 0.041666666666666664, 0.008333333333333333),
            (1e-4, 0.041666666652777774, 0.008333333329365079),
            (1e-3, 0.0416666652777778, 0.008333332936507945),
            (1e-2, 0.04166652777802579, 0.008333293650876322),
            (0.1, 0.041652780257660955, 0.008329365905984456),
            (0.5, 0.04132099024596346, 0.008234642121237716),
            (1.0, 0.040302305868139716, 0.0079446757222251),
            (1.4999, 0.0386645230022885, 0.0074813160788483445),
            (1.5001, 0.03866375417828015, 0.007481099413491533),
            (2.0, 0.0364908227158036, 0.0068720944754479705),
            (3.0, 0.030987746955550056, 0.005363503057652391),
            (3.1, 0.030382252809916833, 0.0052008860598991595),
        ];
        for (t, c, e) in refs {
            let x: f64 = t * t;
            for (name, got, want) in [("C", q_coeff_c(x), c), ("E", q_coeff_e(x), e)] {
                let rel = (got - want).abs() / want;
                assert!(rel < 1e-15, "{name}({t}) relative error {rel:e}");
            }
        }
    }

    #[test]
    fn e_series_is_within_one_ulp_just_below_its_threshold() {
        // Near θ = 1.5 the ten-term series of E is at its least accurate, and its last
        // term still moves the result by about an ulp: within one ulp of the value
        // rounded from mpmath (60 digits) at these θ, as the series gives it.
        let refs = [
            (1.49_f64, 0.007492011716125178_f64),
            (1.4935, 0.007488236999971724),
            (1.4953, 0.00748629291747816),
            (1.4988, 0.007482507319851689),
        ];
        for (t, want) in refs {
            let got: f64 = q_coeff_e(t * t);
            let ulp = f64::from_bits(want.to_bits() + 1) - want;
            assert!(
                (got - want).abs() <= ulp,
                "E({t}) = {got:e}, off by {} ulp",
                (got - want) / ulp
            );
        }
    }

    #[test]
    fn jinv_at_pi_is_one_over_pi_squared() {
        let pi = core::f64::consts::PI;
        let d = jinv_coeff(pi * pi);
        assert!((d - 1.0 / (pi * pi)).abs() < 1e-16, "D(π) = {d}");
    }
}
