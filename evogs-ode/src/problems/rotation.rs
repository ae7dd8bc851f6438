//! Pure rotation kinematics on SO(3): constant rate (`docs/integrators.md` §7.4) and the
//! time-varying "Problem K" (§7.5). Fields return **world-frame** angular velocities
//! (`R' = ω̂R`), as every SO(3) block in this crate.

use super::ExactProblem;
use crate::{Block, StateLayout, VectorField};
use evogs_math::so3::exp_quat;
use evogs_math::{Quat, Real, Vec3};

/// `R' = ω̂R` with a constant world-frame rate ω, θ = ω.
///
/// Exact: `R(t) = Exp(ωt)·R₀`. Every exp-based method (Lie–Euler, RKMK) must reproduce it
/// to rounding, for any step: with `Ωᵢ ∥ ω`, `Jl⁻¹(Ωᵢ)ω = ω`. This is the regression test
/// for the multiplication side (world vs body) too.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstantRate<T> {
    /// The world-frame angular velocity.
    pub omega: Vec3<T>,
    /// Initial rotation (unit quaternion).
    pub r0: Quat<T>,
    /// End time.
    pub t_end: T,
}

impl<T: Real> Default for ConstantRate<T> {
    fn default() -> Self {
        Self {
            omega: Vec3::new(T::from_f64(0.3), T::from_f64(-0.5), T::from_f64(0.9)),
            r0: exp_quat(Vec3::new(
                T::from_f64(0.2),
                T::from_f64(0.7),
                T::from_f64(-0.4),
            )),
            t_end: T::from_f64(3.0),
        }
    }
}

impl<T: Real> VectorField<T> for ConstantRate<T> {
    type Record = ();
    fn dim(&self) -> usize {
        3
    }
    fn layout(&self) -> StateLayout {
        StateLayout::particles(&[Block::So3], 1)
    }
    fn n_params(&self) -> usize {
        3
    }
    fn eval(&mut self, _t: T, _y: &[T], dydt: &mut [T]) {
        self.omega.write_to(dydt);
    }
    /// The rate does not depend on R; `∂f/∂ω = I`.
    fn vjp(&mut self, _t: T, _y: &[T], w: &[T], _d_y: &mut [T], d_params: &mut [T]) {
        for (d, wi) in d_params.iter_mut().zip(w) {
            *d += *wi;
        }
    }
}

impl<T: Real> ExactProblem<T> for ConstantRate<T> {
    fn name(&self) -> &'static str {
        "so3-constant-rate"
    }
    fn t_end(&self) -> T {
        self.t_end
    }
    fn initial_state(&self, y0: &mut [T]) {
        self.r0.write_to(y0);
    }
    fn exact(&self, t: T, out: &mut [T]) {
        exp_quat(self.omega * t).mul_quat(self.r0).write_to(out);
    }
}

/// "Problem K" (`docs/integrators.md` §7.5): `R(t) = Rz(a(t))·Rx(b(t))` with
/// `a(t) = 0.7t + 0.3 sin 2t`, `b(t) = 0.5 sin 1.3t`, `R(0) = I`, `T = 4`.
///
/// Differentiating, `Ṙ = ȧ ẑ^ R + ḃ (Rz x̂)^ R`, so the **world-frame** rate is
/// `ω_s(t) = (ḃ cos a, ḃ sin a, ȧ)` (the body rate of §4.7, `(ḃ, ȧ sin b, ȧ cos b)`, is
/// `Rᵀω_s`). The rates at different times do not commute, so the problem separates the
/// orders of Lie integrators: Lie–Euler 1, RKMK midpoint/Heun 2, RKMK4 4 (RKMK4 without
/// the `dexp⁻¹` correction would be 2). No parameters.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProblemK;

impl ProblemK {
    /// The angles `(a(t), b(t))`.
    #[must_use]
    pub fn angles<T: Real>(t: T) -> (T, T) {
        let a = T::from_f64(0.7) * t + T::from_f64(0.3) * (T::TWO * t).sin();
        let b = T::from_f64(0.5) * (T::from_f64(1.3) * t).sin();
        (a, b)
    }

    /// The world-frame angular velocity `(ḃ cos a, ḃ sin a, ȧ)`.
    #[must_use]
    pub fn world_rate<T: Real>(t: T) -> Vec3<T> {
        let (a, _) = Self::angles(t);
        let a_dot = T::from_f64(0.7) + T::from_f64(0.6) * (T::TWO * t).cos();
        let b_dot = T::from_f64(0.65) * (T::from_f64(1.3) * t).cos();
        let (s, c) = a.sin_cos();
        Vec3::new(b_dot * c, b_dot * s, a_dot)
    }
}

impl<T: Real> VectorField<T> for ProblemK {
    type Record = ();
    fn dim(&self) -> usize {
        3
    }
    fn layout(&self) -> StateLayout {
        StateLayout::particles(&[Block::So3], 1)
    }
    fn n_params(&self) -> usize {
        0
    }
    fn eval(&mut self, t: T, _y: &[T], dydt: &mut [T]) {
        Self::world_rate(t).write_to(dydt);
    }
    /// The rate depends on time only: nothing to add.
    fn vjp(&mut self, _t: T, _y: &[T], _w: &[T], _d_y: &mut [T], _d_params: &mut [T]) {}
}

impl<T: Real> ExactProblem<T> for ProblemK {
    fn name(&self) -> &'static str {
        "problem-k"
    }
    fn t_end(&self) -> T {
        T::from_f64(4.0)
    }
    fn initial_state(&self, y0: &mut [T]) {
        Quat::<T>::identity().write_to(y0);
    }
    fn exact(&self, t: T, out: &mut [T]) {
        let (a, b) = Self::angles(t);
        let rz = exp_quat(Vec3::new(T::ZERO, T::ZERO, a));
        let rx = exp_quat(Vec3::new(b, T::ZERO, T::ZERO));
        rz.mul_quat(rx).write_to(out);
    }
}
