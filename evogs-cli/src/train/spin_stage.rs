//! The spin search as a stage of training (`[spin_search] at_iter`): see [`crate::motion`].

use super::search_stage::search_context;
use super::trainer::Trainer;
use crate::motion::bodies::{Paths, find_bodies};
use crate::motion::spin::{refit, search};
use evogs_math::Vec3;
use std::time::Instant;

impl Trainer {
    /// Whether the spin search is due before the next step: `at_iter` iterations done, the
    /// dynamics on, `velocity` motion.
    #[must_use]
    pub fn spin_search_due(&self) -> bool {
        self.search_due(self.cfg.spin_search.at_iter)
    }

    /// Runs the spin search on the current model: finds the bodies in the learnt motion,
    /// scans their spin multipliers by the photometric loss over the training views, and if
    /// any was searched teaches the field the chosen spins and sets the anchors. Progress
    /// and results go to `log`. Returns the chosen multipliers (`None`: body not searched).
    pub fn spin_search(&mut self, log: &mut dyn FnMut(&str)) -> Vec<Option<f64>> {
        let cfg = self.cfg.spin_search.clone();
        let start = Instant::now();
        let mut stepper = None;
        let paths = Paths::record(&mut self.model, self.time_range, &mut stepper);
        let views = match self.views.every(cfg.view_stride) {
            Ok(v) => v,
            Err(e) => {
                log(&format!("spin search skipped: {e}"));
                return Vec::new();
            }
        };
        let mut ctx = search_context(&views, 1, &self.model.canonical, &self.cfg, self.par);
        let mut bodies = find_bodies(&paths, &ctx.p0, &cfg);
        // A body the orbit search moved keeps its orbit and spin: the spin search's model of
        // it (a sampled centroid path) is coarser, and its refits moved a found tumble away
        // from the truth (README, "The spin search refits its bodies").
        bodies.retain(|b| {
            let orbit = self.orbit_bodies.iter().find(|(c, r)| {
                let d = b.c0 - Vec3::new(c[0], c[1], c[2]);
                d.norm() <= *r
            });
            if let Some((c, _)) = orbit {
                log(&format!(
                    "spin search: the body about {:.3?} ({} Gaussians) is the orbit search's \
                     body about {c:.3?}; left to its orbit",
                    b.c0.to_array(),
                    b.members.len()
                ));
            }
            orbit.is_none()
        });
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
        let (chosen, _) = search(
            &mut self.model,
            &mut ctx,
            &mut bodies,
            &cfg,
            &mut stepper,
            log,
        );
        if chosen.iter().any(Option::is_some) {
            let lr = self.refit_rates();
            refit(
                &mut self.model,
                &paths,
                &bodies,
                &chosen,
                &ctx.p0,
                &ctx.q0,
                lr,
                (cfg.fit_iters, 0.0),
                log,
            );
        }
        log(&format!(
            "spin search: {} of {} bodies searched in {:.0} s",
            chosen.iter().filter(|c| c.is_some()).count(),
            chosen.len(),
            start.elapsed().as_secs_f64()
        ));
        chosen
    }
}
