//! One benchmark configuration as a training run in miniature: a [`Model`] built the way
//! training builds one (canonical Gaussians, the neural field over their bounding box, one
//! anchor at t = 0, RK4 with steps of 1/8), one supervised view at t = 0.45, the Adam
//! optimiser and the step's buffers; [`BenchRun::step`] is one training iteration through
//! the trainer's own calls ([`batch_loss_and_grad`], the finiteness checks, the densification
//! statistics, [`Optimizer::step`]) with the time of each phase.

use super::report::Phases;
use super::scene::{BenchScene, SH_DEGREE};
use evogs::config::TrainConfig;
use evogs::field::regularize::PlaneRegWeights;
use evogs::field::{FieldProfile, FieldTimes, NeuralField, TimeMapping};
use evogs::model::{Model, ModelGrad, Motion, Waypoints};
use evogs::train::densify::DensifyStats;
use evogs::train::optim::{LearningRates, Optimizer};
use evogs::train::step::{
    StepSettings, StepWorkspace, ViewData, accumulate_screen_stats, batch_loss_and_grad,
    render_options,
};
use evogs_math::Par;
use evogs_ode::Method;
use evogs_splat::RenderOptions;
use std::sync::Arc;
use std::time::Instant;

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
    model: Model<f32>,
    view: ViewData<f32>,
    optim: Optimizer,
    cfg: TrainConfig,
    ws: StepWorkspace<f32>,
    grad: ModelGrad<f32>,
    settings: StepSettings,
    opts: RenderOptions<f32>,
    stats: DensifyStats,
    profile: Arc<FieldProfile>,
    iteration: u64,
}

impl BenchRun {
    /// The model of `scene` with the field, optimiser settings and loss weight of `cfg`
    /// (the `paper` or `fast` preset), moving by `motion` (velocity or deformation), with
    /// the dynamics on; the loss is `(1 − λ)·L1 + λ·D-SSIM` with the preset's λ (the
    /// regularisers run with zero weights, as a step always runs them).
    #[must_use]
    pub fn new(scene: &BenchScene, cfg: TrainConfig, motion: Motion) -> Self {
        let means = &scene.splats.means;
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in means {
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
        let time = TimeMapping::Normalized {
            t_min: 0.0,
            t_max: 1.0,
        };
        let mut field = NeuralField::new(&cfg.field, lo, hi, time, cfg.seed ^ 0x5eed);
        let profile = Arc::new(FieldProfile::default());
        field.set_par(Par::best());
        field.set_profile(Some(Arc::clone(&profile)));
        let mut model = Model::new(
            scene.splats.clone(),
            field,
            motion,
            Waypoints::Off,
            Method::Rk4,
            MAX_STEP,
            vec![0.0],
        );
        model.dynamics_active = true;
        // As training does: the Gaussians in spatial order.
        model.sort_spatially();
        let optim = Optimizer::new(&model);
        let grad = model.zero_grad();
        let n = model.len();
        let settings = StepSettings {
            lambda_ssim: cfg.loss.lambda_ssim,
            plane_reg: PlaneRegWeights {
                plane_tv: 0.0,
                time_smoothness: 0.0,
                l1_time: 0.0,
            },
            lambda_coherence: 0.0,
            lambda_anchor: 0.0,
            anchor_segment: None,
            coherence_points: Vec::new(),
        };
        let opts = render_options(cfg.data.background, SH_DEGREE, Par::best());
        Self {
            model,
            view: ViewData {
                camera: scene.camera,
                time: VIEW_TIME,
                image: Arc::new(scene.target.clone()),
            },
            optim,
            cfg,
            ws: StepWorkspace::default(),
            grad,
            settings,
            opts,
            stats: DensifyStats::new(n),
            profile,
            iteration: 0,
        }
    }

    /// The number of field parameters.
    #[must_use]
    pub fn field_params(&self) -> usize {
        self.model.field.params().len()
    }

    /// The MLP's floating-point operations in matrix products for `field`'s rows.
    #[must_use]
    pub fn gemm_flops(&self, field: &FieldTimes) -> u64 {
        self.model
            .field
            .mlp()
            .gemm_flops(field.forward_rows, field.backward_rows)
    }

    /// One training iteration, as the trainer runs it after the warm-up: zero the gradient,
    /// loss and gradient of the view, refuse non-finite values, accumulate the
    /// densification statistics, one Adam step.
    ///
    /// # Errors
    /// A non-finite loss or gradient.
    pub fn step(&mut self) -> Result<IterationSample, String> {
        self.profile.take();
        let start = Instant::now();
        self.iteration += 1;
        self.grad.fill_zero();
        let (losses, stats) = batch_loss_and_grad(
            &mut self.model,
            &[&self.view],
            &self.opts,
            &self.settings,
            &mut self.ws,
            &mut self.grad,
        );
        if !losses.total.is_finite() || !self.grad.is_finite() {
            return Err(format!(
                "non-finite loss or gradient at iteration {}",
                self.iteration
            ));
        }
        accumulate_screen_stats(
            &stats,
            &mut self.stats.accum,
            &mut self.stats.count,
            &mut self.stats.max_radius,
        );
        let lr = LearningRates::at(&self.cfg.optim, EXTENT, self.iteration, 0);
        let optimizer_start = Instant::now();
        self.optim.step(&mut self.model, &self.grad, &lr);
        let optimizer = optimizer_start.elapsed().as_secs_f64();
        let seconds = start.elapsed().as_secs_f64();
        let field = self.profile.take();
        let t = &losses.timings;
        let mut phases = Phases {
            field_forward: field.forward,
            field_vjp: field.vjp,
            projection: t.phases.projection,
            raster_forward: t.phases.raster_forward,
            raster_backward: t.phases.raster_backward,
            loss: t.loss,
            regularizers: t.extra,
            optimizer,
            other: 0.0,
        };
        phases.other = seconds - phases.named_sum();
        Ok(IterationSample {
            seconds,
            phases,
            field,
            loss: losses.total,
        })
    }
}
