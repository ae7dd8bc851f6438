//! The discrete adjoint: [`discrete_adjoint`] (details in its docs).

use crate::{Checkpointing, Stepper, Trajectory, VectorField};
use alloc::vec;
use evogs_math::Real;

/// Gradient of `L(y_N)` with respect to `y_0` and the field parameters, by the exact
/// discrete adjoint.
///
/// For a loss `L(y_N)` of the final state, the reverse sweep starts from
/// `λ_N = ∂L/∂y_N` and applies the transposed step ([`Stepper::step_vjp`]) for
/// `n = N−1, …, 0`, accumulating `∂L/∂θ` on the way; `λ_0 = ∂L/∂y_0`. Every operation is
/// transposed algebra, so the result is the gradient of what the forward solver computed,
/// up to rounding (not an approximation of the gradient of the exact flow). For Runge–Kutta
/// methods with positive weights this gradient is also an approximation of the exact one,
/// of the method's order (Hager 2000; `docs/integrators.md` §4).
///
/// States are taken from the [`Trajectory`]: directly with `StoreAll`, or, with
/// `Every(k)`, by recomputing each k-step segment forward from its checkpoint into a
/// k-state buffer (the two-level √N scheme of `docs/integrators.md` §5). Both give bitwise
/// identical results.
///
/// - `d_final = ∂L/∂y_N` (tangent coordinates; SO(3) blocks: left-perturbation
///   cotangents);
/// - `d_y0` is **overwritten** with `∂L/∂y_0` (tangent coordinates);
/// - `d_params` is **accumulated** into (so several losses or frames can share it).
///
/// `stepper` must use the method (tableau) that produced the trajectory.
///
/// # Panics
/// If the lengths do not match the layout and the field.
///
/// ```
/// use evogs_ode::{Checkpointing, Method, Stepper, TimeGrid, VectorField};
/// use evogs_ode::{discrete_adjoint, integrate_trajectory, fields::LinearField};
/// // y' = a·y: y_N = R(ha)^N y_0, so ∂y_N/∂y_0 = R(ha)^N exactly.
/// let mut f = LinearField::new(1, vec![-0.7]);
/// let mut st = Stepper::new(Method::Rk4, f.layout());
/// let grid = TimeGrid::uniform(0.0, 2.0, 10);
/// let traj = integrate_trajectory(&mut f, &mut st, &grid, &[1.3], Checkpointing::StoreAll);
/// let (mut d_y0, mut d_a) = ([0.0], [0.0]);
/// discrete_adjoint(&mut f, &mut st, &traj, &[1.0], &mut d_y0, &mut d_a);
/// let r = Method::Rk4.tableau().stability_function(-0.7 * 0.2_f64);
/// assert!((d_y0[0] - r.powi(10)).abs() < 1e-15);
/// ```
pub fn discrete_adjoint<T: Real, F: VectorField<T> + ?Sized>(
    field: &mut F,
    stepper: &mut Stepper<T>,
    trajectory: &Trajectory<T>,
    d_final: &[T],
    d_y0: &mut [T],
    d_params: &mut [T],
) {
    discrete_adjoint_observed(
        field,
        stepper,
        trajectory,
        d_final,
        d_y0,
        d_params,
        |_, _| {},
    );
}

/// [`discrete_adjoint`] with observations at intermediate states: after the reverse sweep
/// has formed the cotangent `λ_k` at grid index `k` (for `k = N−1, …, 0`), it calls
/// `observe(k, λ_k)`, which may add `∂L/∂y_k` of a loss on `y_k` into it.
///
/// # Panics
/// If the lengths do not match the layout and the field.
pub fn discrete_adjoint_observed<T, F, O>(
    field: &mut F,
    stepper: &mut Stepper<T>,
    trajectory: &Trajectory<T>,
    d_final: &[T],
    d_y0: &mut [T],
    d_params: &mut [T],
    mut observe: O,
) where
    T: Real,
    F: VectorField<T> + ?Sized,
    O: FnMut(usize, &mut [T]),
{
    assert_eq!(
        d_final.len(),
        d_y0.len(),
        "d_final and d_y0 differ in length"
    );
    let grid = trajectory.grid();
    let n = grid.n_steps();
    let lambda = d_y0;
    lambda.copy_from_slice(d_final);
    match trajectory.checkpointing() {
        Checkpointing::StoreAll => {
            for k in (0..n).rev() {
                let (t, h) = grid.step(k);
                let y = trajectory.state(k).expect("every state is stored");
                stepper.step_vjp(field, t, h, y, lambda, d_params);
                observe(k, lambda);
            }
        }
        Checkpointing::Every(every) => {
            let len = trajectory.state_len();
            let mut segment = vec![T::ZERO; every * len];
            let mut end = n;
            while end > 0 {
                let start = (end - 1) / every * every;
                let first = trajectory.state(start).expect("checkpoint is stored");
                segment[..len].copy_from_slice(first);
                for k in start..end - 1 {
                    let (prev, next) = segment.split_at_mut((k + 1 - start) * len);
                    next[..len].copy_from_slice(&prev[(k - start) * len..]);
                    let (t, h) = grid.step(k);
                    stepper.step(field, t, h, &mut next[..len]);
                }
                for k in (start..end).rev() {
                    let (t, h) = grid.step(k);
                    let y = &segment[(k - start) * len..(k - start + 1) * len];
                    stepper.step_vjp(field, t, h, y, lambda, d_params);
                    observe(k, lambda);
                }
                end = start;
            }
        }
    }
}
