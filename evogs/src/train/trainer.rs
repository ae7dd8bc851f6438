//! The training loop: [`Trainer`].
//!
//! One iteration: pick the next supervised view (a fresh random permutation each epoch),
//! compute the loss and its exact gradient ([`loss_and_grad`](super::step::loss_and_grad)), refuse non-finite values,
//! take an Adam step, then the periodic tasks: SH-degree increments, densification and
//! pruning, opacity resets, snapshot-anchor refreshes. The first `warmup_iters` iterations
//! are static (plain 3DGS); then the dynamics are switched on and the anchors are
//! initialised by integrating the field from the canonical state.

use super::coherence::COHERENCE_K;
use super::densify::{DensifyReport, DensifyStats, densify_and_prune, reset_opacity};
use super::frames::TrainViews;
use super::neighbours::local_clusters;
use super::optim::{LearningRates, Optimizer, StateGroups};
use super::rigidity::{RigidityGraph, RigidityWeights, even_spacing};
use super::step::{
    StepLosses, StepSettings, StepWorkspace, ViewData, accumulate_screen_stats,
    batch_loss_and_grad, render_options,
};
use crate::config::TimeCoordinate;
use crate::config::TrainConfig;
use crate::field::regularize::PlaneRegWeights;
use crate::field::{NeuralField, TimeMapping};
use crate::model::anchors::anchor_times;
use crate::model::init::{gaussians_from_points, random_points};
use crate::model::{Model, ModelGrad, Motion, Waypoints};
use evogs_math::Par;
use evogs_math::rng::SplitMix64;
use std::time::Instant;

/// Slack on time comparisons of the curriculum window (times are read from JSON).
const WINDOW_EPS: f64 = 1e-9;

/// Steps of views whose frames are decoded ahead of use.
const PREFETCH_STEPS: usize = 2;

/// Initial point positions with optional colours.
pub type InitPoints<'a> = (&'a [[f32; 3]], Option<&'a [[f32; 3]]>);

/// Why training stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// A NaN or infinity appeared; nothing of this iteration was applied.
    #[error(
        "non-finite {what} at iteration {iteration}; the model was not updated (the last checkpoint is intact)"
    )]
    NonFinite {
        /// Iteration.
        iteration: u64,
        /// `loss` or `gradient`.
        what: &'static str,
    },
    /// The configuration or the data cannot be used.
    #[error("{0}")]
    Setup(String),
    /// A training frame could not be decoded; nothing of this iteration was applied.
    #[error("iteration {iteration}: {msg}")]
    Frame {
        /// Iteration.
        iteration: u64,
        /// The decode error (names the file).
        msg: String,
    },
}

/// One line of the training log.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LogRow {
    /// Iteration.
    pub iteration: u64,
    /// Training seconds so far.
    pub seconds: f64,
    /// Total loss.
    pub loss: f64,
    /// L1 term.
    pub l1: f64,
    /// PSNR of the training view (dB).
    pub psnr: f64,
    /// SSIM of the training view.
    pub ssim: f64,
    /// Weighted regularisers (planes + coherence + anchor).
    pub regularizers: f64,
    /// Number of Gaussians.
    pub gaussians: usize,
    /// Position learning rate.
    pub lr_position: f64,
}

/// What one iteration did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StepReport {
    /// Iteration number (1-based).
    pub iteration: u64,
    /// Loss terms.
    pub losses: StepLosses,
    /// Densification, if it ran.
    pub densify: Option<DensifyReport>,
    /// Whether the dynamics were switched on at this iteration.
    pub dynamics_started: bool,
    /// Time of the supervised view.
    pub view_time: f64,
}

/// A training run in memory: build it with [`Trainer::new`] (or resume one from a
/// checkpoint), advance it with [`Trainer::step`], read it through the accessors.
#[derive(Debug)]
pub struct Trainer {
    /// The resolved configuration.
    pub(crate) cfg: TrainConfig,
    /// The model.
    pub(crate) model: Model<f32>,
    /// Adam states.
    pub(crate) optim: Optimizer,
    /// Supervised training views (images in memory or behind a bounded frame cache).
    pub(crate) views: TrainViews,
    /// Scene extent (learning-rate scale).
    pub(crate) extent: f64,
    /// Training time range.
    pub(crate) time_range: (f64, f64),
    /// Iterations done.
    pub(crate) iteration: u64,
    /// Seconds spent in iterations.
    pub(crate) train_seconds: f64,
    /// Log rows so far.
    pub(crate) log: Vec<LogRow>,
    /// Densification accumulators.
    pub(crate) stats: DensifyStats,
    /// Random state (view order, coherence samples, split offsets).
    pub(crate) rng: SplitMix64,
    /// Current view permutation and position in it.
    pub(crate) order: Vec<usize>,
    /// Position in `order`.
    pub(crate) order_pos: usize,
    /// Parallelism.
    pub(crate) par: Par,
    ws: StepWorkspace<f32>,
    grad: Option<ModelGrad<f32>>,
}

impl Trainer {
    /// A new run: initial Gaussians from `points` (else random), the field over their
    /// bounding box, the optimiser.
    ///
    /// # Errors
    /// No views, or an invalid configuration.
    pub fn new(
        cfg: TrainConfig,
        views: impl Into<TrainViews>,
        points: Option<InitPoints<'_>>,
    ) -> Result<Self, TrainError> {
        let views = views.into();
        cfg.validate().map_err(TrainError::Setup)?;
        if views.is_empty() {
            return Err(TrainError::Setup(
                "no supervised training views (check the protocol and split time)".into(),
            ));
        }
        let mut rng = SplitMix64::new(cfg.seed);
        let (t0, t1) = views.time_range();
        let t1 = if t1 > t0 { t1 } else { t0 + 1.0 };
        let random;
        let (pts, cols) = match points {
            Some((p, c)) if cfg.init.use_points && !p.is_empty() => (p, c),
            _ => {
                random = random_points(cfg.init.random_points, cfg.init.random_extent, &mut rng);
                (random.as_slice(), None)
            }
        };
        let canonical = gaussians_from_points(pts, cols, cfg.init.sh_degree, &mut rng);
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for p in pts {
            for a in 0..3 {
                lo[a] = lo[a].min(f64::from(p[a]));
                hi[a] = hi[a].max(f64::from(p[a]));
            }
        }
        for a in 0..3 {
            let m = cfg.init.aabb_margin * (hi[a] - lo[a]).max(1e-3);
            lo[a] -= m;
            hi[a] += m;
        }
        let time = match cfg.dynamics.time_mapping {
            TimeCoordinate::Normalized => TimeMapping::Normalized {
                t_min: t0,
                t_max: t1,
            },
        };
        let field = NeuralField::new(&cfg.field, lo, hi, time, cfg.seed ^ 0x5eed);
        let method = cfg.dynamics.method;
        let mut model = Model::new(
            canonical,
            field,
            cfg.dynamics.motion,
            cfg.dynamics.waypoints,
            method,
            cfg.dynamics.step_fraction * (t1 - t0),
            anchor_times(t0, t1, cfg.dynamics.anchors),
        );
        // The field reads consecutive Gaussians together: keep them in spatial order.
        model.sort_spatially();
        let optim = Optimizer::new(&model);
        let n = model.len();
        let extent = views.camera_extent();
        let par = Par::best();
        let mut t = Self {
            cfg,
            model,
            optim,
            views,
            extent,
            time_range: (t0, t1),
            iteration: 0,
            train_seconds: 0.0,
            log: Vec::new(),
            stats: DensifyStats::new(n),
            rng,
            order: Vec::new(),
            order_pos: 0,
            par,
            ws: StepWorkspace::default(),
            grad: None,
        };
        t.model.field.set_par(par);
        if t.model.motion == Motion::Static {
            t.model.dynamics_active = false;
        }
        Ok(t)
    }

    /// The resolved configuration.
    #[must_use]
    pub const fn cfg(&self) -> &TrainConfig {
        &self.cfg
    }

    /// The model.
    #[must_use]
    pub const fn model(&self) -> &Model<f32> {
        &self.model
    }

    /// The model, to evaluate or render with it (rendering caches per-call state in it).
    pub const fn model_mut(&mut self) -> &mut Model<f32> {
        &mut self.model
    }

    /// Iterations done.
    #[must_use]
    pub const fn iteration(&self) -> u64 {
        self.iteration
    }

    /// Seconds spent in iterations.
    #[must_use]
    pub const fn train_seconds(&self) -> f64 {
        self.train_seconds
    }

    /// The log rows so far.
    #[must_use]
    pub fn log(&self) -> &[LogRow] {
        &self.log
    }

    /// The training time range.
    #[must_use]
    pub const fn time_range(&self) -> (f64, f64) {
        self.time_range
    }

    /// The optimiser's state (Adam moments and steps per parameter group).
    #[must_use]
    pub const fn optimizer(&self) -> &Optimizer {
        &self.optim
    }

    /// The densification accumulators.
    #[must_use]
    pub const fn densify_stats(&self) -> &DensifyStats {
        &self.stats
    }

    /// The current permutation of the views (the epoch's order).
    #[must_use]
    pub fn view_order(&self) -> &[usize] {
        &self.order
    }

    /// The state of the random generator (view order, coherence samples, split offsets).
    #[must_use]
    pub const fn rng_state(&self) -> u64 {
        self.rng.state()
    }

    /// The scene extent that scales the position learning rate.
    #[must_use]
    pub const fn extent(&self) -> f64 {
        self.extent
    }

    /// The supervised training views.
    #[must_use]
    pub const fn views(&self) -> &TrainViews {
        &self.views
    }

    /// The parallelism of the iterations.
    #[must_use]
    pub const fn par(&self) -> Par {
        self.par
    }

    /// Sets the parallelism (results are deterministic for a given thread count).
    pub const fn set_par(&mut self, par: Par) {
        self.par = par;
    }

    /// Sets the total iteration count (`--iters` on resume extends a run); the schedules keep
    /// their planned lengths.
    pub const fn set_total_iterations(&mut self, iterations: u64) {
        self.cfg.schedule.iterations = iterations;
    }

    /// Whether all iterations are done.
    #[must_use]
    pub fn finished(&self) -> bool {
        self.iteration >= self.cfg.schedule.iterations
    }

    /// The active SH degree at the current iteration.
    #[must_use]
    pub fn active_sh_degree(&self) -> usize {
        let steps = usize::try_from(self.iteration / self.cfg.schedule.sh_degree_interval.max(1))
            .unwrap_or(usize::MAX);
        steps.min(self.model.canonical.sh_degree)
    }

    /// The latest supervised time at iteration `it` (the temporal curriculum): during the
    /// static warm-up the first `warmup_time_window` of the time range, then a window growing
    /// linearly to the whole range over `curriculum_iters` dynamic iterations. Static motion
    /// always sees every view.
    #[must_use]
    pub fn time_window_end(&self, it: u64) -> f64 {
        let (t0, t1) = self.time_range;
        let s = &self.cfg.schedule;
        if self.model.motion == Motion::Static {
            return t1;
        }
        let w0 = s.warmup_time_window;
        #[allow(clippy::cast_precision_loss, reason = "iteration counts are small")]
        let frac = if it <= s.warmup_iters {
            w0
        } else if s.curriculum_iters == 0 {
            1.0
        } else {
            let f = (it - s.warmup_iters) as f64 / s.curriculum_iters as f64;
            if f >= 1.0 { 1.0 } else { w0 + (1.0 - w0) * f }
        };
        if frac >= 1.0 {
            t1
        } else {
            t0 + frac * (t1 - t0)
        }
    }

    /// The next view: a fresh random permutation of the views inside the time window each
    /// epoch, or sooner when the window has grown.
    fn next_view(&mut self) -> usize {
        let (t0, t1) = self.time_range;
        let hi = self.time_window_end(self.iteration);
        let focus = self.cfg.schedule.curriculum_focus;
        if self.model.dynamics_active && hi < t1 && focus > 0.0 && self.rng.next_f64() < focus {
            let lo = hi - (t1 - t0) / 20.0;
            let times = self.views.times();
            let newest =
                || (0..times.len()).filter(|&i| times[i] > lo && times[i] <= hi + WINDOW_EPS);
            let count = newest().count();
            if count > 0 {
                let pick = self.rng.below(count);
                return newest().nth(pick).unwrap_or(0);
            }
        }
        let hi = hi + WINDOW_EPS;
        let times = self.views.times();
        let eligible = times.iter().filter(|&&t| t <= hi).count();
        if self.order_pos >= self.order.len() || self.order.len() != eligible {
            self.order = (0..times.len()).filter(|&i| times[i] <= hi).collect();
            for i in (1..self.order.len()).rev() {
                let j = self.rng.below(i + 1);
                self.order.swap(i, j);
            }
            self.order_pos = 0;
        }
        self.order_pos += 1;
        self.order[self.order_pos - 1]
    }

    /// Switches the dynamics on: anchors start as the state integrated from the canonical one.
    fn start_dynamics(&mut self) {
        self.model.dynamics_active = true;
        self.model.refresh_anchors_from_start(&mut self.ws.stepper);
        let n = self.model.len();
        self.optim.anchors = self
            .model
            .anchors
            .iter()
            .map(|_| StateGroups::new(n))
            .collect();
    }

    /// Re-initialises the trainable anchors the curriculum's window reached at this
    /// iteration (from the anchor before each), with fresh optimiser states.
    fn anchors_reached_by_window(&mut self) {
        let it = self.iteration;
        if !self.model.dynamics_active
            || self.model.waypoints != Waypoints::Trainable
            || self.cfg.schedule.curriculum_iters == 0
        {
            return;
        }
        let (prev, hi) = (self.time_window_end(it - 1), self.time_window_end(it));
        for k in 1..self.model.anchor_times.len() {
            let tau = self.model.anchor_times[k];
            if tau > prev + WINDOW_EPS && tau <= hi + WINDOW_EPS {
                self.model
                    .refresh_anchor_from_previous(k, &mut self.ws.stepper);
                self.optim.anchors[k - 1] = StateGroups::new(self.model.len());
            }
        }
    }

    fn settings(&mut self) -> StepSettings {
        let l = &self.cfg.loss;
        // Segments whose end the time window has reached (all of them without a curriculum).
        let hi = self.time_window_end(self.iteration) + WINDOW_EPS;
        let k = self
            .model
            .anchor_times
            .iter()
            .filter(|&&tau| tau <= hi)
            .count();
        let anchor_segment = (self.model.waypoints == Waypoints::Trainable
            && k > 1
            && l.anchor_every > 0
            && self.iteration.is_multiple_of(l.anchor_every))
        .then(|| usize::try_from(self.iteration / l.anchor_every).unwrap_or(0) % (k - 1));
        let n = self.model.len();
        let m = l.coherence_samples.min(n);
        let coherence_points = if l.lambda_coherence > 0.0
            && self.model.dynamics_active
            && self.model.motion == Motion::Velocity
            && m > 1
        {
            let means = &self.model.canonical.means;
            let picks = if l.coherence_local {
                local_clusters(means, m, COHERENCE_K + 1, &mut self.rng)
            } else {
                // Sample without replacement (partial Fisher–Yates on a scratch index list).
                let mut idx: Vec<usize> = (0..n).collect();
                for i in 0..m {
                    let j = i + self.rng.below(n - i);
                    idx.swap(i, j);
                }
                idx.truncate(m);
                idx
            };
            picks
                .iter()
                .map(|&i| means[i].cast::<f64>().to_array())
                .collect()
        } else {
            Vec::new()
        };
        let rigidity = RigidityWeights {
            rigidity: l.lambda_rigidity,
            rotation: l.lambda_rotation,
            isometry: l.lambda_isometry,
        };
        let (rigidity_sample, rigidity_graph) = if rigidity.any()
            && self.model.dynamics_active
            && self.model.motion != Motion::Static
            && n > 1
        {
            // Local clusters, so that the neighbours within the sample are neighbours in the
            // cloud.
            let means = &self.model.canonical.means;
            let picks = local_clusters(
                means,
                l.rigidity_samples.min(n),
                COHERENCE_K + 1,
                &mut self.rng,
            );
            let positions: Vec<[f64; 3]> = picks
                .iter()
                .map(|&i| means[i].cast::<f64>().to_array())
                .collect();
            let (lo, hi) = self.model.field.hexplane().aabb();
            let graph = RigidityGraph::new(&positions, COHERENCE_K, even_spacing(lo, hi, n));
            (picks, graph)
        } else {
            (Vec::new(), RigidityGraph::default())
        };
        StepSettings {
            lambda_ssim: l.lambda_ssim,
            plane_reg: PlaneRegWeights {
                plane_tv: l.plane_tv,
                time_smoothness: l.time_smoothness,
                l1_time: l.l1_time,
            },
            lambda_coherence: l.lambda_coherence,
            lambda_anchor: l.lambda_anchor,
            anchor_segment,
            coherence_points,
            rigidity,
            rigidity_sample,
            rigidity_graph,
        }
    }

    /// One iteration.
    ///
    /// # Errors
    /// [`TrainError::NonFinite`] if the loss or a gradient is not finite (nothing applied).
    pub fn step(&mut self) -> Result<StepReport, TrainError> {
        let start = Instant::now();
        self.iteration += 1;
        let it = self.iteration;
        let mut report = StepReport {
            iteration: it,
            ..StepReport::default()
        };
        if it == self.cfg.schedule.warmup_iters + 1
            && self.model.motion != Motion::Static
            && !self.model.dynamics_active
        {
            self.start_dynamics();
            report.dynamics_started = true;
        }
        self.anchors_reached_by_window();
        let batch = self.cfg.schedule.views_per_step.max(1);
        let picks: Vec<usize> = (0..batch).map(|_| self.next_view()).collect();
        report.view_time = self.views.time(picks[0]);
        // Decode this step's frames and the next steps' (as far as the current epoch's order
        // tells) on the pool; the order of views never depends on when a decode finishes.
        let ahead = self.order[self.order_pos.min(self.order.len())..]
            .iter()
            .take(PREFETCH_STEPS * picks.len());
        let upcoming: Vec<usize> = picks.iter().chain(ahead).copied().collect();
        self.views.prefetch(&upcoming);
        let batch_data = match picks
            .iter()
            .map(|&i| self.views.view(i))
            .collect::<Result<Vec<_>, _>>()
        {
            Ok(b) => b,
            Err(msg) => {
                self.iteration -= 1;
                return Err(TrainError::Frame { iteration: it, msg });
            }
        };
        let settings = self.settings();
        let opts = render_options(self.cfg.data.background, self.active_sh_degree(), self.par);
        let mut grad = match self.grad.take() {
            Some(mut g) if g.canonical.len() == self.model.len() => {
                g.fill_zero();
                g
            }
            _ => self.model.zero_grad(),
        };
        let batch_views: Vec<&ViewData<f32>> = batch_data.iter().collect();
        let (losses, stats) = batch_loss_and_grad(
            &mut self.model,
            &batch_views,
            &opts,
            &settings,
            &mut self.ws,
            &mut grad,
        );
        if !losses.total.is_finite() {
            self.iteration -= 1;
            return Err(TrainError::NonFinite {
                iteration: it,
                what: "loss",
            });
        }
        if !grad.is_finite() {
            self.iteration -= 1;
            return Err(TrainError::NonFinite {
                iteration: it,
                what: "gradient",
            });
        }
        let d = &self.cfg.densify;
        // 3DGS convention: the densification window is `from_iter ≤ it < until_iter`, so an
        // opacity reset never lands on `until_iter` itself (which is often the last iteration).
        if it < d.until_iter {
            accumulate_screen_stats(
                &stats,
                &mut self.stats.accum,
                &mut self.stats.count,
                &mut self.stats.max_radius,
            );
        }
        let dyn_start = if self.model.motion == Motion::Static {
            0
        } else {
            self.cfg.schedule.warmup_iters
        };
        // The position and field schedules pause while the curriculum's window grows: each
        // new stretch of time is fitted at the rates the dynamics started with.
        let paused = if self.model.motion == Motion::Static {
            0
        } else {
            it.saturating_sub(self.cfg.schedule.warmup_iters)
                .min(self.cfg.schedule.curriculum_iters)
        };
        let lr = LearningRates::at(&self.cfg.optim, self.extent, it - paused, dyn_start);
        self.optim.step(&mut self.model, &grad, &lr);
        self.grad = Some(grad);
        let s = &self.cfg.schedule;
        if self.model.dynamics_active
            && self.model.waypoints == Waypoints::Snapshot
            && s.snapshot_every > 0
            && it.is_multiple_of(s.snapshot_every)
        {
            self.model.refresh_anchors_from_start(&mut self.ws.stepper);
        }
        if it >= d.from_iter && it < d.until_iter && it.is_multiple_of(d.interval) {
            let prune_big = d.opacity_reset_interval > 0 && it > d.opacity_reset_interval;
            let d = d.clone();
            report.densify = Some(densify_and_prune(
                &mut self.model,
                &mut self.optim,
                &mut self.stats,
                &d,
                self.extent,
                prune_big,
                &mut self.rng,
            ));
        }
        let d = &self.cfg.densify;
        if d.opacity_reset_interval > 0
            && it < d.until_iter
            && it.is_multiple_of(d.opacity_reset_interval)
        {
            reset_opacity(&mut self.model, &mut self.optim);
        }
        self.train_seconds += start.elapsed().as_secs_f64();
        if it.is_multiple_of(self.cfg.schedule.log_every) || it == self.cfg.schedule.iterations {
            self.log.push(LogRow {
                iteration: it,
                seconds: self.train_seconds,
                loss: losses.total,
                l1: losses.l1,
                psnr: psnr_of_mse(losses.mse),
                ssim: losses.ssim,
                regularizers: losses.planes + losses.coherence + losses.anchor + losses.rigidity,
                gaussians: self.model.len(),
                lr_position: lr.position,
            });
        }
        report.losses = losses;
        Ok(report)
    }
}

/// `10·log10(1/mse)` (∞ for a perfect match).
#[must_use]
pub fn psnr_of_mse(mse: f64) -> f64 {
    if mse > 0.0 {
        -10.0 * mse.log10()
    } else {
        f64::INFINITY
    }
}
