//! The orbit search as a stage of training (`[orbit_search] at_iter`): see
//! [`crate::motion::orbit`].

use super::search_stage::search_context;
use super::trainer::Trainer;
use crate::motion::bodies::Paths;
use crate::motion::orbit::{Found, canonical_groups, search};
use crate::motion::spin::refit;
use std::time::Instant;

impl Trainer {
    /// Whether the orbit search is due before the next step: `at_iter` iterations done, the
    /// dynamics on, `velocity` motion.
    #[must_use]
    pub fn orbit_search_due(&self) -> bool {
        self.search_due(self.cfg.orbit_search.at_iter)
    }

    /// Runs the orbit search on the current model: groups the canonical cloud, searches each
    /// small group for an orbit about a larger one by the photometric loss over the training
    /// views, and teaches the field the orbits found (the other Gaussians keep their learnt
    /// motion) and sets their anchors. Progress and results go to `log`.
    pub fn orbit_search(&mut self, log: &mut dyn FnMut(&str)) -> Vec<Found> {
        let cfg = self.cfg.orbit_search.clone();
        let start = Instant::now();
        let mut stepper = None;
        let views = match self.views.every(cfg.view_stride) {
            Ok(v) => v,
            Err(e) => {
                log(&format!("orbit search skipped: {e}"));
                return Vec::new();
            }
        };
        let mut ctx = search_context(&views, 1, &self.model.canonical, &self.cfg, self.par);
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
            &mut ctx,
            &groups,
            range,
            &cfg,
            &mut stepper,
            log,
        );
        self.orbit_bodies.extend(
            found
                .iter()
                .map(|f| (f.group.centroid.to_array(), f.group.radius)),
        );
        if !found.is_empty() {
            // The search leaves the model as it was, so the learnt paths the fit keeps for
            // every other Gaussian are sampled only when there is a fit.
            let paths = Paths::record(&mut self.model, self.time_range, &mut stepper);
            let bodies: Vec<_> = found
                .iter()
                .map(|f| f.orbit.body(&f.group, range))
                .collect();
            let lr = self.refit_rates();
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
