//! The harmonic oscillator (`docs/integrators.md` §7.3).

use super::ExactProblem;
use crate::VectorField;
use evogs_math::Real;

/// `x'' = −ω²x` as the first-order system `(x, v)' = (v, −ω²x)`, θ = `[ω]`.
///
/// Exact: `x = x₀ cos ωt + (v₀/ω) sin ωt`, `v = −x₀ω sin ωt + v₀ cos ωt`; energy
/// `E = ½(v² + ω²x²)` ([`HarmonicOscillator::energy`]). RK4 is not energy-preserving: it
/// loses about `(ωh)⁶/72` of the energy per step. Reference setting ([`Default`]):
/// `ω = 2`, `(x₀, v₀) = (1, 0)`, `T = 5`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HarmonicOscillator<T> {
    /// Angular frequency ω (the parameter).
    pub omega: T,
    /// Initial position.
    pub x0: T,
    /// Initial velocity.
    pub v0: T,
    /// End time.
    pub t_end: T,
}

impl<T: Real> Default for HarmonicOscillator<T> {
    fn default() -> Self {
        Self {
            omega: T::TWO,
            x0: T::ONE,
            v0: T::ZERO,
            t_end: T::from_f64(5.0),
        }
    }
}

impl<T: Real> HarmonicOscillator<T> {
    /// `E = ½(v² + ω²x²)` of a state `(x, v)`.
    #[must_use]
    pub fn energy(&self, y: &[T]) -> T {
        T::HALF * (y[1].sq() + (self.omega * y[0]).sq())
    }
}

impl<T: Real> VectorField<T> for HarmonicOscillator<T> {
    type Record = ();
    fn dim(&self) -> usize {
        2
    }
    fn n_params(&self) -> usize {
        1
    }
    fn eval(&mut self, _t: T, y: &[T], dydt: &mut [T]) {
        dydt[0] = y[1];
        dydt[1] = -self.omega.sq() * y[0];
    }
    /// `d_x += −ω² w_v`, `d_v += w_x`, `dω += −2ωx w_v`.
    fn vjp(&mut self, _t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        d_y[0] -= self.omega.sq() * w[1];
        d_y[1] += w[0];
        d_params[0] -= T::TWO * self.omega * y[0] * w[1];
    }
}

impl<T: Real> ExactProblem<T> for HarmonicOscillator<T> {
    fn name(&self) -> &'static str {
        "harmonic-oscillator"
    }
    fn t_end(&self) -> T {
        self.t_end
    }
    fn initial_state(&self, y0: &mut [T]) {
        y0[0] = self.x0;
        y0[1] = self.v0;
    }
    fn exact(&self, t: T, out: &mut [T]) {
        let (s, c) = (self.omega * t).sin_cos();
        out[0] = self.x0 * c + self.v0 / self.omega * s;
        out[1] = -self.x0 * self.omega * s + self.v0 * c;
    }
}
