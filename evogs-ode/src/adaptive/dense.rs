//! Dense output: the pair's continuous extension `y(tₙ + θh) = yₙ ⊕ h Σ bᵢ(θ)Kᵢ`, and which
//! step an output time belongs to.
//!
//! The weights `bᵢ(θ)` are polynomials with `bᵢ(0) = 0` and `bᵢ(1) = bᵢ`
//! ([`Pair::dense_coefficients`]). On a Lie-group block the extension is
//! `Exp(h Σ bᵢ(θ)Kᵢ)·yₙ`: the same tangent combination fed to the same exponential update as
//! the step itself ([`Stepper`](crate::Stepper)'s block machinery), so it works on any block
//! the stepper supports. Its θ-derivative, needed for gradients with respect to output
//! times, uses `bᵢ'(θ)`.

use super::{Pair, StepSequence};
use crate::MAX_STAGES;
use evogs_math::Real;

/// The continuous extension of a pair, in floating point.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Extension<T> {
    /// `P[i][k]`: coefficient of `θ^{k+1}` in `bᵢ(θ)`.
    p: [[T; 4]; MAX_STAGES],
    /// The propagated weights `b`, returned exactly at θ = 1.
    b: [T; MAX_STAGES],
    /// Stages with a non-zero polynomial `bᵢ(θ)` (kept in updates even where `bᵢ(θ) = 0`).
    support: [bool; MAX_STAGES],
    s: usize,
}

impl<T: Real> Extension<T> {
    pub(crate) fn new(pair: Pair) -> Self {
        let t = pair.tableau();
        let rp = pair.dense_coefficients();
        let mut p = [[T::ZERO; 4]; MAX_STAGES];
        let mut b = [T::ZERO; MAX_STAGES];
        let mut support = [false; MAX_STAGES];
        for i in 0..t.stages() {
            support[i] = rp[i].iter().any(|c| !c.is_zero());
            b[i] = T::from_f64(t.b(i).to_f64());
            for k in 0..4 {
                p[i][k] = T::from_f64(rp[i][k].to_f64());
            }
        }
        Self {
            p,
            b,
            support,
            s: t.stages(),
        }
    }

    /// The stages the extension uses.
    pub(crate) fn support(&self) -> &[bool] {
        &self.support[..self.s]
    }

    /// `w[i] = bᵢ(θ)` (exactly `bᵢ` at θ = 1, so dense output at a step's end is bitwise
    /// the step's value) and `dw[i] = bᵢ'(θ)`.
    pub(crate) fn weights(&self, theta: T, w: &mut [T], dw: &mut [T]) {
        let (two, three, four) = (T::TWO, T::from_f64(3.0), T::from_f64(4.0));
        for i in 0..self.s {
            let p = &self.p[i];
            dw[i] = p[0] + theta * (two * p[1] + theta * (three * p[2] + theta * four * p[3]));
            w[i] = if theta == T::ONE {
                // bᵢ exactly (θ − 1 = 0); dual numbers keep the derivative bᵢ'(1)·dθ.
                self.b[i] + (theta - T::ONE) * dw[i]
            } else {
                theta * (p[0] + theta * (p[1] + theta * (p[2] + theta * p[3])))
            };
        }
    }
}

impl<T: Real> StepSequence<T> {
    /// The step an output time `tau` belongs to: the first step whose end `tₙ + hₙ` is not
    /// before `tau` (in the direction of integration), the last step for later times (a
    /// step's extension then extrapolates slightly; only replays allow that), and step 0
    /// for times before `t0`. `None` without steps.
    #[must_use]
    pub fn locate(&self, tau: T) -> Option<usize> {
        let n = self.len();
        if n == 0 {
            return None;
        }
        let dir = self.direction();
        // Binary search for the first n with (tau − end_n)·dir ≤ 0 (ends are monotone).
        let (mut lo, mut hi) = (0, n);
        while lo < hi {
            let mid = (lo + hi) / 2;
            let (t, h) = self.step(mid);
            if (tau - (t + h)) * dir <= T::ZERO {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        Some(lo.min(n - 1))
    }

    /// `θ = (tau − tₙ)/hₙ` of an output time in step `n`; exactly 1 when `tau` is the
    /// step's end `tₙ + hₙ` (which `(tau − tₙ)/hₙ` may miss by an ulp), so dense output at
    /// a step's end is bitwise the step's value.
    #[must_use]
    pub fn theta(&self, n: usize, tau: T) -> T {
        let (t, h) = self.step(n);
        let end = t + h;
        if tau == end {
            // 1, with the derivative 1/h of dual numbers kept.
            T::ONE + (tau - end) / h
        } else {
            (tau - t) / h
        }
    }
}

#[cfg(test)]
mod tests {
    use crate::adaptive::StepSequence;
    use evogs_math::Dual;

    /// At a step's end `θ` is exactly 1, where `(τ − tₙ)/hₙ` misses it by an ulp
    /// (0.1 + 0.2 is not 0.3), and its derivative with respect to τ is still `1/hₙ`.
    #[test]
    fn theta_is_one_at_a_step_end_and_keeps_its_derivative() {
        let c = |v: f64| Dual::new(v, 0.0);
        let seq = StepSequence::from_sizes(c(0.1), &[c(0.2), c(0.4)]);
        let (t, h) = seq.step(0);
        let end = t + h;
        assert!(
            ((end.re - t.re) / h.re).to_bits() != 1.0_f64.to_bits(),
            "an ulp off"
        );
        let theta = seq.theta(0, Dual::new(end.re, 1.0));
        assert!(theta.re.to_bits() == 1.0_f64.to_bits(), "θ = {}", theta.re);
        assert!((theta.eps - 5.0).abs() < 1e-15, "dθ/dτ = {}", theta.eps);
        // Inside the step: (τ − tₙ)/hₙ and 1/hₙ.
        let theta = seq.theta(0, Dual::new(0.15, 1.0));
        assert!((theta.re - 0.25).abs() < 1e-15 && (theta.eps - 5.0).abs() < 1e-15);
    }
}
