//! The training configuration: one TOML-serialisable struct with documented defaults and two
//! presets, `fast` (the default: sized for 2 CPU cores) and `paper` (the released code's D-NeRF
//! numbers; `docs/method.md` §10).
//!
//! Resolution order: preset → config file (`--config`, any subset of fields) → command-line
//! flags. The resolved configuration is written to `RUN/config.toml`.

use crate::data::DataFormat;
use crate::field::{HexPlaneConfig, NeuralFieldConfig};
use crate::model::{HopLaw, HopRender, Motion, Waypoints};
use serde::{Deserialize, Serialize};

pub mod changes;
mod removed;
mod sections;
pub use changes::{ConfigChange, RESUMABLE_KEYS, changes};
pub use sections::{
    DataConfig, DensifyConfig, DynamicsConfig, HopConfig, InitConfig, LossConfig, OptimConfig,
    Preset, Protocol, ScheduleConfig, TimeCoordinate,
};

/// Everything a training run needs to know.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainConfig {
    /// Preset this configuration started from (`fast` or `paper`).
    pub preset: Preset,
    /// Random seed (initialisation, view order, densification noise).
    pub seed: u64,
    /// Data loading and the training protocol.
    pub data: DataConfig,
    /// Initial Gaussians.
    pub init: InitConfig,
    /// Dynamics.
    pub dynamics: DynamicsConfig,
    /// Continuous waypoints and hops.
    pub hop: HopConfig,
    /// The neural field.
    pub field: NeuralFieldConfig,
    /// Loss weights.
    pub loss: LossConfig,
    /// Learning rates and schedules.
    pub optim: OptimConfig,
    /// Densification, pruning and opacity reset.
    pub densify: DensifyConfig,
    /// Iteration counts and periodic tasks.
    pub schedule: ScheduleConfig,
}

/// Top-level tables of the motion searches, which were removed: stored run configurations
/// may still hold them ([`TrainConfig::from_run_toml`] drops them), a configuration file given
/// to a new run may not ([`TrainConfig::merge_toml`] names them).
/// The largest field memory a configuration may ask for (64 GiB: the paper's field needs
/// 38 MB), checked before anything is allocated.
pub const MAX_FIELD_BYTES: f64 = 64.0 * GIB;

const GIB: f64 = 1024.0 * 1024.0 * 1024.0;

const REMOVED_SECTIONS: [&str; 2] = ["spin_search", "orbit_search"];

impl TrainConfig {
    /// The `fast` preset: sized so the shipped 200×200 scene trains in a few minutes
    /// on two CPU cores: a smaller field (2 × 16 channels at [32, 32, 32, 16], MLP 32 wide),
    /// five anchors with one midpoint step (of at most a quarter of the time range) from the
    /// nearest one to each frame, at most 20 000 Gaussians, 200 static + 2500 dynamic
    /// iterations, no opacity reset, no velocity coherence loss, and a temporal curriculum
    /// (static warm-up on the first 5 % of the time range, window grown over 1500 dynamic
    /// iterations).
    #[must_use]
    pub fn fast() -> Self {
        let mut c = Self::paper();
        c.preset = Preset::Fast;
        c.field = NeuralFieldConfig {
            hexplane: HexPlaneConfig {
                channels: 16,
                resolution: [32, 32, 32, 16],
                multires: vec![1, 2],
            },
            width: 32,
            output_scales: [10.0, 1.0, 1.0],
            zero_init_output: true,
        };
        // Five trainable waypoints, one midpoint step of at most a quarter of the range from
        // the nearest one (every frame lies within an eighth of the range of a waypoint, so one
        // step). Midpoint costs two field evaluations and two VJPs where RK4 costs four: on
        // toys-mini the velocity runs took 0.5-0.6x the time of RK4's at the same held-out
        // PSNR within a seed's noise (full +0.34 dB, sparse:4 -0.22 / -0.08 dB, future:0.75
        // -0.30 / -0.04 dB); Euler (one evaluation, so the field is sampled only at the
        // waypoint times) lost 1.2 dB with full supervision. See docs/results.md.
        c.dynamics.method = evogs_ode::Method::Midpoint;
        // `dynamics.waypoints = "off"` (every frame from the start, steps of half the range)
        // learns more of the motion and generalises better between the training times
        // (toys-mini sparse:4 +0.4/+0.7 dB, the sliding patch of `tests/suite/motion_learning.rs`
        // +5.1 dB) but fits the training times worse (toys-mini full −2.1 dB) and diverged on
        // toys sparse:4: see docs/results.md.
        c.dynamics.anchors = 5;
        c.dynamics.step_fraction = 0.25;
        // A short warm-up: the warm-up sees only the few views of its time window, and the
        // longer it fits them the more the canonical scene overfits those views; the moving
        // objects' unseen sides then look wrong in their true pose and the learnt motion stays
        // short of it. 200 warm-up iterations instead of 1500 (and no opacity reset, which
        // would fall in the curriculum) moved the toys cube about twice as far along its true
        // motion at the same test PSNR, in less time (one run each on toys, during development).
        c.schedule.warmup_iters = 200;
        c.schedule.iterations = 2700;
        c.schedule.sh_degree_interval = 500;
        c.schedule.checkpoint_every = 1000;
        c.densify.from_iter = 300;
        c.densify.until_iter = 2200;
        c.densify.interval = 100;
        c.densify.opacity_reset_interval = 0;
        c.densify.max_gaussians = 20_000;
        // Temporal curriculum: warm up on the first 5 % of the time range, grow the window
        // over 1500 dynamic iterations with half of them on its newest stretch (toys-mini:
        // +0.95 dB test PSNR at the same cost, one run each). The position and field decays pause
        // meanwhile, so the position decay runs over the remaining 200 + 1000 iterations.
        c.schedule.warmup_time_window = 0.05;
        c.schedule.curriculum_iters = 1500;
        c.schedule.curriculum_focus = 0.5;
        c.optim.lr_max_steps = 1200;
        // No velocity coherence loss (the released code's λ = 0.01 stays in `paper`): off, the
        // velocity runs on toys-mini scored +0.25 dB (full), +0.06 / +0.03 dB (sparse:4) and
        // +0.49 / −0.01 dB (future:0.75) at the same or lower cost, and the sliding patch of
        // tests/suite/motion_learning.rs +0.4 dB with 4 % more of its travel carried by the field.
        c.loss.lambda_coherence = 0.0;
        c.loss.coherence_samples = 500;
        c
    }

    /// The `paper` preset: the released code's D-NeRF numbers (`docs/method.md` §10; 5000
    /// static + 20000 dynamic iterations, HexPlane 2 × 32 channels at [64, 64, 64, 25], MLP 64
    /// wide, RK4 with steps of 1/8 of the time range, three trainable anchors).
    #[must_use]
    pub fn paper() -> Self {
        Self {
            preset: Preset::Paper,
            seed: 0,
            data: DataConfig {
                background: [1.0; 3],
                downscale: 1,
                protocol: Protocol::Full,
                stride: 2,
                split_time: 0.75,
                format: DataFormat::Auto,
                cache_mb: 2048,
                test_cameras: vec!["cam00".into()],
                val_cameras: Vec::new(),
                times_file: None,
            },
            init: InitConfig {
                use_points: true,
                random_points: 2000,
                random_extent: 1.3,
                sh_degree: 3,
                aabb_margin: 0.2,
            },
            dynamics: DynamicsConfig {
                motion: Motion::Velocity,
                method: evogs_ode::Method::Rk4,
                step_fraction: 0.125,
                waypoints: Waypoints::Trainable,
                anchors: 3,
                time_mapping: TimeCoordinate::Normalized,
            },
            hop: HopConfig {
                length: 0.05,
                steps: 1,
                render: HopRender::Hop,
                law: HopLaw::FirstOrder,
                teacher: 0.0,
                teacher_samples: 500,
                teacher_span: 0.25,
            },
            field: NeuralFieldConfig {
                hexplane: HexPlaneConfig {
                    channels: 32,
                    resolution: [64, 64, 64, 25],
                    multires: vec![1, 2],
                },
                width: 64,
                output_scales: [10.0, 1.0, 1.0],
                zero_init_output: true,
            },
            loss: LossConfig {
                lambda_ssim: 0.2,
                plane_tv: 1e-4,
                time_smoothness: 1e-5,
                l1_time: 1e-4,
                lambda_coherence: 0.01,
                coherence_samples: 1000,
                lambda_anchor: 1.0,
                anchor_every: 10,
            },
            optim: OptimConfig {
                position_lr_init: 1.6e-4,
                position_lr_final: 1.6e-6,
                deformation_lr_init: 1.6e-4,
                deformation_lr_final: 1.6e-6,
                grid_lr_init: 1.6e-3,
                grid_lr_final: 1.6e-5,
                lr_max_steps: 25_000,
                feature_lr: 2.5e-3,
                opacity_lr: 0.05,
                scaling_lr: 5e-3,
                rotation_lr: 1e-3,
            },
            densify: DensifyConfig {
                from_iter: 500,
                until_iter: 15_000,
                interval: 100,
                grad_threshold: 2e-4,
                percent_dense: 0.01,
                min_opacity: 0.005,
                max_screen_size: 0.0,
                opacity_reset_interval: 3000,
                max_gaussians: 360_000,
            },
            schedule: ScheduleConfig {
                warmup_iters: 5000,
                iterations: 25_000,
                sh_degree_interval: 1000,
                checkpoint_every: 5000,
                checkpoint_minutes: 5.0,
                log_every: 50,
                warmup_time_window: 1.0,
                curriculum_iters: 0,
                curriculum_focus: 0.0,
                views_per_step: 1,
            },
        }
    }

    /// A preset's configuration.
    #[must_use]
    pub fn from_preset(preset: Preset) -> Self {
        match preset {
            Preset::Fast => Self::fast(),
            Preset::Paper => Self::paper(),
        }
    }

    /// Overlays a TOML document (any subset of the fields) onto this configuration.
    ///
    /// # Errors
    /// Malformed TOML, unknown keys (a removed motion-search table by its own message) or
    /// wrongly typed values. A key of a removed training technique (`loss.lambda_rigidity`,
    /// `schedule.snapshot_every`, ...) is read only at its off value, and then ignored.
    pub fn merge_toml(&self, text: &str) -> Result<Self, String> {
        let mut over: toml::Value = toml::from_str(text).map_err(|e| toml_error_line(text, &e))?;
        removed::drop_removed_keys(&mut over)?;
        if let Some(name) = REMOVED_SECTIONS.iter().find(|&&k| over.get(k).is_some()) {
            return Err(format!(
                "[{name}]: the motion searches were removed from evogs; delete the table"
            ));
        }
        self.merge_value(over)
    }

    fn merge_value(&self, over: toml::Value) -> Result<Self, String> {
        let mut base = toml::Value::try_from(self).map_err(|e| e.to_string())?;
        merge(&mut base, over);
        let lookup = base.clone();
        serde_path_to_error::deserialize(base).map_err(|e| {
            let path = e.path().to_string();
            let msg = e.inner().message().trim().to_string();
            // A choice (an enum) given as a number or a boolean: the TOML reader says
            // "unit variant, expected string only"; say what is wanted instead.
            let value = path.split('.').try_fold(&lookup, |v, k| v.get(k));
            match value {
                Some(v) if msg.contains("variant") && !v.is_str() => {
                    format!("{path}: expected one of its names in quotes, got {v}")
                }
                _ => format!("{path}: {msg}"),
            }
        })
    }

    /// A stored run configuration (`RUN/config.toml`, a checkpoint's copy). Read over `fast`
    /// with the temporal curriculum off, so runs written before the curriculum existed keep
    /// training as they did when resumed; validated like any other configuration. The tables
    /// of the removed motion searches, which runs written while they existed hold, are
    /// ignored: a search that had run left its result in the model, one still pending does
    /// not run. The keys of removed training techniques are read as by
    /// [`merge_toml`](Self::merge_toml).
    ///
    /// # Errors
    /// As [`merge_toml`](Self::merge_toml) and [`validate`](Self::validate).
    pub fn from_run_toml(text: &str) -> Result<Self, String> {
        let mut base = Self::fast();
        base.schedule.warmup_time_window = 1.0;
        base.schedule.curriculum_iters = 0;
        base.schedule.curriculum_focus = 0.0;
        let mut over: toml::Value = toml::from_str(text).map_err(|e| e.to_string())?;
        if let Some(table) = over.as_table_mut() {
            for name in REMOVED_SECTIONS {
                table.remove(name);
            }
        }
        removed::drop_removed_keys(&mut over)?;
        let cfg = base.merge_value(over)?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// The configuration as TOML.
    #[must_use]
    pub fn to_toml(&self) -> String {
        toml::to_string_pretty(self).unwrap_or_default()
    }

    /// Checks the values for consistency.
    ///
    /// # Errors
    /// A message naming the offending field.
    pub fn validate(&self) -> Result<(), String> {
        let chk = |ok: bool, msg: &str| if ok { Ok(()) } else { Err(msg.to_string()) };
        self.validate_numbers()?;
        chk(
            self.data.downscale >= 1,
            "data.downscale must be at least 1",
        )?;
        chk(self.data.stride >= 1, "data.stride must be at least 1")?;
        chk(
            self.data.cache_mb >= 1,
            "data.cache_mb must be at least 1 (MiB of decoded frames)",
        )?;
        chk(
            self.data.test_cameras.iter().all(|c| !c.is_empty())
                && self.data.val_cameras.iter().all(|c| !c.is_empty()),
            "data.test_cameras and data.val_cameras must name camera folders (cam00, ...)",
        )?;
        chk(self.init.sh_degree <= 3, "init.sh_degree must be 0..=3")?;
        chk(
            self.dynamics.step_fraction > 0.0 && self.dynamics.step_fraction <= 1.0,
            "dynamics.step_fraction must be in (0, 1]",
        )?;
        chk(
            self.dynamics.anchors >= 1,
            "dynamics.anchors must be at least 1",
        )?;
        chk(
            self.hop.length > 0.0 && self.hop.length <= 1.0,
            "hop.length must be in (0, 1] (a fraction of the training time range)",
        )?;
        chk(self.hop.steps >= 1, "hop.steps must be at least 1")?;
        chk(
            self.hop.teacher_span > 0.0 && self.hop.teacher_span <= 1.0,
            "hop.teacher_span must be in (0, 1] (a fraction of the training time range)",
        )?;
        chk(
            self.hop.teacher_samples >= 1,
            "hop.teacher_samples must be at least 1",
        )?;
        chk(
            self.field.hexplane.resolution.iter().all(|&r| r >= 2),
            "field.hexplane.resolution entries must be at least 2",
        )?;
        chk(
            !self.field.hexplane.multires.is_empty(),
            "field.hexplane.multires must list at least one level",
        )?;
        chk(
            self.field.hexplane.channels > 0,
            "field.hexplane.channels must be at least 1",
        )?;
        chk(self.field.width > 0, "field.width must be at least 1")?;
        chk(
            self.field.hexplane.multires.iter().all(|&m| m >= 1),
            "field.hexplane.multires entries must be at least 1 (spatial resolution multipliers)",
        )?;
        self.check_field_memory()?;
        self.check_gaussian_memory()?;
        chk(
            self.loss.lambda_coherence == 0.0 || self.loss.coherence_samples >= 2,
            "loss.coherence_samples must be at least 2 when loss.lambda_coherence is not 0 \
             (the coherence loss compares pairs of sampled Gaussians; set the weight to 0 to \
             switch it off)",
        )?;
        chk(
            self.schedule.warmup_iters <= self.schedule.iterations,
            "schedule.warmup_iters must not exceed schedule.iterations",
        )?;
        chk(
            self.schedule.warmup_time_window > 0.0 && self.schedule.warmup_time_window <= 1.0,
            "schedule.warmup_time_window must be in (0, 1]",
        )?;
        chk(
            self.schedule.curriculum_iters
                <= self.schedule.iterations
                    - self.schedule.warmup_iters.min(self.schedule.iterations),
            "schedule.curriculum_iters must not exceed the dynamic iterations (iterations − \
             warmup_iters), or the latest times would never be supervised",
        )?;
        chk(
            (0.0..=1.0).contains(&self.schedule.curriculum_focus),
            "schedule.curriculum_focus must be in [0, 1]",
        )?;
        chk(
            (1..=64).contains(&self.schedule.views_per_step),
            "schedule.views_per_step must be between 1 and 64",
        )?;
        chk(
            self.schedule.log_every > 0 && self.densify.interval > 0,
            "log_every and densify.interval must be positive",
        )?;
        chk(
            (0.0..=1.0).contains(&self.loss.lambda_ssim),
            "loss.lambda_ssim must be in [0, 1]",
        )
    }

    /// The field's memory, estimated from its shape before anything is allocated: the
    /// HexPlane's values and the MLP's weights (a second copy with continuous waypoints),
    /// each held four times in f32 (parameters, gradient, Adam's two moments). Refused above
    /// [`MAX_FIELD_BYTES`], with the estimate.
    fn check_field_memory(&self) -> Result<(), String> {
        let f = &self.field;
        let levels = f.hexplane.multires.len();
        let planes = f.hexplane.param_count();
        let mlp = (|| {
            let w = f.width;
            let input = f.hexplane.channels.checked_mul(levels)?;
            let trunk = w.checked_mul(input.checked_add(1)?)?;
            let heads = w.checked_mul(w.checked_add(1)?)?.checked_mul(3)?;
            trunk.checked_add(heads)?.checked_add(w.checked_mul(12)?)
        })();
        let copies = if self.dynamics.waypoints == Waypoints::Continuous {
            2.0
        } else {
            1.0
        };
        let bytes = match (planes, mlp) {
            (Some(p), Some(m)) => copies * 16.0 * (p as f64 + m as f64),
            _ => f64::INFINITY,
        };
        if bytes <= MAX_FIELD_BYTES {
            return Ok(());
        }
        let shape = format!(
            "field.width = {}, field.hexplane.channels = {}, resolution = {:?}, multires = {:?}",
            f.width, f.hexplane.channels, f.hexplane.resolution, f.hexplane.multires
        );
        Err(if bytes.is_finite() {
            format!(
                "{shape}: the field would need about {:.1} GiB (parameters, gradient and Adam's \
                 moments in f32), more than the {:.0} GiB evogs accepts; lower the resolution, \
                 channels or width",
                bytes / GIB,
                MAX_FIELD_BYTES / GIB
            )
        } else {
            format!(
                "{shape}: the field's size does not fit in memory at all; lower the resolution, channels or width"
            )
        })
    }

    /// The Gaussians' memory, estimated before anything is allocated: at most
    /// `max(init.random_points, densify.max_gaussians)` Gaussians, each with its position,
    /// scale, rotation, opacity and SH colour and a state per anchor, held four times in f32
    /// (parameters, gradient, Adam's two moments). Refused above [`MAX_FIELD_BYTES`] (the same
    /// bound as the field's), with the estimate.
    fn check_gaussian_memory(&self) -> Result<(), String> {
        let n = self.init.random_points.max(self.densify.max_gaussians) as f64;
        let sh = (self.init.sh_degree.saturating_add(1) as f64).powi(2);
        let per = 16.0 * (11.0 + 3.0 * sh + 10.0 * self.dynamics.anchors as f64);
        let bytes = n * per;
        if bytes <= MAX_FIELD_BYTES {
            return Ok(());
        }
        Err(format!(
            "init.random_points = {}, densify.max_gaussians = {}, dynamics.anchors = {}: up to \
             {n:.0} Gaussians would need about {:.1} GiB (parameters, gradient and Adam's \
             moments in f32), more than the {:.0} GiB evogs accepts; lower the counts",
            self.init.random_points,
            self.densify.max_gaussians,
            self.dynamics.anchors,
            bytes / GIB,
            MAX_FIELD_BYTES / GIB
        ))
    }

    /// Every real-valued setting is finite and in its range: rates and loss weights are
    /// non-negative, probabilities and colours lie in [0, 1], sizes are positive.
    fn validate_numbers(&self) -> Result<(), String> {
        let nonneg = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be a finite number >= 0 (got {v})"))
            }
        };
        let positive = |name: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be a finite number > 0 (got {v})"))
            }
        };
        for (i, &c) in self.data.background.iter().enumerate() {
            if !(0.0..=1.0).contains(&c) {
                return Err(format!("data.background[{i}] must lie in [0, 1] (got {c})"));
            }
        }
        if matches!(self.data.protocol, Protocol::Future | Protocol::Backward)
            && !(self.data.split_time > 0.0 && self.data.split_time < 1.0)
        {
            return Err(format!(
                "data.split_time must lie in (0, 1) for the {} protocol (got {}): training \
                 times are in [0, 1]",
                if self.data.protocol == Protocol::Future {
                    "future"
                } else {
                    "backward"
                },
                self.data.split_time
            ));
        }
        nonneg(
            "schedule.checkpoint_minutes",
            self.schedule.checkpoint_minutes,
        )?;
        positive("init.random_extent", self.init.random_extent)?;
        nonneg("init.aabb_margin", self.init.aabb_margin)?;
        if self.init.random_points == 0 {
            return Err(
                "init.random_points must be at least 1 (the initial cloud when the dataset has \
                 no points3d.ply or init.use_points is false)"
                    .into(),
            );
        }
        for (i, &v) in self.field.output_scales.iter().enumerate() {
            positive(&format!("field.output_scales[{i}]"), v)?;
        }
        let l = &self.loss;
        for (name, v) in [
            ("loss.plane_tv", l.plane_tv),
            ("loss.time_smoothness", l.time_smoothness),
            ("loss.l1_time", l.l1_time),
            ("loss.lambda_coherence", l.lambda_coherence),
            ("loss.lambda_anchor", l.lambda_anchor),
            ("hop.teacher", self.hop.teacher),
        ] {
            nonneg(name, v)?;
        }
        let o = &self.optim;
        for (name, v) in [
            ("optim.position_lr_init", o.position_lr_init),
            ("optim.position_lr_final", o.position_lr_final),
            ("optim.deformation_lr_init", o.deformation_lr_init),
            ("optim.deformation_lr_final", o.deformation_lr_final),
            ("optim.grid_lr_init", o.grid_lr_init),
            ("optim.grid_lr_final", o.grid_lr_final),
            ("optim.feature_lr", o.feature_lr),
            ("optim.opacity_lr", o.opacity_lr),
            ("optim.scaling_lr", o.scaling_lr),
            ("optim.rotation_lr", o.rotation_lr),
        ] {
            nonneg(name, v)?;
        }
        let d = &self.densify;
        positive("densify.grad_threshold", d.grad_threshold)?;
        positive("densify.percent_dense", d.percent_dense)?;
        nonneg("densify.max_screen_size", d.max_screen_size)?;
        if !(0.0..1.0).contains(&d.min_opacity) {
            return Err(format!(
                "densify.min_opacity must lie in [0, 1) (got {}): opacities are below 1, so \
                 a threshold of 1 or more prunes every Gaussian",
                d.min_opacity
            ));
        }
        if d.max_gaussians == 0 {
            return Err("densify.max_gaussians must be at least 1".into());
        }
        if self.schedule.iterations == 0 {
            return Err("schedule.iterations must be at least 1".into());
        }
        Ok(())
    }
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self::fast()
    }
}

/// A TOML syntax error as one line: where (line and the line's text) and what.
fn toml_error_line(text: &str, e: &toml::de::Error) -> String {
    let msg = e.message().trim();
    match e.span() {
        Some(span) => {
            let start = span.start.min(text.len());
            let line = text[..start].matches('\n').count() + 1;
            let src = text.lines().nth(line - 1).unwrap_or("").trim();
            format!("line {line} (`{src}`): {msg}")
        }
        None => msg.to_string(),
    }
}

/// Recursively overlays `over` onto `base` (tables merge, other values replace).
fn merge(base: &mut toml::Value, over: toml::Value) {
    match (base, over) {
        (toml::Value::Table(b), toml::Value::Table(o)) => {
            for (k, v) in o {
                match b.get_mut(&k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (slot, v) => *slot = v,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every leaf of `v` (not tables) with its key path.
    fn leaves(v: &toml::Value, path: &mut Vec<String>, out: &mut Vec<(Vec<String>, toml::Value)>) {
        match v {
            toml::Value::Table(t) => {
                for (k, child) in t {
                    path.push(k.clone());
                    leaves(child, path, out);
                    path.pop();
                }
            }
            leaf => out.push((path.clone(), leaf.clone())),
        }
    }

    /// `value` at `path` inside otherwise empty tables.
    fn overlay(path: &[String], value: toml::Value) -> toml::Value {
        path.iter().rev().fold(value, |inner, key| {
            let mut t = toml::map::Map::new();
            t.insert(key.clone(), inner);
            toml::Value::Table(t)
        })
    }

    #[test]
    fn validation_messages_are_one_line_without_double_spaces() {
        use toml::Value as V;
        let base = TrainConfig::fast();
        let mut all = Vec::new();
        leaves(
            &V::try_from(&base).expect("a table"),
            &mut Vec::new(),
            &mut all,
        );
        let mut messages = std::collections::BTreeSet::new();
        for protocol in [Protocol::Full, Protocol::Future] {
            let mut start = base.clone();
            start.data.protocol = protocol;
            for (path, leaf) in &all {
                let candidates: Vec<V> = match leaf {
                    V::Integer(_) => [0, 1, 65, 1 << 40].map(V::Integer).to_vec(),
                    V::Float(_) => [-1.0, 0.0, 1.0, 2.0, 1e12, f64::NAN].map(V::Float).to_vec(),
                    V::Array(_) => vec![
                        V::Array(Vec::new()),
                        V::Array(vec![V::Integer(0)]),
                        V::Array(vec![V::Float(-1.0); 3]),
                        V::Array(vec![V::String(String::new())]),
                    ],
                    _ => Vec::new(),
                };
                for c in candidates {
                    if let Ok(cfg) = start.merge_value(overlay(path, c))
                        && let Err(e) = cfg.validate()
                    {
                        messages.insert(e);
                    }
                }
            }
        }
        assert!(messages.len() >= 20, "few checks reached: {messages:?}");
        for key in [
            "data.split_time",
            "init.random_points",
            "densify.min_opacity",
            "loss.lambda_coherence",
            "schedule.curriculum_iters",
        ] {
            assert!(
                messages.iter().any(|m| m.starts_with(key)),
                "no message for {key}: {messages:?}"
            );
        }
        for m in &messages {
            assert!(!m.contains("  ") && !m.contains('\n'), "`{m}`");
        }
    }

    #[test]
    fn fields_too_large_to_allocate_are_refused_with_an_estimate_before_any_allocation() {
        let c = TrainConfig::fast();
        for (overlay, says) in [
            ("[field]\nwidth = 1000000000\n", "GiB"),
            ("[field]\nwidth = 10000000000\n", "does not fit in memory"),
            ("[field]\nwidth = 100000\n", "GiB"),
            (
                "[field.hexplane]\nresolution = [100000, 100000, 100000, 16]\n",
                "GiB",
            ),
            ("[field.hexplane]\nmultires = [0]\n", "at least 1"),
            (
                "[field.hexplane]\nmultires = [1, 9223372036854775807]\n",
                "does not fit",
            ),
        ] {
            let cfg = c.merge_toml(overlay).expect("reads");
            let e = cfg.validate().expect_err(overlay);
            assert!(e.contains(says), "{overlay}: {e}");
        }
        let e = c
            .merge_toml("[field]\nwidth = 100000\n")
            .expect("reads")
            .validate()
            .expect_err("too wide");
        assert!(
            e.contains("field.width = 100000") && e.contains("more than the 64 GiB"),
            "{e}"
        );
        assert!(
            TrainConfig::paper().validate().is_ok(),
            "the paper's field fits"
        );
        let e = c
            .merge_toml("[loss]\nlambda_coherence = 0.01\ncoherence_samples = 0\n")
            .expect("reads")
            .validate()
            .expect_err("coherence on with no samples");
        assert!(e.contains("loss.coherence_samples"), "{e}");
        c.merge_toml("[loss]\nlambda_coherence = 0.0\ncoherence_samples = 0\n")
            .expect("reads")
            .validate()
            .expect("coherence off");
    }

    #[test]
    fn toml_round_trip_and_partial_overlay() {
        let c = TrainConfig::fast();
        assert_eq!(
            c.merge_toml(&c.to_toml()).expect("round trip"),
            c,
            "identity overlay"
        );
        let d = c
            .merge_toml("seed = 9\n[dynamics]\nmethod = \"euler\"\n")
            .expect("overlay");
        assert_eq!(
            (d.seed, d.dynamics.method),
            (9, evogs_ode::Method::Euler),
            "overlaid fields"
        );
        assert_eq!(d.loss, c.loss, "other fields kept");
        let e = c
            .merge_toml("[dynamics]\nmethd = \"rk4\"\n")
            .expect_err("unknown key");
        assert!(e.contains("methd"), "error names the key: {e}");
        assert!(
            TrainConfig::paper().validate().is_ok() && c.validate().is_ok(),
            "presets are valid"
        );
        let e = c
            .merge_toml("[dynamics]\nmethod = \"rk5\"\n")
            .expect_err("unknown method rejected");
        assert!(e.contains("dynamics.method") && e.contains("rk5"), "{e}");
        let e = c
            .merge_toml("[dynamics]\ntime_mapping = \"warped\"\n")
            .expect_err("unknown time mapping rejected");
        assert!(
            e.contains("dynamics.time_mapping") && e.contains("warped"),
            "{e}"
        );
        let e = c
            .merge_toml("[dynamics]\ntime_mapping = \"raw\"\n")
            .expect_err("the raw time mapping was removed");
        assert!(
            e.contains("dynamics.time_mapping") && e.contains("raw"),
            "{e}"
        );
        let old = c
            .merge_toml("[dynamics]\ntime_mapping = \"normalized\"\n[field]\ntwist = false\n")
            .expect("a configuration written before the twist key was removed loads");
        assert_eq!(old, c, "and means the same");
        let e = c
            .merge_toml("[field]\ntwist = true\n")
            .expect_err("the twist velocity was removed");
        assert!(e.contains("twist"), "{e}");
        let long = c
            .merge_toml("[schedule]\ncurriculum_iters = 2501\n")
            .expect("parses");
        assert!(
            long.validate().is_err(),
            "a curriculum longer than the dynamic stage is rejected"
        );
        for bad in [0, 65] {
            let c = c
                .merge_toml(&format!("[schedule]\nviews_per_step = {bad}\n"))
                .expect("parses");
            assert!(c.validate().is_err(), "views_per_step = {bad} rejected");
        }
    }

    #[test]
    fn every_key_with_a_bad_value_gets_one_plain_line_naming_it() {
        let fast = TrainConfig::fast();
        // Every leaf key as (table path, key), nested tables included.
        fn leaves(path: &str, v: &toml::Value, out: &mut Vec<(Option<String>, String)>) {
            for (k, x) in v.as_table().expect("table") {
                if x.is_table() {
                    let sub = if path.is_empty() {
                        k.clone()
                    } else {
                        format!("{path}.{k}")
                    };
                    leaves(&sub, x, out);
                } else {
                    out.push(((!path.is_empty()).then(|| path.to_string()), k.clone()));
                }
            }
        }
        let mut keys = Vec::new();
        leaves("", &toml::Value::try_from(&fast).expect("toml"), &mut keys);
        assert!(keys.len() > 60, "{} keys", keys.len());
        // An unknown key is refused in every table.
        let mut tables: Vec<Option<String>> = keys.iter().map(|(t, _)| t.clone()).collect();
        tables.dedup();
        for t in tables {
            let text = match &t {
                Some(t) => format!("[{t}]\nno_such_key = 1\n"),
                None => "no_such_key = 1\n".to_string(),
            };
            let e = fast.merge_toml(&text).expect_err(&text);
            assert!(e.contains("no_such_key"), "{text}: {e}");
        }
        let mut checked = 0;
        for (section, key) in &keys {
            for bad in [
                "\"x\"",
                "-1",
                "1e300",
                "nan",
                "[]",
                "{}",
                "true",
                "99999999999999",
            ] {
                let text = match section {
                    Some(s) => format!("[{s}]\n{key} = {bad}\n"),
                    None => format!("{key} = {bad}\n"),
                };
                let Err(e) = fast
                    .merge_toml(&text)
                    .and_then(|c| c.validate().map(|()| c))
                else {
                    continue;
                };
                checked += 1;
                assert!(!e.contains('\n') && !e.contains("   "), "{text}: {e:?}");
                assert!(!e.contains("unit variant"), "{text}: {e}");
            }
        }
        assert!(checked > 300, "{checked} errors checked");
    }

    #[test]
    fn a_choice_given_as_a_number_or_a_boolean_is_named() {
        for (overlay, want) in [
            (
                "[dynamics]\nmotion = 3",
                "dynamics.motion: expected one of its names in quotes, got 3",
            ),
            (
                "[data]\nprotocol = true",
                "data.protocol: expected one of its names in quotes, got true",
            ),
            (
                "[data]\nformat = 1.5",
                "data.format: expected one of its names in quotes, got 1.5",
            ),
        ] {
            let e = TrainConfig::fast().merge_toml(overlay).expect_err(overlay);
            assert_eq!(e, want);
        }
    }

    #[test]
    fn non_finite_negative_and_out_of_range_values_are_rejected_by_name() {
        let c = TrainConfig::fast();
        for (overlay, field) in [
            ("[optim]\nposition_lr_init = nan", "optim.position_lr_init"),
            ("[optim]\nfeature_lr = nan", "optim.feature_lr"),
            ("[optim]\nopacity_lr = inf", "optim.opacity_lr"),
            ("[optim]\nscaling_lr = -0.001", "optim.scaling_lr"),
            ("[optim]\ngrid_lr_final = -inf", "optim.grid_lr_final"),
            ("[loss]\nlambda_coherence = nan", "loss.lambda_coherence"),
            ("[loss]\nplane_tv = -1.0", "loss.plane_tv"),
            ("[init]\nrandom_extent = -1.0", "init.random_extent"),
            ("[init]\nrandom_points = 0", "init.random_points"),
            ("[init]\naabb_margin = nan", "init.aabb_margin"),
            ("[densify]\ngrad_threshold = -1.0", "densify.grad_threshold"),
            ("[densify]\nmin_opacity = 1.5", "densify.min_opacity"),
            ("[densify]\nmin_opacity = nan", "densify.min_opacity"),
            ("[densify]\nmax_gaussians = 0", "densify.max_gaussians"),
            ("[init]\nrandom_points = 99999999999", "init.random_points"),
            ("[densify]\nmax_gaussians = 99999999999999", "GiB"),
            ("[dynamics]\nanchors = 100000", "dynamics.anchors = 100000"),
            ("[data]\nbackground = [1.0, nan, 1.0]", "data.background[1]"),
            ("[data]\nbackground = [1.0, 1.0, 2.0]", "data.background[2]"),
            (
                "[data]\nprotocol = \"future\"\nsplit_time = 2.0",
                "data.split_time",
            ),
            (
                "[data]\nprotocol = \"backward\"\nsplit_time = 0.0",
                "data.split_time",
            ),
            (
                "[field]\noutput_scales = [10.0, nan, 1.0]",
                "field.output_scales[1]",
            ),
            ("[dynamics]\nstep_fraction = nan", "dynamics.step_fraction"),
            (
                "[schedule]\niterations = 0\nwarmup_iters = 0\ncurriculum_iters = 0",
                "schedule.iterations",
            ),
        ] {
            let bad = c
                .merge_toml(overlay)
                .unwrap_or_else(|e| panic!("`{overlay}` parses: {e}"));
            let e = bad.validate().expect_err(overlay);
            assert!(e.contains(field), "`{overlay}`: {e}");
            // A stored run configuration goes through the same check.
            let e = TrainConfig::from_run_toml(&bad.to_toml()).expect_err(overlay);
            assert!(e.contains(field), "`{overlay}` as a run's config.toml: {e}");
        }
        let ok = c
            .merge_toml("[data]\nprotocol = \"full\"\nsplit_time = 2.0")
            .expect("parses");
        assert!(
            ok.validate().is_ok(),
            "split_time is read only by future/backward"
        );
    }

    #[test]
    fn run_configs_without_curriculum_fields_read_with_it_off() {
        let mut text: toml::Value = toml::from_str(&TrainConfig::fast().to_toml()).expect("toml");
        let sched = text
            .get_mut("schedule")
            .and_then(toml::Value::as_table_mut)
            .expect("schedule table");
        for k in ["warmup_time_window", "curriculum_iters", "curriculum_focus"] {
            assert!(sched.remove(k).is_some(), "fast writes {k}");
        }
        let old =
            TrainConfig::from_run_toml(&toml::to_string(&text).expect("toml")).expect("reads");
        assert!(
            old.schedule.curriculum_iters == 0
                && old.schedule.curriculum_focus.to_bits() == 0.0f64.to_bits()
                && old.schedule.warmup_time_window.to_bits() == 1.0f64.to_bits(),
            "curriculum off for an old run"
        );
        let now = TrainConfig::fast();
        assert_eq!(
            TrainConfig::from_run_toml(&now.to_toml()).expect("reads"),
            now,
            "a current run's configuration round-trips"
        );
    }

    #[test]
    fn removed_search_tables_are_ignored_in_runs_and_named_in_config_files() {
        let now = TrainConfig::fast();
        for name in REMOVED_SECTIONS {
            let text = format!("{}\n[{name}]\nat_iter = 400\nlink = 0.06\n", now.to_toml());
            let old = TrainConfig::from_run_toml(&text).expect("an old run reads");
            assert_eq!(old, now, "[{name}] ignored in a stored run");
            let e = now.merge_toml(&text).expect_err("a config file with it");
            assert!(
                e.contains(&format!("[{name}]")) && e.contains("removed"),
                "the error names [{name}]: {e}"
            );
        }
    }

    #[test]
    fn removed_training_keys_at_their_off_values_still_read() {
        let now = TrainConfig::fast();
        let mut text: toml::Value = toml::from_str(&now.to_toml()).expect("toml");
        let loss = text
            .get_mut("loss")
            .and_then(toml::Value::as_table_mut)
            .expect("loss table");
        loss.insert("lambda_rigidity".into(), toml::Value::Float(0.0));
        loss.insert("lambda_rotation".into(), toml::Value::Float(0.0));
        loss.insert("lambda_isometry".into(), toml::Value::Float(0.0));
        loss.insert("rigidity_samples".into(), toml::Value::Integer(512));
        loss.insert("coherence_local".into(), toml::Value::Boolean(false));
        let sched = text
            .get_mut("schedule")
            .and_then(toml::Value::as_table_mut)
            .expect("schedule table");
        sched.insert("snapshot_every".into(), toml::Value::Integer(500));
        let old = toml::to_string(&text).expect("toml");
        assert_eq!(
            TrainConfig::from_run_toml(&old).expect("an older run reads"),
            now,
            "the removed keys ignored in a stored run"
        );
        assert_eq!(
            now.merge_toml(&old).expect("a config file reads"),
            now,
            "and in a config file"
        );
        let on = old.replace("lambda_rigidity = 0.0", "lambda_rigidity = 0.3");
        let e = now.merge_toml(&on).expect_err("the prior switched on");
        assert!(
            e.contains("loss.lambda_rigidity") && e.contains("removed"),
            "{e}"
        );
    }
}
