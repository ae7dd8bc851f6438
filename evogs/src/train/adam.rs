//! Adam with per-group learning rates, and the exponential learning-rate schedule of
//! 3DGS/4DGS/EvoGS (`docs/method.md` §7.3).
//!
//! `m ← β₁m + (1 − β₁)g`, `v ← β₂v + (1 − β₂)g²`, `x ← x − lr·m̂/(√v̂ + ε)` with bias
//! corrections `m̂ = m/(1 − β₁ᵗ)`, `v̂ = v/(1 − β₂ᵗ)`; β = (0.9, 0.999), ε = 1e-15 (EvoGS).
//! Each parameter group keeps its own step count, so groups created later (anchors when the
//! dynamics start) start their bias correction at 1.

use crate::model::retain::{permute_items, retain_items};
use evogs_math::Par;

/// Units (Gaussians, parameters) of a group that one task steps: a fixed number, so a
/// parallel step splits the work the same way on any thread count.
const RUN_UNITS: usize = 4096;

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

/// The scalars of one Adam step of a group: β₁, β₂, ε and the bias corrections of its
/// step count, in f32 as the update runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdamStep {
    b1: f32,
    b2: f32,
    step_size: f32,
    eps: f32,
    inv_sqrt_bc2: f32,
}

impl AdamStep {
    /// Steps `(parameter, gradient)` pairs against their moments `m` and `v`, in order.
    ///
    /// # Panics
    /// If the number of pairs differs from the number of moments.
    pub fn apply<'a>(
        self,
        pairs: impl Iterator<Item = (&'a mut f32, f32)>,
        m: &mut [f32],
        v: &mut [f32],
    ) {
        let mut count = 0;
        for ((x, gi), (m, v)) in pairs.zip(m.iter_mut().zip(v.iter_mut())) {
            self.value(x, gi, m, v);
            count += 1;
        }
        assert_eq!(count, m.len(), "Adam group size mismatch");
    }

    /// The update of one value `x` with gradient `g` and moments `m`, `v`.
    #[inline(always)]
    fn value(self, x: &mut f32, g: f32, m: &mut f32, v: &mut f32) {
        *m = self.b1 * *m + (1.0 - self.b1) * g;
        *v = self.b2 * *v + (1.0 - self.b2) * g * g;
        *x -= self.step_size * *m / (v.sqrt() * self.inv_sqrt_bc2 + self.eps);
    }

    /// [`apply`](Self::apply) to contiguous parameters and gradients: the same arithmetic
    /// on each value (so the same bits), in a loop over four slices that the compiler
    /// vectorises.
    ///
    /// # Panics
    /// If the four slices differ in length.
    pub fn apply_slices(self, x: &mut [f32], g: &[f32], m: &mut [f32], v: &mut [f32]) {
        let n = x.len();
        assert!(
            g.len() == n && m.len() == n && v.len() == n,
            "Adam group size mismatch"
        );
        for (((x, &gi), m), v) in x.iter_mut().zip(g).zip(m.iter_mut()).zip(v.iter_mut()) {
            self.value(x, gi, m, v);
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
    /// moments are still updated, as PyTorch does), in fixed runs on `par` (see
    /// [`AdamState::step_units`]).
    ///
    /// # Panics
    /// If the lengths differ.
    pub fn step(&mut self, adam: &Adam, lr: f64, par: Par, x: &mut [f32], g: &[f32]) {
        self.step_units(adam, lr, par, x, g, [1, 1], |s, x, g, m, v| {
            s.apply_slices(x, g, m, v);
        });
    }

    /// Counts a step of the group and returns its scalars (the bias corrections of the
    /// new step count).
    pub fn begin(&mut self, adam: &Adam, lr: f64) -> AdamStep {
        self.step += 1;
        #[allow(clippy::cast_possible_truncation, reason = "step counts are small")]
        let t = self.step.min(i32::MAX as u64) as i32;
        let bc1 = 1.0 - adam.beta1.powi(t);
        let bc2 = 1.0 - adam.beta2.powi(t);
        #[allow(
            clippy::cast_possible_truncation,
            reason = "optimiser arithmetic in f32"
        )]
        AdamStep {
            b1: adam.beta1 as f32,
            b2: adam.beta2 as f32,
            step_size: (lr / bc1) as f32,
            eps: adam.eps as f32,
            inv_sqrt_bc2: (1.0 / bc2.sqrt()) as f32,
        }
    }

    /// One Adam step of a group stored as units (a Gaussian, a parameter): `x` and `g`
    /// hold `shape[0]` items per unit and the moments `shape[1]` values per unit.
    /// `apply` steps one run of whole units against their moments (usually with
    /// [`AdamStep::apply`]). The units are cut into runs of a fixed length, which
    /// `Par::Rayon` steps in parallel: every value is updated by the same arithmetic, so
    /// the result is bitwise the sequential one on any thread count.
    ///
    /// # Panics
    /// If `x` and `g` differ in length, are not whole units, or hold another number of
    /// units than the moments; or if `apply` does (a run of pairs that does not match its
    /// moments).
    pub fn step_units<I: Send, G: Sync>(
        &mut self,
        adam: &Adam,
        lr: f64,
        par: Par,
        x: &mut [I],
        g: &[G],
        shape: [usize; 2],
        apply: impl Fn(AdamStep, &mut [I], &[G], &mut [f32], &mut [f32]) + Sync,
    ) {
        let [items, moments] = shape;
        assert!(
            x.len() == g.len()
                && items > 0
                && x.len().is_multiple_of(items)
                && x.len() / items * moments == self.m.len(),
            "Adam group size mismatch"
        );
        let s = self.begin(adam, lr);
        let (xn, mn) = (RUN_UNITS * items, RUN_UNITS * moments);
        let runs = x
            .chunks_mut(xn)
            .zip(g.chunks(xn))
            .zip(self.m.chunks_mut(mn).zip(self.v.chunks_mut(mn)));
        match par {
            Par::Seq => runs.for_each(|((x, g), (m, v))| apply(s, x, g, m, v)),
            #[cfg(feature = "rayon")]
            Par::Rayon => {
                use rayon::prelude::*;
                x.par_chunks_mut(xn)
                    .zip(g.par_chunks(xn))
                    .zip(self.m.par_chunks_mut(mn).zip(self.v.par_chunks_mut(mn)))
                    .for_each(|((x, g), (m, v))| apply(s, x, g, m, v));
            }
        }
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
            s.step(&adam, 0.05, Par::Seq, &mut x, &g);
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
        s.step(&Adam::default(), 0.1, Par::Seq, &mut x, &[0.3]);
        assert!((x[0] - 0.9).abs() < 1e-6, "x = {}", x[0]);
    }

    #[test]
    fn parallel_runs_step_bitwise_as_one_thread_does() {
        // Units of two items of three values (as the SH groups are stored), over more units
        // than one run, with a ragged last run.
        let units = 2 * RUN_UNITS + 37;
        let x0: Vec<[f32; 3]> = (0..2 * units)
            .map(|i| {
                let t = i as f32;
                [(t * 0.37).sin(), (t * 0.11).cos(), 0.5 - (t * 0.05).sin()]
            })
            .collect();
        let apply =
            |s: AdamStep, x: &mut [[f32; 3]], g: &[[f32; 3]], m: &mut [f32], v: &mut [f32]| {
                s.apply(
                    x.iter_mut()
                        .zip(g)
                        .flat_map(|(a, d)| a.iter_mut().zip(d.iter().copied())),
                    m,
                    v,
                );
            };
        let run = |par: Par| {
            let mut x = x0.clone();
            let mut st = AdamState::new(6 * units);
            for k in 0..3 {
                let shift = 0.1 * k as f32;
                let g: Vec<[f32; 3]> = x
                    .iter()
                    .map(|a| [a[0] - shift, 2.0 * a[1], a[2] * a[0]])
                    .collect();
                st.step_units(&Adam::default(), 0.01, par, &mut x, &g, [2, 6], apply);
            }
            (x, st)
        };
        let (xs, ss) = run(Par::Seq);
        assert_ne!(xs, x0, "the parameters moved");
        let (xp, sp) = run(Par::best());
        let bits = |x: &[[f32; 3]]| x.iter().flatten().map(|e| e.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&xs), bits(&xp), "parameters");
        let mbits =
            |s: &AdamState| [&s.m, &s.v].map(|a| a.iter().map(|e| e.to_bits()).collect::<Vec<_>>());
        assert_eq!(mbits(&ss), mbits(&sp), "moments");
        assert_eq!(ss.step, 3, "steps counted");
    }

    #[test]
    fn the_slice_step_is_bitwise_the_pairs_step() {
        let n = 67;
        let wave =
            |a: f32, b: f32| -> Vec<f32> { (0..n).map(|i| (i as f32 * a + b).sin()).collect() };
        let (x0, g, m0) = (wave(0.37, 0.1), wave(0.11, 1.0), wave(0.05, 2.0));
        let v0: Vec<f32> = wave(0.23, 0.3).iter().map(|v| v * v).collect();
        let mut st = AdamState::new(n);
        let s = st.begin(&Adam::default(), 0.02);
        let (mut xa, mut ma, mut va) = (x0.clone(), m0.clone(), v0.clone());
        s.apply(xa.iter_mut().zip(g.iter().copied()), &mut ma, &mut va);
        let (mut xb, mut mb, mut vb) = (x0.clone(), m0, v0);
        s.apply_slices(&mut xb, &g, &mut mb, &mut vb);
        let bits = |x: &[f32]| x.iter().map(|e| e.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&xa), bits(&xb), "parameters");
        assert_eq!(bits(&ma), bits(&mb), "first moments");
        assert_eq!(bits(&va), bits(&vb), "second moments");
        assert_ne!(xa, x0, "the parameters moved");
    }

    #[test]
    #[should_panic(expected = "Adam group size mismatch")]
    fn the_slice_step_refuses_slices_of_other_lengths() {
        let mut st = AdamState::new(3);
        let s = st.begin(&Adam::default(), 0.02);
        s.apply_slices(&mut [0.0; 3], &[0.0; 3], &mut [0.0; 3], &mut [0.0; 2]);
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
