//! Seeded generation of ordinary and extreme inputs.

use evogs_math::rng::SplitMix64;
use evogs_math::{Quat, Vec3};

/// Finite values at the edges of f64 (signed zeros, subnormals, huge and tiny magnitudes).
const EXTREME_FINITE: [f64; 14] = [
    0.0,
    -0.0,
    5e-324,
    -1e-300,
    1e-30,
    -1e-12,
    1e-8,
    1e6,
    -1e12,
    1e30,
    -1e150,
    1e300,
    f64::MAX,
    f64::MIN,
];
/// The non-finite values.
const NON_FINITE: [f64; 3] = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY];

/// A seeded source of test inputs.
#[derive(Debug)]
pub struct Gen {
    rng: SplitMix64,
}

impl Gen {
    /// A generator for one seed.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self {
            rng: SplitMix64::new(seed),
        }
    }

    /// Uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.rng.uniform(lo, hi)
    }

    /// Standard normal.
    pub fn normal(&mut self) -> f64 {
        self.rng.normal()
    }

    /// `true` with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        self.rng.next_f64() < p
    }

    /// Uniform index below `n`.
    pub fn below(&mut self, n: usize) -> usize {
        self.rng.below(n)
    }

    /// An extreme finite value.
    pub fn extreme_finite(&mut self) -> f64 {
        EXTREME_FINITE[self.below(EXTREME_FINITE.len())]
    }

    /// NaN, +∞ or −∞.
    pub fn non_finite(&mut self) -> f64 {
        NON_FINITE[self.below(NON_FINITE.len())]
    }

    /// `ordinary` mostly; with probability `p` an extreme finite value, and (if
    /// `allow_non_finite`) sometimes a non-finite one.
    pub fn maybe_extreme(&mut self, ordinary: f64, p: f64, allow_non_finite: bool) -> f64 {
        if !self.chance(p) {
            ordinary
        } else if allow_non_finite && self.chance(0.3) {
            self.non_finite()
        } else {
            self.extreme_finite()
        }
    }

    /// A 3-vector of standard normals.
    pub fn normal3(&mut self) -> Vec3<f64> {
        Vec3::new(self.normal(), self.normal(), self.normal())
    }

    /// A random (unnormalised) quaternion, sometimes exactly zero or tiny.
    pub fn quat(&mut self) -> Quat<f64> {
        match self.below(12) {
            0 => Quat::zero(),
            1 => Quat::new(1e-300, 0.0, -1e-300, 0.0),
            2 => Quat::new(0.0, 0.0, 0.0, 1e-200),
            _ => Quat::new(self.normal(), self.normal(), self.normal(), self.normal()),
        }
    }
}
