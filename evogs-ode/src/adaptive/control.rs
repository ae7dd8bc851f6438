//! Step-size control: the mixed absolute/relative error norm over tangent components
//! ([`error_norm`]), the PI controller ([`StepControl`]) and the initial-step heuristic of
//! Hairer, Nørsett & Wanner (book I, §II.4) ([`initial_step_size`]).

use crate::{Block, StateLayout};
use evogs_math::Real;

/// The PI step-size controller's constants (Hairer's `DOPRI5` defaults).
///
/// With `q` the order of the embedded solution and `k = q + 1` (the local error estimate
/// is `O(hᵏ)`), `α = 1/k − 0.75 β`, and an error `err` (≤ 1: accept) after a previous
/// accepted error `err_prev`,
///
/// ```text
/// accept:  factor = clamp(safety · err^(−α) · err_prev^β, min_factor, max_factor),
///          at most 1 right after a rejection;            err_prev ← max(err, 1e-4)
/// reject:  factor = max(min_factor, safety · err^(−α))
/// h_new  = factor · h
/// ```
///
/// `beta = 0` gives the classical (I) controller `safety · err^(−1/k)` of scipy's
/// `solve_ivp`; `beta > 0` damps the step-size oscillations of the I controller on
/// problems at the edge of stability (Gustafsson; Söderlind). Before the first step,
/// `err_prev = 1e-4` as in `DOPRI5`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepControl<T> {
    /// Safety factor on the optimal step (default 0.9).
    pub safety: T,
    /// Smallest factor per step (default 0.2).
    pub min_factor: T,
    /// Largest factor per step (default 10).
    pub max_factor: T,
    /// The PI controller's `β` (default 0.04; 0 for a pure I controller).
    pub beta: T,
}

impl<T: Real> Default for StepControl<T> {
    fn default() -> Self {
        Self {
            safety: T::from_f64(0.9),
            min_factor: T::from_f64(0.2),
            max_factor: T::from_f64(10.0),
            beta: T::from_f64(0.04),
        }
    }
}

/// The smallest remembered error (`DOPRI5`'s `facold` floor).
const ERR_FLOOR: f64 = 1e-4;

/// `x^p` for `x ≥ 0` (`0^(−α) = ∞`, clamped by the callers).
fn pow<T: Real>(x: T, p: T) -> T {
    (p * x.ln()).exp()
}

impl<T: Real> StepControl<T> {
    /// A pure I controller (`beta = 0`).
    #[must_use]
    pub fn integral() -> Self {
        Self {
            beta: T::ZERO,
            ..Self::default()
        }
    }

    /// `α = 1/k − 0.75 β` for an error estimate of order `O(hᵏ)`.
    fn alpha(&self, k: usize) -> T {
        T::ONE / T::from_usize(k) - T::from_f64(0.75) * self.beta
    }

    /// `true` if the constants are usable: finite, `0 < safety ≤ 1`,
    /// `0 < min_factor ≤ 1 ≤ max_factor`, `0 ≤ beta < 1/k`.
    pub(crate) fn is_valid(&self, k: usize) -> bool {
        let all_finite = [self.safety, self.min_factor, self.max_factor, self.beta]
            .iter()
            .all(|v| v.is_finite());
        all_finite
            && self.safety > T::ZERO
            && self.safety <= T::ONE
            && self.min_factor > T::ZERO
            && self.min_factor <= T::ONE
            && self.max_factor >= T::ONE
            && self.beta >= T::ZERO
            && self.alpha(k) > T::ZERO
    }

    /// The factor after an accepted step with error `err ≤ 1`.
    pub(crate) fn accept_factor(&self, err: T, err_prev: T, k: usize, after_reject: bool) -> T {
        let f = self.safety * pow(err, -self.alpha(k)) * pow(err_prev, self.beta);
        let f = if f.is_nan() { self.max_factor } else { f };
        let f = f.clamp(self.min_factor, self.max_factor);
        if after_reject { f.min(T::ONE) } else { f }
    }

    /// The factor after a rejected step (`err > 1`, or not finite).
    pub(crate) fn reject_factor(&self, err: T, k: usize) -> T {
        if !err.is_finite() {
            return self.min_factor;
        }
        (self.safety * pow(err, -self.alpha(k)))
            .max(self.min_factor)
            .min(self.safety)
    }

    /// The error remembered for the next accepted step.
    pub(crate) fn remembered(err: T) -> T {
        err.max(T::from_f64(ERR_FLOOR))
    }

    /// The error remembered before the first step.
    pub(crate) fn initial_memory() -> T {
        T::from_f64(ERR_FLOOR)
    }
}

/// Per tangent component, the magnitude `|y|` that scales the relative tolerance.
///
/// Euclidean entries: `|yₑ|`. A block of a Lie group (every other block, e.g. an SO(3)
/// rotation): all its tangent components get `max(1, max |ambient entries|)`; a rotation's
/// natural unit is one radian, so a rotation gets 1.
pub(crate) fn tangent_magnitudes<T: Real>(layout: &StateLayout, y: &[T], out: &mut [T]) {
    let (pa, pt) = (layout.particle_ambient_len(), layout.particle_tangent_len());
    for p in 0..layout.count() {
        for sp in layout.spans() {
            let a = p * pa + sp.ambient;
            let t = p * pt + sp.tangent;
            if let Block::Euclidean(m) = sp.block {
                for e in 0..m {
                    out[t + e] = y[a + e].abs();
                }
            } else {
                let big = y[a..a + sp.block.ambient_len()]
                    .iter()
                    .fold(T::ONE, |acc, v| acc.max(v.abs()));
                for o in &mut out[t..t + sp.block.tangent_len()] {
                    *o = big;
                }
            }
        }
    }
}

/// The RMS norm `sqrt(1/n Σₑ (vₑ / scₑ)²)` with `scₑ = atol + rtol·max(m0ₑ, m1ₑ)`
/// (Hairer's mixed error norm; `m` from [`tangent_magnitudes`] of the two states).
/// 0 for an empty state.
pub(crate) fn error_norm<T: Real>(v: &[T], m0: &[T], m1: &[T], rtol: T, atol: T) -> T {
    if v.is_empty() {
        return T::ZERO;
    }
    let mut acc = T::ZERO;
    for ((x, a), b) in v.iter().zip(m0).zip(m1) {
        let sc = atol + rtol * a.max(*b);
        acc += (*x / sc).sq();
    }
    (acc / T::from_usize(v.len())).sqrt()
}

/// The initial step of HNW I §II.4 from the norms (all with [`error_norm`]'s scale at y₀):
/// `d0 = ‖y₀‖`, `d1 = ‖f(t₀, y₀)‖`, and `d2 = ‖f(t₀ + h₀, y₀ ⊕ h₀f₀) − f₀‖ / |h₀|` after
/// the trial step `h₀` of [`trial_step_size`]:
/// `h₁ = (0.01 / max(d1, d2))^(1/k)` (or `max(1e-6, 1e-3 |h₀|)` if both are ≤ 1e-15),
/// `h = min(100 |h₀|, h₁, h_max)`.
pub(crate) fn initial_step_size<T: Real>(h0: T, d1: T, d2: T, k: usize, h_max: T) -> T {
    let dmax = d1.max(d2);
    let h1 = if dmax <= T::from_f64(1e-15) {
        T::from_f64(1e-6).max(h0.abs() * T::from_f64(1e-3))
    } else {
        pow(T::from_f64(0.01) / dmax, T::ONE / T::from_usize(k))
    };
    (T::from_f64(100.0) * h0.abs()).min(h1).min(h_max)
}

/// The trial step `h₀ = 0.01 d0/d1` (or 1e-6 if `d0` or `d1` is below 1e-5), at most
/// `h_max`.
pub(crate) fn trial_step_size<T: Real>(d0: T, d1: T, h_max: T) -> T {
    let tiny = T::from_f64(1e-5);
    let h0 = if d0 < tiny || d1 < tiny {
        T::from_f64(1e-6)
    } else {
        T::from_f64(0.01) * d0 / d1
    };
    h0.min(h_max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controller_factors_are_bounded_and_monotone() {
        let c = StepControl::<f64>::default();
        assert!(c.is_valid(5), "defaults");
        // Zero error: the largest growth; tiny errors saturate.
        assert!(
            (c.accept_factor(0.0, 1e-4, 5, false) - 10.0).abs() < 1e-15,
            "err = 0"
        );
        // Smaller errors give larger steps.
        let f1 = c.accept_factor(0.5, 0.5, 5, false);
        let f2 = c.accept_factor(0.1, 0.5, 5, false);
        assert!(f2 > f1 && f1 > 0.2, "monotone: {f1} {f2}");
        // No growth right after a rejection.
        assert!(c.accept_factor(1e-3, 0.5, 5, true) <= 1.0, "after reject");
        // Rejections shrink, at least by the safety factor.
        let r = c.reject_factor(4.0, 5);
        assert!((0.2..=0.9).contains(&r), "reject {r}");
        assert!(
            (c.reject_factor(f64::NAN, 5) - 0.2).abs() < 1e-15,
            "NaN error"
        );
        // The I controller is scipy's: safety · err^(−1/5).
        let i = StepControl::<f64>::integral();
        let want = 0.9 * 0.3_f64.powf(-0.2);
        assert!(
            (i.accept_factor(0.3, 0.7, 5, false) - want).abs() < 1e-14,
            "I controller"
        );
        let bad = StepControl {
            beta: 0.5,
            ..StepControl::<f64>::default()
        };
        assert!(!bad.is_valid(5), "β ≥ 1/k");
    }

    #[test]
    fn each_bound_of_the_constants_is_where_it_says() {
        let d = StepControl::<f64>::default();
        let with = |f: fn(&mut StepControl<f64>)| {
            let mut c = d;
            f(&mut c);
            c
        };
        // At each inclusive bound: valid.
        assert!(with(|c| c.safety = 1.0).is_valid(5), "safety = 1");
        assert!(with(|c| c.min_factor = 1.0).is_valid(5), "min_factor = 1");
        assert!(with(|c| c.max_factor = 1.0).is_valid(5), "max_factor = 1");
        assert!(with(|c| c.beta = 0.0).is_valid(5), "beta = 0");
        // At each exclusive bound, or a hair past an inclusive one: invalid.
        assert!(!with(|c| c.safety = 0.0).is_valid(5), "safety = 0");
        assert!(!with(|c| c.safety = 1.0 + 1e-15).is_valid(5), "safety > 1");
        assert!(!with(|c| c.min_factor = 0.0).is_valid(5), "min_factor = 0");
        assert!(
            !with(|c| c.min_factor = 1.0 + 1e-15).is_valid(5),
            "min_factor > 1"
        );
        assert!(
            !with(|c| c.max_factor = 1.0 - 1e-15).is_valid(5),
            "max_factor < 1"
        );
        assert!(!with(|c| c.beta = -1e-300).is_valid(5), "beta < 0");
        assert!(
            !with(|c| c.max_factor = f64::INFINITY).is_valid(5),
            "infinite"
        );
        // α = 1/k − 0.75β is exactly 0 in f64 for k = 2, β = 2/3 (and positive just below).
        let edge = with(|c| c.beta = 2.0 / 3.0);
        assert!(edge.alpha(2).to_bits() == 0, "α = {}", edge.alpha(2));
        assert!(!edge.is_valid(2), "α = 0");
        assert!(with(|c| c.beta = 0.66).is_valid(2), "α > 0");
    }

    #[test]
    fn factors_follow_their_formulas() {
        let c = StepControl::<f64>::default();
        let alpha = 0.2 - 0.75 * 0.04;
        // Rejected: safety · err^(−α), between min_factor and safety.
        let want = 0.9 * 4.0_f64.powf(-alpha);
        let r = c.reject_factor(4.0, 5);
        assert!((r - want).abs() < 1e-15, "reject {r} vs {want}");
        // Accepted (PI): safety · err^(−α) · err_prev^β.
        let want = 0.9 * 0.3_f64.powf(-alpha) * 0.7_f64.powf(0.04);
        let a = c.accept_factor(0.3, 0.7, 5, false);
        assert!((a - want).abs() < 1e-15, "accept {a} vs {want}");
        // err = err_prev = 0: ∞ · 0 is NaN, taken as the largest growth.
        assert!(c.accept_factor(0.0, 0.0, 5, false).to_bits() == 10.0_f64.to_bits());
        // A floor above the formula's value is reached.
        let high_floor = StepControl {
            min_factor: 0.95,
            ..c
        };
        let a = high_floor.accept_factor(1.0, 1e-4, 5, false);
        assert!(a.to_bits() == 0.95_f64.to_bits(), "{a}");
    }

    #[test]
    fn initial_steps_follow_the_heuristic() {
        let bits = |x: f64| x.to_bits();
        // h₁ = (0.01 / max(d1, d2))^(1/k): (0.01/4)^(1/2) = 0.05, below 100|h₀| and h_max.
        let h = initial_step_size(1.0, 4.0, 0.5, 2, 1.0);
        assert!((h - 0.05).abs() < 1e-16, "{h}");
        // Both norms negligible: h₁ = max(1e-6, 1e-3 |h₀|).
        let h = initial_step_size(-0.01, 0.0, 1e-16, 2, 1.0);
        assert!((h - 1e-5).abs() < 1e-20, "{h}");
        let h = initial_step_size(1e-4, 0.0, 0.0, 2, 1.0);
        assert!(bits(h) == bits(1e-6), "{h}");
        // 100 |h₀| binds: h₁ = (0.01/1e-12)^(1/2) = 1e5.
        let h = initial_step_size(1e-4, 1e-12, 0.0, 2, 1.0);
        assert!((h - 0.01).abs() < 1e-17, "{h}");
        // h_max binds.
        assert!(bits(initial_step_size(1.0, 1e-12, 0.0, 2, 0.3)) == bits(0.3));
        // The trial step 0.01 d0/d1, or 1e-6 when either norm is below 1e-5.
        assert!((trial_step_size(2.0, 4.0, 1.0) - 0.005).abs() < 1e-18);
        assert!(
            bits(trial_step_size(1e-6, 4.0, 1.0)) == bits(1e-6),
            "d0 small"
        );
        assert!(
            bits(trial_step_size(4.0, 1e-6, 1.0)) == bits(1e-6),
            "d1 small"
        );
        assert!(
            (trial_step_size(1e-5, 1e-5, 1.0) - 0.01).abs() < 1e-17,
            "at 1e-5"
        );
        assert!(
            bits(trial_step_size(2.0, 1.0, 0.004)) == bits(0.004),
            "h_max"
        );
    }

    #[test]
    fn the_norm_is_rms_with_mixed_scale() {
        let v = [1e-6, -2e-6];
        let m = [0.0, 3.0];
        let n = error_norm(&v, &m, &m, 1e-3, 1e-6);
        let want = (((1e-6 / 1e-6_f64).powi(2) + (2e-6 / (1e-6 + 3e-3_f64)).powi(2)) / 2.0).sqrt();
        assert!((n - want).abs() < 1e-15, "{n} vs {want}");
        let l = StateLayout::particles(&[Block::Euclidean(1), Block::So3], 1);
        let mut out = [0.0; 4];
        tangent_magnitudes(&l, &[-2.5, 0.6, 0.0, 0.8, 0.0], &mut out);
        let want = [2.5, 1.0, 1.0, 1.0];
        assert!(
            out.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-300),
            "rotation components scaled by 1: {out:?}"
        );
        // Two particles: the second's entries are read and written at its own offsets.
        let l = StateLayout::particles(&[Block::Euclidean(1), Block::Se3], 2);
        let mut y = [0.0; 16];
        y[..8].copy_from_slice(&[-2.5, 1.0, 0.0, 0.0, 0.0, 0.4, -0.3, 0.2]);
        y[8..].copy_from_slice(&[0.7, 1.0, 0.0, 0.0, 0.0, -3.0, 0.5, 0.1]);
        let mut out = [0.0; 14];
        tangent_magnitudes(&l, &y, &mut out);
        let mut want = [1.0; 14];
        (want[0], want[7]) = (2.5, 0.7);
        want[8..].fill(3.0);
        assert!(out.to_vec() == want.to_vec(), "two particles: {out:?}");
    }
}
