//! The exact discrete adjoint of an adaptive solve: [`AdaptiveSolver::adjoint`].

use super::{AdaptiveError, AdaptiveSolution, AdaptiveSolver, output_order};
use crate::{Checkpointing, VectorField};
use alloc::vec;
use evogs_math::Real;

impl<T: Real> AdaptiveSolver<T> {
    /// Gradients of `L = Σⱼ ⟨d_outputs[j], y(τⱼ)⟩` (a loss linearised at the outputs of
    /// `sol`) with respect to the initial state, the field parameters and the output
    /// times, by the exact discrete adjoint of the accepted steps and the dense output.
    ///
    /// The step sizes are held fixed (they are constants of the computation, as in any
    /// discrete adjoint of an adaptive solver): the result is the exact gradient, to
    /// rounding, of [`replay`](Self::replay) of the solution's steps, which reproduces
    /// the solve bitwise. Output `j` in step `n` is `yₙ ⊕ h Σ bᵢ(θⱼ)Kᵢ(yₙ)` with
    /// `θⱼ = (τⱼ − tₙ)/hₙ`; its cotangent enters step `n`'s reverse pass as a second
    /// update term beside the step's own `yₙ ⊕ h Σ bᵢKᵢ`, so a step with outputs costs
    /// one reverse pass over all `s` stages (the FSAL stage included) however many
    /// outputs it has, and one without over the stages the update uses.
    ///
    /// - `d_outputs`: one tangent cotangent per output time (`m·n` entries, SO(3) blocks
    ///   as left-perturbation cotangents);
    /// - `d_y0` (n): **overwritten** with `∂L/∂y0`;
    /// - `d_params` (`field.n_params()`): `∂L/∂θ` is **added**;
    /// - `d_times` (m): **overwritten** with `∂L/∂τⱼ = ⟨ȳⱼ, d y(τ)/dτ⟩`, through the
    ///   extension's θ-derivative (`dθ/dτ = 1/hₙ`).
    ///
    /// States come from the solution's checkpoints: directly with `StoreAll`, or by
    /// recomputing each k-step segment from its checkpoint with `Every(k)`; both give
    /// bitwise identical gradients.
    ///
    /// # Errors
    /// [`AdaptiveError::ForeignSolution`] if `sol` was made by another pair or layout,
    /// [`AdaptiveError::LengthMismatch`] or [`AdaptiveError::LayoutMismatch`].
    ///
    /// ```
    /// use evogs_ode::adaptive::{AdaptiveOptions, AdaptiveSolver, Pair};
    /// use evogs_ode::{VectorField, fields::LinearField};
    /// // y' = a·y, L = y(2): ∂L/∂y0 ≈ e^{2a}, ∂L/∂a ≈ 2 e^{2a} y0, ∂L/∂τ = a·y(2).
    /// let a: f64 = -0.5;
    /// let mut f = LinearField::new(1, vec![a]);
    /// let mut solver = AdaptiveSolver::new(Pair::Dopri5, f.layout(), AdaptiveOptions::with_tolerances(1e-10, 1e-10));
    /// let sol = solver.solve(&mut f, 0.0, 2.0, &[1.5], &[2.0]).unwrap();
    /// let (mut d_y0, mut d_a, mut d_t) = ([0.0], [0.0], [0.0]);
    /// solver.adjoint(&mut f, &sol, &[1.0], &mut d_y0, &mut d_a, &mut d_t).unwrap();
    /// let e = (2.0 * a).exp();
    /// assert!((d_y0[0] - e).abs() < 1e-8 && (d_a[0] - 3.0 * e).abs() < 1e-8);
    /// assert!((d_t[0] - a * 1.5 * e).abs() < 1e-8);
    /// ```
    pub fn adjoint<F: VectorField<T> + ?Sized>(
        &mut self,
        field: &mut F,
        sol: &AdaptiveSolution<T>,
        d_outputs: &[T],
        d_y0: &mut [T],
        d_params: &mut [T],
        d_times: &mut [T],
    ) -> Result<(), AdaptiveError> {
        if sol.pair != self.pair || sol.layout != self.layout {
            return Err(AdaptiveError::ForeignSolution);
        }
        self.check_field(field)?;
        let n = self.layout.tangent_len();
        let len = self.layout.ambient_len();
        let m = sol.times.len();
        Self::check_len("d_outputs", m * n, d_outputs.len())?;
        Self::check_len("d_y0", n, d_y0.len())?;
        Self::check_len("d_params", field.n_params(), d_params.len())?;
        Self::check_len("d_times", m, d_times.len())?;
        if let Checkpointing::Every(0) = sol.checkpointing {
            return Err(AdaptiveError::InvalidOption(
                "checkpoint interval must be ≥ 1",
            ));
        }
        let steps = &sol.steps;
        let n_steps = steps.len();
        let lambda = d_y0;
        lambda.fill(T::ZERO);
        d_times.fill(T::ZERO);
        if n_steps == 0 {
            for c in d_outputs.chunks_exact(n.max(1)).take(m) {
                for (l, v) in lambda.iter_mut().zip(c) {
                    *l += *v;
                }
            }
            return Ok(());
        }
        let order = output_order(steps, &sol.times);
        let mut cursor = order.len();
        let s = self.pair.stages();
        let needed = self.stepper.needed_stages();
        let mut tmp = vec![T::ZERO; n];
        let every = sol.checkpointing.interval();
        let mut segment = vec![T::ZERO; every.min(n_steps) * len];
        let mut end = n_steps;
        while end > 0 {
            // States of steps start..end: the checkpoint and a recomputed segment.
            let start = (end - 1) / every * every;
            let first = sol.state(start).ok_or(AdaptiveError::ForeignSolution)?;
            segment[..len].copy_from_slice(first);
            for k in start..end - 1 {
                let (prev, next) = segment.split_at_mut((k + 1 - start) * len);
                next[..len].copy_from_slice(&prev[(k - start) * len..]);
                let (t, h) = steps.step(k);
                self.stepper.step(field, t, h, &mut next[..len]);
            }
            for k in (start..end).rev() {
                let (t, h) = steps.step(k);
                let y = &segment[(k - start) * len..(k - start + 1) * len];
                let last = cursor;
                while cursor > 0 && order[cursor - 1].0 == k {
                    cursor -= 1;
                }
                let upto = if cursor < last { s } else { needed };
                self.stepper.vjp_begin(field, t, h, y, upto);
                // The step's own update: λ is the cotangent at y_{k+1}.
                self.stepper.vjp_update(&self.b, None, h, lambda);
                for &(_, j) in &order[cursor..last] {
                    let theta = steps.theta(k, sol.times[j]);
                    self.ext.weights(theta, &mut self.w, &mut self.dw);
                    tmp.copy_from_slice(&d_outputs[j * n..(j + 1) * n]);
                    let d_theta = self
                        .stepper
                        .vjp_update(&self.w, Some(&self.dw), h, &mut tmp);
                    d_times[j] = d_theta / h;
                    for (l, v) in lambda.iter_mut().zip(&tmp) {
                        *l += *v;
                    }
                }
                self.stepper
                    .vjp_stages(field, t, h, y, upto, lambda, d_params);
            }
            end = start;
        }
        Ok(())
    }
}
