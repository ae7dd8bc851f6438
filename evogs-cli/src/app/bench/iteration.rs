//! One benchmark configuration as a training run in miniature: a [`Trainer`] on a model
//! built as training builds one ([`build_model`]: canonical Gaussians, the neural field over
//! their bounding box, one anchor at t = 0, RK4 with steps of 1/8) with one supervised view
//! at t = 0.45, the dynamics on from the first iteration, no regularisers (their weights are
//! zero, so a step skips them, as the PyTorch peer runs without them) and no densification; [`BenchRun::step`] is one
//! [`Trainer::step`], with the time of each phase.

use super::report::Phases;
use super::scene::BenchScene;
use evogs::config::{TimeCoordinate, TrainConfig};
use evogs::field::{FieldProfile, FieldTimes};
use evogs::model::{ModelFrame, Motion, Waypoints, build_model};
use evogs::train::state::TrainerState;
use evogs::train::step::ViewData;
use evogs::train::trainer::Trainer;
use evogs_math::rng::SplitMix64;
use evogs_ode::Method;
use std::sync::Arc;

/// Time of the supervised view.
pub const VIEW_TIME: f64 = 0.45;
/// Largest ODE step (RK4 from t = 0 to 0.45: three steps of 1/8 and one of 0.075).
pub const MAX_STEP: f64 = 0.125;
/// Scene extent for the learning rates (the rates do not change the cost).
const EXTENT: f64 = 1.0;

/// What one timed iteration measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IterationSample {
    /// Wall-clock seconds of the whole iteration.
    pub seconds: f64,
    /// Its phases.
    pub phases: Phases,
    /// The field's work.
    pub field: FieldTimes,
    /// The loss.
    pub loss: f64,
}

/// A benchmark configuration ready to iterate.
#[derive(Debug)]
pub struct BenchRun {
    trainer: Trainer,
    profile: Arc<FieldProfile>,
}

impl BenchRun {
    /// The model of `scene` with the field, optimiser settings and loss weight of `cfg`
    /// (the `paper` or `fast` preset), moving by `motion` (velocity or deformation), with
    /// the dynamics on; the loss is `(1 − λ)·L1 + λ·D-SSIM` with the preset's λ. The SH
    /// degree grows by one per iteration to the scene's (degree 3 from the third iteration).
    #[must_use]
    pub fn new(scene: &BenchScene, cfg: TrainConfig, motion: Motion) -> Self {
        let mut cfg = cfg;
        cfg.dynamics.motion = motion;
        cfg.dynamics.waypoints = Waypoints::Off;
        cfg.dynamics.method = Method::Rk4;
        cfg.dynamics.anchors = 1;
        cfg.dynamics.step_fraction = MAX_STEP;
        cfg.dynamics.time_mapping = TimeCoordinate::Normalized;
        cfg.schedule.warmup_iters = 0;
        cfg.schedule.curriculum_iters = 0;
        cfg.schedule.curriculum_focus = 0.0;
        cfg.schedule.sh_degree_interval = 1;
        cfg.schedule.views_per_step = 1;
        cfg.schedule.iterations = u64::MAX;
        cfg.densify.from_iter = u64::MAX;
        cfg.densify.until_iter = u64::MAX;
        cfg.densify.opacity_reset_interval = 0;
        cfg.loss.plane_tv = 0.0;
        cfg.loss.time_smoothness = 0.0;
        cfg.loss.l1_time = 0.0;
        cfg.loss.lambda_coherence = 0.0;
        cfg.loss.lambda_anchor = 0.0;
        let range = (0.0, 1.0);
        let frame = ModelFrame::for_training(&cfg, &scene.splats, range);
        let mut model = build_model(&cfg, scene.splats.clone(), frame);
        let profile = Arc::new(FieldProfile::default());
        model.field.set_profile(Some(Arc::clone(&profile)));
        model.dynamics_active = true;
        // As training does: the Gaussians in spatial order.
        model.sort_spatially();
        let state = TrainerState::new(&model, SplitMix64::new(cfg.seed), EXTENT, range);
        let view = ViewData {
            camera: scene.camera,
            time: VIEW_TIME,
            image: Arc::new(scene.target.clone()),
        };
        let trainer = Trainer::from_parts(cfg, model, state, vec![view])
            .unwrap_or_else(|e| unreachable!("one view and a fresh state fit: {e}"));
        Self { trainer, profile }
    }

    /// The number of field parameters.
    #[must_use]
    pub fn field_params(&self) -> usize {
        self.trainer.model().field.params().len()
    }

    /// The MLP's floating-point operations in matrix products for `field`'s rows.
    #[must_use]
    pub fn gemm_flops(&self, field: &FieldTimes) -> u64 {
        self.trainer
            .model()
            .field
            .mlp()
            .gemm_flops(field.forward_rows, field.backward_rows)
    }

    /// One training iteration ([`Trainer::step`]) and the time of its phases.
    ///
    /// # Errors
    /// A non-finite loss or gradient.
    pub fn step(&mut self) -> Result<IterationSample, String> {
        self.profile.take();
        let r = self.trainer.step().map_err(|e| e.to_string())?;
        let field = self.profile.take();
        let t = &r.losses.timings;
        let mut phases = Phases {
            field_forward: field.forward,
            field_vjp: field.vjp,
            projection: t.phases.projection,
            raster_forward: t.phases.raster_forward,
            raster_backward: t.phases.raster_backward,
            loss: t.loss,
            regularizers: t.extra,
            optimizer: r.optimizer_seconds,
            other: 0.0,
        };
        phases.other = r.seconds - phases.named_sum();
        Ok(IterationSample {
            seconds: r.seconds,
            phases,
            field,
            loss: r.losses.total,
        })
    }
}
