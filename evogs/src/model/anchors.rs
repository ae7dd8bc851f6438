//! Waypoints ("Gaussian waypoints" of the paper): anchor states at fixed times.
//!
//! A frame at time `t` is integrated from the nearest anchor at or before `t`; after the last
//! anchor from the last one; before the first, backward from the first. In
//! [`Waypoints::Trainable`] mode (multiple shooting) every anchor state is a parameter and an
//! anchor loss ties the segments into one trajectory; in
//! [`Waypoints::Off`] mode everything integrates from anchor 0 (the released code); in
//! [`Waypoints::Continuous`] mode a waypoint field replaces the anchors
//! ([`super::hop`]).

use evogs_math::{Quat, Real, Vec3};

/// Waypoint mode.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Waypoints {
    /// Anchor states are trainable; the anchor loss ties them (default).
    Trainable,
    /// A single anchor at the start of the time range.
    Off,
    /// Continuous waypoints: a second field gives the state at any time inside the window
    /// and the velocity field carries it over short hops ([`super::hop`]); one anchor.
    Continuous,
}

impl std::str::FromStr for Waypoints {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "trainable" => Ok(Self::Trainable),
            "off" => Ok(Self::Off),
            "continuous" => Ok(Self::Continuous),
            _ => Err(format!(
                "unknown waypoint mode `{s}` (trainable, off, continuous)"
            )),
        }
    }
}

/// The dynamic state of all Gaussians at one anchor time.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AnchorState<T> {
    /// Positions.
    pub means: Vec<Vec3<T>>,
    /// Log-scales.
    pub log_scales: Vec<Vec3<T>>,
    /// Raw quaternions (normalised when used).
    pub quats: Vec<Quat<T>>,
}

impl<T: Real> AnchorState<T> {
    /// Zeros of the same shape.
    #[must_use]
    pub fn zeros_like(&self) -> Self {
        let n = self.means.len();
        Self {
            means: vec![Vec3::zero(); n],
            log_scales: vec![Vec3::zero(); n],
            quats: vec![Quat::zero(); n],
        }
    }
    /// Sets every entry to zero.
    pub fn fill_zero(&mut self) {
        self.means.fill(Vec3::zero());
        self.log_scales.fill(Vec3::zero());
        self.quats.fill(Quat::zero());
    }
    /// `true` if every entry is finite.
    #[must_use]
    pub fn is_finite(&self) -> bool {
        self.means.iter().all(|v| v.is_finite())
            && self.log_scales.iter().all(|v| v.is_finite())
            && self.quats.iter().all(|q| q.is_finite())
    }
    /// Keeps the Gaussians flagged in `keep`.
    pub fn retain(&mut self, keep: &[bool]) {
        super::retain::retain_items(&mut self.means, keep, 1);
        super::retain::retain_items(&mut self.log_scales, keep, 1);
        super::retain::retain_items(&mut self.quats, keep, 1);
    }
}

/// The anchor a frame at time `t` integrates from: the last anchor at or before `t`
/// (anchor 0 for times before the first).
#[must_use]
pub fn anchor_for_time(times: &[f64], t: f64) -> usize {
    let mut k = 0;
    for (i, &tau) in times.iter().enumerate() {
        if tau <= t {
            k = i;
        }
    }
    k
}

/// `k` anchor times evenly spaced over `[t_min, t_max]` (one anchor at `t_min` if `k ≤ 1`).
#[must_use]
pub fn anchor_times(t_min: f64, t_max: f64, k: usize) -> Vec<f64> {
    if k <= 1 || t_max <= t_min {
        return vec![t_min];
    }
    let step = (t_max - t_min) / (k - 1) as f64;
    (0..k)
        .map(|i| {
            if i + 1 == k {
                t_max
            } else {
                t_min + step * i as f64
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_pick_the_anchor_at_or_before() {
        let t = anchor_times(0.0, 1.0, 3);
        assert_eq!(t, vec![0.0, 0.5, 1.0], "three anchors");
        assert_eq!(anchor_for_time(&t, -0.2), 0, "before the first: the first");
        assert_eq!(anchor_for_time(&t, 0.49), 0, "inside the first segment");
        assert_eq!(anchor_for_time(&t, 0.5), 1, "at an anchor: that anchor");
        assert_eq!(anchor_for_time(&t, 1.7), 2, "after the last: the last");
    }
}
