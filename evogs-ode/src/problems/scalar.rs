//! Scalar problems with closed forms (`docs/integrators.md` §7.2): the logistic equation
//! (nonlinear) and `y' = k cos(t) y` (non-autonomous).

use super::ExactProblem;
use crate::VectorField;
use evogs_math::Real;

/// The logistic equation `y' = r y (1 − y)`, θ = `[r]`.
///
/// Exact: `y(t) = 1/(1 + (1/y₀ − 1) e^{−r t})`. Reference setting (`docs/integrators.md` §7.2,
/// [`Default`]): `r = 1`, `y₀ = 0.1`, `T = 5`, `y = 1/(1 + 9e^{−t})`. Nonlinear, so every
/// order condition matters (the fake RK4 of `docs/integrators.md` §2 shows slope 2 here).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Logistic<T> {
    /// Growth rate r (the parameter).
    pub rate: T,
    /// Initial value y₀ (in (0, 1)).
    pub y0: T,
    /// End time.
    pub t_end: T,
}

impl<T: Real> Default for Logistic<T> {
    fn default() -> Self {
        Self {
            rate: T::ONE,
            y0: T::from_f64(0.1),
            t_end: T::from_f64(5.0),
        }
    }
}

impl<T: Real> VectorField<T> for Logistic<T> {
    type Record = ();
    fn dim(&self) -> usize {
        1
    }
    fn n_params(&self) -> usize {
        1
    }
    fn eval(&mut self, _t: T, y: &[T], dydt: &mut [T]) {
        dydt[0] = self.rate * y[0] * (T::ONE - y[0]);
    }
    /// `∂f/∂y = r(1 − 2y)`, `∂f/∂r = y(1 − y)`.
    fn vjp(&mut self, _t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        d_y[0] += self.rate * (T::ONE - T::TWO * y[0]) * w[0];
        d_params[0] += y[0] * (T::ONE - y[0]) * w[0];
    }
}

impl<T: Real> ExactProblem<T> for Logistic<T> {
    fn name(&self) -> &'static str {
        "logistic"
    }
    fn t_end(&self) -> T {
        self.t_end
    }
    fn initial_state(&self, y0: &mut [T]) {
        y0[0] = self.y0;
    }
    fn exact(&self, t: T, out: &mut [T]) {
        out[0] = T::ONE / (T::ONE + (T::ONE / self.y0 - T::ONE) * (-self.rate * t).exp());
    }
}

/// The non-autonomous growth `y' = k cos(t) y`, θ = `[k]`.
///
/// Exact: `y(t) = y₀ e^{k sin t}` (from t = 0). Reference setting ([`Default`]): `k = 1`,
/// `y₀ = 1`, `T = 4` (`docs/integrators.md` §7.2). Only a non-autonomous problem sees a wrong node
/// vector `c`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CosGrowth<T> {
    /// Coefficient k (the parameter).
    pub k: T,
    /// Initial value y₀.
    pub y0: T,
    /// End time.
    pub t_end: T,
}

impl<T: Real> Default for CosGrowth<T> {
    fn default() -> Self {
        Self {
            k: T::ONE,
            y0: T::ONE,
            t_end: T::from_f64(4.0),
        }
    }
}

impl<T: Real> VectorField<T> for CosGrowth<T> {
    type Record = ();
    fn dim(&self) -> usize {
        1
    }
    fn n_params(&self) -> usize {
        1
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        dydt[0] = self.k * t.cos() * y[0];
    }
    /// `∂f/∂y = k cos t`, `∂f/∂k = y cos t`.
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let c = t.cos();
        d_y[0] += self.k * c * w[0];
        d_params[0] += c * y[0] * w[0];
    }
}

impl<T: Real> ExactProblem<T> for CosGrowth<T> {
    fn name(&self) -> &'static str {
        "cos-growth"
    }
    fn t_end(&self) -> T {
        self.t_end
    }
    fn initial_state(&self, y0: &mut [T]) {
        y0[0] = self.y0;
    }
    fn exact(&self, t: T, out: &mut [T]) {
        out[0] = self.y0 * (self.k * t.sin()).exp();
    }
}
