//! The searches' refit stages: several refits of one body from different spins, the best
//! kept and written into the model (refits: [`super::body_fit`]).

use super::bodies::Body;
use super::body_fit::{BodyParams, Frames, Subject, refit_body};
use super::orbit::{Group, Orbit};
use super::spin::{SearchContext, place};
use crate::model::Model;
use evogs_math::{Par, Vec3};
use evogs_ode::Stepper;

/// [`refit_body`] from `start` turned at each of `spins`, the refits shared among the threads
/// when `ctx.par` is parallel (each refit's own renders sequential, so the results do not
/// depend on the thread count; a single refit's renders take the threads). Returns the
/// fitted parameters and losses in `spins`' order.
pub(super) fn refit_spins(
    ctx: &SearchContext<'_>,
    frames: &Frames<'_>,
    body: Subject<'_>,
    start: &BodyParams,
    spins: &[Vec3<f64>],
    iters: usize,
) -> Vec<(BodyParams, f64)> {
    let from = |s: &Vec3<f64>| BodyParams {
        spin: *s,
        ..start.clone()
    };
    if let [s] = spins {
        return vec![refit_body(ctx, frames, body, &from(s), iters, ctx.par)];
    }
    let one = |s: &Vec3<f64>| refit_body(ctx, frames, body, &from(s), iters, Par::Seq);
    match ctx.par {
        Par::Seq => spins.iter().map(one).collect(),
        #[cfg(feature = "rayon")]
        Par::Rayon => {
            use rayon::prelude::*;
            spins.par_iter().map(one).collect()
        }
    }
}

/// The orbit search's refit stage: refits `group` from `orbit` with each of `spins` over the
/// views to `horizon` (fraction of `range`) with `iters` steps each, and adopts the best: its
/// members' canonical parameters go into `model` and `ctx`. Returns the best refit's orbit.
pub(super) fn adopt_best_refit(
    model: &mut Model<f32>,
    ctx: &mut SearchContext<'_>,
    (group, orbit, range): (&Group, Orbit, (f64, f64)),
    spins: &[Vec3<f64>],
    (horizon, iters): (f64, usize),
    stepper: &mut Option<Stepper<f32>>,
    log: &mut dyn FnMut(&str),
) -> Orbit {
    let frames = Frames::new(model, ctx, (range, horizon), stepper);
    let start = BodyParams::orbit(&model.canonical, &group.members, &orbit);
    let body = Subject::group(group, range);
    let (_, before) = refit_body(ctx, &frames, body, &start, 0, ctx.par);
    let fits = refit_spins(ctx, &frames, body, &start, spins, iters);
    let Some(best) = (0..fits.len()).min_by(|&i, &j| fits[i].1.total_cmp(&fits[j].1)) else {
        return orbit;
    };
    let worst = fits.iter().map(|f| f.1).fold(f64::NEG_INFINITY, f64::max);
    let Some(o) = fits[best].0.as_orbit() else {
        return orbit;
    };
    log(&format!(
        "orbit search: refit from {} spins over {} views to {horizon:.2}, {iters} steps each: spin {:.2?} -> {:.2?}, |Ω| {:.3} -> {:.3}, centre moved {:.3}, loss per view {before:.4e} before, {:.4e} after (the worst refit {worst:.4e})",
        spins.len(),
        frames.len(),
        spins[best].to_array(),
        o.spin.to_array(),
        orbit.omega.norm(),
        o.omega.norm(),
        (o.centre - orbit.centre).norm(),
        fits[best].1,
    ));
    fits[best]
        .0
        .scatter(&group.members, &mut model.canonical, ctx);
    o
}

/// The spin search's refits of `bodies[b]` from each of `spins` along its learnt centroid
/// path: its canonical Gaussians, spin and path samples fitted over every view of `ctx`, the
/// bodies chosen before it placed at their spins (`chosen`). The best refit goes into `model`
/// and `ctx`, and is returned.
#[allow(clippy::too_many_arguments, reason = "the search's whole state")]
pub(super) fn adopt_body_refit(
    model: &mut Model<f32>,
    ctx: &mut SearchContext<'_>,
    (bodies, chosen, b): (&[Body], &[Option<f64>], usize),
    spins: &[Vec3<f64>],
    iters: usize,
    stepper: &mut Option<Stepper<f32>>,
    log: &mut dyn FnMut(&str),
) -> Option<BodyParams> {
    let body = &bodies[b];
    let mut frames = Frames::new(model, ctx, (body.range, f64::INFINITY), stepper);
    frames.for_each_state(|t, st| {
        for (c, other) in bodies.iter().enumerate() {
            if let (true, Some(s)) = (c != b, chosen[c]) {
                place(st, other, t, s, &ctx.p0, &ctx.q0, &ctx.log_scales);
            }
        }
    });
    let sub = Subject::body(body);
    let start = BodyParams::gather(
        &model.canonical,
        &body.members,
        Vec3::zero(),
        body.path.clone(),
    );
    let fits = refit_spins(ctx, &frames, sub, &start, spins, iters);
    let best = (0..fits.len()).min_by(|&i, &j| fits[i].1.total_cmp(&fits[j].1))?;
    let each: Vec<String> = spins
        .iter()
        .zip(&fits)
        .map(|(s, f)| format!("{:.2} -> {:.2} ({:.4e})", s.norm(), f.0.spin.norm(), f.1))
        .collect();
    let fitted = fits.into_iter().nth(best)?.0;
    log(&format!(
        "spin search: body {b}: refits over {} views, {iters} steps, spin |start| -> |end| (loss per view): {}; kept spin {:.3?} (|{:.3}|)",
        frames.len(),
        each.join(", "),
        fitted.spin.to_array(),
        fitted.spin.norm(),
    ));
    fitted.scatter(&body.members, &mut model.canonical, ctx);
    Some(fitted)
}
