//! Scoring candidate motions of one group by the photometric training loss, the candidates
//! shared among the threads.

use super::bodies::Body;
use super::orbit::{Group, Orbit};
use super::spin::{SearchContext, place};
use super::window_loss::WindowLoss;
use crate::train::step::ViewData;
use evogs_math::Par;
use evogs_ode::Stepper;
use evogs_splat::{RenderOptions, Splats};

/// Per-worker buffers of [`score`].
struct Workspace {
    probe: Splats<f32>,
    window: WindowLoss,
}

/// Photometric loss of `view` rendered from `st` with each of `bodies` placed in turn (with
/// no bodies, of `st` itself).
fn losses(
    ctx: &SearchContext<'_>,
    view: &ViewData<f32>,
    st: &Splats<f32>,
    bodies: &[Body],
    ws: &mut Workspace,
) -> Vec<f64> {
    let Workspace { probe, window } = ws;
    let Some(first) = bodies.first() else {
        return vec![window.full_loss(view, st)];
    };
    // Every body moves the same members: one base (the view without them) and one copy
    // serve them all, each placement scored through a window around it (`window_loss`).
    let members = &first.members;
    window.set_base(view, st, members);
    probe.clone_from(st);
    bodies
        .iter()
        .map(|body| {
            debug_assert!(body.members == *members, "one group's orbits");
            place(
                probe,
                body,
                view.time,
                1.0,
                &ctx.p0,
                &ctx.q0,
                &ctx.log_scales,
            );
            window.loss(view, probe, members)
        })
        .collect()
}

/// Mean loss per view, over the views up to `horizon` (fraction of `range`), of the model with
/// `group` moved along each of `orbits`; last, that of the model's own motion. Returns the
/// losses and the number of views. With `ctx.par` parallel, the orbits are shared among the
/// threads (each renders one at a time); the sums are in view order either way.
pub(super) fn score(
    model: &mut crate::model::Model<f32>,
    ctx: &SearchContext<'_>,
    group: &Group,
    orbits: &[Orbit],
    (range, horizon): ((f64, f64), f64),
    stepper: &mut Option<Stepper<f32>>,
) -> (Vec<f64>, usize) {
    let mut st = Splats::default();
    let bodies: Vec<Body> = orbits.iter().map(|o| o.body(group, range)).collect();
    let workers = match ctx.par {
        Par::Seq => 1,
        #[cfg(feature = "rayon")]
        Par::Rayon => rayon::current_num_threads().max(1),
    };
    // Each worker renders one placement at a time.
    let opts = RenderOptions {
        par: Par::Seq,
        ..ctx.opts
    };
    let mut ws: Vec<Workspace> = (0..workers)
        .map(|_| Workspace {
            probe: Splats::default(),
            window: WindowLoss::new(opts, ctx.lambda),
        })
        .collect();
    let mut total = vec![0.0; bodies.len() + 1];
    let mut count = 0usize;
    for v in ctx.views_to((range, horizon)) {
        count += 1;
        model.splats_at(v.time, stepper, &mut st);
        // Last, the model's own motion.
        total[bodies.len()] += losses(ctx, v, &st, &[], &mut ws[0])[0];
        let per: Vec<Vec<f64>> = match ctx.par {
            Par::Seq => vec![losses(ctx, v, &st, &bodies, &mut ws[0])],
            #[cfg(feature = "rayon")]
            Par::Rayon => {
                use rayon::prelude::*;
                let chunk = bodies.len().div_ceil(workers);
                bodies
                    .par_chunks(chunk)
                    .zip(ws.par_iter_mut())
                    .map(|(b, w)| losses(ctx, v, &st, b, w))
                    .collect()
            }
        };
        for (t, l) in total.iter_mut().zip(per.iter().flatten()) {
            *t += l;
        }
    }
    #[allow(clippy::cast_precision_loss, reason = "a count")]
    let inv = 1.0 / count.max(1) as f64;
    (total.into_iter().map(|l| l * inv).collect(), count)
}

/// The best of `orbits` by [`score`] over the views up to `horizon` (fraction of `range`).
pub(super) struct Pick {
    /// Its index in `orbits`.
    pub index: usize,
    /// The orbit.
    pub orbit: Orbit,
    /// Its mean loss per view below the model's own motion.
    pub gain: f64,
    /// The number of views scored.
    pub views: usize,
    /// Every orbit's mean loss per view, in `orbits`' order.
    pub losses: Vec<f64>,
}

/// Scores `orbits` (not empty) and picks the best; of equal losses, the first.
pub(super) fn pick(
    model: &mut crate::model::Model<f32>,
    ctx: &SearchContext<'_>,
    group: &Group,
    orbits: &[Orbit],
    range_horizon: ((f64, f64), f64),
    stepper: &mut Option<Stepper<f32>>,
) -> Pick {
    let (mut l, views) = score(model, ctx, group, orbits, range_horizon, stepper);
    let index = (0..orbits.len())
        .min_by(|&i, &j| l[i].total_cmp(&l[j]))
        .unwrap_or(0);
    let own = l.pop().unwrap_or(0.0);
    Pick {
        index,
        orbit: orbits[index],
        gain: own - l[index],
        views,
        losses: l,
    }
}
