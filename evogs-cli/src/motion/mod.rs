//! Whole-body motion search: a global correction of the learnt motion that gradient descent
//! cannot make.
//!
//! Photometric training turns a spinning body in nearly the right direction but stops at a
//! fraction of its spin: along the path of rigid poses from the learnt spin to the true one
//! the loss rises before it falls (README, "What stops it"), so the gradient points back.
//! A search over that path needs no gradient. [`bodies`] groups the Gaussians that move
//! together into bodies and fits each body's learnt motion as a constant spin `ω` about its
//! centroid; [`spin`] scans a multiplier `s` of each body's spin by the photometric training
//! loss, then teaches the field the best spin (velocity regression) and sets the anchors, so
//! that training continues from it. [`crate::train::trainer::Trainer::spin_search`] runs
//! both at `[spin_search] at_iter`.
//!
//! The model of a body's motion is `x(t) = c(t) + R(s·ω·(t − t₀))(x₀ − c₀)`: its centroid
//! path `c(t)` kept as learnt, its orientation turned at a constant rate. Bodies that do not
//! spin (or groups too large to be one body) are left as learnt.
//!
//! [`orbit`] finds what the spin search cannot: a small body the learnt motion has already
//! lost, circling a larger one (`[orbit_search]`).

pub mod ballistic;
pub mod bodies;
mod body_fit;
pub mod orbit;
mod orbit_refine;
mod orbit_score;
mod refit_stage;
pub mod spin;
#[cfg(test)]
pub(crate) mod test_support;
mod window_loss;

use serde::{Deserialize, Serialize};

/// Settings of the spin search (`[spin_search]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpinSearchConfig {
    /// Run the search after this many iterations (0: never). It needs the dynamics on and
    /// `velocity` motion; after the temporal curriculum is the natural time.
    pub at_iter: u64,
    /// A Gaussian moves if its learnt path leaves its canonical position by more than this
    /// (scene units).
    pub move_threshold: f64,
    /// Moving Gaussians closer than this at the canonical time belong to one body.
    pub link: f64,
    /// Smallest group of moving Gaussians taken as a body.
    pub min_body: usize,
    /// Largest body radius searched (scene units; larger groups are not one rigid body).
    pub max_radius: f64,
    /// Slowest learnt spin searched (radians per unit time).
    pub min_spin: f64,
    /// Fraction of the time range, from its start, over which the constant spin is fitted
    /// to the learnt rotations (short, so the fitted angles stay below π).
    pub spin_fit_until: f64,
    /// Every this-many-th training view enters the search's loss.
    pub view_stride: usize,
    /// Spin multipliers scanned first.
    pub multipliers: Vec<f64>,
    /// Step of the fine scan, four steps either side of the best coarse multiplier (0: no
    /// fine scan).
    pub fine_step: f64,
    /// Adam steps of the velocity regression that teaches the field the chosen spins.
    pub fit_iters: usize,
    /// Adam steps of a refit of each searched body's canonical Gaussians, spin and centroid
    /// path from its chosen spin, over the views (0: none). The best refit is kept.
    pub refit_iters: usize,
    /// Spin rates (radians per unit time) about the learnt axis that are refitted too: a body
    /// fitted under a slow learnt motion is smeared, and its scan may not show the true
    /// spin until its shape is refitted.
    pub refit_speeds: Vec<f64>,
    /// Accelerations (scene units per unit time squared) from which each searched body is
    /// also refitted as a thrown body bouncing on a floor, its acceleration along the
    /// cameras' mean down axis (empty: none; needs `refit_iters`). The best refit of all is
    /// kept.
    pub ballistic_gravities: Vec<f64>,
    /// Horizons (increasing fractions of the time range) over whose views a thrown body's
    /// refits run in turn, each from the last, so each flight is fitted before the next.
    pub ballistic_horizons: Vec<f64>,
    /// A body is refitted as thrown only if its learnt centroid leaves its start by more
    /// than this (scene units): a body that stays put is not flying.
    pub ballistic_min_travel: f64,
}

impl Default for SpinSearchConfig {
    fn default() -> Self {
        Self {
            at_iter: 0,
            move_threshold: 0.05,
            link: 0.04,
            min_body: 150,
            max_radius: 0.6,
            min_spin: 0.5,
            spin_fit_until: 0.25,
            view_stride: 2,
            multipliers: vec![
                0.0, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 2.75, 3.0, 3.5, 4.0,
                5.0, 6.0,
            ],
            fine_step: 0.0625,
            fit_iters: 1000,
            refit_iters: 0,
            refit_speeds: Vec::new(),
            ballistic_gravities: Vec::new(),
            ballistic_horizons: vec![0.12, 0.25, 0.5, 1.0],
            ballistic_min_travel: 0.2,
        }
    }
}

impl SpinSearchConfig {
    /// Checks the values for consistency.
    ///
    /// # Errors
    /// A message naming the offending field.
    pub fn validate(&self) -> Result<(), String> {
        let chk = |ok: bool, msg: &str| if ok { Ok(()) } else { Err(msg.to_string()) };
        chk(
            self.move_threshold > 0.0 && self.link > 0.0 && self.max_radius > 0.0,
            "spin_search.move_threshold, link and max_radius must be positive",
        )?;
        chk(
            self.spin_fit_until > 0.0 && self.spin_fit_until <= 1.0,
            "spin_search.spin_fit_until must be in (0, 1]",
        )?;
        chk(
            self.view_stride >= 1,
            "spin_search.view_stride must be at least 1",
        )?;
        chk(
            !self.multipliers.is_empty() && self.multipliers.iter().all(|m| m.is_finite()),
            "spin_search.multipliers must be a non-empty list of finite numbers",
        )?;
        chk(
            self.fine_step >= 0.0 && self.fine_step.is_finite(),
            "spin_search.fine_step must be a non-negative number",
        )?;
        chk(
            self.ballistic_gravities
                .iter()
                .all(|g| g.is_finite() && *g >= 0.0),
            "spin_search.ballistic_gravities must be non-negative numbers",
        )?;
        chk(
            self.ballistic_min_travel >= 0.0,
            "spin_search.ballistic_min_travel must be a non-negative number",
        )?;
        chk(
            !self.ballistic_horizons.is_empty()
                && self
                    .ballistic_horizons
                    .iter()
                    .all(|h| *h > 0.0 && *h <= 1.0)
                && self.ballistic_horizons.windows(2).all(|w| w[0] < w[1]),
            "spin_search.ballistic_horizons must be a non-empty increasing list of fractions in (0, 1]",
        )
    }
}

/// Settings of the orbit search (`[orbit_search]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OrbitSearchConfig {
    /// Run the search after this many iterations (0: never). It needs the dynamics on and
    /// `velocity` motion; just after the static warm-up, before a fast body fades, is the
    /// natural time.
    pub at_iter: u64,
    /// Gaussians at least this opaque enter the grouping.
    pub min_opacity: f64,
    /// Canonical Gaussians closer than this belong to one group.
    pub link: f64,
    /// Smallest group taken as a body or a centre.
    pub min_body: usize,
    /// Largest radius of a searched body (scene units).
    pub max_radius: f64,
    /// Smallest group taken as a centre.
    pub centre_min_body: usize,
    /// Largest radius of a centre's group.
    pub centre_max_radius: f64,
    /// Largest orbit radius: centres farther from a body are not tried.
    pub max_orbit_radius: f64,
    /// Largest initial speed tried (scene units per unit time).
    pub max_speed: f64,
    /// Step of the first, global velocity grid.
    pub speed_step: f64,
    /// Horizons of the stages, as fractions of the time range: the first is the global grid's,
    /// each later one refines around the best with half the previous step.
    pub horizons: Vec<f64>,
    /// Steps either side of the best velocity in each refining stage.
    pub local_steps: usize,
    /// Largest own spin of the body tried (radians per unit time; 0: the body turns with its
    /// orbit, unsearched). The spins are searched on a grid of step `spin_step` at the first
    /// horizon, then on 3×3×3 grids of half the previous step at each later one.
    pub max_spin: f64,
    /// Step of the global spin grid.
    pub spin_step: f64,
    /// Rounds of the last local search over centre, velocity and spin, at the last horizon
    /// (0: none).
    pub polish_rounds: usize,
    /// Its first step of the centre (scene units); those of the velocity and the spin are
    /// the last stage's.
    pub polish_step: f64,
    /// Adam steps of each refit of the body's canonical Gaussians and own spin, after the
    /// global spin grid (0: none). The grid's `refit_candidates` best spins (and turning with
    /// the orbit) are each refitted over the views to `refit_horizon`, and the best refit is
    /// kept: a body fitted to the warm-up's one or two views shows little of its spin until
    /// its shape is fitted to views from elsewhere (the private module `body_fit`).
    pub refit_iters: usize,
    /// How many of the spin grid's best spins are refitted.
    pub refit_candidates: usize,
    /// Horizon of those refits (fraction of the time range).
    pub refit_horizon: f64,
    /// Adam steps of a last refit of the body and its spin over the views to the last
    /// horizon, after the compass search (0: none).
    pub final_refit_iters: usize,
    /// Every this-many-th training view enters the loss.
    pub view_stride: usize,
    /// Smallest gain (mean loss per view below the learnt motion's, over the views to the
    /// last horizon) for an orbit to be taken.
    pub min_gain: f64,
    /// Adam steps of the velocity regression that teaches the field the orbits.
    pub fit_iters: usize,
    /// Deviation of the noise added to the positions the orbits' velocities are taught at
    /// (scene units): an integrator's intermediate stages leave the orbit (with a step of
    /// `h` and speed `v`, RK4's midpoint stage lies `(h·v/2)²/(2·radius)` outside it).
    pub fit_jitter: f64,
}

impl Default for OrbitSearchConfig {
    fn default() -> Self {
        Self {
            at_iter: 0,
            min_opacity: 0.05,
            link: 0.04,
            min_body: 30,
            max_radius: 0.2,
            centre_min_body: 150,
            centre_max_radius: 0.6,
            max_orbit_radius: 1.0,
            max_speed: 10.0,
            speed_step: 1.0,
            horizons: vec![0.06, 0.12, 0.25, 0.5, 1.0],
            local_steps: 2,
            max_spin: 16.0,
            spin_step: 2.0,
            polish_rounds: 6,
            polish_step: 0.02,
            refit_iters: 0,
            refit_candidates: 16,
            refit_horizon: 0.25,
            final_refit_iters: 0,
            view_stride: 2,
            min_gain: 1e-4,
            fit_iters: 1000,
            fit_jitter: 0.05,
        }
    }
}

impl OrbitSearchConfig {
    /// Checks the values for consistency.
    ///
    /// # Errors
    /// A message naming the offending field.
    pub fn validate(&self) -> Result<(), String> {
        let chk = |ok: bool, msg: &str| if ok { Ok(()) } else { Err(msg.to_string()) };
        let pos = |x: f64| x > 0.0 && x.is_finite();
        chk(
            pos(self.link)
                && pos(self.max_radius)
                && pos(self.centre_max_radius)
                && pos(self.max_orbit_radius),
            "orbit_search.link and the radii must be positive",
        )?;
        chk(
            pos(self.max_speed) && pos(self.speed_step),
            "orbit_search.max_speed and speed_step must be positive",
        )?;
        chk(
            !self.horizons.is_empty() && self.horizons.iter().all(|&h| h > 0.0 && h <= 1.0),
            "orbit_search.horizons must be a non-empty list of fractions in (0, 1]",
        )?;
        chk(
            self.view_stride >= 1,
            "orbit_search.view_stride must be at least 1",
        )?;
        chk(
            self.max_spin >= 0.0 && self.max_spin.is_finite() && pos(self.spin_step),
            "orbit_search.max_spin must be a non-negative number and spin_step positive",
        )?;
        chk(
            self.polish_step >= 0.0 && self.polish_step.is_finite(),
            "orbit_search.polish_step must be a non-negative number",
        )?;
        chk(
            self.refit_horizon > 0.0 && self.refit_horizon <= 1.0 && self.refit_candidates >= 1,
            "orbit_search.refit_horizon must be a fraction in (0, 1] and refit_candidates at least 1",
        )?;
        chk(
            self.fit_jitter >= 0.0 && self.fit_jitter.is_finite(),
            "orbit_search.fit_jitter must be a non-negative number",
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::TrainConfig;

    #[test]
    fn bad_settings_are_rejected() {
        let c = TrainConfig::fast();
        for bad in [
            "view_stride = 0",
            "multipliers = []",
            "spin_fit_until = 0.0",
            "link = -1.0",
            "ballistic_gravities = [-1.0]",
            "ballistic_horizons = []",
            "ballistic_horizons = [0.5, 0.25]",
            "ballistic_horizons = [1.5]",
            "ballistic_min_travel = -0.1",
        ] {
            let c = c
                .merge_toml(&format!("[spin_search]\n{bad}\n"))
                .expect("parses");
            assert!(c.validate().is_err(), "spin_search.{bad} rejected");
        }
    }

    #[test]
    fn run_configs_without_a_spin_search_read_with_it_off() {
        let mut text: toml::Value = toml::from_str(&TrainConfig::fast().to_toml()).expect("toml");
        let table = text.as_table_mut().expect("a table");
        assert!(table.remove("spin_search").is_some(), "fast writes it");
        let old =
            TrainConfig::from_run_toml(&toml::to_string(&text).expect("toml")).expect("reads");
        assert_eq!(old.spin_search, SpinSearchConfig::default());
        assert_eq!(old.spin_search.at_iter, 0, "off");
    }

    #[test]
    fn bad_settings_are_rejected_and_old_runs_read_with_it_off() {
        let c = TrainConfig::fast();
        for bad in [
            "view_stride = 0",
            "horizons = []",
            "horizons = [0.0]",
            "speed_step = 0.0",
            "link = -1.0",
            "max_spin = -1.0",
            "spin_step = 0.0",
            "polish_step = -0.1",
            "refit_horizon = 0.0",
            "refit_candidates = 0",
        ] {
            let c = c
                .merge_toml(&format!("[orbit_search]\n{bad}\n"))
                .expect("parses");
            assert!(c.validate().is_err(), "orbit_search.{bad} rejected");
        }
        let mut text: toml::Value = toml::from_str(&c.to_toml()).expect("toml");
        let table = text.as_table_mut().expect("a table");
        assert!(table.remove("orbit_search").is_some(), "fast writes it");
        let old =
            TrainConfig::from_run_toml(&toml::to_string(&text).expect("toml")).expect("reads");
        assert_eq!(old.orbit_search, OrbitSearchConfig::default());
        assert_eq!(old.orbit_search.at_iter, 0, "off");
    }
}
