//! The sections of [`TrainConfig`](super::TrainConfig): data, initial Gaussians, dynamics,
//! losses, optimiser, densification and schedule (the field's own is beside its code).

use crate::data::DataFormat;
use crate::model::{HopLaw, HopRender, Motion, Waypoints};
use evogs_ode::Method;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Data loading and the training protocol.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataConfig {
    /// Background colour the RGBA frames are composited onto and renders end on (a
    /// multi-view capture's opaque frames carry their own background).
    pub background: [f32; 3],
    /// Integer downscale factor of the images.
    pub downscale: usize,
    /// `full`, `sparse` (every `stride`-th distinct training time), `future` (train on
    /// `t ≤ split_time`) or `backward` (train on `t ≥ split_time`).
    pub protocol: Protocol,
    /// Stride of the sparse protocol.
    pub stride: usize,
    /// Split time of the future and backward protocols.
    pub split_time: f64,
    /// Dataset layout: `auto` (recognised from the folder), `dnerf` or `n3dv`.
    pub format: DataFormat,
    /// Memory budget of decoded frames, in MiB: a dataset whose decoded images fit is decoded
    /// when loaded; a larger one is decoded as training reaches its frames, through a cache
    /// of this size (the least recently used frames leave first).
    pub cache_mb: usize,
    /// Multi-view: the cameras held out as the test split (N3DV: `cam00`).
    pub test_cameras: Vec<String>,
    /// Multi-view: the cameras held out as the validation split.
    pub val_cameras: Vec<String>,
    /// Multi-view: a file of frame times (one per frame index), relative to the dataset
    /// folder. Unset: the folder's `times.txt` if present, else frame `k` of `T` at
    /// `k / (T − 1)`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub times_file: Option<PathBuf>,
}

impl DataConfig {
    /// The frame memory budget in bytes (`cache_mb` MiB).
    #[must_use]
    pub fn cache_bytes(&self) -> usize {
        self.cache_mb.saturating_mul(1024 * 1024)
    }
}

/// Which training frames are supervised.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Protocol {
    /// All training frames.
    Full,
    /// Every k-th distinct training time.
    Sparse,
    /// Train on `t ≤ split_time`.
    Future,
    /// Train on `t ≥ split_time`.
    Backward,
}

impl std::str::FromStr for Protocol {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "full" => Ok(Self::Full),
            "sparse" => Ok(Self::Sparse),
            "future" => Ok(Self::Future),
            "backward" => Ok(Self::Backward),
            _ => Err(format!(
                "unknown protocol `{s}` (full, sparse, future, backward)"
            )),
        }
    }
}

/// A named starting configuration.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Preset {
    /// Sized for two CPU cores (the default).
    #[default]
    Fast,
    /// The paper's D-NeRF settings.
    Paper,
}

impl Preset {
    /// The preset's name.
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Fast => "fast",
            Self::Paper => "paper",
        }
    }
}

impl std::fmt::Display for Preset {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for Preset {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "fast" => Ok(Self::Fast),
            "paper" => Ok(Self::Paper),
            _ => Err(format!("unknown preset `{s}` (fast, paper)")),
        }
    }
}

/// The time coordinate the HexPlane sees: the training time range mapped to `[−1, 1]`, or
/// none (the raw time of the released code measured worse, `docs/results.md`; a file that
/// says `time_mapping = "raw"` is refused).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TimeCoordinate {
    /// The training time range mapped to `[−1, 1]`; after the window the field reads the
    /// law of the window's nearest end (border clamping, documented in `docs/method.md`).
    Normalized,
    /// No time input: the field is a function of position alone (an autonomous vector
    /// field), the same law at every time, inside the window and after it.
    Autonomous,
}

/// The ODE method in a configuration file: its name (`rk4`), through `Method`'s `FromStr`
/// and `Display`.
mod method_name {
    use evogs_ode::Method;
    use serde::{Deserialize, Deserializer, Serializer};

    pub(super) fn serialize<S: Serializer>(m: &Method, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(m.name())
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Method, D::Error> {
        let name = String::deserialize(d)?;
        name.parse()
            .map_err(|e| serde::de::Error::custom(format!("`{name}`: {e}")))
    }
}

/// Initial Gaussians.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct InitConfig {
    /// Use the dataset's `points3d.ply` when present (else random points).
    pub use_points: bool,
    /// Number of random points when there is no point cloud.
    pub random_points: usize,
    /// Half-size of the cube of random points.
    pub random_extent: f64,
    /// Storage SH degree (0–3).
    pub sh_degree: usize,
    /// Margin added to each side of the point cloud's bounding box for the HexPlane, as a
    /// fraction of the box size.
    pub aabb_margin: f64,
}

/// Dynamics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DynamicsConfig {
    /// `velocity` (EvoGS), `deformation` (4DGS-style) or `static`.
    pub motion: Motion,
    /// ODE method: euler, midpoint, heun, rk4, rk38.
    #[serde(with = "method_name")]
    pub method: Method,
    /// Largest step as a fraction of the training time range (the last step of a frame is
    /// shortened to land on its time).
    pub step_fraction: f64,
    /// Waypoints: trainable, off or continuous (a waypoint field and hops: `[hop]`).
    pub waypoints: Waypoints,
    /// Number of anchors (start, …, end of the training time range).
    pub anchors: usize,
    /// Time coordinate of the HexPlane: `normalized` (`[t_min, t_max] → [−1, 1]`) or
    /// `autonomous` (no time input: a field of position alone; velocity motion only, the
    /// deformation motion reads `normalized` whatever this says).
    pub time_mapping: TimeCoordinate,
}

/// Loss weights.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LossConfig {
    /// λ of the D-SSIM term: `(1 − λ)·L1 + λ·(1 − SSIM)`.
    pub lambda_ssim: f64,
    /// Spatial-plane smoothness weight.
    pub plane_tv: f64,
    /// Space-time-plane smoothness weight.
    pub time_smoothness: f64,
    /// L1-of-time-planes-toward-1 weight.
    pub l1_time: f64,
    /// Velocity coherence weight.
    pub lambda_coherence: f64,
    /// Gaussians sampled for the coherence loss.
    pub coherence_samples: usize,
    /// Anchor loss weight.
    pub lambda_anchor: f64,
    /// Iterations between anchor-loss evaluations (cycling through the segments).
    pub anchor_every: u64,
}

/// Learning rates (per group) and schedules.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OptimConfig {
    /// Positions: initial rate (× scene extent).
    pub position_lr_init: f64,
    /// Positions: final rate (× scene extent).
    pub position_lr_final: f64,
    /// MLP ("deformation") initial rate (× scene extent).
    pub deformation_lr_init: f64,
    /// MLP final rate (× scene extent).
    pub deformation_lr_final: f64,
    /// HexPlane ("grid") initial rate (× scene extent).
    pub grid_lr_init: f64,
    /// HexPlane final rate (× scene extent).
    pub grid_lr_final: f64,
    /// Steps of the exponential decays (the position and field decays pause during the
    /// temporal curriculum, so they end at `iterations − curriculum_iters`).
    pub lr_max_steps: u64,
    /// SH DC rate (higher coefficients: /20).
    pub feature_lr: f64,
    /// Opacity-logit rate.
    pub opacity_lr: f64,
    /// Log-scale rate.
    pub scaling_lr: f64,
    /// Quaternion rate.
    pub rotation_lr: f64,
}

/// Densification, pruning and opacity reset (3DGS adaptive density control).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DensifyConfig {
    /// First iteration of densification.
    pub from_iter: u64,
    /// End of the densification window (exclusive, as 3DGS: densification, statistics and
    /// opacity resets run while `from_iter ≤ iteration < until_iter`).
    pub until_iter: u64,
    /// Iterations between densifications.
    pub interval: u64,
    /// Threshold on the view-averaged 2D-mean gradient norm (NDC units, as 3DGS).
    pub grad_threshold: f64,
    /// Clone vs split boundary: max scale ≤ `percent_dense` × extent clones.
    pub percent_dense: f64,
    /// Prune Gaussians with opacity below this.
    pub min_opacity: f64,
    /// Prune Gaussians with screen radius above this (pixels; 0 disables).
    pub max_screen_size: f64,
    /// Iterations between opacity resets (0 disables).
    pub opacity_reset_interval: u64,
    /// Upper bound on the number of Gaussians.
    pub max_gaussians: usize,
}

/// Continuous waypoints and hops (`dynamics.waypoints = "continuous"` with velocity motion;
/// ignored otherwise): `docs/method.md` §6.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HopConfig {
    /// Hop length as a fraction of the training time range (k frame spacings of a scene
    /// with F training times over the range: `k/(F − 1)`).
    pub length: f64,
    /// ODE steps per hop (the velocity field's step is `length/steps` everywhere, also
    /// after the window).
    pub steps: usize,
    /// What a frame inside the window renders: `hop` (the end of a hop from the waypoint
    /// state; both fields learn from the image) or `direct` (the waypoint state itself; the
    /// velocity field learns from the teacher loss alone).
    pub render: HopRender,
    /// The law that carries a hop and every frame after the window: `first-order` (the
    /// field is the velocity) or `second-order` (the field is the acceleration; the
    /// Gaussians carry velocities from the waypoint field's finite difference).
    pub law: HopLaw,
    /// Weight of the teacher loss (the velocity field against the waypoint field's
    /// trajectories in 3D, no rendering; 0 disables it).
    pub teacher: f64,
    /// Gaussians sampled per teacher evaluation.
    pub teacher_samples: usize,
    /// Length of a teacher window as a fraction of the training time range (each step
    /// draws its start uniformly inside the supervised window).
    pub teacher_span: f64,
}

/// Iteration counts and periodic tasks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScheduleConfig {
    /// Static warm-up iterations (plain 3DGS) before the dynamics are switched on.
    pub warmup_iters: u64,
    /// Total iterations (warm-up included).
    pub iterations: u64,
    /// Iterations between SH-degree increments.
    pub sh_degree_interval: u64,
    /// Iterations between checkpoints (0: only at the end).
    pub checkpoint_every: u64,
    /// Minutes of training between checkpoints besides `checkpoint_every` (0: none), so a
    /// run killed without warning loses at most this much work.
    pub checkpoint_minutes: f64,
    /// Iterations between log lines.
    pub log_every: u64,
    /// Temporal curriculum, start: the fraction of the training time range, from its start,
    /// whose views the static warm-up sees (1: all of them). A small window keeps moving
    /// objects sharp in the canonical state instead of smearing them along their paths.
    pub warmup_time_window: f64,
    /// Temporal curriculum, growth: dynamic iterations over which the window of supervised
    /// times grows linearly from `warmup_time_window` to the whole range (0: the whole range
    /// as soon as the dynamics start). Each trainable anchor is re-initialised, by integrating
    /// from the anchor before it, when the window reaches its time, so every new stretch of
    /// motion is learnt as a small step from motion already fitted.
    pub curriculum_iters: u64,
    /// Temporal curriculum, focus: while the window grows, the probability that an
    /// iteration supervises a view from the newest twentieth of the time range inside the
    /// window (the motion not yet fitted) instead of the next view of the epoch.
    pub curriculum_focus: f64,
    /// Views per iteration (the released code's batch size): the step's loss is the mean of
    /// their photometric terms, the regularisers are counted once, and each iteration costs
    /// about this many single-view iterations.
    pub views_per_step: u64,
}
