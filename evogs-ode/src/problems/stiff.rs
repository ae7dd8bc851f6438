//! The dissipative adjoint stress test of `docs/integrators.md` §7.9.

use crate::VectorField;
use evogs_math::Real;

/// `x₀' = −θ₀x₀ + θ₂x₁`, `x₁' = −θ₁x₁ + θ₃ sin x₀`, θ = `[θ₀, θ₁, θ₂, θ₃]`.
///
/// Reference setting ([`Default`]): `θ = (1, 50, 2, 0.5)`, `x(0) = (1, 1)`, `T = 1`,
/// loss `L = x₀(T) + 2x₁(T)`. The `−50` mode decays forward and therefore **grows** like
/// `e^{50t}` when x is re-integrated backward: the backsolve continuous adjoint
/// ([`ContinuousVariant::Reintegrate`](crate::ContinuousVariant)) reconstructs `x(0)` with
/// an enormous error and returns garbage gradients, while the checkpoint variant and the
/// exact discrete adjoint are fine. With `θ₁ = 5` every variant agrees to `O(hᵖ)`. No
/// closed form.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DissipativePair<T> {
    /// `[θ₀, θ₁, θ₂, θ₃]`.
    pub theta: [T; 4],
}

impl<T: Real> Default for DissipativePair<T> {
    fn default() -> Self {
        Self {
            theta: [T::ONE, T::from_f64(50.0), T::TWO, T::HALF],
        }
    }
}

impl<T: Real> DissipativePair<T> {
    /// The initial state `(1, 1)`.
    #[must_use]
    pub const fn initial_state() -> [T; 2] {
        [T::ONE, T::ONE]
    }

    /// The loss weights `c` of `L = cᵀx(T) = x₀(T) + 2x₁(T)`.
    #[must_use]
    pub const fn loss_weights() -> [T; 2] {
        [T::ONE, T::TWO]
    }
}

impl<T: Real> VectorField<T> for DissipativePair<T> {
    type Record = ();
    fn dim(&self) -> usize {
        2
    }
    fn n_params(&self) -> usize {
        4
    }
    fn eval(&mut self, _t: T, y: &[T], dydt: &mut [T]) {
        let [a, b, c, d] = self.theta;
        dydt[0] = -a * y[0] + c * y[1];
        dydt[1] = -b * y[1] + d * y[0].sin();
    }
    fn vjp(&mut self, _t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let [a, b, c, d] = self.theta;
        let (s, co) = y[0].sin_cos();
        d_y[0] += -a * w[0] + d * co * w[1];
        d_y[1] += c * w[0] - b * w[1];
        d_params[0] -= y[0] * w[0];
        d_params[1] -= y[1] * w[1];
        d_params[2] += y[1] * w[0];
        d_params[3] += s * w[1];
    }
}
