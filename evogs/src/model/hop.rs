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
//!   trains both fields through the hop, as `FreeGave` and `TRACE` do), or the waypoint state
//!   at `t` itself (the image trains the waypoint field only, and the velocity field learns
//!   from the teacher loss alone, as ODE-GS does).
//! - **The law of a hop** ([`HopLaw`]): the velocity field (first order), or Newtonian
//!   dynamics in which the field is the acceleration and the Gaussians carry velocities
//!   that start from the waypoint field's finite difference over one hop
//!   ([`SecondOrderField`]); after the window a Gaussian then keeps moving by inertia.
//! - **The teacher loss** ([`Model::teacher_loss`], in [`super::teacher`]): multiple shooting of the velocity
//!   field against the waypoint field's trajectories in 3D, without rendering: from the
//!   waypoint state at `a` integrate to `b` and compare with the waypoint state at `b`
//!   (`|Δp|² + |Log(q q̃*)|² + |Δs|²`, mean over sampled Gaussians). The waypoint states are
//!   held fixed (no gradient): the teacher moves only the velocity field.
//!
//! `docs/method.md` §6 tells the design and `docs/results.md` the measurements.

use super::displace::{OUTPUTS, displace, displace_vjp, displaced, flat_positions};
use super::packing::{TANGENT, pack_state, unpack};
use super::{Model, ModelGrad};
use crate::field::neural::STATE_STRIDE;
use crate::field::second_order::second_order_layout;
use crate::field::{
    Batch, Gemm, NeuralField, SECOND_ORDER_STRIDE, SECOND_ORDER_TANGENT, SecondOrderField,
};
use evogs_math::activation::normalize_quat_vjp;
use evogs_math::so3::log_quat;
use evogs_math::so3_jacobians::{left_jacobian_inv, right_jacobian_inv};
use evogs_math::update::{ambient_from_left_cotangent, left_cotangent_from_ambient};
use evogs_math::{Quat, Vec3};
use evogs_ode::{
    Checkpointing, Stepper, TimeGrid, Trajectory, VectorField, discrete_adjoint,
    discrete_adjoint_recorded, integrate_recorded, integrate_trajectory,
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

/// The law that carries a hop (and every frame after the window).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum HopLaw {
    /// The velocity field: `d(p, R, s)/dt = (v, ω, ṡ)(p, t)`.
    FirstOrder,
    /// Newtonian dynamics ([`SecondOrderField`]): the Gaussians carry velocities, taken
    /// from the waypoint field's finite difference over one hop before the start, and the
    /// field gives the accelerations `(a, α, ṡ)(p, t)`.
    SecondOrder,
}

impl std::str::FromStr for HopLaw {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "first-order" => Ok(Self::FirstOrder),
            "second-order" => Ok(Self::SecondOrder),
            _ => Err(format!("unknown hop law `{s}` (first-order, second-order)")),
        }
    }
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
    /// The law of the hop.
    pub law: HopLaw,
}

impl Default for HopSettings {
    fn default() -> Self {
        Self {
            window: (0.0, 1.0),
            length: 0.0,
            render: HopRender::Hop,
            law: HopLaw::FirstOrder,
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

    /// The second time of the finite difference that gives a second-order hop starting at
    /// `start` its velocities: one hop length before (after, where that leaves the window).
    #[must_use]
    pub fn velocity_from(&self, start: f64) -> f64 {
        let (a, b) = self.window;
        let before = start - self.length;
        if before >= a || start + self.length > b {
            before
        } else {
            start + self.length
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
    /// Second-order law: the other time of the velocities' finite difference and the
    /// waypoint field's outputs there.
    prev: Option<(T, Vec<T>)>,
    /// The waypoint-field evaluations that hold `net`'s (and `prev`'s) activations.
    waypoint_recording: u64,
    /// The integration from `start` (none when the frame is the waypoint state) and its
    /// recording.
    flow: Option<(Trajectory<T>, u64)>,
}

/// Appends to every Gaussian's packed state `[p, q̂, s]` (stride 10) the velocities of the
/// finite difference from `prev` (at `t_prev`) to it (at `t`): `v = (p − p″)/Δ`,
/// `ω = Log(q̂ q̂″*)/Δ`, `Δ = t − t_prev`; returns the second-order state (stride 16).
fn with_velocities<T: Gemm>(y: &[T], prev: &[T], t: T, t_prev: T) -> Vec<T> {
    let n = y.len() / STATE_STRIDE;
    let inv = T::ONE / (t - t_prev);
    let mut out = Vec::with_capacity(n * SECOND_ORDER_STRIDE);
    for i in 0..n {
        let (p, q, _) = unpack(y, i);
        let (pp, qp, _) = unpack(prev, i);
        let v = (p - pp) * inv;
        let w = log_quat(q.mul_quat(qp.conj())) * inv;
        out.extend_from_slice(&y[i * STATE_STRIDE..(i + 1) * STATE_STRIDE]);
        out.extend_from_slice(&[v.x, v.y, v.z, w.x, w.y, w.z]);
    }
    out
}

/// Gaussian `i`'s position, rotation and log-scale in a state of either law.
pub(super) fn pose<T: Gemm>(y: &[T], i: usize, law: HopLaw) -> (Vec3<T>, Quat<T>, Vec3<T>) {
    let stride = match law {
        HopLaw::FirstOrder => STATE_STRIDE,
        HopLaw::SecondOrder => SECOND_ORDER_STRIDE,
    };
    let s = &y[i * stride..];
    (
        Vec3::from_slice(s),
        Quat::from_slice(&s[3..]),
        Vec3::from_slice(&s[7..]),
    )
}

/// Tangent entries per Gaussian of a law's state.
pub(super) const fn tangent(law: HopLaw) -> usize {
    match law {
        HopLaw::FirstOrder => TANGENT,
        HopLaw::SecondOrder => SECOND_ORDER_TANGENT,
    }
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

    /// Integrates the hop law from `y0` over `grid` as a new recording (the stage records
    /// within the field's budget are kept for the adjoint).
    fn flow_recorded(
        &mut self,
        grid: &TimeGrid<T>,
        y0: &[T],
        stepper: &mut Option<Stepper<T>>,
    ) -> (Trajectory<T>, u64) {
        let n = self.len();
        match self.hop.law {
            HopLaw::FirstOrder => self.integrate_recorded(grid, y0, stepper),
            HopLaw::SecondOrder => {
                let mut st = self.stepper_for(second_order_layout(n), stepper);
                let recording = self.new_recording();
                let mut law = SecondOrderField::new(&mut self.field, n);
                let trajectory =
                    integrate_recorded(&mut law, &mut st, grid, y0, &mut self.records.stages);
                *stepper = Some(st);
                (trajectory, recording)
            }
        }
    }

    /// The discrete adjoint of [`flow_recorded`](Self::flow_recorded): adds the field's
    /// gradient into `d_params` and returns the initial state's cotangent.
    fn flow_adjoint(
        &mut self,
        trajectory: &Trajectory<T>,
        recording: u64,
        d_final: &[T],
        stepper: &mut Option<Stepper<T>>,
        d_params: &mut [T],
    ) -> Vec<T> {
        let n = self.len();
        match self.hop.law {
            HopLaw::FirstOrder => self.adjoint(trajectory, recording, d_final, stepper, d_params),
            HopLaw::SecondOrder => {
                let mut d_y0 = vec![T::ZERO; n * SECOND_ORDER_TANGENT];
                let mut st = self.stepper_for(second_order_layout(n), stepper);
                let current = recording == self.records.serial;
                let mut law = SecondOrderField::new(&mut self.field, n);
                if current {
                    discrete_adjoint_recorded(
                        &mut law,
                        &mut st,
                        trajectory,
                        &mut self.records.stages,
                        d_final,
                        &mut d_y0,
                        d_params,
                    );
                } else {
                    discrete_adjoint(&mut law, &mut st, trajectory, d_final, &mut d_y0, d_params);
                }
                *stepper = Some(st);
                d_y0
            }
        }
    }

    /// Integrates the hop law from `y` (a state of `count` Gaussians) over `grid` in place,
    /// with no record (the teacher and the diagnostics).
    pub(super) fn flow_plain(
        &mut self,
        grid: &TimeGrid<T>,
        y: &mut [T],
        count: usize,
    ) -> Trajectory<T> {
        self.field.set_count(count);
        let trajectory = match self.hop.law {
            HopLaw::FirstOrder => {
                let mut st = self.new_stepper(VectorField::layout(&self.field));
                integrate_trajectory(&mut self.field, &mut st, grid, y, Checkpointing::StoreAll)
            }
            HopLaw::SecondOrder => {
                let mut st = self.new_stepper(second_order_layout(count));
                let mut law = SecondOrderField::new(&mut self.field, count);
                integrate_trajectory(&mut law, &mut st, grid, y, Checkpointing::StoreAll)
            }
        };
        self.field.set_count(self.len());
        y.copy_from_slice(trajectory.final_state());
        trajectory
    }

    /// The discrete adjoint of [`flow_plain`](Self::flow_plain) for `count` Gaussians and
    /// the final cotangent `d_final`: adds the field's gradient into `d_params` and returns
    /// the initial state's cotangent.
    pub(super) fn flow_adjoint_plain(
        &mut self,
        trajectory: &Trajectory<T>,
        d_final: &[T],
        count: usize,
        d_params: &mut [T],
    ) -> Vec<T> {
        let mut d_y0 = vec![T::ZERO; count * tangent(self.hop.law)];
        self.field.set_count(count);
        match self.hop.law {
            HopLaw::FirstOrder => {
                let mut st = self.new_stepper(VectorField::layout(&self.field));
                discrete_adjoint(
                    &mut self.field,
                    &mut st,
                    trajectory,
                    d_final,
                    &mut d_y0,
                    d_params,
                );
            }
            HopLaw::SecondOrder => {
                let mut st = self.new_stepper(second_order_layout(count));
                let mut law = SecondOrderField::new(&mut self.field, count);
                discrete_adjoint(&mut law, &mut st, trajectory, d_final, &mut d_y0, d_params);
            }
        }
        self.field.set_count(self.len());
        d_y0
    }

    /// The time grid of a hop from `a` to `b` (steps of at most `max_step`).
    pub(super) fn hop_grid(&self, a: f64, b: f64) -> TimeGrid<T> {
        TimeGrid::with_max_step(T::from_f64(a), T::from_f64(b), T::from_f64(self.max_step))
    }

    /// The Gaussians at `t` under continuous waypoints: the waypoint state at
    /// [`HopSettings::start`], carried to `t` by the hop law.
    pub(super) fn hop_forward(
        &mut self,
        t: f64,
        side: HopStart,
        stepper: &mut Option<Stepper<T>>,
        out: &mut Splats<T>,
    ) -> HopTape<T> {
        let start = self.hop.start(t, side);
        let law = self.hop.law;
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
            (&mut out.means, &mut out.log_scales, &mut out.quats),
        );
        #[allow(
            clippy::float_cmp,
            reason = "`start` is `t` itself when no hop is taken"
        )]
        let moves = start != t;
        let prev = (moves && law == HopLaw::SecondOrder).then(|| {
            let t_prev = self.hop.velocity_from(start);
            let n = self.canonical.len();
            let mut at_prev = (
                vec![Vec3::zero(); n],
                vec![Vec3::zero(); n],
                vec![Quat::zero(); n],
            );
            let net_prev = displace(
                field,
                &mut self.records.waypoint_prev,
                &self.canonical,
                T::from_f64(t_prev),
                (&mut at_prev.0, &mut at_prev.1, &mut at_prev.2),
            );
            (T::from_f64(t_prev), net_prev, at_prev)
        });
        let flow = moves.then(|| {
            let n = self.len();
            let mut y0 = Vec::with_capacity(n * STATE_STRIDE);
            pack_state(
                &out.means,
                &out.log_scales,
                &out.quats,
                &mut y0,
                self.field.par(),
            );
            if let Some((t_prev, _, at_prev)) = &prev {
                let mut y_prev = Vec::with_capacity(n * STATE_STRIDE);
                pack_state(
                    &at_prev.0,
                    &at_prev.1,
                    &at_prev.2,
                    &mut y_prev,
                    self.field.par(),
                );
                y0 = with_velocities(&y0, &y_prev, T::from_f64(start), *t_prev);
            }
            let grid = self.hop_grid(start, t);
            let (trajectory, recording) = self.flow_recorded(&grid, &y0, stepper);
            let y = trajectory.final_state();
            for i in 0..n {
                let (p, q, s) = pose(y, i, law);
                out.means[i] = p;
                out.quats[i] = q;
                out.log_scales[i] = s;
            }
            (trajectory, recording)
        });
        HopTape {
            start: T::from_f64(start),
            net,
            prev: prev.map(|(t_prev, net_prev, _)| (t_prev, net_prev)),
            waypoint_recording: self.records.waypoint_serial,
            flow,
        }
    }

    /// The backward pass of [`hop_forward`](Self::hop_forward) for the cotangent `d` of
    /// the rendered Gaussians' positions, rotations and log-scales: through the hop law's
    /// discrete adjoint, then the waypoint displacement(s).
    pub(super) fn hop_backward(
        &mut self,
        tape: &HopTape<T>,
        stepper: &mut Option<Stepper<T>>,
        d: &SplatsGrad<T>,
        grad: &mut ModelGrad<T>,
    ) {
        let n = self.len();
        let law = self.hop.law;
        let tan = tangent(law);
        // Cotangents of the waypoint states at the start and (second order) at the
        // finite difference's other time: positions, log-scales, rotations (left).
        let mut at_start: Option<StateCotangent<T>> = None;
        let mut at_prev: Option<StateCotangent<T>> = None;
        if let Some((trajectory, recording)) = &tape.flow {
            let y = trajectory.final_state();
            let mut d_final = vec![T::ZERO; n * tan];
            for i in 0..n {
                let (_, q, _) = pose(y, i, law);
                let o = &mut d_final[i * tan..];
                d.means[i].write_to(o);
                left_cotangent_from_ambient(q, d.quats[i]).write_to(&mut o[3..]);
                d.log_scales[i].write_to(&mut o[6..]);
            }
            let d_y0 =
                self.flow_adjoint(trajectory, *recording, &d_final, stepper, &mut grad.field);
            let y0 = trajectory.initial_state();
            let mut start = StateCotangent::zeros(n);
            let mut prev = tape.prev.as_ref().map(|_| StateCotangent::zeros(n));
            let delta = tape.prev.as_ref().map(|(t_prev, _)| tape.start - *t_prev);
            for i in 0..n {
                let o = &d_y0[i * tan..(i + 1) * tan];
                start.means[i] = Vec3::from_slice(o);
                start.log_scales[i] = Vec3::from_slice(&o[6..]);
                let mut rot = Vec3::from_slice(&o[3..]);
                if let (Some(p), Some(dt)) = (prev.as_mut(), delta) {
                    // v = (p − p″)/Δ and ω = Log(q̂ q̂″*)/Δ: their cotangents go to both
                    // waypoint states (left perturbations: Jl⁻¹(φ)ᵀ to q̂, −Jr⁻¹(φ)ᵀ to q̂″).
                    let dv = Vec3::from_slice(&o[9..]) * (T::ONE / dt);
                    let dw = Vec3::from_slice(&o[12..]) * (T::ONE / dt);
                    start.means[i] += dv;
                    p.means[i] = -dv;
                    let phi = Vec3::from_slice(&y0[i * SECOND_ORDER_STRIDE + 13..]) * dt;
                    rot += left_jacobian_inv(phi).transpose().mul_vec(dw);
                    p.rot[i] = -right_jacobian_inv(phi).transpose().mul_vec(dw);
                }
                start.rot[i] = rot;
            }
            at_start = Some(start);
            at_prev = prev;
        }
        let current = tape.waypoint_recording == self.records.waypoint_serial;
        let record = current.then_some(&self.records.waypoint);
        let record_prev = current.then_some(&self.records.waypoint_prev);
        let field = self
            .waypoint_field
            .as_mut()
            .expect("continuous waypoints need a waypoint field");
        let c = &mut grad.canonical;
        match &at_start {
            Some(cot) => {
                let quats = cot.ambient(&self.canonical, &tape.net);
                displace_vjp(
                    field,
                    record,
                    &self.canonical,
                    tape.start,
                    &tape.net,
                    (&cot.means, &cot.log_scales, &quats),
                    (&mut c.means, &mut c.log_scales, &mut c.quats),
                    &mut grad.waypoint_field,
                );
            }
            None => displace_vjp(
                field,
                record,
                &self.canonical,
                tape.start,
                &tape.net,
                (&d.means, &d.log_scales, &d.quats),
                (&mut c.means, &mut c.log_scales, &mut c.quats),
                &mut grad.waypoint_field,
            ),
        }
        if let (Some(cot), Some((t_prev, net_prev))) = (&at_prev, &tape.prev) {
            let quats = cot.ambient(&self.canonical, net_prev);
            displace_vjp(
                field,
                record_prev,
                &self.canonical,
                *t_prev,
                net_prev,
                (&cot.means, &cot.log_scales, &quats),
                (&mut c.means, &mut c.log_scales, &mut c.quats),
                &mut grad.waypoint_field,
            );
        }
    }

    /// The packed ODE states of the hop law for the Gaussians `indices` starting at the
    /// waypoint time `t` (second order: with the finite-difference velocities), from their
    /// canonical positions `pos`; no record (nothing differentiates through it).
    pub(super) fn law_states(&mut self, t: f64, indices: &[usize], pos: &[T]) -> Vec<T> {
        let y = self.waypoint_states(t, indices, pos);
        match self.hop.law {
            HopLaw::FirstOrder => y,
            HopLaw::SecondOrder => {
                let t_prev = self.hop.velocity_from(t);
                let y_prev = self.waypoint_states(t_prev, indices, pos);
                with_velocities(&y, &y_prev, T::from_f64(t), T::from_f64(t_prev))
            }
        }
    }

    /// The packed states `[p, q̂, s]` (stride 10) of the Gaussians `indices` at the
    /// waypoint time `t`, from their canonical positions `pos`.
    pub(super) fn waypoint_states(&mut self, t: f64, indices: &[usize], pos: &[T]) -> Vec<T> {
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
            let (p, q, s) = displaced(&self.canonical, i, &net[j * OUTPUTS..]);
            let q = q.normalize();
            y.extend_from_slice(&[p.x, p.y, p.z, q.w, q.x, q.y, q.z, s.x, s.y, s.z]);
        }
        y
    }

    /// The share of the waypoint field's displacement from `t′` to `t` that the hop law
    /// carries, `Σ_i ⟨Δ_i^hop, Δ_i^wp⟩ / Σ_i |Δ_i^wp|²` over the Gaussians' positions (1:
    /// the hop follows the waypoint field; 0: it carries nothing), for the hop a frame at
    /// `t` inside the window takes (`None` without continuous waypoints, or where the hop
    /// has no length or the waypoint field does not move the Gaussians).
    pub fn hop_share(&mut self, t: f64, side: HopStart) -> Option<f64> {
        if self.waypoint_field.is_none() || !self.dynamics_active {
            return None;
        }
        let law = self.hop.law;
        let all: Vec<usize> = (0..self.len()).collect();
        let pos = flat_positions(&self.canonical);
        let hop = HopSettings {
            render: HopRender::Hop,
            ..self.hop
        };
        let start = hop.start(t, side);
        #[allow(
            clippy::float_cmp,
            reason = "`start` is `t` itself when no hop is taken"
        )]
        if start == t {
            return None;
        }
        let mut y = self.law_states(start, &all, &pos);
        let y_start = y.clone();
        let y_end = self.waypoint_states(t, &all, &pos);
        let grid = self.hop_grid(start, t);
        self.flow_plain(&grid, &mut y, all.len());
        let (mut num, mut den) = (0.0, 0.0);
        for i in 0..self.len() {
            let p0 = pose(&y_start, i, law).0;
            let flow = pose(&y, i, law).0 - p0;
            let wp = unpack(&y_end, i).0 - p0;
            num += flow.dot(wp).to_f64();
            den += wp.norm_squared().to_f64();
        }
        (den > 0.0).then(|| num / den)
    }
}

/// Cotangents of a waypoint state: positions, log-scales and left rotation cotangents.
struct StateCotangent<T> {
    means: Vec<Vec3<T>>,
    log_scales: Vec<Vec3<T>>,
    rot: Vec<Vec3<T>>,
}

impl<T: Gemm> StateCotangent<T> {
    fn zeros(n: usize) -> Self {
        Self {
            means: vec![Vec3::zero(); n],
            log_scales: vec![Vec3::zero(); n],
            rot: vec![Vec3::zero(); n],
        }
    }

    /// The rotation cotangents as ambient gradients of the displaced quaternions
    /// `Exp(Δω)·q̂₀` (`net` the waypoint field's outputs), through the left cotangent at the
    /// normalised quaternion and the normalisation the packing applies.
    fn ambient(&self, canonical: &Splats<T>, net: &[T]) -> Vec<Quat<T>> {
        (0..self.rot.len())
            .map(|i| {
                let q = displaced(canonical, i, &net[i * OUTPUTS..]).1;
                let amb = ambient_from_left_cotangent(q.normalize(), self.rot[i]);
                normalize_quat_vjp(q, amb)
            })
            .collect()
    }
}

#[cfg(test)]
#[allow(clippy::float_cmp, reason = "the window's ends are returned exactly")]
mod tests {
    use super::*;

    #[test]
    fn hops_start_inside_the_window_and_future_frames_from_its_end() {
        let h = HopSettings {
            window: (0.0, 0.75),
            length: 0.1,
            render: HopRender::Hop,
            law: HopLaw::FirstOrder,
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
