//! The orbit search as a stage of training (`[orbit_search] at_iter`): see
//! [`crate::motion::orbit`].

use super::spin_stage::search_context;
use super::trainer::Trainer;
use crate::model::Motion;
use crate::motion::bodies::Paths;
use crate::motion::orbit::{Found, canonical_groups, search};
use crate::motion::spin::refit;
use std::time::Instant;

impl Trainer {
    /// Whether the orbit search is due before the next step: `at_iter` iterations done, the
    /// dynamics on, `velocity` motion.
    #[must_use]
    pub fn orbit_search_due(&self) -> bool {
        let at = self.cfg.orbit_search.at_iter;
        at > 0
            && self.iteration == at
            && self.model.dynamics_active
            && self.model.motion == Motion::Velocity
    }

    /// Runs the orbit search on the current model: groups the canonical cloud, searches each
    /// small group for an orbit about a larger one by the photometric loss over the training
    /// views, and teaches the field the orbits found (the other Gaussians keep their learnt
    /// motion) and sets their anchors. Progress and results go to `log`.
    pub fn orbit_search(&mut self, log: &mut dyn FnMut(&str)) -> Vec<Found> {
        let cfg = self.cfg.orbit_search.clone();
        let start = Instant::now();
        let mut stepper = None;
        let paths = Paths::record(&mut self.model, self.time_range, &mut stepper);
        let ctx = search_context(
            &self.views,
            cfg.view_stride,
            &self.model.canonical,
            &self.cfg,
            self.par,
        );
        let groups = canonical_groups(&ctx.p0, &self.model.canonical.opacity_logits, &cfg);
        for (b, g) in groups.iter().enumerate() {
            log(&format!(
                "orbit search: group {b}: {} Gaussians about {:.3?}, radius {:.3}",
                g.members.len(),
                g.centroid.to_array(),
                g.radius
            ));
        }
        let range = (self.time_range.0, self.time_range.1 - self.time_range.0);
        let found = search(
            &mut self.model,
            &ctx,
            &groups,
            range,
            &cfg,
            &mut stepper,
            log,
        );
        if !found.is_empty() {
            let bodies: Vec<_> = found
                .iter()
                .map(|f| f.orbit.body(&f.group, range))
                .collect();
            let o = &self.cfg.optim;
            let lr = (
                o.grid_lr_init * self.extent,
                o.deformation_lr_init * self.extent,
            );
            refit(
                &mut self.model,
                &paths,
                &bodies,
                &vec![Some(1.0); bodies.len()],
                &ctx.p0,
                &ctx.q0,
                lr,
                (cfg.fit_iters, cfg.fit_jitter),
                log,
            );
        }
        log(&format!(
            "orbit search: {} orbits taken in {:.0} s",
            found.len(),
            start.elapsed().as_secs_f64()
        ));
        found
    }
}
