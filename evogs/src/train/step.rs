//! One training step's loss and exact gradient, generic over the scalar (f32 to train, f64
//! to check by finite differences):
//!
//! ```text
//! L = (1 − λ)·L1(I, Î) + λ·(1 − SSIM(I, Î))            photometric, I = render(Gaussians(t))
//!   + w_tv·TV + w_t·TimeSmooth + w_l1·L1Time            HexPlane regularisers (dynamics on)
//!   + λ_coh·L_coh(v at sampled Gaussians, t)            velocity coherence (velocity motion)
//!   + λ_anchor·L_anchor(segment k)                      anchor loss (trainable waypoints)
//!   + λ_teacher·L_teacher(window a → b)                 teacher loss (continuous waypoints)
//! ```
//!
//! The gradient flows end to end: pixel cotangents → rasterizer VJP → projection/SH VJP →
//! the Gaussians at t → the discrete adjoint of the ODE (or the displacement VJP) → anchors,
//! canonical Gaussians and every field parameter.

use crate::field::regularize::{PlaneRegWeights, plane_regularizers};
use crate::field::{Batch, BatchVjp, FieldRecord, Gemm};
use crate::model::{HopStart, Model, ModelGrad, Motion, Waypoints};
use crate::train::coherence::{COHERENCE_K, coherence_loss};
use crate::train::render_pass::{RenderTimes, render_backward, render_forward};
use evogs_math::Real;
use evogs_ode::Stepper;
use evogs_splat::loss::photometric_loss_and_grad;
use evogs_splat::ssim::SsimWorkspace;
use evogs_splat::{
    CameraGrad, DensifyStats, Image, PinholeCamera, PixelGrad, RasterInputGrad, Render, RenderGrad,
    RenderOptions, Splats, TiledRasterizer,
};
use std::sync::Arc;

/// One supervised view: camera, time and target image (shared, so a view handed out by a
/// frame cache costs no copy).
#[derive(Clone, Debug)]
pub struct ViewData<T> {
    /// Camera.
    pub camera: PinholeCamera<T>,
    /// Frame time.
    pub time: f64,
    /// Target image.
    pub image: Arc<Image<T>>,
}

/// The loss weights and switches a step needs.
#[derive(Clone, Debug, PartialEq)]
pub struct StepSettings {
    /// λ of `(1 − λ)·L1 + λ·(1 − SSIM)`.
    pub lambda_ssim: f64,
    /// HexPlane regulariser weights.
    pub plane_reg: PlaneRegWeights,
    /// Coherence weight (0 disables).
    pub lambda_coherence: f64,
    /// Anchor-loss weight.
    pub lambda_anchor: f64,
    /// The anchor segment whose loss is added this step, if any.
    pub anchor_segment: Option<usize>,
    /// Positions where the coherence loss queries the velocity: canonical positions of
    /// sampled Gaussians, copied (detached) when sampled (fewer than two: no coherence).
    pub coherence_points: Vec<[f64; 3]>,
    /// The side of the rendered time a hop starts from (continuous waypoints).
    pub hop_start: HopStart,
    /// The teacher loss of this step, if any (continuous waypoints).
    pub teacher: Option<TeacherSample>,
}

/// One evaluation of the teacher loss ([`Model::teacher_loss`]): its window, the sampled
/// Gaussians and the weight.
#[derive(Clone, Debug, PartialEq)]
pub struct TeacherSample {
    /// From the waypoint state at `window.0` to `window.1`.
    pub window: (f64, f64),
    /// The Gaussians it follows.
    pub indices: Vec<usize>,
    /// Its weight.
    pub weight: f64,
}

/// The terms of one step's loss.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepLosses {
    /// The total.
    pub total: f64,
    /// L1 term (unweighted).
    pub l1: f64,
    /// SSIM of the render.
    pub ssim: f64,
    /// Mean squared error of the render (for the training PSNR).
    pub mse: f64,
    /// Weighted plane regularisers.
    pub planes: f64,
    /// Weighted coherence.
    pub coherence: f64,
    /// Weighted anchor loss.
    pub anchor: f64,
    /// Weighted teacher loss (continuous waypoints).
    pub teacher: f64,
    /// Seconds spent in each phase of the step.
    pub timings: StepTimings,
}

/// Wall-clock seconds of the phases of one step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepTimings {
    /// Gaussians at t (ODE integration or displacement).
    pub dynamics: f64,
    /// Render, loss and render VJP (the four entries below and their glue).
    pub render: f64,
    /// Of `render`: projection, rasterization and their VJPs.
    pub phases: RenderTimes,
    /// Of `render`: the photometric loss (L1, SSIM) and its image gradient.
    pub loss: f64,
    /// Back through the dynamics (discrete adjoint or displacement VJP).
    pub adjoint: f64,
    /// Regularisers, coherence and anchor loss.
    pub extra: f64,
    /// Exchanging a batch's shares between processes and summing them
    /// ([`shared_batch_loss_and_grad`](super::batch::shared_batch_loss_and_grad)).
    pub exchange: f64,
}

impl StepTimings {
    /// Adds another view's timings (all entries).
    pub fn add(&mut self, o: &Self) {
        self.dynamics += o.dynamics;
        self.render += o.render;
        self.phases.add(&o.phases);
        self.loss += o.loss;
        self.adjoint += o.adjoint;
        self.extra += o.extra;
        self.exchange += o.exchange;
    }
}

/// Reusable buffers of the step.
#[derive(Debug)]
pub struct StepWorkspace<T: Real> {
    /// The Gaussians at the frame time.
    pub splats_t: Splats<T>,
    /// The ODE stepper (rebuilt when the Gaussian count changes).
    pub stepper: Option<Stepper<T>>,
    /// SSIM buffers.
    pub ssim: SsimWorkspace<T>,
    /// Gradient of the loss with respect to the rendered image.
    pub d_image: Option<Image<T>>,
    /// The tiled rasterizer and its buffers.
    pub rasterizer: TiledRasterizer<T>,
    /// The last render (buffers reused).
    pub render: Option<Render<T>>,
    /// The last render gradient (buffers reused).
    pub render_grad: Option<RenderGrad<T>>,
}

impl<T: Real> Default for StepWorkspace<T> {
    fn default() -> Self {
        Self {
            splats_t: Splats::default(),
            stepper: None,
            ssim: SsimWorkspace::default(),
            d_image: None,
            rasterizer: TiledRasterizer::new(),
            render: None,
            render_grad: None,
        }
    }
}

/// What densification needs from a step: the 2D-mean gradients and screen radii.
#[derive(Clone, Debug, Default)]
pub struct ScreenStats<T> {
    /// `∂L/∂means2d` (pixels) per Gaussian.
    pub grad2d: Vec<[T; 2]>,
    /// `max(r_x, r_y)` per Gaussian (0 if culled).
    pub radius: Vec<u32>,
    /// Image size.
    pub size: (usize, usize),
}

/// Loss and gradient of one step on one view; **adds** the gradient into `grad` (zero it
/// first) and returns the loss terms and the densification statistics: the view's
/// photometric term ([`view_loss_and_grad`], weight 1) plus the regularisers at its time
/// ([`regularizers_and_grad`]). A batch of views is
/// [`batch_loss_and_grad`](super::batch::batch_loss_and_grad).
pub fn loss_and_grad<T: Gemm>(
    model: &mut Model<T>,
    view: &ViewData<T>,
    opts: &RenderOptions<T>,
    s: &StepSettings,
    ws: &mut StepWorkspace<T>,
    grad: &mut ModelGrad<T>,
) -> (StepLosses, ScreenStats<T>) {
    let (l, stats) = view_loss_and_grad(model, view, opts, s, 1.0, ws, grad);
    let mut losses = StepLosses {
        total: l.total,
        l1: l.l1,
        ssim: l.ssim,
        mse: l.mse,
        timings: l.timings,
        ..StepLosses::default()
    };
    regularizers_and_grad(model, view.time, s, ws, grad, &mut losses);
    (losses, stats)
}

/// The photometric term of one view, `weight·((1 − λ)·L1 + λ·(1 − SSIM))` (`weight` = 1/B
/// for the mean over a batch of B views), through the render and the dynamics: **adds** its
/// gradient into `grad` and returns the unweighted L1, SSIM and MSE with the weighted total,
/// and the view's densification statistics.
pub fn view_loss_and_grad<T: Gemm>(
    model: &mut Model<T>,
    view: &ViewData<T>,
    opts: &RenderOptions<T>,
    s: &StepSettings,
    weight: f64,
    ws: &mut StepWorkspace<T>,
    grad: &mut ModelGrad<T>,
) -> (StepLosses, ScreenStats<T>) {
    let clock = std::time::Instant::now();
    let mut timings = StepTimings::default();
    let mut splats_t = core::mem::take(&mut ws.splats_t);
    let tape = model.splats_at_from(view.time, s.hop_start, &mut ws.stepper, &mut splats_t);
    timings.dynamics = clock.elapsed().as_secs_f64();
    let mut fwd = ws.render.take().unwrap_or_else(|| Render {
        pre: evogs_splat::Preprocessed::default(),
        raster: evogs_splat::RasterOutput::new(
            view.camera.width,
            view.camera.height,
            opts.background,
        ),
    });
    let mut phases = RenderTimes::default();
    render_forward(
        &splats_t,
        &view.camera,
        opts,
        &mut ws.rasterizer,
        &mut fwd,
        &mut phases,
    );
    let loss_start = std::time::Instant::now();
    let (w, h) = (view.image.width(), view.image.height());
    let mut d_image = ws
        .d_image
        .take()
        .filter(|d| d.width() == w && d.height() == h)
        .unwrap_or_else(|| Image::new(w, h));
    d_image.data_mut().fill(T::ZERO);
    let photo = photometric_loss_and_grad(
        &mut ws.ssim,
        &fwd.raster.rgb,
        &view.image,
        T::from_f64(s.lambda_ssim),
        T::from_f64(weight),
        &mut d_image,
        opts.par,
    );
    timings.loss = loss_start.elapsed().as_secs_f64();
    let mut g = ws.render_grad.take().unwrap_or_else(|| RenderGrad {
        splats: Splats::default(),
        camera: CameraGrad::zero(),
        raster: RasterInputGrad::default(),
        background: [T::ZERO; 3],
        densify: DensifyStats::default(),
    });
    render_backward(
        &splats_t,
        &view.camera,
        opts,
        &mut ws.rasterizer,
        &fwd,
        &PixelGrad {
            rgb: d_image.data(),
            alpha: None,
            depth: None,
        },
        &mut g,
        &mut phases,
    );
    timings.render = clock.elapsed().as_secs_f64() - timings.dynamics;
    timings.phases = phases;
    let adjoint_start = std::time::Instant::now();
    model.backward_at(&tape, &mut ws.stepper, &g.splats, grad);
    timings.adjoint = adjoint_start.elapsed().as_secs_f64();
    let mut losses = StepLosses {
        l1: photo.l1.to_f64(),
        ssim: photo.ssim.to_f64(),
        mse: photo.mse.to_f64(),
        ..StepLosses::default()
    };
    losses.total = weight * photo.total.to_f64();
    losses.timings = timings;
    let stats = ScreenStats {
        grad2d: g.raster.means2d.iter().map(|v| [v.x, v.y]).collect(),
        radius: fwd.pre.radii.iter().map(|r| r[0].max(r[1])).collect(),
        size: (w, h),
    };
    ws.splats_t = splats_t;
    ws.d_image = Some(d_image);
    ws.render = Some(fwd);
    ws.render_grad = Some(g);
    (losses, stats)
}

/// The regularisers of a step at time `t`: the HexPlane terms (of both fields with
/// continuous waypoints), the velocity coherence, the anchor loss and the teacher loss, as
/// `s` enables them and the model's motion uses them. **Adds** their
/// gradients into `grad`, their values into `losses` (and its total) and their time into
/// `losses.timings.extra`. Counted once per step, however many views it has.
pub fn regularizers_and_grad<T: Gemm>(
    model: &mut Model<T>,
    t: f64,
    s: &StepSettings,
    ws: &mut StepWorkspace<T>,
    grad: &mut ModelGrad<T>,
    losses: &mut StepLosses,
) {
    let clock = std::time::Instant::now();
    let dynamic = model.dynamics_active && model.motion != Motion::Static;
    if dynamic {
        let hex = model.field.hexplane().clone();
        let range = model.field.grid_range();
        let v = plane_regularizers(
            &hex,
            &model.field.params()[range.clone()],
            &s.plane_reg,
            &mut grad.field[range],
            model.field.par(),
        );
        losses.planes = v.total;
        if let Some(wf) = &model.waypoint_field {
            let hex = wf.hexplane().clone();
            let range = wf.grid_range();
            let v = plane_regularizers(
                &hex,
                &wf.params()[range.clone()],
                &s.plane_reg,
                &mut grad.waypoint_field[range],
                wf.par(),
            );
            losses.planes += v.total;
        }
    }
    if dynamic
        && model.motion == Motion::Velocity
        && s.lambda_coherence > 0.0
        && s.coherence_points.len() > 1
    {
        losses.coherence = coherence_term(model, t, s, grad);
    }
    if let (true, Some(k)) = (
        dynamic && model.motion == Motion::Velocity && model.waypoints == Waypoints::Trainable,
        s.anchor_segment,
    ) {
        losses.anchor = model.anchor_loss(k, s.lambda_anchor, &mut ws.stepper, grad);
    }
    if let (true, Some(teacher)) = (dynamic, &s.teacher) {
        losses.teacher = model.teacher_loss(teacher.window, &teacher.indices, teacher.weight, grad);
    }
    losses.total += losses.planes + losses.coherence + losses.anchor + losses.teacher;
    losses.timings.extra += clock.elapsed().as_secs_f64();
}

/// The velocity-coherence term at the sampled (detached) positions, with its gradient into
/// the field parameters.
fn coherence_term<T: Gemm>(
    model: &mut Model<T>,
    t: f64,
    s: &StepSettings,
    grad: &mut ModelGrad<T>,
) -> f64 {
    let m = s.coherence_points.len();
    let pos: Vec<T> = s
        .coherence_points
        .iter()
        .flatten()
        .map(|&v| T::from_f64(v))
        .collect();
    let mut out = vec![T::ZERO; 9 * m];
    let at = Batch {
        t: T::from_f64(t),
        positions: &pos,
        stride: 3,
        n: m,
    };
    let mut record = FieldRecord::default();
    model.field.eval_batch(&at, &mut out, Some(&mut record));
    let v: Vec<[f64; 3]> = out
        .chunks(9)
        .map(|c| [c[0].to_f64(), c[1].to_f64(), c[2].to_f64()])
        .collect();
    let mut d_v = vec![[0.0; 3]; m];
    let l = coherence_loss(&s.coherence_points, &v, COHERENCE_K, &mut d_v);
    let mut d_out = vec![T::ZERO; 9 * m];
    for (i, d) in d_v.iter().enumerate() {
        for a in 0..3 {
            d_out[9 * i + a] = T::from_f64(s.lambda_coherence * d[a]);
        }
    }
    let mut d_pos = vec![T::ZERO; 3 * m];
    model.field.vjp_batch(BatchVjp {
        at,
        record: Some(&record),
        d_out: &d_out,
        d_positions: &mut d_pos,
        d_stride: 3,
        d_params: &mut grad.field,
    });
    s.lambda_coherence * l
}

/// Accumulates a step's screen statistics into the densification accumulators:
/// `accum += |∂L/∂m|` in 3DGS's NDC units (`(g_x·W/2, g_y·H/2)`) and `count += 1` for
/// Gaussians visible in this view, and `max_radius = max(max_radius, radius)`.
pub fn accumulate_screen_stats<T: Real>(
    stats: &ScreenStats<T>,
    accum: &mut [f32],
    count: &mut [u32],
    max_radius: &mut [u32],
) {
    let (sx, sy) = (0.5 * stats.size.0 as f64, 0.5 * stats.size.1 as f64);
    for (i, (g, &r)) in stats.grad2d.iter().zip(&stats.radius).enumerate() {
        if r > 0 {
            let n = (g[0].to_f64() * sx).hypot(g[1].to_f64() * sy);
            #[allow(clippy::cast_possible_truncation, reason = "statistics in f32")]
            {
                accum[i] += n as f32;
            }
            count[i] += 1;
            max_radius[i] = max_radius[i].max(r);
        }
    }
}
