//! The teacher loss of continuous waypoints ([`Model::teacher_loss`]): multiple shooting of
//! the hop law against the waypoint field's trajectories in 3D, without rendering
//! (`docs/losses.md` §9).

use super::hop::{pose, tangent};
use super::packing::unpack;
use super::{Model, ModelGrad};
use crate::field::Gemm;
use evogs_math::so3::log_quat;

impl<T: Gemm> Model<T> {
    /// The teacher loss over the window `(a, b)` (`a ≠ b`, both inside the training
    /// window) for the Gaussians `indices`:
    /// `weight/m · Σ_i (|p_i − p̃_i|² + |Log(q_i q̃_i*)|² + |s_i − s̃_i|²)` between the
    /// waypoint state at `a` carried to `b` by the hop law and the waypoint state at `b`.
    /// **Adds** the field's gradient into `grad.field` (the waypoint states are held fixed)
    /// and returns the loss. Zero without continuous waypoints or samples.
    pub fn teacher_loss(
        &mut self,
        (a, b): (f64, f64),
        indices: &[usize],
        weight: f64,
        grad: &mut ModelGrad<T>,
    ) -> f64 {
        let m = indices.len();
        #[allow(
            clippy::float_cmp,
            reason = "an empty window or a zero weight, exactly"
        )]
        let nothing = m == 0 || weight == 0.0 || self.waypoint_field.is_none() || a == b;
        if nothing {
            return 0.0;
        }
        let law = self.hop.law;
        let pos: Vec<T> = indices
            .iter()
            .flat_map(|&i| self.canonical.means[i].to_array())
            .collect();
        let mut y = self.law_states(a, indices, &pos);
        let target = self.waypoint_states(b, indices, &pos);
        let grid = self.hop_grid(a, b);
        let trajectory = self.flow_plain(&grid, &mut y, m);
        let tan = tangent(law);
        let w = T::from_f64(weight / m as f64);
        let mut d_final = vec![T::ZERO; m * tan];
        let mut loss = 0.0;
        for j in 0..m {
            let (p, q, s) = pose(&y, j, law);
            let (pt, qt, st) = unpack(&target, j);
            let dp = p - pt;
            let ds = s - st;
            let delta = log_quat(q.mul_quat(qt.conj()));
            loss += (dp.norm_squared() + ds.norm_squared() + delta.norm_squared()).to_f64();
            let o = &mut d_final[j * tan..];
            (dp * (T::TWO * w)).write_to(o);
            (delta * (T::TWO * w)).write_to(&mut o[3..]);
            (ds * (T::TWO * w)).write_to(&mut o[6..]);
        }
        self.flow_adjoint_plain(&trajectory, &d_final, m, &mut grad.field);
        loss * weight / m as f64
    }
}
