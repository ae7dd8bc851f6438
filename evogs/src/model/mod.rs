//! The dynamic scene model: canonical Gaussians, waypoint (anchor) states and the neural
//! field, with the three dynamics modes (`docs/method.md` §5 and §6).
//!
//! - [`Motion::Velocity`] (EvoGS): the state `(p, R, s)` of every Gaussian evolves under
//!   `d(p, R, s)/dt = (v, ω, ṡ)(p, t)`, integrated from the nearest anchor with an ODE
//!   stepper (RK4 by default; R updated on the manifold, `R ← Exp(hω)R`).
//! - [`Motion::Deformation`] (the 4DGS baseline): the same network, read as a displacement
//!   of the canonical state: `p = p₀ + Δp`, `R = Exp(Δω)R₀`, `s = s₀ + Δs`.
//! - [`Motion::Static`]: plain 3DGS.
//!
//! Opacity and SH colour are canonical (shared by all times). Anchor `0` is the canonical
//! state itself; anchors `1..K` hold their own positions, log-scales and raw quaternions.
//! With continuous waypoints ([`Waypoints::Continuous`], [`hop`]) a second field gives the
//! state at any time inside the window, and the velocity field carries it over short hops.

pub mod anchors;
pub mod build;
pub mod displace;
pub mod dynamics;
pub mod gaussian_runs;
pub mod grad_values;
pub mod hop;
pub mod init;
pub mod order;
pub mod packing;
pub mod render;
pub mod retain;
pub mod teacher;

pub use anchors::{AnchorState, Waypoints, anchor_for_time};
pub use build::{ModelFrame, build_model};
use dynamics::FrameRecords;
pub use dynamics::FrameTape;
pub use hop::{HopLaw, HopRender, HopSettings, HopStart};
pub use render::render_options;

use crate::aligned::CacheAligned;
use crate::field::{Gemm, NeuralField};
use evogs_math::{Par, Quat, Vec3};
use evogs_ode::Method;
use evogs_splat::{Splats, SplatsGrad};
use gaussian_runs::all_gaussian_runs;
use std::ops::Range;

/// How the Gaussians move.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Motion {
    /// EvoGS: a learned velocity field integrated in time.
    Velocity,
    /// 4DGS-style: a learned displacement of the canonical state.
    Deformation,
    /// No motion (3DGS).
    Static,
}

impl Motion {
    /// Lowercase name (`velocity`, `deformation`, `static`), as on the command line.
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Velocity => "velocity",
            Self::Deformation => "deformation",
            Self::Static => "static",
        }
    }
}

impl std::str::FromStr for Motion {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "velocity" => Ok(Self::Velocity),
            "deformation" => Ok(Self::Deformation),
            "static" => Ok(Self::Static),
            _ => Err(format!(
                "unknown motion `{s}` (velocity, deformation, static)"
            )),
        }
    }
}

/// The trainable scene, generic over the scalar (f32 to train, f64 to check gradients).
#[derive(Debug)]
pub struct Model<T> {
    /// Canonical Gaussians (anchor 0's state, opacity and colour for every time).
    pub canonical: Splats<T>,
    /// Anchor times `τ_0 < τ_1 < …` (`τ_0` is the canonical time).
    pub anchor_times: Vec<f64>,
    /// States of anchors `1..K` (index `k − 1`).
    pub anchors: Vec<AnchorState<T>>,
    /// The neural field (used by velocity and deformation motion).
    pub field: NeuralField<T>,
    /// Dynamics mode.
    pub motion: Motion,
    /// Waypoint mode.
    pub waypoints: Waypoints,
    /// ODE method (velocity motion).
    pub method: Method,
    /// Largest ODE step (velocity motion).
    pub max_step: f64,
    /// Whether the dynamics are switched on (off during the static warm-up).
    pub dynamics_active: bool,
    /// The waypoint field of continuous waypoints (a displacement of the canonical state,
    /// read at the time a hop starts); `None` in every other mode.
    pub waypoint_field: Option<NeuralField<T>>,
    /// Where hops start (continuous waypoints).
    pub hop: HopSettings,
    /// The field's forward records of the last frame or anchor segment, for its backward
    /// pass.
    records: FrameRecords<T>,
}

/// Borrowed positions, log-scales and raw quaternions of one anchor.
pub type StateRef<'a, T> = (&'a [Vec3<T>], &'a [Vec3<T>], &'a [Quat<T>]);
/// Mutably borrowed positions, log-scales and raw quaternions of one anchor.
pub type StateMut<'a, T> = (&'a mut [Vec3<T>], &'a mut [Vec3<T>], &'a mut [Quat<T>]);

/// Gradients of every trainable part of a [`Model`] (same shapes).
#[derive(Clone, Debug)]
pub struct ModelGrad<T> {
    /// Canonical Gaussians.
    pub canonical: SplatsGrad<T>,
    /// Anchors `1..K`.
    pub anchors: Vec<AnchorState<T>>,
    /// Field parameters (on a cache-line boundary, like the field's own: the plane scatter
    /// adds into it texel by texel).
    pub field: CacheAligned<T>,
    /// Waypoint-field parameters (empty without continuous waypoints).
    pub waypoint_field: Vec<T>,
}

impl<T: Gemm> Model<T> {
    /// A model with the dynamics off; anchors `1..K` start as copies of the canonical state.
    #[must_use]
    pub fn new(
        canonical: Splats<T>,
        field: NeuralField<T>,
        motion: Motion,
        waypoints: Waypoints,
        method: Method,
        max_step: f64,
        anchor_times: Vec<f64>,
    ) -> Self {
        let anchor_times = if waypoints != Waypoints::Trainable {
            anchor_times.into_iter().take(1).collect()
        } else {
            anchor_times
        };
        let copy = AnchorState {
            means: canonical.means.clone(),
            log_scales: canonical.log_scales.clone(),
            quats: canonical.quats.clone(),
        };
        let anchors = vec![copy; anchor_times.len().saturating_sub(1)];
        Self {
            canonical,
            anchor_times,
            anchors,
            field,
            motion,
            waypoints,
            method,
            max_step,
            dynamics_active: false,
            waypoint_field: None,
            hop: HopSettings::default(),
            records: FrameRecords::default(),
        }
    }

    /// Sets the parallelism of the fields' evaluations (results are deterministic for a
    /// given thread count).
    pub fn set_par(&mut self, par: evogs_math::Par) {
        self.field.set_par(par);
        if let Some(f) = self.waypoint_field.as_mut() {
            f.set_par(par);
        }
    }

    /// Number of Gaussians.
    #[must_use]
    pub fn len(&self) -> usize {
        self.canonical.len()
    }

    /// `true` if there are no Gaussians.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.canonical.is_empty()
    }

    /// A zero gradient shaped like the model.
    #[must_use]
    pub fn zero_grad(&self) -> ModelGrad<T> {
        ModelGrad {
            canonical: self.canonical.zeros_like(),
            anchors: self.anchors.iter().map(AnchorState::zeros_like).collect(),
            field: CacheAligned::new(self.field.params().len(), T::ZERO),
            waypoint_field: vec![
                T::ZERO;
                self.waypoint_field.as_ref().map_or(0, |f| f.params().len())
            ],
        }
    }

    /// Reorders the Gaussians (every canonical and anchor array): Gaussian `i` becomes the
    /// old Gaussian `order[i]`.
    ///
    /// # Panics
    /// If `order` is not a permutation of the Gaussians' indices.
    pub fn permute_gaussians(&mut self, order: &[usize]) {
        use retain::permute_items;
        let k = self.canonical.coeffs_per_gaussian();
        let c = &mut self.canonical;
        permute_items(&mut c.means, order, 1);
        permute_items(&mut c.log_scales, order, 1);
        permute_items(&mut c.quats, order, 1);
        permute_items(&mut c.opacity_logits, order, 1);
        permute_items(&mut c.sh, order, k);
        for a in &mut self.anchors {
            permute_items(&mut a.means, order, 1);
            permute_items(&mut a.log_scales, order, 1);
            permute_items(&mut a.quats, order, 1);
        }
    }

    /// Puts the Gaussians in the Morton order of their canonical positions in the field's box
    /// ([`order::spatial_order`]) and returns that order (Gaussian `i` is the old Gaussian
    /// `order[i]`), for whatever else holds per-Gaussian state (the optimiser) to follow.
    pub fn sort_spatially(&mut self) -> Vec<usize> {
        let (lo, hi) = self.field.hexplane().aabb();
        let order = order::spatial_order(&self.canonical.means, lo, hi);
        self.permute_gaussians(&order);
        order
    }

    /// The state of anchor `k` (0 = canonical): positions, log-scales, raw quaternions.
    #[must_use]
    pub fn anchor_state(&self, k: usize) -> StateRef<'_, T> {
        if k == 0 {
            (
                &self.canonical.means,
                &self.canonical.log_scales,
                &self.canonical.quats,
            )
        } else {
            let a = &self.anchors[k - 1];
            (&a.means, &a.log_scales, &a.quats)
        }
    }
}

impl<T: Gemm> ModelGrad<T> {
    /// Sets every entry to zero; `par` zeroes the field's parameters (most of the
    /// entries) in runs on the pool.
    pub fn fill_zero(&mut self, par: Par) {
        self.canonical.fill_zero(par);
        for a in &mut self.anchors {
            a.fill_zero();
        }
        zero_runs(&mut self.field, par);
        zero_runs(&mut self.waypoint_field, par);
    }

    /// The gradient slots of anchor `k` (0 = canonical).
    pub fn anchor_state_mut(&mut self, k: usize) -> StateMut<'_, T> {
        if k == 0 {
            let c = &mut self.canonical;
            (&mut c.means, &mut c.log_scales, &mut c.quats)
        } else {
            let a = &mut self.anchors[k - 1];
            (&mut a.means, &mut a.log_scales, &mut a.quats)
        }
    }

    /// `true` if every entry is finite; `par` checks the opacities, the colours and the
    /// field's parameters (most of the entries) in runs on the pool.
    #[must_use]
    pub fn is_finite(&self, par: Par) -> bool {
        let c = &self.canonical;
        // Each field's part of the run (the fields have one length in a consistent gradient).
        let part = |r: &Range<usize>, len: usize| r.start.min(len)..r.end.min(len);
        let geometry = |r: Range<usize>| {
            c.means[part(&r, c.means.len())]
                .iter()
                .all(|v| v.is_finite())
                && c.log_scales[part(&r, c.log_scales.len())]
                    .iter()
                    .all(|v| v.is_finite())
                && c.quats[part(&r, c.quats.len())]
                    .iter()
                    .all(|q| q.is_finite())
        };
        let n = c.means.len().max(c.log_scales.len()).max(c.quats.len());
        all_gaussian_runs(par, n, geometry)
            && all_finite(&c.opacity_logits, par)
            && all_finite(c.sh.as_flattened(), par)
            && self.anchors.iter().all(AnchorState::is_finite)
            && all_finite(&self.field, par)
            && all_finite(&self.waypoint_field, par)
    }
}

/// Values per run of [`all_finite`] and [`zero_runs`]: a fixed length, so the work splits
/// the same way on any thread count.
const RUN: usize = 1 << 15;

/// `true` if every value is finite. Each run folds its values without stopping early (a
/// loop the compiler vectorises); `Par::Rayon` checks the runs in parallel.
fn all_finite<T: Gemm>(xs: &[T], par: Par) -> bool {
    let run = |c: &[T]| c.iter().fold(true, |ok, v| ok & v.is_finite());
    match par {
        Par::Seq => xs.chunks(RUN).all(run),
        #[cfg(feature = "rayon")]
        Par::Rayon => {
            use rayon::prelude::*;
            xs.par_chunks(RUN).all(run)
        }
    }
}

/// `dst += src`, element by element, in runs on the pool for `Par::Rayon`.
pub(super) fn add_runs<T: Gemm>(dst: &mut [T], src: &[T], par: Par) {
    debug_assert_eq!(dst.len(), src.len(), "add_runs lengths");
    let run = |(d, s): (&mut [T], &[T])| {
        for (d, &s) in d.iter_mut().zip(s) {
            *d += s;
        }
    };
    match par {
        Par::Seq => run((dst, src)),
        #[cfg(feature = "rayon")]
        Par::Rayon => {
            use rayon::prelude::*;
            dst.par_chunks_mut(RUN)
                .zip(src.par_chunks(RUN))
                .for_each(run);
        }
    }
}

/// Sets every value to zero, in runs on the pool for `Par::Rayon`.
fn zero_runs<T: Gemm>(xs: &mut [T], par: Par) {
    match par {
        Par::Seq => xs.fill(T::ZERO),
        #[cfg(feature = "rayon")]
        Par::Rayon => {
            use rayon::prelude::*;
            xs.par_chunks_mut(RUN).for_each(|c| c.fill(T::ZERO));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A gradient of three Gaussians (SH degree 1) and a field of two runs and a bit.
    fn grad() -> ModelGrad<f32> {
        ModelGrad {
            canonical: SplatsGrad::zeros(3, 1),
            anchors: Vec::new(),
            field: CacheAligned::new(2 * RUN + 7, 0.0),
            waypoint_field: vec![0.0; 5],
        }
    }

    #[test]
    fn a_single_non_finite_entry_anywhere_is_found_on_any_par() {
        let pars = [Par::Seq, Par::best()];
        for par in pars {
            assert!(grad().is_finite(par), "zeros are finite");
        }
        let n = 2 * RUN + 7;
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            for at in [0, RUN - 1, RUN, 2 * RUN, n - 1] {
                let mut g = grad();
                g.field[at] = bad;
                for par in pars {
                    assert!(!g.is_finite(par), "{bad} at field[{at}] with {par:?}");
                }
            }
            let mut g = grad();
            g.waypoint_field[4] = bad;
            assert!(pars.iter().all(|&p| !g.is_finite(p)), "waypoint field");
            let mut g = grad();
            g.canonical.sh[3][2] = bad;
            assert!(pars.iter().all(|&p| !g.is_finite(p)), "colours");
            // The means, scales and rotations are checked in runs of Gaussians.
            let m = 2 * gaussian_runs::RUN + 3;
            for at in [0, gaussian_runs::RUN - 1, gaussian_runs::RUN, m - 1] {
                let fresh = || ModelGrad {
                    canonical: SplatsGrad::<f32>::zeros(m, 0),
                    ..grad()
                };
                let mut g = fresh();
                assert!(pars.iter().all(|&p| g.is_finite(p)), "{m} zeros");
                g.canonical.means[at].y = bad;
                assert!(pars.iter().all(|&p| !g.is_finite(p)), "mean {at}");
                let mut g = fresh();
                g.canonical.log_scales[at].z = bad;
                assert!(pars.iter().all(|&p| !g.is_finite(p)), "scale {at}");
                let mut g = fresh();
                g.canonical.quats[at].w = bad;
                assert!(pars.iter().all(|&p| !g.is_finite(p)), "rotation {at}");
            }
        }
    }

    #[test]
    fn fill_zero_clears_every_run_on_any_par() {
        for par in [Par::Seq, Par::best()] {
            let mut g = grad();
            g.field
                .iter_mut()
                .enumerate()
                .for_each(|(i, v)| *v = i as f32);
            g.waypoint_field.fill(-1.0);
            g.canonical.means[2] = Vec3::new(1.0, 2.0, 3.0);
            g.fill_zero(par);
            assert!(g.field.iter().all(|v| v.to_bits() == 0), "field, {par:?}");
            assert!(
                g.waypoint_field.iter().all(|v| v.to_bits() == 0),
                "waypoints"
            );
            assert_eq!(g.canonical.means[2].x.to_bits(), 0, "canonical");
        }
    }
}
