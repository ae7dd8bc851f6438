//! The Gaussians at a time `t` ([`Model::splats_at`]) and the way back
//! ([`Model::backward_at`]): ODE integration with its exact discrete adjoint (velocity
//! motion), the direct displacement and its VJP (deformation motion), and the anchor loss.
//!
//! The ODE state of Gaussian `i` is `[p (3), q̂ (4, unit), s (3)]`
//! ([`gaussian_layout`](crate::field::gaussian_layout)); its tangent/cotangent is
//! `[p (3), δ (3, world-frame rotation), s (3)]`. A raw anchor quaternion `q` enters as
//! `q̂ = q/|q|`; the gradient returns through the left-cotangent conversion and the
//! normalisation VJP.

use super::displace::{displace, displace_vjp};
use super::gaussian_runs::{for_each_gaussian, for_each_gaussian3};
use super::hop::{HopStart, HopTape};
use super::packing::{TANGENT, pack_state, unpack, unpack_into};
use super::{Model, ModelGrad, Motion, Waypoints, add_runs};
use crate::field::neural::STATE_STRIDE;
use crate::field::{FieldRecord, Gemm};
use evogs_math::activation::normalize_quat_vjp;
use evogs_math::so3::log_quat;
use evogs_math::update::{ambient_from_left_cotangent, left_cotangent_from_ambient};
use evogs_math::{Quat, Vec3};
use evogs_ode::{
    StageTape, Stepper, TimeGrid, Trajectory, VectorField, discrete_adjoint,
    discrete_adjoint_recorded, integrate, integrate_recorded,
};
use evogs_splat::{Splats, SplatsGrad};

/// How far outside its trained time range a model is evaluated, in multiples of that range
/// ([`Model::check_time`]).
pub const MAX_EXTRAPOLATION: f64 = 10.0;

/// What [`Model::backward_at`] needs from the forward pass of one frame.
///
/// The field's forward records (its activations, for the field VJPs) stay in the model,
/// which keeps those of the last recording only (one frame's worth of memory, reused);
/// `recording` names it. A tape whose recording was replaced by a later frame is still
/// valid: its backward pass evaluates the field again (bitwise the same gradient).
#[derive(Debug)]
pub enum FrameTape<T> {
    /// The canonical Gaussians were rendered as they are.
    Static,
    /// Integrated from `anchor` along `trajectory`.
    Velocity {
        /// Anchor index.
        anchor: usize,
        /// The stored states.
        trajectory: Trajectory<T>,
        /// The recording that holds the stages' field records.
        recording: u64,
    },
    /// A hop of the velocity field from a continuous waypoint state.
    Hop(HopTape<T>),
    /// Displaced by the network outputs `out` (N × 9) evaluated at time `t`.
    Deformation {
        /// Frame time.
        t: T,
        /// Network outputs `[Δp, Δω, Δs]`.
        out: Vec<T>,
        /// The recording that holds the evaluation's field record.
        recording: u64,
    },
}

/// The field records of the model's last recording: the stages of an integration (the
/// last steps that fit the field's memory budget) or one displacement evaluation.
#[derive(Debug)]
pub(super) struct FrameRecords<T> {
    /// Which recording the records belong to (incremented for every new one).
    pub(super) serial: u64,
    /// The stage records of the last integration.
    pub(super) stages: StageTape<T, FieldRecord<T>>,
    /// The record of the last displacement.
    pub(super) displacement: FieldRecord<T>,
    /// Which waypoint evaluation `waypoint` belongs to (continuous waypoints).
    pub(super) waypoint_serial: u64,
    /// The record of the last waypoint-field evaluation.
    pub(super) waypoint: FieldRecord<T>,
    /// The record of the waypoint-field evaluation at the other time of a second-order
    /// hop's finite difference.
    pub(super) waypoint_prev: FieldRecord<T>,
}

impl<T: Gemm> Default for FrameRecords<T> {
    fn default() -> Self {
        Self {
            serial: 0,
            stages: StageTape::new(0),
            displacement: FieldRecord::default(),
            waypoint_serial: 0,
            waypoint: FieldRecord::default(),
            waypoint_prev: FieldRecord::default(),
        }
    }
}

impl<T: Gemm> Model<T> {
    /// A stepper for the current number of Gaussians (rebuilt when the count changes).
    pub(super) fn stepper(&mut self, stepper: &mut Option<Stepper<T>>) -> Stepper<T> {
        self.field.set_count(self.len());
        let layout = self.field.layout();
        self.stepper_for(layout, stepper)
    }

    /// The cached stepper if it has `layout`, else a new one; either way with the field's
    /// parallelism for its per-Gaussian block updates (bitwise the same results on any
    /// thread count).
    pub(super) fn stepper_for(
        &self,
        layout: evogs_ode::StateLayout,
        stepper: &mut Option<Stepper<T>>,
    ) -> Stepper<T> {
        match stepper.take() {
            Some(mut s) if *s.layout() == layout => {
                s.set_par(self.field.par());
                s
            }
            _ => self.new_stepper(layout),
        }
    }

    /// A new stepper of the model's method for `layout`, with the field's parallelism.
    pub(super) fn new_stepper(&self, layout: evogs_ode::StateLayout) -> Stepper<T> {
        Stepper::new(self.method, layout).with_par(self.field.par())
    }

    /// The time grid from anchor `k` to `t`.
    pub(super) fn grid(&self, k: usize, t: f64) -> TimeGrid<T> {
        TimeGrid::with_max_step(
            T::from_f64(self.anchor_times[k]),
            T::from_f64(t),
            T::from_f64(self.max_step),
        )
    }

    /// The ODE state `[p, q̂, s]` per Gaussian of anchor `k`.
    #[must_use]
    pub fn initial_state(&self, k: usize) -> Vec<T> {
        let (m, s, q) = self.anchor_state(k);
        let mut y = Vec::with_capacity(self.len() * STATE_STRIDE);
        pack_state(m, s, q, &mut y, self.field.par());
        y
    }

    /// The time grid of a frame at `t` integrated from anchor `k`.
    #[must_use]
    pub fn grid_to(&self, k: usize, t: f64) -> TimeGrid<T> {
        self.grid(k, t)
    }

    /// The Gaussians of an ODE state (opacity and colour from the canonical ones).
    pub fn splats_from_state(&self, y: &[T], out: &mut Splats<T>) {
        let par = self.field.par();
        out.copy_from(&self.canonical, par);
        unpack_into(y, &mut out.means, &mut out.quats, &mut out.log_scales, par);
    }

    /// Checks that the model can be evaluated at `t` in bounded time and memory: `t` is
    /// finite and lies within [`MAX_EXTRAPOLATION`] times the anchors' time range of that
    /// range (from 0.25 to 0.75 that is [−4.75, 5.75]). A velocity model integrates from the
    /// nearest anchor in steps of at most `max_step`, so a time far outside would take
    /// unbounded work (and keep every step for the way back).
    ///
    /// # Errors
    /// A message naming the time and the accepted interval.
    pub fn check_time(&self, t: f64) -> Result<(), String> {
        let (a, b) = match (self.anchor_times.first(), self.anchor_times.last()) {
            (Some(&a), Some(&b)) => (a, b),
            _ => (0.0, 1.0),
        };
        let span = if b > a { b - a } else { 1.0 };
        let (lo, hi) = (a - MAX_EXTRAPOLATION * span, b + MAX_EXTRAPOLATION * span);
        if t.is_finite() && t >= lo && t <= hi {
            Ok(())
        } else {
            Err(format!(
                "time {t} is outside [{lo}, {hi}], the times this model can be evaluated at \
                 ({MAX_EXTRAPOLATION} times its trained range [{a}, {b}] on either side)"
            ))
        }
    }

    /// The anchor a frame at `t` starts from under the current waypoint mode.
    #[must_use]
    pub fn anchor_for(&self, t: f64) -> usize {
        match self.waypoints {
            Waypoints::Off | Waypoints::Continuous => 0,
            _ => super::anchor_for_time(&self.anchor_times, t),
        }
    }

    /// Writes the Gaussians at time `t` into `out` and returns what the backward needs.
    /// `stepper` caches the ODE stepper between calls. With continuous waypoints a frame
    /// inside the window hops from the waypoint state one hop before `t`
    /// ([`HopStart::Before`]; [`splats_at_from`](Self::splats_at_from) chooses).
    pub fn splats_at(
        &mut self,
        t: f64,
        stepper: &mut Option<Stepper<T>>,
        out: &mut Splats<T>,
    ) -> FrameTape<T> {
        self.splats_at_from(t, HopStart::Before, stepper, out)
    }

    /// [`splats_at`](Self::splats_at) with the side a hop inside the window starts from
    /// (continuous waypoints; ignored otherwise).
    pub fn splats_at_from(
        &mut self,
        t: f64,
        side: HopStart,
        stepper: &mut Option<Stepper<T>>,
        out: &mut Splats<T>,
    ) -> FrameTape<T> {
        out.copy_from(&self.canonical, self.field.par());
        if !self.dynamics_active || self.motion == Motion::Static {
            return FrameTape::Static;
        }
        let tf = T::from_f64(t);
        let n = self.len();
        match self.motion {
            Motion::Velocity if self.waypoints == Waypoints::Continuous => {
                FrameTape::Hop(self.hop_forward(t, side, stepper, out))
            }
            Motion::Velocity => {
                let k = self.anchor_for(t);
                let (m, s, q) = self.anchor_state(k);
                let par = self.field.par();
                let mut y0 = Vec::with_capacity(n * STATE_STRIDE);
                pack_state(m, s, q, &mut y0, par);
                let grid = self.grid(k, t);
                let (trajectory, recording) = self.integrate_recorded(&grid, &y0, stepper);
                let y = trajectory.final_state();
                unpack_into(y, &mut out.means, &mut out.quats, &mut out.log_scales, par);
                FrameTape::Velocity {
                    anchor: k,
                    trajectory,
                    recording,
                }
            }
            Motion::Deformation => {
                self.records.serial += 1;
                let recording = self.records.serial;
                let net = displace(
                    &mut self.field,
                    &mut self.records.displacement,
                    &self.canonical,
                    tf,
                    (&mut out.means, &mut out.log_scales, &mut out.quats),
                );
                FrameTape::Deformation {
                    t: tf,
                    out: net,
                    recording,
                }
            }
            Motion::Static => FrameTape::Static,
        }
    }

    /// Accumulates into `grad` the gradient of a loss whose gradient with respect to the
    /// Gaussians returned by [`splats_at`](Self::splats_at) is `d`.
    pub fn backward_at(
        &mut self,
        tape: &FrameTape<T>,
        stepper: &mut Option<Stepper<T>>,
        d: &SplatsGrad<T>,
        grad: &mut ModelGrad<T>,
    ) {
        let n = self.len();
        let c = &mut grad.canonical;
        let par = self.field.par();
        add_runs(&mut c.opacity_logits[..n], &d.opacity_logits[..n], par);
        add_runs(c.sh.as_flattened_mut(), d.sh.as_flattened(), par);
        match tape {
            FrameTape::Static => {
                for i in 0..n {
                    c.means[i] += d.means[i];
                    c.log_scales[i] += d.log_scales[i];
                    c.quats[i] = c.quats[i] + d.quats[i];
                }
            }
            FrameTape::Velocity {
                anchor,
                trajectory,
                recording,
            } => {
                let y = trajectory.final_state();
                let mut d_final = vec![T::ZERO; n * TANGENT];
                for_each_gaussian(par, &mut d_final, TANGENT, |i, o| {
                    let (_, q, _) = unpack(y, i);
                    d.means[i].write_to(o);
                    left_cotangent_from_ambient(q, d.quats[i]).write_to(&mut o[3..]);
                    d.log_scales[i].write_to(&mut o[6..]);
                });
                self.adjoint_to_anchor(*anchor, trajectory, *recording, &d_final, stepper, grad);
            }
            FrameTape::Deformation { t, out, recording } => {
                let record =
                    (*recording == self.records.serial).then_some(&self.records.displacement);
                displace_vjp(
                    &mut self.field,
                    record,
                    &self.canonical,
                    *t,
                    out,
                    (&d.means, &d.log_scales, &d.quats),
                    {
                        let c = &mut grad.canonical;
                        (&mut c.means, &mut c.log_scales, &mut c.quats)
                    },
                    &mut grad.field,
                );
            }
            FrameTape::Hop(hop) => self.hop_backward(hop, stepper, d, grad),
        }
    }

    /// Integrates from `y0` over `grid` as a new recording: the field records of the last
    /// steps that fit the field's memory budget are kept for the adjoint. Returns the
    /// trajectory and the recording's serial number.
    pub(super) fn integrate_recorded(
        &mut self,
        grid: &TimeGrid<T>,
        y0: &[T],
        stepper: &mut Option<Stepper<T>>,
    ) -> (Trajectory<T>, u64) {
        let mut st = self.stepper(stepper);
        let recording = self.new_recording();
        let trajectory =
            integrate_recorded(&mut self.field, &mut st, grid, y0, &mut self.records.stages);
        *stepper = Some(st);
        (trajectory, recording)
    }

    /// Starts a new recording of stage records: the tape sized to the field's memory budget
    /// for the current Gaussians, and the recording's serial number.
    pub(super) fn new_recording(&mut self) -> u64 {
        let budget = self.field.records_within_budget(self.len());
        if self.records.stages.capacity() != budget {
            self.records.stages.set_capacity(budget);
        }
        self.records.serial += 1;
        self.records.serial
    }

    /// Runs the discrete adjoint of `trajectory` (integrated as `recording`) for the final
    /// cotangent `d_final`, adds the field gradient into `d_params` and returns the
    /// cotangent of the initial state (`N × 9`).
    pub(super) fn adjoint(
        &mut self,
        trajectory: &Trajectory<T>,
        recording: u64,
        d_final: &[T],
        stepper: &mut Option<Stepper<T>>,
        d_params: &mut [T],
    ) -> Vec<T> {
        let n = self.len();
        let mut d_y0 = vec![T::ZERO; n * TANGENT];
        let mut st = self.stepper(stepper);
        if recording == self.records.serial {
            discrete_adjoint_recorded(
                &mut self.field,
                &mut st,
                trajectory,
                &mut self.records.stages,
                d_final,
                &mut d_y0,
                d_params,
            );
        } else {
            discrete_adjoint(
                &mut self.field,
                &mut st,
                trajectory,
                d_final,
                &mut d_y0,
                d_params,
            );
        }
        *stepper = Some(st);
        d_y0
    }

    /// Runs the discrete adjoint of `trajectory` (integrated from anchor `k` as
    /// `recording`) for the final cotangent `d_final` and adds the anchor and field
    /// gradients into `grad`.
    fn adjoint_to_anchor(
        &mut self,
        k: usize,
        trajectory: &Trajectory<T>,
        recording: u64,
        d_final: &[T],
        stepper: &mut Option<Stepper<T>>,
        grad: &mut ModelGrad<T>,
    ) {
        let n = self.len();
        let d_y0 = self.adjoint(trajectory, recording, d_final, stepper, &mut grad.field);
        let y0 = trajectory.initial_state();
        let raw = self.anchor_state(k).2;
        let (gm, gs, gq) = grad.anchor_state_mut(k);
        let (gm, gs, gq) = (&mut gm[..n], &mut gs[..n], &mut gq[..n]);
        for_each_gaussian3(self.field.par(), gm, gs, gq, |i, gm, gs, gq| {
            let (_, q_hat, _) = unpack(y0, i);
            let o = &d_y0[i * TANGENT..];
            *gm += Vec3::from_slice(o);
            *gs += Vec3::from_slice(&o[6..]);
            let amb = ambient_from_left_cotangent(q_hat, Vec3::from_slice(&o[3..]));
            *gq = *gq + normalize_quat_vjp(raw[i], amb);
        });
    }

    /// The anchor loss of segment `k → k+1` (trainable waypoints):
    /// `weight/N · Σ_i (|p_i − p̃_i|² + |s_i − s̃_i|² + |Log(q_i q̃_i*)|²)` between the state
    /// integrated from anchor `k` to `τ_{k+1}` and anchor `k+1`'s state; gradients to both
    /// anchors and the field. Returns the loss.
    ///
    /// # Panics
    /// If `k + 1` is not an anchor.
    pub fn anchor_loss(
        &mut self,
        k: usize,
        weight: f64,
        stepper: &mut Option<Stepper<T>>,
        grad: &mut ModelGrad<T>,
    ) -> f64 {
        assert!(
            k + 1 < self.anchor_times.len(),
            "anchor loss needs a next anchor"
        );
        let n = self.len();
        if n == 0 {
            return 0.0;
        }
        let (m, s, q) = self.anchor_state(k);
        let mut y0 = Vec::with_capacity(n * STATE_STRIDE);
        pack_state(m, s, q, &mut y0, self.field.par());
        let grid = self.grid(k, self.anchor_times[k + 1]);
        let (trajectory, recording) = self.integrate_recorded(&grid, &y0, stepper);
        let y = trajectory.final_state();
        let w = T::from_f64(weight / n as f64);
        let mut d_final = vec![T::ZERO; n * TANGENT];
        let mut loss = 0.0_f64;
        let target = &self.anchors[k];
        let (gm, gs, gq) = {
            let a = &mut grad.anchors[k];
            (&mut a.means, &mut a.log_scales, &mut a.quats)
        };
        for i in 0..n {
            let (p, q, s) = unpack(y, i);
            let qa = target.quats[i].normalize();
            let dp = p - target.means[i];
            let ds = s - target.log_scales[i];
            let delta = log_quat(q.mul_quat(qa.conj()));
            loss += (dp.norm_squared() + ds.norm_squared() + delta.norm_squared()).to_f64();
            let o = &mut d_final[i * TANGENT..(i + 1) * TANGENT];
            (dp * (T::TWO * w)).write_to(o);
            (delta * (T::TWO * w)).write_to(&mut o[3..]);
            (ds * (T::TWO * w)).write_to(&mut o[6..]);
            gm[i] -= dp * (T::TWO * w);
            gs[i] -= ds * (T::TWO * w);
            // d|Log(q qa*)|²/d(left perturbation of qa) = −2δ.
            let amb = ambient_from_left_cotangent(qa, delta * (-T::TWO * w));
            gq[i] = gq[i] + normalize_quat_vjp(target.quats[i], amb);
        }
        self.adjoint_to_anchor(k, &trajectory, recording, &d_final, stepper, grad);
        loss * weight / n as f64
    }

    /// Sets anchor `k ≥ 1` to the state integrated from anchor `k − 1` to `τ_k` (the
    /// temporal curriculum's initialisation of an anchor when the supervised window reaches
    /// it; the anchor loss of segment `k − 1 → k` is then zero).
    ///
    /// # Panics
    /// If `k` is 0 or not an anchor.
    pub fn refresh_anchor_from_previous(&mut self, k: usize, stepper: &mut Option<Stepper<T>>) {
        assert!(
            k >= 1 && k < self.anchor_times.len(),
            "anchor {k} has no previous anchor"
        );
        let mut y = self.initial_state(k - 1);
        self.integrate_into_anchor(k, &mut y, stepper);
    }

    /// Integrates the ODE state `y` of anchor `k − 1` over segment `k − 1 → k` and writes the
    /// result into anchor `k ≥ 1` (`y` is left at `τ_k`).
    fn integrate_into_anchor(&mut self, k: usize, y: &mut [T], stepper: &mut Option<Stepper<T>>) {
        let grid = self.grid(k - 1, self.anchor_times[k]);
        let mut st = self.stepper(stepper);
        integrate(&mut self.field, &mut st, &grid, y);
        *stepper = Some(st);
        let n = self.len();
        let a = &mut self.anchors[k - 1];
        a.means.resize(n, Vec3::zero());
        a.log_scales.resize(n, Vec3::zero());
        a.quats.resize(n, Quat::identity());
        for i in 0..n {
            let (p, q, s) = unpack(y, i);
            a.means[i] = p;
            a.quats[i] = q;
            a.log_scales[i] = s;
        }
    }

    /// Sets anchors `1..K` to the state integrated from anchor 0 (through each anchor in
    /// turn): the initialisation of trainable anchors.
    pub fn refresh_anchors_from_start(&mut self, stepper: &mut Option<Stepper<T>>) {
        let mut y = self.initial_state(0);
        for k in 1..self.anchor_times.len() {
            self.integrate_into_anchor(k, &mut y, stepper);
        }
    }
}
