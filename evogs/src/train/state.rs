//! Everything a run carries from one iteration to the next besides the model and the
//! configuration: a checkpoint writes a [`TrainerState`] whole and reads it back whole.

use super::densify::DensifyStats;
use super::optim::Optimizer;
use super::sampler::ViewSampler;
use crate::data::DataIdentity;
use crate::model::Model;
use evogs_math::rng::SplitMix64;

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

/// The state of a training run (with its model, enough to continue bit for bit).
#[derive(Clone, Debug)]
pub struct TrainerState {
    /// Iterations done.
    pub iteration: u64,
    /// Seconds spent in iterations.
    pub train_seconds: f64,
    /// Scene extent (learning-rate scale).
    pub extent: f64,
    /// Training time range.
    pub time_range: (f64, f64),
    /// Random state (view order, coherence samples, split offsets).
    pub rng: SplitMix64,
    /// The views' order and the position in it.
    pub sampler: ViewSampler,
    /// Log rows so far.
    pub log: Vec<LogRow>,
    /// Densification accumulators.
    pub stats: DensifyStats,
    /// Adam states.
    pub optim: Optimizer,
    /// The training data this run has seen (`None` until a caller records it, and in
    /// checkpoints written before it was recorded).
    pub data: Option<DataIdentity>,
}

impl TrainerState {
    /// The state of a run that has not started, for `model`, continuing the random
    /// state `rng`.
    #[must_use]
    pub fn new(model: &Model<f32>, rng: SplitMix64, extent: f64, time_range: (f64, f64)) -> Self {
        Self {
            iteration: 0,
            train_seconds: 0.0,
            extent,
            time_range,
            rng,
            sampler: ViewSampler::new(),
            log: Vec::new(),
            stats: DensifyStats::new(model.len()),
            optim: Optimizer::new(model),
            data: None,
        }
    }

    /// Checks that the state fits `model` (per-Gaussian arrays, anchors, field).
    ///
    /// # Errors
    /// The first mismatch, in words.
    pub fn check(&self, model: &Model<f32>) -> Result<(), String> {
        let n = model.len();
        let s = &self.stats;
        if s.accum.len() != n || s.count.len() != n || s.max_radius.len() != n {
            return Err(format!(
                "densification statistics have the wrong length (the model has {n} Gaussians)"
            ));
        }
        if self.optim.anchors.len() != model.anchors.len() {
            return Err(format!(
                "{} anchor optimiser states for {} anchors",
                self.optim.anchors.len(),
                model.anchors.len()
            ));
        }
        let fresh = Optimizer::new(model);
        let mut bad = None;
        for g in fresh.groups() {
            let (want, got) = (fresh.state(g), self.optim.state(g));
            if bad.is_none() && (got.m.len() != want.len() || got.v.len() != want.len()) {
                bad = Some(format!(
                    "Adam state `{}` has {} entries, the model needs {}",
                    g.name(),
                    got.m.len(),
                    want.len()
                ));
            }
        }
        bad.map_or(Ok(()), Err)
    }
}
