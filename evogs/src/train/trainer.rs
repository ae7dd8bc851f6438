//! The training loop: [`Trainer`].
//!
//! One iteration: pick the next supervised view (a fresh random permutation each epoch),
//! compute the loss and its exact gradient ([`loss_and_grad`], or a batch of views spread
//! over processes), refuse non-finite values, take an Adam step, then the periodic tasks:
//! SH-degree increments, densification and pruning, opacity resets, snapshot-anchor
//! refreshes. The first `warmup_iters` iterations
//! are static (plain 3DGS); then the dynamics are switched on and the anchors are
//! initialised by integrating the field from the canonical state.

use super::batch::{BatchPart, ViewShare, shared_batch_loss_and_grad};
use super::collective::{Collective, Solo};
use super::densify::{DensifyReport, densify_and_prune, reset_opacity};
use super::frames::TrainViews;
use super::optim::StateGroups;
use super::schedule::Schedule;
pub use super::state::LogRow;
use super::state::TrainerState;
use super::step::{
    StepLosses, StepSettings, StepWorkspace, TeacherSample, ViewData, accumulate_screen_stats,
    loss_and_grad,
};
use crate::awake::KeepAwake;
use crate::config::{ConfigChange, TrainConfig, changes};
use crate::data::DataIdentity;
use crate::field::regularize::PlaneRegWeights;
use crate::model::init::{gaussians_from_points, random_points};
use crate::model::{HopStart, Model, ModelFrame, ModelGrad, Motion, build_model, render_options};
use evogs_math::Par;
use evogs_math::rng::SplitMix64;
use std::time::Instant;

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
    /// The processes sharing the run could not exchange a step (a rank died or timed
    /// out); nothing of this iteration was applied.
    #[error("iteration {iteration}: {msg}")]
    Collective {
        /// Iteration.
        iteration: u64,
        /// What failed (names the rank where known).
        msg: String,
    },
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
    /// Seconds of the Adam step.
    pub optimizer_seconds: f64,
    /// Seconds of the whole iteration.
    pub seconds: f64,
}

/// A training run in memory: build it with [`Trainer::new`] (or from a checkpoint's model and
/// state with [`Trainer::from_parts`]), advance it with [`Trainer::step`].
#[derive(Debug)]
pub struct Trainer {
    cfg: TrainConfig,
    model: Model<f32>,
    state: TrainerState,
    schedule: Schedule,
    views: TrainViews,
    par: Par,
    ws: StepWorkspace<f32>,
    grad: Option<ModelGrad<f32>>,
    shares: Vec<ViewShare<f32>>,
}

/// The training time range of `views` (a range of length 1 from a single time).
fn time_range(views: &TrainViews) -> (f64, f64) {
    let (t0, t1) = views.time_range();
    (t0, if t1 > t0 { t1 } else { t0 + 1.0 })
}

impl Trainer {
    /// A new run: initial Gaussians from `points` (else random), the model
    /// ([`build_model`]) with the field over their bounding box, a fresh state.
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
        let range = time_range(&views);
        let random;
        let (pts, cols) = match points {
            Some((p, c)) if cfg.init.use_points && !p.is_empty() => (p, c),
            _ => {
                random = random_points(cfg.init.random_points, cfg.init.random_extent, &mut rng);
                (random.as_slice(), None)
            }
        };
        let canonical = gaussians_from_points(pts, cols, cfg.init.sh_degree, &mut rng);
        let frame = ModelFrame::for_training(&cfg, &canonical, range);
        let mut model = build_model(&cfg, canonical, frame);
        // The field reads consecutive Gaussians together: keep them in spatial order.
        model.sort_spatially();
        let state = TrainerState::new(&model, rng, views.camera_extent(), range);
        Self::from_parts(cfg, model, state, views)
    }

    /// A run from its parts: a model, the state of the run that trained it (a fresh one,
    /// [`TrainerState::new`], to start) and the same training views.
    ///
    /// # Errors
    /// No views, or a state that does not fit the model.
    pub fn from_parts(
        cfg: TrainConfig,
        mut model: Model<f32>,
        state: TrainerState,
        views: impl Into<TrainViews>,
    ) -> Result<Self, TrainError> {
        let views = views.into();
        if views.is_empty() {
            return Err(TrainError::Setup(
                "no supervised training views (check the protocol and split time)".into(),
            ));
        }
        state.check(&model).map_err(TrainError::Setup)?;
        let schedule = Schedule::new(&cfg, state.time_range, &model.anchor_times, state.extent);
        let par = Par::best();
        model.set_par(par);
        Ok(Self {
            cfg,
            model,
            state,
            schedule,
            views,
            par,
            ws: StepWorkspace::default(),
            grad: None,
            shares: Vec::new(),
        })
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

    /// The run's state (iteration, random state, view order, log, optimiser, ...).
    #[must_use]
    pub const fn state(&self) -> &TrainerState {
        &self.state
    }

    /// The schedule.
    #[must_use]
    pub const fn schedule(&self) -> &Schedule {
        &self.schedule
    }

    /// Iterations done.
    #[must_use]
    pub const fn iteration(&self) -> u64 {
        self.state.iteration
    }

    /// Seconds spent in iterations.
    #[must_use]
    pub const fn train_seconds(&self) -> f64 {
        self.state.train_seconds
    }

    /// The log rows so far.
    #[must_use]
    pub fn log(&self) -> &[LogRow] {
        &self.state.log
    }

    /// The training time range.
    #[must_use]
    pub const fn time_range(&self) -> (f64, f64) {
        self.state.time_range
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
        self.schedule.set_iterations(iterations);
    }

    /// Records the training data the run sees (checkpoints keep it, so that a resume or an
    /// evaluation can tell the same scene from another).
    pub fn set_data(&mut self, data: DataIdentity) {
        self.state.data = Some(data);
    }

    /// Takes `asked` as the configuration for the rest of a resumed run. The changes a
    /// resume may make ([`ConfigChange::resumable`]: the iteration count, the checkpoint and
    /// log cadence, the frame cache, the layout's name) are applied and returned; any other
    /// difference is refused, each key named with the checkpoint's value and the asked one,
    /// and nothing changes.
    ///
    /// # Errors
    /// [`TrainError::Setup`] naming the refused keys, or an invalid `asked`.
    pub fn continue_with(&mut self, asked: &TrainConfig) -> Result<Vec<ConfigChange>, TrainError> {
        let all = changes(&self.cfg, asked);
        let refused: Vec<String> = all
            .iter()
            .filter(|c| !c.resumable())
            .map(ToString::to_string)
            .collect();
        if !refused.is_empty() {
            return Err(TrainError::Setup(format!(
                "a resumed run keeps its checkpoint's model, data and optimiser; these differ \
                 from the checkpoint: {}",
                refused.join(", ")
            )));
        }
        asked.validate().map_err(TrainError::Setup)?;
        self.cfg = asked.clone();
        self.schedule = Schedule::new(
            &self.cfg,
            self.state.time_range,
            &self.model.anchor_times,
            self.state.extent,
        );
        Ok(all)
    }

    /// Whether all iterations are done.
    #[must_use]
    pub const fn finished(&self) -> bool {
        self.schedule.finished(self.state.iteration)
    }

    /// Switches the dynamics on: anchors start as the state integrated from the canonical one.
    fn start_dynamics(&mut self) {
        self.model.dynamics_active = true;
        self.model.refresh_anchors_from_start(&mut self.ws.stepper);
        let n = self.model.len();
        self.state.optim.anchors = self
            .model
            .anchors
            .iter()
            .map(|_| StateGroups::new(n))
            .collect();
    }

    /// The loss settings of iteration `it`: the weights, the anchor segment, and the
    /// coherence sample (drawn without replacement when the coherence loss applies).
    fn settings(&mut self, it: u64) -> StepSettings {
        let continuous = self.model.dynamics_active && self.model.waypoint_field.is_some();
        // Drawn only with continuous waypoints, so the other modes' random streams are the
        // ones they always were.
        let hop_start = if continuous && self.state.rng.below(2) == 1 {
            HopStart::After
        } else {
            HopStart::Before
        };
        let teacher = (continuous && self.cfg.hop.teacher > 0.0).then(|| self.teacher_sample(it));
        let l = &self.cfg.loss;
        let n = self.model.len();
        let m = l.coherence_samples.min(n);
        let coherence_points = if l.lambda_coherence > 0.0
            && self.model.dynamics_active
            && self.model.motion == Motion::Velocity
            && m > 1
        {
            // Partial Fisher–Yates on a scratch index list.
            let mut picks: Vec<usize> = (0..n).collect();
            for i in 0..m {
                let j = i + self.state.rng.below(n - i);
                picks.swap(i, j);
            }
            let means = &self.model.canonical.means;
            picks[..m]
                .iter()
                .map(|&i| means[i].cast::<f64>().to_array())
                .collect()
        } else {
            Vec::new()
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
            anchor_segment: self.schedule.anchor_segment(it),
            coherence_points,
            hop_start,
            teacher,
        }
    }

    /// The teacher loss's draw for iteration `it`: `hop.teacher_samples` Gaussians (without
    /// replacement) and a window of `hop.teacher_span` of the time range (shortened to the
    /// supervised window) starting uniformly inside the supervised window.
    fn teacher_sample(&mut self, it: u64) -> TeacherSample {
        let h = &self.cfg.hop;
        let n = self.model.len();
        let m = h.teacher_samples.min(n);
        let rng = &mut self.state.rng;
        let mut picks: Vec<usize> = (0..n).collect();
        for i in 0..m {
            let j = i + rng.below(n - i);
            picks.swap(i, j);
        }
        picks.truncate(m);
        let (t0, t1) = self.state.time_range;
        let hi = self.schedule.window_end(it).clamp(t0, t1);
        let span = (h.teacher_span * (t1 - t0)).min(hi - t0);
        let a = t0 + rng.uniform(0.0, 1.0) * (hi - t0 - span);
        TeacherSample {
            window: (a, a + span),
            indices: picks,
            weight: h.teacher,
        }
    }

    /// One iteration in one process.
    ///
    /// # Errors
    /// [`TrainError::NonFinite`] if the loss or a gradient is not finite, or
    /// [`TrainError::Frame`] if a frame cannot be decoded (nothing applied either way).
    pub fn step(&mut self) -> Result<StepReport, TrainError> {
        self.step_with(&Solo)
    }

    /// Checks that the batch (`schedule.views_per_step`) splits evenly over the ranks of
    /// `collective`.
    ///
    /// # Errors
    /// [`TrainError::Setup`] naming both numbers.
    pub fn check_collective(&self, collective: &dyn Collective) -> Result<(), TrainError> {
        let (k, p) = (self.cfg.schedule.views_per_step.max(1), collective.size());
        if k % p as u64 == 0 {
            Ok(())
        } else {
            Err(TrainError::Setup(format!(
                "schedule.views_per_step = {k} does not split over {p} processes: each \
                 process computes K/P views of a step, so make it a multiple of {p}"
            )))
        }
    }

    /// One iteration, its batch of views spread over the ranks of `collective` (every rank
    /// calls it at the same iteration and ends with the same parameters; one process with
    /// the same batch gives the same bits).
    ///
    /// # Errors
    /// As [`Trainer::step`], [`TrainError::Setup`] if the batch does not split over the
    /// ranks ([`Trainer::check_collective`]), and [`TrainError::Collective`] if the ranks
    /// cannot exchange the step.
    pub fn step_with(&mut self, collective: &dyn Collective) -> Result<StepReport, TrainError> {
        self.check_collective(collective)?;
        // The pool's other threads poll for the iteration's parallel passes instead of
        // sleeping between them (bitwise the same results; `crate::awake`).
        let _awake = KeepAwake::start(self.par);
        let start = Instant::now();
        let it = self.state.iteration + 1;
        let mut report = StepReport {
            iteration: it,
            ..StepReport::default()
        };
        if self.schedule.dynamics_start() == Some(it) && !self.model.dynamics_active {
            self.start_dynamics();
            report.dynamics_started = true;
        }
        if self.model.dynamics_active {
            for k in self.schedule.anchors_reached(it) {
                self.model
                    .refresh_anchor_from_previous(k, &mut self.ws.stepper);
                self.state.optim.anchors[k - 1] = StateGroups::new(self.model.len());
            }
        }
        let hi = self.schedule.window_end(it);
        let focus = if self.model.dynamics_active {
            self.schedule.focus(it)
        } else {
            0.0
        };
        let batch = self.cfg.schedule.views_per_step.max(1);
        let st = &mut self.state;
        let picks: Vec<usize> = (0..batch)
            .map(|_| {
                st.sampler
                    .next(self.views.times(), st.time_range, hi, focus, &mut st.rng)
            })
            .collect();
        report.view_time = self.views.time(picks[0]);
        // This rank's views: rank·K/P .. (rank+1)·K/P of the batch (only their frames load).
        let m = picks.len() / collective.size();
        let mine = &picks[collective.rank() * m..(collective.rank() + 1) * m];
        st.sampler.prefetch(&self.views, mine);
        let batch_data = mine
            .iter()
            .map(|&i| self.views.view(i))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|msg| TrainError::Frame { iteration: it, msg })?;
        let settings = self.settings(it);
        let sh = self.schedule.sh_degree(it, self.model.canonical.sh_degree);
        let opts = render_options(self.cfg.data.background, sh, self.par);
        let mut grad = match self.grad.take() {
            Some(mut g) if g.canonical.len() == self.model.len() => {
                g.fill_zero(self.par);
                g
            }
            _ => self.model.zero_grad(),
        };
        let batch_views: Vec<&ViewData<f32>> = batch_data.iter().collect();
        let (losses, stats) = if picks.len() == 1 {
            loss_and_grad(
                &mut self.model,
                batch_views[0],
                &opts,
                &settings,
                &mut self.ws,
                &mut grad,
            )
        } else {
            let part = BatchPart {
                batch: picks.len(),
                first_time: report.view_time,
                mine: &batch_views,
            };
            shared_batch_loss_and_grad(
                &mut self.model,
                part,
                collective,
                &opts,
                &settings,
                &mut self.ws,
                &mut self.shares,
                &mut grad,
            )
            .map_err(|msg| TrainError::Collective { iteration: it, msg })?
        };
        let non_finite = |what| TrainError::NonFinite {
            iteration: it,
            what,
        };
        if !losses.total.is_finite() {
            return Err(non_finite("loss"));
        }
        if !grad.is_finite(self.par) {
            return Err(non_finite("gradient"));
        }
        self.state.iteration = it;
        let st = &mut self.state;
        if self.schedule.accumulates_stats(it) {
            accumulate_screen_stats(
                &stats,
                &mut st.stats.accum,
                &mut st.stats.count,
                &mut st.stats.max_radius,
            );
        }
        let lr = self.schedule.learning_rates(it);
        let optimizer_start = Instant::now();
        st.optim.step(&mut self.model, &grad, &lr, self.par);
        report.optimizer_seconds = optimizer_start.elapsed().as_secs_f64();
        self.grad = Some(grad);
        if let Some(prune_big) = self.schedule.densify(it) {
            report.densify = Some(densify_and_prune(
                &mut self.model,
                &mut st.optim,
                &mut st.stats,
                &self.cfg.densify,
                st.extent,
                prune_big,
                &mut st.rng,
            ));
        }
        if self.schedule.opacity_reset(it) {
            reset_opacity(&mut self.model, &mut st.optim);
        }
        report.seconds = start.elapsed().as_secs_f64();
        st.train_seconds += report.seconds;
        if self.schedule.logs(it) {
            st.log.push(LogRow {
                iteration: it,
                seconds: st.train_seconds,
                loss: losses.total,
                l1: losses.l1,
                psnr: evogs_splat::metrics::psnr_from_mse(losses.mse),
                ssim: losses.ssim,
                regularizers: losses.planes + losses.coherence + losses.anchor + losses.teacher,
                gaussians: self.model.len(),
                lr_position: lr.position,
            });
        }
        report.losses = losses;
        Ok(report)
    }
}
