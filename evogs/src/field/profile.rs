//! [`FieldProfile`]: opt-in timing of the neural field's work, for `evogs bench`.
//!
//! A [`NeuralField`](super::NeuralField) without a profile (the default, and always in
//! training) pays one branch per call and per matrix product. With one
//! ([`NeuralField::set_profile`](super::NeuralField::set_profile)) it adds, per call, the
//! wall-clock time of its batched evaluations and VJPs (measured on the calling thread), and,
//! per chunk, the time spent inside the MLP's matrix products (summed over the threads that
//! ran the chunks, so with several threads it is thread-time, not wall time) and the number of
//! rows the MLP ran forward and backward (from which [`Mlp::gemm_flops`](super::Mlp::gemm_flops)
//! counts the floating-point operations). Counters are relaxed atomics, read and reset by
//! [`FieldProfile::take`]; timing never changes a result.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

/// Accumulated timings and counts of a neural field's work (see the module docs).
#[derive(Debug, Default)]
pub struct FieldProfile {
    forward_nanos: AtomicU64,
    vjp_nanos: AtomicU64,
    gemm_nanos: AtomicU64,
    forward_rows: AtomicU64,
    backward_rows: AtomicU64,
    evaluations: AtomicU64,
    vjps: AtomicU64,
}

/// What a [`FieldProfile`] accumulated since it was last read.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FieldTimes {
    /// Wall-clock seconds in batched evaluations (`eval_batch`).
    pub forward: f64,
    /// Wall-clock seconds in batched VJPs (including any forward pass they recompute).
    pub vjp: f64,
    /// Seconds inside the MLP's matrix products, summed over threads.
    pub gemm_thread_seconds: f64,
    /// Rows (Gaussians) the MLP ran forward, in evaluations and in VJPs without a record
    /// (which run the forward pass again).
    pub forward_rows: u64,
    /// Rows the MLP ran backward.
    pub backward_rows: u64,
    /// Batched evaluations.
    pub evaluations: u64,
    /// Batched VJPs.
    pub vjps: u64,
}

/// Whole nanoseconds elapsed since `start` (saturating).
fn nanos_since(start: Instant) -> u64 {
    u64::try_from(start.elapsed().as_nanos()).unwrap_or(u64::MAX)
}

fn seconds(nanos: u64) -> f64 {
    nanos as f64 * 1e-9
}

impl FieldProfile {
    /// Reads the counters and resets them to zero.
    pub fn take(&self) -> FieldTimes {
        let get = |c: &AtomicU64| c.swap(0, Ordering::Relaxed);
        FieldTimes {
            forward: seconds(get(&self.forward_nanos)),
            vjp: seconds(get(&self.vjp_nanos)),
            gemm_thread_seconds: seconds(get(&self.gemm_nanos)),
            forward_rows: get(&self.forward_rows),
            backward_rows: get(&self.backward_rows),
            evaluations: get(&self.evaluations),
            vjps: get(&self.vjps),
        }
    }

    /// Adds the wall time of one batched evaluation of `rows` rows since `start`.
    pub(super) fn add_evaluation(&self, start: Instant, rows: usize) {
        self.forward_nanos
            .fetch_add(nanos_since(start), Ordering::Relaxed);
        self.evaluations.fetch_add(1, Ordering::Relaxed);
        self.forward_rows.fetch_add(rows as u64, Ordering::Relaxed);
    }

    /// Adds the wall time of one batched VJP of `rows` rows since `start`; with `recomputed`
    /// the forward pass of those rows was run again.
    pub(super) fn add_vjp(&self, start: Instant, rows: usize, recomputed: bool) {
        self.vjp_nanos
            .fetch_add(nanos_since(start), Ordering::Relaxed);
        self.vjps.fetch_add(1, Ordering::Relaxed);
        self.backward_rows.fetch_add(rows as u64, Ordering::Relaxed);
        if recomputed {
            self.forward_rows.fetch_add(rows as u64, Ordering::Relaxed);
        }
    }
}

/// Times the matrix products of one MLP pass when a profile is attached: each product runs
/// through [`time`](Self::time), and the total is added to the profile when the timer is
/// dropped (one atomic add per pass). Without a profile, `time` just runs the product.
#[derive(Debug)]
pub struct GemmTimer<'a> {
    profile: Option<&'a FieldProfile>,
    nanos: u64,
}

impl<'a> GemmTimer<'a> {
    /// A timer adding into `profile` (none: no timing).
    #[must_use]
    pub const fn new(profile: Option<&'a FieldProfile>) -> Self {
        Self { profile, nanos: 0 }
    }

    /// Runs one matrix product `f`, timing it if a profile is attached.
    #[inline]
    pub fn time(&mut self, f: impl FnOnce()) {
        if self.profile.is_some() {
            let start = Instant::now();
            f();
            self.nanos = self.nanos.saturating_add(nanos_since(start));
        } else {
            f();
        }
    }
}

impl Drop for GemmTimer<'_> {
    fn drop(&mut self) {
        if let Some(p) = self.profile {
            p.gemm_nanos.fetch_add(self.nanos, Ordering::Relaxed);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counters_accumulate_and_reset() {
        let p = FieldProfile::default();
        p.add_evaluation(Instant::now(), 10);
        p.add_evaluation(Instant::now(), 3);
        p.add_vjp(Instant::now(), 7, true);
        p.add_vjp(Instant::now(), 2, false);
        {
            let mut t = GemmTimer::new(Some(&p));
            t.time(|| std::thread::sleep(std::time::Duration::from_millis(2)));
        }
        let got = p.take();
        assert_eq!((got.evaluations, got.vjps), (2, 2), "call counts");
        assert_eq!((got.forward_rows, got.backward_rows), (20, 9), "rows");
        assert!(got.gemm_thread_seconds >= 0.002, "timed product");
        assert_eq!(p.take(), FieldTimes::default(), "reset by take");
        let mut off = GemmTimer::new(None);
        let mut ran = false;
        off.time(|| ran = true);
        assert!(ran, "an untimed product still runs");
    }
}
