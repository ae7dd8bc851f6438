//! The order in which training visits its views: a fresh random permutation of the views
//! inside the curriculum's time window each epoch (sooner when the window has grown), with a
//! share of iterations on the window's newest stretch while it grows, and the views of the
//! next steps for the frame cache to decode ahead.

use super::frames::TrainViews;
use super::schedule::WINDOW_EPS;
use evogs_math::rng::SplitMix64;

/// Steps of views whose frames are decoded ahead of use.
const PREFETCH_STEPS: usize = 2;

/// The epoch's permutation of the views and the position in it (part of a checkpoint).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ViewSampler {
    order: Vec<usize>,
    pos: usize,
}

impl ViewSampler {
    /// A sampler that starts a new epoch at its first draw.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            order: Vec::new(),
            pos: 0,
        }
    }

    /// A sampler at position `pos` of the permutation `order` (a resumed run).
    ///
    /// # Errors
    /// `pos` past the end of `order`.
    pub fn from_parts(order: Vec<usize>, pos: usize) -> Result<Self, String> {
        if pos > order.len() {
            return Err(format!(
                "view order position {pos} is past its {} views",
                order.len()
            ));
        }
        Ok(Self { order, pos })
    }

    /// The current permutation.
    #[must_use]
    pub fn order(&self) -> &[usize] {
        &self.order
    }

    /// The position in it.
    #[must_use]
    pub const fn pos(&self) -> usize {
        self.pos
    }

    /// The next view among `times` (the views' times) whose time is at most `hi`: with
    /// probability `focus` (drawn only when positive) a random view from the newest
    /// twentieth of `range` below `hi`, else the next view of the epoch's permutation,
    /// reshuffled when the epoch ends or the window has taken in more views.
    pub fn next(
        &mut self,
        times: &[f64],
        range: (f64, f64),
        hi: f64,
        focus: f64,
        rng: &mut SplitMix64,
    ) -> usize {
        let (t0, t1) = range;
        if focus > 0.0 && rng.next_f64() < focus {
            let lo = hi - (t1 - t0) / 20.0;
            let newest =
                || (0..times.len()).filter(|&i| times[i] > lo && times[i] <= hi + WINDOW_EPS);
            let count = newest().count();
            if count > 0 {
                let pick = rng.below(count);
                return newest().nth(pick).unwrap_or(0);
            }
        }
        let hi = hi + WINDOW_EPS;
        let eligible = times.iter().filter(|&&t| t <= hi).count();
        if self.pos >= self.order.len() || self.order.len() != eligible {
            self.order = (0..times.len()).filter(|&i| times[i] <= hi).collect();
            for i in (1..self.order.len()).rev() {
                let j = rng.below(i + 1);
                self.order.swap(i, j);
            }
            self.pos = 0;
        }
        self.pos += 1;
        self.order[self.pos - 1]
    }

    /// Asks `views` to decode the frames of `picks` and of the next steps' views (as far as
    /// the epoch's permutation tells) on its pool; the order of views never depends on when
    /// a decode finishes.
    pub fn prefetch(&self, views: &TrainViews, picks: &[usize]) {
        let ahead = self.order[self.pos.min(self.order.len())..]
            .iter()
            .take(PREFETCH_STEPS * picks.len());
        let upcoming: Vec<usize> = picks.iter().chain(ahead).copied().collect();
        views.prefetch(&upcoming);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_epoch_visits_every_view_in_the_window_once() {
        let times: Vec<f64> = (0..10).map(|i| f64::from(i) / 10.0).collect();
        let mut s = ViewSampler::new();
        let mut rng = SplitMix64::new(7);
        let mut seen: Vec<usize> = (0..6)
            .map(|_| s.next(&times, (0.0, 0.9), 0.5, 0.0, &mut rng))
            .collect();
        seen.sort_unstable();
        assert_eq!(
            seen,
            vec![0, 1, 2, 3, 4, 5],
            "the six views up to 0.5, once each"
        );
        let grown = s.next(&times, (0.0, 0.9), 0.9, 0.0, &mut rng);
        assert_eq!(s.order().len(), 10, "reshuffled over the grown window");
        assert_eq!(s.pos(), 1, "from its start");
        assert_eq!(grown, s.order()[0], "the first of the new epoch");
        let mut a = SplitMix64::new(3);
        let mut b = SplitMix64::new(3);
        let (mut x, mut y) = (ViewSampler::new(), ViewSampler::new());
        for _ in 0..25 {
            assert_eq!(
                x.next(&times, (0.0, 0.9), 0.9, 0.5, &mut a),
                y.next(&times, (0.0, 0.9), 0.9, 0.5, &mut b),
                "deterministic for a given random state"
            );
        }
        assert!(
            ViewSampler::from_parts(vec![1, 0], 3).is_err(),
            "position past the end"
        );
    }

    #[test]
    fn focus_draws_from_the_newest_stretch() {
        let times: Vec<f64> = (0..100).map(|i| f64::from(i) / 100.0).collect();
        let mut s = ViewSampler::new();
        let mut rng = SplitMix64::new(1);
        for _ in 0..50 {
            let v = s.next(&times, (0.0, 0.99), 0.5, 1.0, &mut rng);
            assert!(
                times[v] > 0.5 - 0.99 / 20.0 && times[v] <= 0.5 + 1e-9,
                "newest: {v}"
            );
        }
    }
}
