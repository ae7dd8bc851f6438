//! What the spin and orbit search stages share: when a search is due, the search's view of
//! the model, and the rates of the field fit that follows it.

use super::step::{ViewData, render_options};
use super::trainer::Trainer;
use crate::config::TrainConfig;
use crate::model::Motion;
use crate::motion::spin::SearchContext;
use evogs_math::Par;
use evogs_splat::Splats;

impl Trainer {
    /// Whether a search set for `at` is due before the next step: `at` iterations done
    /// (0: never), the dynamics on, `velocity` motion.
    pub(super) fn search_due(&self, at: u64) -> bool {
        at > 0
            && self.iteration == at
            && self.model.dynamics_active
            && self.model.motion == Motion::Velocity
    }

    /// Base rates (grid, MLP) of the field fit after a search: training's initial rates.
    pub(super) fn refit_rates(&self) -> (f64, f64) {
        let o = &self.cfg.optim;
        (
            o.grid_lr_init * self.extent,
            o.deformation_lr_init * self.extent,
        )
    }
}

/// The search's view of a trainer's model: every `stride`-th of `views`, the render settings
/// and loss weight of training (`cfg`), and the canonical poses of `canonical`.
pub(super) fn search_context<'a>(
    views: &'a [ViewData<f32>],
    stride: usize,
    canonical: &Splats<f32>,
    cfg: &TrainConfig,
    par: Par,
) -> SearchContext<'a> {
    #[allow(clippy::cast_possible_truncation, reason = "the loss runs in f32")]
    let lambda = cfg.loss.lambda_ssim as f32;
    SearchContext {
        views: views.iter().step_by(stride).collect(),
        opts: render_options(cfg.data.background, canonical.sh_degree, par),
        lambda,
        p0: canonical.means.iter().map(|m| m.cast()).collect(),
        q0: canonical
            .quats
            .iter()
            .map(|q| q.normalize().cast())
            .collect(),
        log_scales: canonical.log_scales.clone(),
        par,
    }
}
