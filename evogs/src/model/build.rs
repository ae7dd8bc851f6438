//! Building a model from its configuration: the neural field over a box around the
//! canonical Gaussians, the time coordinate, the anchors, and [`Model::new`]. Training,
//! resuming from a checkpoint and the benchmark all build their models here.

use super::anchors::anchor_times;
use super::{HopSettings, Model, Motion, Waypoints};
use crate::config::{TimeCoordinate, TrainConfig};
use crate::field::{NeuralField, TimeMapping};
use evogs_splat::Splats;

/// Where and when a model lives: the field's box and time coordinate, the ODE's largest
/// step and the anchor times (a checkpoint stores them; a new run derives them).
#[derive(Clone, Debug, PartialEq)]
pub struct ModelFrame {
    /// The field's axis-aligned box (lower, upper corner).
    pub aabb: ([f64; 3], [f64; 3]),
    /// How the field reads time.
    pub time: TimeMapping,
    /// Largest ODE step.
    pub max_step: f64,
    /// Anchor times (the first is the canonical state's).
    pub anchor_times: Vec<f64>,
    /// The training time range (continuous waypoints read their field over it).
    pub window: (f64, f64),
}

impl ModelFrame {
    /// The frame of a new run over the training time range `(t0, t1)`: the bounding box of
    /// the canonical positions widened by `init.aabb_margin` of its size on each axis (a unit
    /// box around the origin on an axis without points), the configured time coordinate
    /// (`autonomous` for velocity motion only; deformation always reads time),
    /// steps of `dynamics.step_fraction` of the range (continuous waypoints: `hop.length /
    /// hop.steps` of it) and `dynamics.anchors` anchor times spread evenly over it.
    #[must_use]
    pub fn for_training(cfg: &TrainConfig, canonical: &Splats<f32>, (t0, t1): (f64, f64)) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in &canonical.means {
            for (a, v) in p.to_array().into_iter().enumerate() {
                lo[a] = lo[a].min(f64::from(v));
                hi[a] = hi[a].max(f64::from(v));
            }
        }
        for a in 0..3 {
            if lo[a] > hi[a] {
                (lo[a], hi[a]) = (-0.5, 0.5);
            }
            let m = cfg.init.aabb_margin * (hi[a] - lo[a]).max(1e-3);
            lo[a] -= m;
            hi[a] += m;
        }
        let normalized = TimeMapping::Normalized {
            t_min: t0,
            t_max: t1,
        };
        // An autonomous field is a law of the dynamics; a displacement without a time input
        // would be a static model, so the deformation motion always reads time.
        let time = match (cfg.dynamics.time_mapping, cfg.dynamics.motion) {
            (TimeCoordinate::Autonomous, Motion::Velocity) => TimeMapping::Autonomous,
            _ => normalized,
        };
        let step_fraction = if continuous(cfg) {
            cfg.hop.length / cfg.hop.steps as f64
        } else {
            cfg.dynamics.step_fraction
        };
        Self {
            aabb: (lo, hi),
            time,
            max_step: step_fraction * (t1 - t0),
            anchor_times: anchor_times(t0, t1, cfg.dynamics.anchors),
            window: (t0, t1),
        }
    }
}

/// Whether `cfg` asks for continuous waypoints (velocity motion only; the other motions
/// ignore the waypoint mode).
#[must_use]
pub fn continuous(cfg: &TrainConfig) -> bool {
    cfg.dynamics.motion == Motion::Velocity && cfg.dynamics.waypoints == Waypoints::Continuous
}

/// The model of `cfg` (field, motion, waypoints, integrator) on the canonical Gaussians in
/// `frame`; the fields' parameters are initialised from the seed (a checkpoint overwrites
/// them), the anchors are copies of the canonical state and the dynamics are off. With
/// continuous waypoints the waypoint field has the velocity field's shape and reads time
/// over the training window.
#[must_use]
pub fn build_model(cfg: &TrainConfig, canonical: Splats<f32>, frame: ModelFrame) -> Model<f32> {
    let (lo, hi) = frame.aabb;
    let field = NeuralField::new(&cfg.field, lo, hi, frame.time, cfg.seed ^ 0x5eed);
    let waypoints: Waypoints = cfg.dynamics.waypoints;
    let (t0, t1) = frame.window;
    let waypoint_field = continuous(cfg).then(|| {
        let time = TimeMapping::Normalized {
            t_min: t0,
            t_max: t1,
        };
        NeuralField::new(&cfg.field, lo, hi, time, cfg.seed ^ 0x0a1f)
    });
    let hop = HopSettings {
        window: frame.window,
        length: cfg.hop.length * (t1 - t0),
        render: cfg.hop.render,
        law: cfg.hop.law,
    };
    let mut model = Model::new(
        canonical,
        field,
        cfg.dynamics.motion,
        waypoints,
        cfg.dynamics.method,
        frame.max_step,
        frame.anchor_times,
    );
    model.waypoint_field = waypoint_field;
    model.hop = hop;
    model
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_velocity_motion_can_drop_the_time_input() {
        let canonical = Splats::<f32>::new(0);
        let mut cfg = TrainConfig::fast();
        cfg.dynamics.time_mapping = TimeCoordinate::Autonomous;
        let velocity = ModelFrame::for_training(&cfg, &canonical, (0.0, 0.75));
        assert_eq!(
            velocity.time,
            TimeMapping::Autonomous,
            "velocity: autonomous"
        );
        cfg.dynamics.motion = Motion::Deformation;
        let deformation = ModelFrame::for_training(&cfg, &canonical, (0.0, 0.75));
        assert_eq!(
            deformation.time,
            TimeMapping::Normalized {
                t_min: 0.0,
                t_max: 0.75
            },
            "deformation reads time"
        );
    }
}
