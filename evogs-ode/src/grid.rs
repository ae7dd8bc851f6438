//! Fixed time grids: [`TimeGrid`].

use evogs_math::Real;

/// A fixed grid of `n` steps from `t0` to `t1`. `Copy`, no allocation.
///
/// Conventions: `time(k) = t0 + k·h` for `k < n` and `time(n) = t1`; `step_size(k) = h`
/// except for the last step, which is `last_h` (equal to `h` for a uniform grid, as in the
/// reference files: `h = (t1 − t0)/n`, `t_k = t0 + k h`).
///
/// Integrating backward in time is a grid with `t1 < t0`: the steps are negative.
///
/// ```text
/// uniform(0, 1, 4):          t = 0, 0.25, 0.5, 0.75 | 1      h = 0.25 for every step
/// with_max_step(0, 1, 0.3):  t = 0, 0.3, 0.6, 0.9 | 1        h = 0.3, 0.3, 0.3, 0.1
/// with_max_step(1, 0, 0.3):  t = 1, 0.7, 0.4, 0.1 | 0        h = −0.3, −0.3, −0.3, −0.1
/// ```
///
/// ```
/// use evogs_ode::TimeGrid;
/// let g = TimeGrid::with_max_step(0.0_f64, 1.0, 0.3);
/// assert_eq!(g.n_steps(), 4);
/// assert!((g.step_size(3) - 0.1).abs() < 1e-15);
/// // An exact multiple does not add a tiny last step.
/// assert_eq!(TimeGrid::with_max_step(0.0, 1.0, 0.1).n_steps(), 10);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeGrid<T> {
    t0: T,
    t1: T,
    n: usize,
    h: T,
    last_h: T,
}

impl<T: Real> TimeGrid<T> {
    /// `n` equal steps `h = (t1 − t0)/n`, `t_k = t0 + k·h`.
    ///
    /// `n = 0` is allowed (no step; then `t1` should equal `t0`).
    #[must_use]
    pub fn uniform(t0: T, t1: T, n: usize) -> Self {
        let h = if n == 0 {
            T::ZERO
        } else {
            (t1 - t0) / T::from_usize(n)
        };
        Self {
            t0,
            t1,
            n,
            h,
            last_h: h,
        }
    }

    /// Steps of size `|h|` (sign taken from `t1 − t0`), the last one shortened to land
    /// exactly on `t1`.
    ///
    /// `n = ceil(|t1 − t0|/|h| − tol)` with `tol = 1000·ε·max(1, |t1 − t0|/|h|)`: when the
    /// span is an exact multiple of `h` up to rounding, no tiny extra step is added (the
    /// last step is then longer than `|h|` by at most that relative tolerance). `n = 0`
    /// when `t1 == t0`.
    ///
    /// # Panics
    /// If `t1 ≠ t0` and `h` is zero or not finite.
    #[must_use]
    pub fn with_max_step(t0: T, t1: T, h: T) -> Self {
        let span = t1 - t0;
        if span == T::ZERO {
            return Self {
                t0,
                t1,
                n: 0,
                h: T::ZERO,
                last_h: T::ZERO,
            };
        }
        assert!(
            h != T::ZERO && h.is_finite(),
            "the maximal step must be finite and non-zero"
        );
        let habs = h.abs();
        let ratio = span.abs() / habs;
        let tol = T::from_f64(1000.0) * T::EPSILON * ratio.max(T::ONE);
        let steps = (ratio - tol).ceil().max(T::ONE);
        let n = count_from(steps);
        let h = if span > T::ZERO { habs } else { -habs };
        let last_start = t0 + T::from_usize(n - 1) * h;
        Self {
            t0,
            t1,
            n,
            h,
            last_h: t1 - last_start,
        }
    }

    /// Start time.
    #[inline]
    #[must_use]
    pub const fn t0(&self) -> T {
        self.t0
    }

    /// End time.
    #[inline]
    #[must_use]
    pub const fn t1(&self) -> T {
        self.t1
    }

    /// Number of steps.
    #[inline]
    #[must_use]
    pub const fn n_steps(&self) -> usize {
        self.n
    }

    /// The regular step `h` (negative backward in time).
    #[inline]
    #[must_use]
    pub const fn h(&self) -> T {
        self.h
    }

    /// Grid time `t_k` (`k ≤ n`; `time(n) = t1`).
    ///
    /// # Panics
    /// If `k > n`.
    #[inline]
    #[must_use]
    pub fn time(&self, k: usize) -> T {
        assert!(k <= self.n, "grid index {k} beyond {} steps", self.n);
        if k == self.n {
            self.t1
        } else {
            self.t0 + T::from_usize(k) * self.h
        }
    }

    /// Size of step `k` (`k < n`).
    ///
    /// # Panics
    /// If `k >= n`.
    #[inline]
    #[must_use]
    pub fn step_size(&self, k: usize) -> T {
        assert!(k < self.n, "step {k} beyond {} steps", self.n);
        if k + 1 == self.n { self.last_h } else { self.h }
    }

    /// `(t_k, h_k)`: start time and size of step `k`.
    #[inline]
    #[must_use]
    pub fn step(&self, k: usize) -> (T, T) {
        (self.time(k), self.step_size(k))
    }

    /// `true` if the grid runs backward in time (`t1 < t0`).
    #[inline]
    #[must_use]
    pub fn is_backward(&self) -> bool {
        self.t1 < self.t0
    }
}

/// Converts a small non-negative integral value to a count.
fn count_from<T: Real>(x: T) -> usize {
    let v = x.to_f64();
    assert!(
        (0.0..9.0e15).contains(&v),
        "step count {v} out of range (is the maximal step tiny?)"
    );
    #[allow(
        clippy::cast_possible_truncation,
        reason = "an integral value checked to lie in [0, 9e15]"
    )]
    {
        v as usize
    }
}

#[cfg(test)]
mod tests {
    use super::TimeGrid;

    #[test]
    fn uniform_grid_matches_the_oracle_convention() {
        let g = TimeGrid::uniform(1.0_f64, 0.0, 8);
        assert!(g.is_backward(), "t1 < t0");
        assert!((g.h() + 0.125).abs() < 1e-300, "h = −1/8 exactly");
        assert!((g.time(3) - 0.625).abs() < 1e-300, "t_3 = 1 − 3/8");
        assert!(g.time(8).abs() < 1e-300, "lands on t1");
    }

    #[test]
    fn only_a_later_time_is_forward() {
        assert!(!TimeGrid::uniform(0.0_f64, 1.0, 8).is_backward(), "t1 > t0");
        assert!(!TimeGrid::uniform(0.5_f64, 0.5, 0).is_backward(), "t1 = t0");
        assert!(
            !TimeGrid::with_max_step(0.5_f64, 0.5, 0.1).is_backward(),
            "empty span"
        );
        assert!(
            TimeGrid::with_max_step(0.5_f64, 0.25, 0.1).is_backward(),
            "t1 < t0"
        );
    }

    #[test]
    fn a_span_of_n_steps_up_to_rounding_takes_n_steps_at_every_count() {
        // `n·h` rounds, and so does `n·h / h`: the tolerance grows with the count, so that
        // no tiny extra step appears however many steps there are.
        let mut worst = 0.0_f64;
        for h in [0.1_f64, 0.3, 1.0 / 3.0, 0.7, 1e-3, 123.456] {
            for n in [1_usize, 3, 10, 97, 1000, 4099, 100_000, 1_000_003] {
                let span = h * n as f64;
                for (t0, t1) in [(0.0, span), (span, 0.0)] {
                    let g = TimeGrid::with_max_step(t0, t1, h);
                    assert_eq!(g.n_steps(), n, "{n} steps of {h}");
                }
                worst = worst.max((span / h - n as f64).abs() / n as f64);
            }
        }
        assert!(worst > 0.0, "some spans are not exact multiples");
    }

    #[test]
    fn max_step_grid_shortens_the_last_step_in_both_directions() {
        for (t0, t1) in [(0.0_f64, 1.0_f64), (1.0, 0.0), (-0.2, 2.3)] {
            let g = TimeGrid::with_max_step(t0, t1, 0.3);
            let total: f64 = (0..g.n_steps()).map(|k| g.step_size(k)).sum();
            assert!((total - (t1 - t0)).abs() < 1e-14, "steps sum to the span");
            assert!(
                (g.time(g.n_steps() - 1) + g.step_size(g.n_steps() - 1) - t1).abs() < 1e-15,
                "last step lands on t1"
            );
            for k in 0..g.n_steps() - 1 {
                assert!((g.step_size(k).abs() - 0.3).abs() < 1e-15, "regular steps");
            }
            assert!(
                g.step_size(g.n_steps() - 1).abs() <= 0.3 + 1e-15,
                "last not longer"
            );
        }
        assert_eq!(
            TimeGrid::with_max_step(0.0, 0.0, 0.1).n_steps(),
            0,
            "empty span"
        );
        assert_eq!(
            TimeGrid::with_max_step(0.0, 0.3, 0.1).n_steps(),
            3,
            "0.3/0.1"
        );
        assert_eq!(
            TimeGrid::with_max_step(0.0, 1.0, -0.1).n_steps(),
            10,
            "|h| used"
        );
        assert_eq!(
            TimeGrid::with_max_step(0.0, 0.05, 0.1).n_steps(),
            1,
            "one short step"
        );
    }
}
