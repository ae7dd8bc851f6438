//! The spin search as a stage of training (`[spin_search] at_iter`): see [`crate::motion`].

use super::step::render_options;
use super::trainer::Trainer;
use crate::model::Motion;
use crate::motion::bodies::{Paths, find_bodies};
use crate::motion::spin::{SearchContext, refit, search};
use evogs_math::{Quat, Vec3};

impl Trainer {
    /// Whether the spin search is due before the next step: `at_iter` iterations done, the
    /// dynamics on, `velocity` motion.
    #[must_use]
    pub fn spin_search_due(&self) -> bool {
        let at = self.cfg.spin_search.at_iter;
        at > 0
            && self.iteration == at
            && self.model.dynamics_active
            && self.model.motion == Motion::Velocity
    }

    /// Runs the spin search on the current model: finds the bodies in the learnt motion,
    /// scans their spin multipliers by the photometric loss over the training views, and if
    /// any was searched teaches the field the chosen spins and sets the anchors. Progress
    /// and results go to `log`. Returns the chosen multipliers (`None`: body not searched).
    pub fn spin_search(&mut self, log: &mut dyn FnMut(&str)) -> Vec<Option<f64>> {
        let cfg = self.cfg.spin_search.clone();
        let mut stepper = None;
        let paths = Paths::record(&mut self.model, self.time_range, &mut stepper);
        let p0: Vec<Vec3<f64>> = self
            .model
            .canonical
            .means
            .iter()
            .map(|m| m.cast())
            .collect();
        let q0: Vec<Quat<f64>> = self
            .model
            .canonical
            .quats
            .iter()
            .map(|q| q.normalize().cast())
            .collect();
        let bodies = find_bodies(&paths, &p0, &cfg);
        for (b, body) in bodies.iter().enumerate() {
            log(&format!(
                "spin search: body {b}: {} Gaussians ({} moving) about {:.3?}, radius {:.3}, learnt spin {:.3} rad per unit time, rigid-fit RMS {:.4}",
                body.members.len(),
                body.moving,
                body.c0.to_array(),
                body.radius,
                body.omega.norm(),
                body.rigid_rms
            ));
        }
        #[allow(clippy::cast_possible_truncation, reason = "the loss runs in f32")]
        let lambda = self.cfg.loss.lambda_ssim as f32;
        let ctx = SearchContext {
            views: self.views.iter().step_by(cfg.view_stride).collect(),
            opts: render_options(
                self.cfg.data.background,
                self.model.canonical.sh_degree,
                self.par,
            ),
            lambda,
            p0,
            q0,
            log_scales: self.model.canonical.log_scales.clone(),
            par: self.par,
        };
        let (chosen, _) = search(&mut self.model, &ctx, &bodies, &cfg, &mut stepper, log);
        if chosen.iter().any(Option::is_some) {
            let o = &self.cfg.optim;
            let lr = (
                o.grid_lr_init * self.extent,
                o.deformation_lr_init * self.extent,
            );
            refit(
                &mut self.model,
                &paths,
                &bodies,
                &chosen,
                &ctx.p0,
                &ctx.q0,
                lr,
                cfg.fit_iters,
                log,
            );
        }
        chosen
    }
}
