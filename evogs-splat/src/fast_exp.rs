//! The exponential of the tiled rasterizer's lane loops ([`ExpMode`]).
//!
//! `exp` is the one transcendental function per (Gaussian, pixel) pair. The standard
//! library's `expf` is a scalar call the compiler cannot vectorise, so in `f32` the tiled
//! rasterizer uses by default ([`ExpMode::Fast`]) an exponential written with plain
//! arithmetic and bit operations, which the lane loops compile to AVX2 code. It is evaluated
//! in `f64` and rounded to `f32`:
//!
//! ```text
//! x = clamp(x, −87, 87) in f64,  k = round(x·log₂e)   (adding and subtracting 1.5·2⁵²)
//! r = x − k·C₁ − k·C₂,  |r| ≤ ln2/2                   (C₁ + C₂ = ln 2, k·C₁ exact)
//! eʳ = 1 + r + r²·(1/2! + r/3! + … + r⁷/9!)           (Taylor, truncation < 10⁻¹¹)
//! eˣ = 2ᵏ·eʳ (2ᵏ from the exponent bits (k + 1023) << 52), rounded to f32
//! ```
//!
//! Before the final rounding the relative error is ~10⁻¹¹, so the `f32` result is the
//! correctly rounded one except when `eˣ` lies within ~10⁻¹¹ of a rounding boundary: on
//! `[−6, 0]` it equals `expf`'s (glibc) in all but 7·10⁻⁵ of the arguments, and then by one
//! ulp (tested). Images and gradients therefore match the reference rasterizer's to the
//! last bits almost everywhere, and a decision can only differ where a value sits within an
//! ulp of a threshold (`α = 1/255`, the 0.999 clamp, `T = 10⁻⁴`). The **same** function is
//! used by the forward and the backward pass, so the backward differentiates exactly the
//! function the forward computed and the reverse traversal recovers the same
//! transmittances. With FMA (`target_feature = "fma"` and `std`) the multiply-adds are
//! fused.
//!
//! [`ExpMode::Exact`] uses `T::exp` (`expf`/`exp`): the tiled rasterizer then makes exactly
//! the reference rasterizer's floating-point decisions in every precision. Only `f32` has a
//! fast path; `f64` and dual numbers always use `T::exp`. The choice is made on the concrete
//! type through `TypeId` (a compile-time constant after monomorphisation), which keeps the
//! kernels generic over `T: Real` without a special trait bound.

use core::any::TypeId;
use evogs_math::Real;

/// How the tiled rasterizer evaluates `exp(−σ)`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExpMode {
    /// In `f32`: the vectorised exponential of the module docs (correctly rounded but for
    /// ~10⁻⁴ of the arguments, off by one ulp there). Other scalar types use `T::exp`.
    #[default]
    Fast,
    /// `T::exp` everywhere: bitwise the same decisions and per-pixel values as the reference
    /// rasterizer.
    Exact,
}

/// `log₂ e`.
const LOG2E: f64 = core::f64::consts::LOG2_E;
/// `1.5·2⁵²`: adding and subtracting it rounds to an integer (for `|v| < 2⁵¹`).
const ROUND_MAGIC: f64 = 6_755_399_441_055_744.0;
/// High part of `ln 2` (fdlibm `ln2_hi`: 32 significant bits, so `k·C₁` is exact).
const LN2_HI: f64 = 6.931_471_803_691_238e-1;
/// Low part of `ln 2` (fdlibm `ln2_lo`).
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
/// `1/n!` for `n = 9, 8, …, 2`: the Taylor polynomial of `eʳ` (Horner, highest first).
const TAYLOR: [f64; 8] = [
    1.0 / 362_880.0,
    1.0 / 40_320.0,
    1.0 / 5_040.0,
    1.0 / 720.0,
    1.0 / 120.0,
    1.0 / 24.0,
    1.0 / 6.0,
    0.5,
];

/// `a·b + c`, fused where the target has FMA (and `std` provides `mul_add`).
#[inline(always)]
fn mul_add(a: f64, b: f64, c: f64) -> f64 {
    #[cfg(all(feature = "std", target_feature = "fma"))]
    {
        a.mul_add(b, c)
    }
    #[cfg(not(all(feature = "std", target_feature = "fma")))]
    {
        a * b + c
    }
}

/// `eˣ` for one `f32` as the module docs describe (the lane loops inline it): computed in
/// `f64` to ~10⁻¹¹ relative, then rounded to `f32`.
#[inline(always)]
#[must_use]
pub(crate) fn exp_f32_fast(x: f32) -> f32 {
    #[allow(
        clippy::manual_clamp,
        reason = "max/min map a NaN to a finite value (the callers mask such lanes with a \
                  0·x that must stay 0); clamp would keep the NaN"
    )]
    let x = f64::from(x.max(-87.0).min(87.0));
    let v = x * LOG2E + ROUND_MAGIC;
    let k = v - ROUND_MAGIC;
    // The low mantissa bits of v hold k (two's complement, |k| ≤ 126).
    let k_bits = v.to_bits().wrapping_sub(ROUND_MAGIC.to_bits());
    let scale = f64::from_bits(k_bits.wrapping_add(1023) << 52);
    let r = mul_add(-k, LN2_LO, mul_add(-k, LN2_HI, x));
    let mut p = TAYLOR[0];
    for c in &TAYLOR[1..] {
        p = mul_add(p, r, *c);
    }
    let e = mul_add(p, r * r, r) + 1.0;
    #[allow(
        clippy::cast_possible_truncation,
        reason = "rounding the f64 result to f32 is the point"
    )]
    let y = (e * scale) as f32;
    y
}

/// `exp(−σ)` as the lane loops evaluate it: [`exp_f32_fast`] for `f32` when `FAST`
/// ([`ExpMode::Fast`]), else `T::exp` where `keep` (and 0 elsewhere, to skip the call for
/// lanes the caller masks anyway). The mode is a compile-time parameter so that the `f32`
/// fast path is branch-free and vectorises with the inlining lane loop.
#[inline(always)]
pub(crate) fn exp_neg<T: Real, const FAST: bool>(sigma: T, keep: bool) -> T {
    if FAST && TypeId::of::<T>() == TypeId::of::<f32>() {
        // T is f32: both conversions are exact and fold away.
        #[allow(
            clippy::cast_possible_truncation,
            reason = "T is f32 on this path, the conversion is exact"
        )]
        let x = sigma.to_f64() as f32;
        return T::from_f64(f64::from(exp_f32_fast(-x)));
    }
    if keep { (-sigma).exp() } else { T::ZERO }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_exp_rounds_like_the_standard_library() {
        // Every 7th f32 in [-6, 0]: the f64 evaluation rounds to the correctly rounded f32
        // except where e^x lies within ~1e-11 of a rounding boundary.
        let (mut n, mut differ, mut worst) = (0_u64, 0_u64, 0.0_f64);
        let lo = (-6.0_f32).to_bits();
        let mut b = 0x8000_0000_u32;
        while b <= lo {
            let x = f32::from_bits(b);
            let e = f64::from(x).exp();
            let y = exp_f32_fast(x);
            worst = worst.max(((f64::from(y) - e) / e).abs());
            differ += u64::from(y.to_bits() != x.exp().to_bits());
            n += 1;
            b += 7;
        }
        println!("fast exp: {differ} of {n} differ from expf, worst relative error {worst:.2e}");
        assert!(worst < 6.0e-8, "worst relative error {worst}");
        assert!(differ * 1000 < n, "{differ} of {n} differ from expf");
        assert!(
            exp_f32_fast(0.0).to_bits() == 1.0_f32.to_bits(),
            "exp(0) = 1"
        );
        assert!(exp_f32_fast(-1e30) < 1e-37, "underflow side");
        assert!(exp_f32_fast(f32::NAN).is_finite(), "NaN input is clamped");
    }

    #[test]
    fn dispatch_on_the_scalar_type() {
        let fast = exp_neg::<f32, true>(0.5, true);
        assert!(
            fast.to_bits() == exp_f32_fast(-0.5).to_bits(),
            "fast f32 uses exp_f32_fast"
        );
        let exact = exp_neg::<f32, false>(0.5, true);
        assert!(exact.to_bits() == (-0.5_f32).exp().to_bits(), "exact f32");
        let f64_fast = exp_neg::<f64, true>(0.5, true);
        assert!(
            f64_fast.to_bits() == (-0.5_f64).exp().to_bits(),
            "f64 is always exact"
        );
        assert!(exp_neg::<f64, false>(0.5, false).to_bits() == 0, "masked");
    }
}
