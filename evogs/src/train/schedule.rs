//! The training schedule: what happens at iteration `i` (1-based), as a pure function of the
//! configuration, the training time range, the anchor times and the scene extent.
//!
//! - Static warm-up for `warmup_iters` iterations; the dynamics start at the next one
//!   (never for static motion).
//! - The temporal curriculum: the latest supervised time grows from the first
//!   `warmup_time_window` of the range to the whole range over `curriculum_iters` dynamic
//!   iterations; each trainable anchor is initialised when the window reaches it.
//! - Learning rates: the position and field decays pause while the window grows.
//! - SH degree increments, the anchor-loss segment, densification, statistics, opacity
//!   resets, log lines and checkpoints.

use super::optim::LearningRates;
use crate::config::{DensifyConfig, OptimConfig, ScheduleConfig, TrainConfig};
use crate::model::{Motion, Waypoints};

/// Slack on time comparisons of the curriculum window (times are read from JSON).
pub const WINDOW_EPS: f64 = 1e-9;

/// The schedule of one run.
#[derive(Clone, Debug, PartialEq)]
pub struct Schedule {
    s: ScheduleConfig,
    densify: DensifyConfig,
    optim: OptimConfig,
    static_motion: bool,
    trainable_anchors: bool,
    anchor_every: u64,
    time_range: (f64, f64),
    anchor_times: Vec<f64>,
    extent: f64,
}

impl Schedule {
    /// The schedule of `cfg` over the training time range `time_range`, with waypoints at
    /// `anchor_times` and position rates scaled by `extent`.
    #[must_use]
    pub fn new(
        cfg: &TrainConfig,
        time_range: (f64, f64),
        anchor_times: &[f64],
        extent: f64,
    ) -> Self {
        Self {
            s: cfg.schedule.clone(),
            densify: cfg.densify.clone(),
            optim: cfg.optim.clone(),
            static_motion: cfg.dynamics.motion == Motion::Static,
            trainable_anchors: cfg.dynamics.waypoints == Waypoints::Trainable,
            anchor_every: cfg.loss.anchor_every,
            time_range,
            anchor_times: anchor_times.to_vec(),
            extent,
        }
    }

    /// Sets the total iteration count (the other schedules keep their planned lengths).
    pub const fn set_iterations(&mut self, iterations: u64) {
        self.s.iterations = iterations;
    }

    /// Total iterations.
    #[must_use]
    pub const fn iterations(&self) -> u64 {
        self.s.iterations
    }

    /// Whether iteration `it` is past the last one.
    #[must_use]
    pub const fn finished(&self, it: u64) -> bool {
        it >= self.s.iterations
    }

    /// The iteration at which the dynamics are switched on (none for static motion).
    #[must_use]
    pub const fn dynamics_start(&self) -> Option<u64> {
        if self.static_motion {
            None
        } else {
            Some(self.s.warmup_iters + 1)
        }
    }

    /// The latest supervised time at iteration `it`: during the static warm-up the first
    /// `warmup_time_window` of the time range, then a window growing linearly to the whole
    /// range over `curriculum_iters` dynamic iterations. Static motion always sees every view.
    #[must_use]
    pub fn window_end(&self, it: u64) -> f64 {
        let (t0, t1) = self.time_range;
        let s = &self.s;
        if self.static_motion {
            return t1;
        }
        let w0 = s.warmup_time_window;
        let frac = if it <= s.warmup_iters {
            w0
        } else if s.curriculum_iters == 0 {
            1.0
        } else {
            let f = (it - s.warmup_iters) as f64 / s.curriculum_iters as f64;
            if f >= 1.0 { 1.0 } else { w0 + (1.0 - w0) * f }
        };
        if frac >= 1.0 {
            t1
        } else {
            t0 + frac * (t1 - t0)
        }
    }

    /// The probability that iteration `it` supervises a view of the newest stretch of the
    /// window instead of the next view of the epoch: the curriculum's focus while the window
    /// is short of the whole range, else 0.
    #[must_use]
    pub fn focus(&self, it: u64) -> f64 {
        if self.window_end(it) < self.time_range.1 {
            self.s.curriculum_focus
        } else {
            0.0
        }
    }

    /// The trainable anchors (indices into the anchor times, never 0) that the window
    /// reaches at iteration `it`: each is initialised from the one before it, with fresh
    /// optimiser states.
    #[must_use]
    pub fn anchors_reached(&self, it: u64) -> Vec<usize> {
        if !self.trainable_anchors || self.s.curriculum_iters == 0 || it == 0 {
            return Vec::new();
        }
        let (prev, hi) = (self.window_end(it - 1), self.window_end(it));
        (1..self.anchor_times.len())
            .filter(|&k| {
                let tau = self.anchor_times[k];
                tau > prev + WINDOW_EPS && tau <= hi + WINDOW_EPS
            })
            .collect()
    }

    /// The anchor segment whose loss iteration `it` adds: every `anchor_every`-th iteration
    /// with trainable waypoints, cycling through the segments whose end the window has
    /// reached.
    #[must_use]
    pub fn anchor_segment(&self, it: u64) -> Option<usize> {
        let hi = self.window_end(it) + WINDOW_EPS;
        let k = self.anchor_times.iter().filter(|&&tau| tau <= hi).count();
        let every = self.anchor_every;
        (self.trainable_anchors && k > 1 && every > 0 && it.is_multiple_of(every))
            .then(|| usize::try_from(it / every).unwrap_or(0) % (k - 1))
    }

    /// The active SH degree at iteration `it`, of at most `max_degree`.
    #[must_use]
    pub fn sh_degree(&self, it: u64, max_degree: usize) -> usize {
        let steps = usize::try_from(it / self.s.sh_degree_interval.max(1)).unwrap_or(usize::MAX);
        steps.min(max_degree)
    }

    /// The learning rates of iteration `it`: the position and field schedules pause while
    /// the curriculum's window grows (each new stretch of time is fitted at the rates the
    /// dynamics started with); the field schedules start with the dynamics.
    #[must_use]
    pub fn learning_rates(&self, it: u64) -> LearningRates {
        let (dyn_start, paused) = if self.static_motion {
            (0, 0)
        } else {
            let w = self.s.warmup_iters;
            (w, it.saturating_sub(w).min(self.s.curriculum_iters))
        };
        LearningRates::at(&self.optim, self.extent, it - paused, dyn_start)
    }

    /// Whether iteration `it` accumulates the densification statistics (3DGS convention: the
    /// window is `from_iter ≤ it < until_iter`, statistics from the start of it).
    #[must_use]
    pub const fn accumulates_stats(&self, it: u64) -> bool {
        it < self.densify.until_iter
    }

    /// Whether iteration `it` densifies and prunes, and if so whether it also prunes
    /// Gaussians with huge screen footprints (after the first opacity reset).
    #[must_use]
    pub const fn densify(&self, it: u64) -> Option<bool> {
        let d = &self.densify;
        if it >= d.from_iter && it < d.until_iter && it.is_multiple_of(d.interval) {
            Some(d.opacity_reset_interval > 0 && it > d.opacity_reset_interval)
        } else {
            None
        }
    }

    /// Whether iteration `it` resets the opacities (never on `until_iter` itself, which is
    /// often the last iteration).
    #[must_use]
    pub const fn opacity_reset(&self, it: u64) -> bool {
        let d = &self.densify;
        d.opacity_reset_interval > 0
            && it < d.until_iter
            && it.is_multiple_of(d.opacity_reset_interval)
    }

    /// Whether iteration `it` writes a log line (every `log_every`, and the last).
    #[must_use]
    pub const fn logs(&self, it: u64) -> bool {
        it.is_multiple_of(self.s.log_every) || it == self.s.iterations
    }

    /// Whether a checkpoint is due after iteration `it` by the iteration count
    /// (`checkpoint_every`; 0: none by count).
    #[must_use]
    pub const fn checkpoint_due(&self, it: u64) -> bool {
        let every = self.s.checkpoint_every;
        every > 0 && it.is_multiple_of(every)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config() -> TrainConfig {
        let mut c = TrainConfig::fast();
        c.schedule.warmup_iters = 10;
        c.schedule.iterations = 100;
        c.schedule.warmup_time_window = 0.2;
        c.schedule.curriculum_iters = 40;
        c.schedule.sh_degree_interval = 25;
        c.schedule.log_every = 30;
        c.schedule.checkpoint_every = 50;
        c.densify.from_iter = 20;
        c.densify.until_iter = 80;
        c.densify.interval = 20;
        c.densify.opacity_reset_interval = 30;
        c.loss.anchor_every = 5;
        c
    }

    fn schedule(c: &TrainConfig) -> Schedule {
        Schedule::new(c, (0.0, 2.0), &[0.0, 0.5, 1.0, 1.5, 2.0], 3.0)
    }

    #[test]
    fn the_window_grows_from_the_warm_up_fraction_to_the_whole_range() {
        let s = schedule(&config());
        assert_eq!(s.dynamics_start(), Some(11), "after the warm-up");
        assert!((s.window_end(1) - 0.4).abs() < 1e-12, "warm-up window");
        assert!((s.window_end(10) - 0.4).abs() < 1e-12, "still the warm-up");
        assert!(
            (s.window_end(30) - 2.0 * (0.2 + 0.8 * 0.5)).abs() < 1e-12,
            "half way"
        );
        assert!(
            s.window_end(50).to_bits() == 2.0f64.to_bits(),
            "whole range"
        );
        for it in 1..100 {
            assert!(s.window_end(it + 1) >= s.window_end(it), "never shrinks");
        }
        assert!(
            s.focus(30) > 0.0 && s.focus(50) <= 0.0,
            "focus while it grows"
        );
        let mut st = config();
        st.dynamics.motion = Motion::Static;
        let st = schedule(&st);
        assert_eq!(st.dynamics_start(), None, "static motion has no dynamics");
        assert!(
            st.window_end(1).to_bits() == 2.0f64.to_bits(),
            "and sees every view"
        );
    }

    #[test]
    fn each_anchor_arrives_once_when_the_window_reaches_it() {
        let s = schedule(&config());
        let mut arrivals = Vec::new();
        for it in 1..=100 {
            for k in s.anchors_reached(it) {
                assert!(s.window_end(it) + WINDOW_EPS >= [0.0, 0.5, 1.0, 1.5, 2.0][k]);
                arrivals.push((k, it));
            }
        }
        let ks: Vec<usize> = arrivals.iter().map(|&(k, _)| k).collect();
        assert_eq!(
            ks,
            vec![1, 2, 3, 4],
            "anchors past the warm-up window, in order, once"
        );
        let mut off = config();
        off.dynamics.waypoints = Waypoints::Off;
        assert!(
            (1..=100).all(|it| schedule(&off).anchors_reached(it).is_empty()),
            "no trainable anchors, no arrivals"
        );
    }

    #[test]
    fn anchor_segments_cycle_through_the_reached_segments() {
        let s = schedule(&config());
        assert_eq!(s.anchor_segment(7), None, "not an anchor-loss iteration");
        assert_eq!(
            s.anchor_segment(5),
            None,
            "one anchor inside the warm-up window"
        );
        for it in (55..100).step_by(5) {
            let k = s.anchor_segment(it).expect("every fifth iteration");
            assert_eq!(
                k,
                usize::try_from(it / 5).expect("small") % 4,
                "cycles over 4"
            );
        }
    }

    #[test]
    fn rates_pause_during_the_curriculum_and_the_periodic_tasks_follow_the_config() {
        let c = config();
        let s = schedule(&c);
        let at = |i| LearningRates::at(&c.optim, 3.0, i, 10);
        assert_eq!(s.learning_rates(5), at(5), "warm-up");
        assert_eq!(
            s.learning_rates(30),
            at(10),
            "paused while the window grows"
        );
        assert_eq!(s.learning_rates(90), at(50), "then resumed");
        assert_eq!(s.sh_degree(24, 3), 0, "degree 0 first");
        assert_eq!(s.sh_degree(50, 3), 2, "one more every 25");
        assert_eq!(s.sh_degree(1000, 3), 3, "capped");
        let densified: Vec<(u64, bool)> = (1..=100)
            .filter_map(|it| s.densify(it).map(|big| (it, big)))
            .collect();
        assert_eq!(
            densified,
            vec![(20, false), (40, true), (60, true)],
            "inside [from, until), huge ones after the first reset"
        );
        let resets: Vec<u64> = (1..=100).filter(|&it| s.opacity_reset(it)).collect();
        assert_eq!(resets, vec![30, 60], "resets before until_iter");
        assert!(
            s.accumulates_stats(79) && !s.accumulates_stats(80),
            "statistics window"
        );
        let logs: Vec<u64> = (1..=100).filter(|&it| s.logs(it)).collect();
        assert_eq!(logs, vec![30, 60, 90, 100], "every 30 and the last");
        let cks: Vec<u64> = (1..=100).filter(|&it| s.checkpoint_due(it)).collect();
        assert_eq!(cks, vec![50, 100], "every 50");
        assert!(
            !s.finished(99) && s.finished(100),
            "finished after the last"
        );
    }
}
