//! Adam with per-group learning rates, and the exponential learning-rate schedule of
//! 3DGS/4DGS/EvoGS (`docs/method.md` §7.3).
//!
//! `m ← β₁m + (1 − β₁)g`, `v ← β₂v + (1 − β₂)g²`, `x ← x − lr·m̂/(√v̂ + ε)` with bias
//! corrections `m̂ = m/(1 − β₁ᵗ)`, `v̂ = v/(1 − β₂ᵗ)`; β = (0.9, 0.999), ε = 1e-15 (EvoGS).
//! Each parameter group keeps its own step count, so groups created later (anchors when the
//! dynamics start) start their bias correction at 1.

use crate::model::retain::{permute_items, retain_items};

/// Adam moments of one parameter group.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AdamState {
    /// First moments.
    pub m: Vec<f32>,
    /// Second moments.
    pub v: Vec<f32>,
    /// Steps taken.
    pub step: u64,
}

/// Adam hyper-parameters shared by all groups.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adam {
    /// β₁.
    pub beta1: f64,
    /// β₂.
    pub beta2: f64,
    /// ε.
    pub eps: f64,
}

impl Default for Adam {
    fn default() -> Self {
        Self {
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-15,
        }
    }
}

impl AdamState {
    /// Zero moments for `n` parameters.
    #[must_use]
    pub fn new(n: usize) -> Self {
        Self {
            m: vec![0.0; n],
            v: vec![0.0; n],
            step: 0,
        }
    }

    /// Number of parameters.
    #[must_use]
    pub fn len(&self) -> usize {
        self.m.len()
    }

    /// `true` if the group is empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.m.is_empty()
    }

    /// One Adam step of `x` with gradient `g` and learning rate `lr` (with lr = 0 the
    /// moments are still updated, as PyTorch does).
    ///
    /// # Panics
    /// If the lengths differ.
    pub fn step(&mut self, adam: &Adam, lr: f64, x: &mut [f32], g: &[f32]) {
        assert!(
            x.len() == self.m.len() && g.len() == x.len(),
            "Adam group size mismatch"
        );
        self.step_iter(adam, lr, x.iter_mut().zip(g.iter().copied()));
    }

    /// One Adam step over `(parameter, gradient)` pairs (e.g. the components of a
    /// `Vec<Vec3<f32>>`), in order; there must be exactly `len()` pairs.
    ///
    /// # Panics
    /// If the number of pairs differs from the group size.
    pub fn step_iter<'a>(
        &mut self,
        adam: &Adam,
        lr: f64,
        items: impl Iterator<Item = (&'a mut f32, f32)>,
    ) {
        self.step += 1;
        #[allow(clippy::cast_possible_truncation, reason = "step counts are small")]
        let t = self.step.min(i32::MAX as u64) as i32;
        let bc1 = 1.0 - adam.beta1.powi(t);
        let bc2 = 1.0 - adam.beta2.powi(t);
        #[allow(
            clippy::cast_possible_truncation,
            reason = "optimiser arithmetic in f32"
        )]
        let (b1, b2, step_size, eps, inv_sqrt_bc2) = (
            adam.beta1 as f32,
            adam.beta2 as f32,
            (lr / bc1) as f32,
            adam.eps as f32,
            (1.0 / bc2.sqrt()) as f32,
        );
        let mut count = 0;
        for ((x, gi), (m, v)) in items.zip(self.m.iter_mut().zip(self.v.iter_mut())) {
            *m = b1 * *m + (1.0 - b1) * gi;
            *v = b2 * *v + (1.0 - b2) * gi * gi;
            *x -= step_size * *m / (v.sqrt() * inv_sqrt_bc2 + eps);
            count += 1;
        }
        assert_eq!(count, self.m.len(), "Adam group size mismatch");
    }

    /// Keeps the entries of the items where `keep[item]` is true (`stride` values per item).
    pub fn retain(&mut self, keep: &[bool], stride: usize) {
        retain_items(&mut self.m, keep, stride);
        retain_items(&mut self.v, keep, stride);
    }

    /// Reorders the items (`stride` values each): item `i` becomes the old item `order[i]`.
    pub fn permute(&mut self, order: &[usize], stride: usize) {
        permute_items(&mut self.m, order, stride);
        permute_items(&mut self.v, order, stride);
    }

    /// Appends zero moments for `n_items` new items of `stride` values.
    pub fn grow(&mut self, n_items: usize, stride: usize) {
        self.m.resize(self.m.len() + n_items * stride, 0.0);
        self.v.resize(self.v.len() + n_items * stride, 0.0);
    }

    /// Zeroes the moments (used by the opacity reset).
    pub fn reset(&mut self) {
        self.m.fill(0.0);
        self.v.fill(0.0);
    }
}

/// The exponential schedule `lr(step) = exp((1 − u) ln lr_init + u ln lr_final)`,
/// `u = clamp(step/max_steps, 0, 1)`; zero if either end is zero (a frozen group).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ExpSchedule {
    /// Learning rate at step 0.
    pub init: f64,
    /// Learning rate from `max_steps` on.
    pub final_: f64,
    /// Steps of the decay.
    pub max_steps: u64,
}

impl ExpSchedule {
    /// A constant learning rate.
    #[must_use]
    pub const fn constant(lr: f64) -> Self {
        Self {
            init: lr,
            final_: lr,
            max_steps: 1,
        }
    }

    /// The learning rate at `step`.
    #[must_use]
    pub fn at(&self, step: u64) -> f64 {
        if self.init <= 0.0 || self.final_ <= 0.0 {
            return 0.0;
        }
        let u = (step as f64 / self.max_steps.max(1) as f64).clamp(0.0, 1.0);
        ((1.0 - u) * self.init.ln() + u * self.final_.ln()).exp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adam_minimises_a_quadratic() {
        let mut x = vec![3.0_f32, -2.0];
        let mut s = AdamState::new(2);
        let adam = Adam {
            eps: 1e-8,
            ..Adam::default()
        };
        for _ in 0..2000 {
            let g = [2.0 * x[0], 8.0 * x[1]];
            s.step(&adam, 0.05, &mut x, &g);
        }
        assert!(
            x[0].abs() < 1e-2 && x[1].abs() < 1e-2,
            "converged to 0: {x:?}"
        );
    }

    #[test]
    fn first_step_moves_by_the_learning_rate() {
        // Bias correction makes the first step lr·sign(g).
        let mut x = vec![1.0_f32];
        let mut s = AdamState::new(1);
        s.step(&Adam::default(), 0.1, &mut x, &[0.3]);
        assert!((x[0] - 0.9).abs() < 1e-6, "x = {}", x[0]);
    }

    #[test]
    fn schedule_is_log_linear() {
        let s = ExpSchedule {
            init: 1e-2,
            final_: 1e-4,
            max_steps: 100,
        };
        assert!((s.at(0) - 1e-2).abs() < 1e-15, "start");
        assert!((s.at(50) - 1e-3).abs() < 1e-15, "geometric midpoint");
        assert!((s.at(500) - 1e-4).abs() < 1e-15, "clamped end");
        assert!(
            (ExpSchedule::constant(0.05).at(123) - 0.05).abs() < 1e-15,
            "constant"
        );
    }

    #[test]
    fn retain_keeps_items_in_order() {
        let mut d = vec![1, 1, 2, 2, 3, 3, 4, 4];
        retain_items(&mut d, &[true, false, true, false], 2);
        assert_eq!(d, vec![1, 1, 3, 3], "kept items 0 and 2");
    }
}
