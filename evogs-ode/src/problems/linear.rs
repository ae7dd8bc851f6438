//! The rotating, decaying linear system of `docs/integrators.md` §7.1, with its exact discrete
//! gradient.

use super::ExactProblem;
use crate::{Tableau, VectorField};
use evogs_math::Real;

/// `x' = A x` with `A = [[α, β], [−β, α]]`, θ = `[α, β]`.
///
/// Exact: `x(t) = e^{αt}(x₁ cos βt + x₂ sin βt, −x₁ sin βt + x₂ cos βt)`. Reference setting
/// ([`Default`]): `α = −0.1`, `β = 2`, `x₀ = (1, 0)`, `T = 10`.
///
/// As a complex scalar `z = x₁ + i x₂` this is `z' = (α − iβ) z`, so one step of any
/// explicit RK method multiplies `z` by the stability polynomial `R(h(α − iβ))`, and the
/// discrete map is `x_N = M^N x₀` with `M = Σₖ γₖ (hA)ᵏ` ([`RotatingDecay::step_matrix`]).
/// For `L = cᵀx_N` the exact discrete gradient is `(Mᵀ)^N c`
/// ([`RotatingDecay::discrete_gradient`]): a machine-precision oracle for the discrete
/// adjoint, with no finite differences.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RotatingDecay<T> {
    /// Decay rate α (negative: decay).
    pub alpha: T,
    /// Angular frequency β.
    pub beta: T,
    /// Initial state.
    pub x0: [T; 2],
    /// End time.
    pub t_end: T,
}

impl<T: Real> Default for RotatingDecay<T> {
    fn default() -> Self {
        Self {
            alpha: T::from_f64(-0.1),
            beta: T::TWO,
            x0: [T::ONE, T::ZERO],
            t_end: T::from_f64(10.0),
        }
    }
}

type M2<T> = [[T; 2]; 2];

fn mat_mul<T: Real>(a: &M2<T>, b: &M2<T>) -> M2<T> {
    let mut out = [[T::ZERO; 2]; 2];
    for i in 0..2 {
        for j in 0..2 {
            out[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j];
        }
    }
    out
}

impl<T: Real> RotatingDecay<T> {
    /// The one-step matrix `M = Σₖ γₖ (hA)ᵏ` of a tableau (`γ` from
    /// [`Tableau::stability_coefficients`]), row-major.
    #[must_use]
    pub fn step_matrix(&self, tableau: &Tableau, h: T) -> M2<T> {
        let ha = [
            [h * self.alpha, h * self.beta],
            [-h * self.beta, h * self.alpha],
        ];
        let mut power = [[T::ONE, T::ZERO], [T::ZERO, T::ONE]];
        let mut m = [[T::ZERO; 2]; 2];
        for g in tableau.stability_coefficients() {
            let g = T::from_f64(g.to_f64());
            for i in 0..2 {
                for j in 0..2 {
                    m[i][j] += g * power[i][j];
                }
            }
            power = mat_mul(&power, &ha);
        }
        m
    }

    /// The exact gradient of `L = cᵀx_N` with respect to `x₀` for `n` steps of size `h`:
    /// `(Mᵀ)^n c`.
    #[must_use]
    pub fn discrete_gradient(&self, tableau: &Tableau, h: T, n: usize, c: [T; 2]) -> [T; 2] {
        let m = self.step_matrix(tableau, h);
        let mut g = c;
        for _ in 0..n {
            g = [
                m[0][0] * g[0] + m[1][0] * g[1],
                m[0][1] * g[0] + m[1][1] * g[1],
            ];
        }
        g
    }
}

impl<T: Real> VectorField<T> for RotatingDecay<T> {
    type Record = ();
    fn dim(&self) -> usize {
        2
    }
    fn n_params(&self) -> usize {
        2
    }
    fn eval(&mut self, _t: T, y: &[T], dydt: &mut [T]) {
        dydt[0] = self.alpha * y[0] + self.beta * y[1];
        dydt[1] = -self.beta * y[0] + self.alpha * y[1];
    }
    /// `d_x += Aᵀw`, `dα += w·x`, `dβ += w₁x₂ − w₂x₁`.
    fn vjp(&mut self, _t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        d_y[0] += self.alpha * w[0] - self.beta * w[1];
        d_y[1] += self.beta * w[0] + self.alpha * w[1];
        d_params[0] += w[0] * y[0] + w[1] * y[1];
        d_params[1] += w[0] * y[1] - w[1] * y[0];
    }
}

impl<T: Real> ExactProblem<T> for RotatingDecay<T> {
    fn name(&self) -> &'static str {
        "rotating-decay"
    }
    fn t_end(&self) -> T {
        self.t_end
    }
    fn initial_state(&self, y0: &mut [T]) {
        y0[..2].copy_from_slice(&self.x0);
    }
    fn exact(&self, t: T, out: &mut [T]) {
        let e = (self.alpha * t).exp();
        let (s, c) = (self.beta * t).sin_cos();
        let [x1, x2] = self.x0;
        out[0] = e * (x1 * c + x2 * s);
        out[1] = e * (-x1 * s + x2 * c);
    }
}
