//! Continuous waypoints and hops ([`Waypoints::Continuous`](super::Waypoints::Continuous)):
//! the state of the Gaussians at any time `t′` inside the training window comes from a
//! second field read as a displacement of the canonical state (the waypoint field, the
//! deformation machinery of [`super::displace`]); the velocity field carries it over a short
//! hop to the rendered time `t`.
//!
//! - **Where a hop starts** ([`HopSettings::start`]): inside the window `t′ = t ∓ L` (one
//!   hop length before `t` or after it, [`HopStart`]; the other side where that one leaves
//!   the window); after the window from its end `t′ = t₁`, before it from its start
//!   `t′ = t₀`. So a future frame is the waypoint state at the end of the window carried
//!   forward by the velocity field alone.
//! - **What is rendered inside the window** ([`HopRender`]): the hop's end (the image
//!   trains both fields through the hop, as FreeGave and TRACE do), or the waypoint state
//!   at `t` itself (the image trains the waypoint field only, and the velocity field learns
//!   from the teacher loss alone, as ODE-GS does).
//! - **The teacher loss** ([`Model::teacher_loss`]): multiple shooting of the velocity
//!   field against the waypoint field's trajectories in 3D, without rendering: from the
//!   waypoint state at `a` integrate to `b` and compare with the waypoint state at `b`
//!   (`|Δp|² + |Log(q q̃*)|² + |Δs|²`, mean over sampled Gaussians). The waypoint states are
//!   held fixed (no gradient): the teacher moves only the velocity field.
//!
//! `docs/method.md` §6 tells the design and `docs/results.md` the measurements.

use super::displace::{OUTPUTS, displace, displace_vjp, flat_positions};
use super::packing::{TANGENT, pack_state, unpack};
use super::{Model, ModelGrad};
use crate::field::neural::STATE_STRIDE;
use crate::field::{Batch, Gemm, NeuralField};
use evogs_math::activation::normalize_quat_vjp;
use evogs_math::so3::log_quat;
use evogs_math::update::{
    ambient_from_left_cotangent, exp_update_left, left_cotangent_from_ambient,
};
use evogs_math::{Quat, Vec3};
use evogs_ode::{
    Checkpointing, Stepper, TimeGrid, Trajectory, discrete_adjoint, integrate, integrate_trajectory,
};
use evogs_splat::{Splats, SplatsGrad};

/// What a frame inside the training window renders (continuous waypoints).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HopRender {
    /// The end of the hop from the waypoint state at `t′` (both fields learn from the
    /// image).
    Hop,
    /// The waypoint state at `t` (the waypoint field learns from the image, the velocity
    /// field from the teacher loss).
    Direct,
}

impl std::str::FromStr for HopRender {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "hop" => Ok(Self::Hop),
            "direct" => Ok(Self::Direct),
            _ => Err(format!("unknown hop render `{s}` (hop, direct)")),
        }
    }
}

/// Which side of `t` a hop inside the window starts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HopStart {
    /// One hop before `t` (integrate forward); evaluation uses this side.
    Before,
    /// One hop after `t` (integrate backward).
    After,
}

/// Where hops start and what the window renders.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HopSettings {
    /// The training window `(t₀, t₁)`: the waypoint field's time range.
    pub window: (f64, f64),
    /// Hop length `L` (time units).
    pub length: f64,
    /// What a frame inside the window renders.
    pub render: HopRender,
}

impl Default for HopSettings {
    fn default() -> Self {
        Self {
            window: (0.0, 1.0),
            length: 0.0,
            render: HopRender::Hop,
        }
    }
}

impl HopSettings {
    /// The time `t′` a frame at `t` starts from: the window's end after it, its start before
    /// it; inside, `t` itself when the window renders the waypoint state, else one hop on
    /// `side` of `t` (the other side where that leaves the window; clamped into the window
    /// when both do).
    #[must_use]
    pub fn start(&self, t: f64, side: HopStart) -> f64 {
        let (a, b) = self.window;
        if t > b {
            return b;
        }
        if t < a {
            return a;
        }
        if self.render == HopRender::Direct || self.length <= 0.0 {
            return t;
        }
        let (first, second) = match side {
            HopStart::Before => (t - self.length, t + self.length),
            HopStart::After => (t + self.length, t - self.length),
        };
        if (a..=b).contains(&first) {
            first
        } else if (a..=b).contains(&second) {
            second
        } else {
            first.clamp(a, b)
        }
    }
}

/// What the backward pass of a hop needs.
#[derive(Debug)]
pub struct HopTape<T> {
    /// Where the hop starts.
    start: T,
    /// The waypoint field's outputs at `start` (`N × 9`).
    net: Vec<T>,
    /// The waypoint-field evaluation that holds `net`'s activations.
    waypoint_recording: u64,
    /// The velocity integration from `start` (none when the frame is the waypoint state)
    /// and its recording.
    flow: Option<(Trajectory<T>, u64)>,
}

impl<T: Gemm> Model<T> {
    /// The waypoint field.
    ///
    /// # Panics
    /// If the model has none (its waypoints are not continuous).
    fn waypoint_field_mut(&mut self) -> &mut NeuralField<T> {
        self.waypoint_field
            .as_mut()
            .expect("continuous waypoints need a waypoint field")
    }

    /// The Gaussians at `t` under continuous waypoints: the waypoint state at
    /// [`HopSettings::start`], carried to `t` by the velocity field.
    pub(super) fn hop_forward(
        &mut self,
        t: f64,
        side: HopStart,
        stepper: &mut Option<Stepper<T>>,
        out: &mut Splats<T>,
    ) -> HopTape<T> {
        let start = self.hop.start(t, side);
        let field = self
            .waypoint_field
            .as_mut()
            .expect("continuous waypoints need a waypoint field");
        self.records.waypoint_serial += 1;
        let net = displace(
            field,
            &mut self.records.waypoint,
            &self.canonical,
            T::from_f64(start),
            out,
        );
        let flow = (start != t).then(|| {
            let mut y0 = Vec::with_capacity(self.len() * STATE_STRIDE);
            pack_state(&out.means, &out.log_scales, &out.quats, &mut y0);
            let grid = TimeGrid::with_max_step(
                T::from_f64(start),
                T::from_f64(t),
                T::from_f64(self.max_step),
            );
            let (trajectory, recording) = self.integrate_recorded(&grid, &y0, stepper);
            let y = trajectory.final_state();
            for i in 0..self.len() {
                let (p, q, s) = unpack(y, i);
                out.means[i] = p;
                out.quats[i] = q;
                out.log_scales[i] = s;
            }
            (trajectory, recording)
        });
        HopTape {
            start: T::from_f64(start),
            net,
            waypoint_recording: self.records.waypoint_serial,
            flow,
        }
    }

    /// The backward pass of [`hop_forward`](Self::hop_forward) for the cotangent `d` of
    /// the rendered Gaussians' positions, rotations and log-scales: through the velocity
    /// field's discrete adjoint, then the waypoint displacement.
    pub(super) fn hop_backward(
        &mut self,
        tape: &HopTape<T>,
        stepper: &mut Option<Stepper<T>>,
        d: &SplatsGrad<T>,
        grad: &mut ModelGrad<T>,
    ) {
        let n = self.len();
        let at_start = tape.flow.as_ref().map(|(trajectory, recording)| {
            let y = trajectory.final_state();
            let mut d_final = vec![T::ZERO; n * TANGENT];
            for i in 0..n {
                let (_, q, _) = unpack(y, i);
                let o = &mut d_final[i * TANGENT..(i + 1) * TANGENT];
                d.means[i].write_to(o);
                left_cotangent_from_ambient(q, d.quats[i]).write_to(&mut o[3..]);
                d.log_scales[i].write_to(&mut o[6..]);
            }
            let d_y0 = self.adjoint(trajectory, *recording, &d_final, stepper, &mut grad.field);
            // The hop starts from the normalised displaced rotation: back through the
            // left cotangent and the normalisation to the displaced quaternion.
            let y0 = trajectory.initial_state();
            let mut means = vec![Vec3::zero(); n];
            let mut log_scales = vec![Vec3::zero(); n];
            let mut quats = vec![Quat::zero(); n];
            for i in 0..n {
                let o = &d_y0[i * TANGENT..];
                means[i] = Vec3::from_slice(o);
                log_scales[i] = Vec3::from_slice(&o[6..]);
                let (_, q_hat, _) = unpack(y0, i);
                let displaced = exp_update_left(
                    self.canonical.quats[i].normalize(),
                    Vec3::from_slice(&tape.net[i * OUTPUTS + 3..]),
                    T::ONE,
                );
                let amb = ambient_from_left_cotangent(q_hat, Vec3::from_slice(&o[3..]));
                quats[i] = normalize_quat_vjp(displaced, amb);
            }
            (means, log_scales, quats)
        });
        let d_start = match &at_start {
            Some((m, s, q)) => (m.as_slice(), s.as_slice(), q.as_slice()),
            None => (
                d.means.as_slice(),
                d.log_scales.as_slice(),
                d.quats.as_slice(),
            ),
        };
        let record = (tape.waypoint_recording == self.records.waypoint_serial)
            .then_some(&self.records.waypoint);
        let field = self
            .waypoint_field
            .as_mut()
            .expect("continuous waypoints need a waypoint field");
        let c = &mut grad.canonical;
        displace_vjp(
            field,
            record,
            &self.canonical,
            tape.start,
            &tape.net,
            d_start,
            (&mut c.means, &mut c.log_scales, &mut c.quats),
            &mut grad.waypoint_field,
        );
    }

    /// The packed ODE states (`[p, q̂, s]` each) of the Gaussians `indices` at the waypoint
    /// time `t` (no record: nothing differentiates through it).
    fn waypoint_states(&mut self, t: f64, indices: &[usize], pos: &[T]) -> Vec<T> {
        let m = indices.len();
        let mut net = vec![T::ZERO; m * OUTPUTS];
        let at = Batch {
            t: T::from_f64(t),
            positions: pos,
            stride: 3,
            n: m,
        };
        self.waypoint_field_mut().eval_batch(&at, &mut net, None);
        let mut y = Vec::with_capacity(m * STATE_STRIDE);
        for (j, &i) in indices.iter().enumerate() {
            let o = &net[j * OUTPUTS..];
            let p = self.canonical.means[i] + Vec3::from_slice(o);
            let q = exp_update_left(
                self.canonical.quats[i].normalize(),
                Vec3::from_slice(&o[3..]),
                T::ONE,
            )
            .normalize();
            let s = self.canonical.log_scales[i] + Vec3::from_slice(&o[6..]);
            y.extend_from_slice(&[p.x, p.y, p.z, q.w, q.x, q.y, q.z, s.x, s.y, s.z]);
        }
        y
    }

    /// The teacher loss over the window `(a, b)` (`a ≠ b`, both inside the training
    /// window) for the Gaussians `indices`:
    /// `weight/m · Σ_i (|p_i − p̃_i|² + |Log(q_i q̃_i*)|² + |s_i − s̃_i|²)` between the
    /// waypoint state at `a` carried to `b` by the velocity field and the waypoint state at
    /// `b`. **Adds** the velocity field's gradient into `grad.field` (the waypoint states
    /// are held fixed) and returns the loss. Zero without continuous waypoints or samples.
    pub fn teacher_loss(
        &mut self,
        (a, b): (f64, f64),
        indices: &[usize],
        weight: f64,
        grad: &mut ModelGrad<T>,
    ) -> f64 {
        let m = indices.len();
        if m == 0 || weight == 0.0 || self.waypoint_field.is_none() || a == b {
            return 0.0;
        }
        let pos: Vec<T> = indices
            .iter()
            .flat_map(|&i| self.canonical.means[i].to_array())
            .collect();
        let y0 = self.waypoint_states(a, indices, &pos);
        let target = self.waypoint_states(b, indices, &pos);
        self.field.set_count(m);
        let mut st = Stepper::new(self.method, evogs_ode::VectorField::layout(&self.field));
        let grid =
            TimeGrid::with_max_step(T::from_f64(a), T::from_f64(b), T::from_f64(self.max_step));
        let trajectory = integrate_trajectory(
            &mut self.field,
            &mut st,
            &grid,
            &y0,
            Checkpointing::StoreAll,
        );
        let y = trajectory.final_state();
        let w = T::from_f64(weight / m as f64);
        let mut d_final = vec![T::ZERO; m * TANGENT];
        let mut loss = 0.0;
        for j in 0..m {
            let (p, q, s) = unpack(y, j);
            let (pt, qt, st_) = unpack(&target, j);
            let dp = p - pt;
            let ds = s - st_;
            let delta = log_quat(q.mul_quat(qt.conj()));
            loss += (dp.norm_squared() + ds.norm_squared() + delta.norm_squared()).to_f64();
            let o = &mut d_final[j * TANGENT..(j + 1) * TANGENT];
            (dp * (T::TWO * w)).write_to(o);
            (delta * (T::TWO * w)).write_to(&mut o[3..]);
            (ds * (T::TWO * w)).write_to(&mut o[6..]);
        }
        let mut d_y0 = vec![T::ZERO; m * TANGENT];
        discrete_adjoint(
            &mut self.field,
            &mut st,
            &trajectory,
            &d_final,
            &mut d_y0,
            &mut grad.field,
        );
        self.field.set_count(self.len());
        loss * weight / m as f64
    }

    /// The share of the waypoint field's displacement from `t′` to `t` that the velocity
    /// field carries over the hop, `Σ_i ⟨Δ_i^flow, Δ_i^wp⟩ / Σ_i |Δ_i^wp|²` over the
    /// Gaussians' positions (1: the hop follows the waypoint field; 0: the velocity carries
    /// nothing), for the hop a frame at `t` inside the window takes (`None` without
    /// continuous waypoints, or where the hop has no length or the waypoint field does not
    /// move the Gaussians).
    pub fn hop_share(&mut self, t: f64, side: HopStart) -> Option<f64> {
        if self.waypoint_field.is_none() || !self.dynamics_active {
            return None;
        }
        let all: Vec<usize> = (0..self.len()).collect();
        let pos = flat_positions(&self.canonical);
        let hop = HopSettings {
            render: HopRender::Hop,
            ..self.hop
        };
        let start = hop.start(t, side);
        if start == t {
            return None;
        }
        let mut y = self.waypoint_states(start, &all, &pos);
        let y_start = y.clone();
        let y_end = self.waypoint_states(t, &all, &pos);
        let mut st = None;
        let mut stepper = self.stepper(&mut st);
        let grid = TimeGrid::with_max_step(
            T::from_f64(start),
            T::from_f64(t),
            T::from_f64(self.max_step),
        );
        integrate(&mut self.field, &mut stepper, &grid, &mut y);
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..self.len() {
            let p0 = unpack(&y_start, i).0;
            let flow = unpack(&y, i).0 - p0;
            let wp = unpack(&y_end, i).0 - p0;
            num += flow.dot(wp).to_f64();
            den += wp.norm_squared().to_f64();
        }
        (den > 0.0).then(|| num / den)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hops_start_inside_the_window_and_future_frames_from_its_end() {
        let h = HopSettings {
            window: (0.0, 0.75),
            length: 0.1,
            render: HopRender::Hop,
        };
        let near = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(near(h.start(0.4, HopStart::Before), 0.3), "one hop before");
        assert!(near(h.start(0.4, HopStart::After), 0.5), "one hop after");
        assert!(
            near(h.start(0.05, HopStart::Before), 0.15),
            "before leaves: after"
        );
        assert!(
            near(h.start(0.7, HopStart::After), 0.6),
            "after leaves: before"
        );
        assert_eq!(
            h.start(1.2, HopStart::Before),
            0.75,
            "future: the window's end"
        );
        assert_eq!(h.start(1.2, HopStart::After), 0.75, "either side");
        assert_eq!(
            h.start(-0.3, HopStart::After),
            0.0,
            "past: the window's start"
        );
        let short = HopSettings {
            window: (0.0, 0.05),
            ..h
        };
        assert_eq!(
            short.start(0.02, HopStart::Before),
            0.0,
            "clamped when both leave"
        );
        let direct = HopSettings {
            render: HopRender::Direct,
            ..h
        };
        assert_eq!(
            direct.start(0.4, HopStart::Before),
            0.4,
            "direct: the waypoint"
        );
        assert_eq!(
            direct.start(0.9, HopStart::Before),
            0.75,
            "direct: future still hops"
        );
    }
}
