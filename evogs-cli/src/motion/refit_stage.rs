//! The searches' refit stages: several refits of one body from different spins, the best
//! kept and written into the model (refits: [`super::body_fit`]).

use super::ballistic::{Ballistic, support_depth};
use super::bodies::{Body, CentrePath, Paths};
use super::body_fit::{BodyParams, Frames, Subject, refit_body};
use super::orbit::{Group, Orbit};
use super::spin::{SearchContext, place};
use crate::model::Model;
use evogs_math::{Par, Vec3};
use evogs_ode::Stepper;

/// [`refit_body`] from `start` turned at each of `spins` ([`refit_all`]).
pub(super) fn refit_spins(
    ctx: &SearchContext<'_>,
    frames: &Frames<'_>,
    body: Subject<'_>,
    start: &BodyParams,
    spins: &[Vec3<f64>],
    iters: usize,
) -> Vec<(BodyParams, f64)> {
    let starts: Vec<BodyParams> = spins
        .iter()
        .map(|s| BodyParams {
            spin: *s,
            ..start.clone()
        })
        .collect();
    refit_all(ctx, frames, body, &starts, iters)
}

/// [`refit_body`] from each of `starts`, the refits shared among the threads when `ctx.par`
/// is parallel (each refit's own renders sequential, so the results do not depend on the
/// thread count; a single refit's renders take the threads). Returns the fitted parameters
/// and losses in `starts`' order.
pub(super) fn refit_all(
    ctx: &SearchContext<'_>,
    frames: &Frames<'_>,
    body: Subject<'_>,
    starts: &[BodyParams],
    iters: usize,
) -> Vec<(BodyParams, f64)> {
    if let [s] = starts {
        return vec![refit_body(ctx, frames, body, s, iters, ctx.par)];
    }
    let one = |s: &BodyParams| refit_body(ctx, frames, body, s, iters, Par::Seq);
    match ctx.par {
        Par::Seq => starts.iter().map(one).collect(),
        #[cfg(feature = "rayon")]
        Par::Rayon => {
            use rayon::prelude::*;
            starts.par_iter().map(one).collect()
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

/// The world's down direction as the cameras see it: the mean of their image-down axes
/// (OpenCV `y`). For upright cameras all around a scene, the horizontal parts of these axes
/// cancel and the vertical parts add up.
pub(super) fn camera_down(ctx: &SearchContext<'_>) -> Vec3<f64> {
    let sum = ctx.views.iter().fold(Vec3::zero(), |a, v| {
        a + v.camera.rotation.row(1).cast::<f64>()
    });
    let n = sum.norm();
    if n > 0.0 { sum * n.recip() } else { sum }
}

/// Quantile of the depths under a thrown body's track taken as the top of its support
/// ([`support_depth`]): low, so the surface, not the slab, but above a stray deep point.
const SUPPORT_QUANTILE: f64 = 0.05;

/// The ballistic refits of `body` (learnt centroid samples on `body.path`): from a first
/// guess at each of `gravities` along `down` ([`Ballistic::guess`] over the first horizon,
/// its floor the body's radius above the top of what lies under its track, where that is
/// deeper: [`support_depth`] of the opaque canonical Gaussians, `opacity_logits`),
/// refitted with `iters` steps over the views to each of `horizons` in turn (fractions of
/// the range), so that each flight's extrapolation meets the next views. Returns the fitted
/// parameters and their losses over every view of `frames`.
fn ballistic_refits(
    ctx: &SearchContext<'_>,
    frames: &mut Frames<'_>,
    (body, sub): (&Body, Subject<'_>),
    (start, opacity_logits): (&BodyParams, &[f32]),
    (down, gravities, horizons): (Vec3<f64>, &[f64], &[f64]),
    iters: usize,
) -> Vec<(BodyParams, f64)> {
    let CentrePath::Sampled(samples) = &body.path else {
        return Vec::new();
    };
    let (t0, span) = body.range;
    let times: Vec<f64> = (0..samples.len())
        .map(|k| Paths::grid_time(0.0, span, k))
        .collect();
    let first = horizons.first().copied().unwrap_or(1.0) * span;
    // The floor: where the body rests on what lies under its learnt track (its radius above
    // the top of the opaque Gaussians there), unless its learnt path goes deeper.
    let support = support_depth(
        &ctx.p0,
        |i| opacity_logits[i] >= 0.0,
        &body.members,
        (samples, down, body.radius),
        SUPPORT_QUANTILE,
    );
    let mut fits: Vec<(BodyParams, f64)> = gravities
        .iter()
        .map(|&g| {
            let mut guess = Ballistic::guess(samples, &times, down * g, first);
            if let Some(d) = support {
                guess.floor = guess.floor.max(d - body.radius);
            }
            let p = BodyParams {
                path: CentrePath::Ballistic(guess),
                ..start.clone()
            };
            (p, f64::NAN)
        })
        .collect();
    for &h in horizons {
        frames.set_horizon(h.mul_add(span, t0));
        let starts: Vec<BodyParams> = fits.into_iter().map(|f| f.0).collect();
        fits = refit_all(ctx, frames, sub, &starts, iters);
    }
    // A refit's loss is over its views: the last horizon's are every view unless it ends
    // before the range does (the guesses have none).
    let last = frames.len();
    frames.set_horizon(f64::INFINITY);
    if frames.len() != last || horizons.is_empty() {
        for f in &mut fits {
            f.1 = refit_body(ctx, frames, sub, &f.0, 0, ctx.par).1;
        }
    }
    fits
}

/// The spin search's refits of `bodies[b]` from each of `spins` along its learnt centroid
/// path: its canonical Gaussians, spin and path samples fitted over every view of `ctx`, the
/// bodies chosen before it placed at their spins (`chosen`). With `gravities`, the body is
/// also refitted as a thrown body from each of them ([`ballistic_refits`] over `horizons`,
/// the first spin). The best refit goes into `model` and `ctx`, and is returned.
#[allow(clippy::too_many_arguments, reason = "the search's whole state")]
pub(super) fn adopt_body_refit(
    model: &mut Model<f32>,
    ctx: &mut SearchContext<'_>,
    (bodies, chosen, b): (&[Body], &[Option<f64>], usize),
    spins: &[Vec3<f64>],
    (gravities, horizons): (&[f64], &[f64]),
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
        spins.first().copied().unwrap_or_else(Vec3::zero),
        body.path.clone(),
    );
    let mut fits = refit_spins(ctx, &frames, sub, &start, spins, iters);
    let mut each: Vec<String> = spins
        .iter()
        .zip(&fits)
        .map(|(s, f)| format!("{:.2} -> {:.2} ({:.4e})", s.norm(), f.0.spin.norm(), f.1))
        .collect();
    if !gravities.is_empty() {
        let down = camera_down(ctx);
        let thrown = ballistic_refits(
            ctx,
            &mut frames,
            (body, sub),
            (&start, &model.canonical.opacity_logits),
            (down, gravities, horizons),
            iters,
        );
        for (g, f) in gravities.iter().zip(&thrown) {
            if let CentrePath::Ballistic(p) = &f.0.path {
                each.push(format!(
                    "thrown along {:.3?} from |a| {g:.1}: |a| {:.2}, floor {:.3}, e {:.2}, spin {:.2} ({:.4e})",
                    down.to_array(),
                    p.accel.norm(),
                    p.floor,
                    p.restitution,
                    f.0.spin.norm(),
                    f.1
                ));
            }
        }
        fits.extend(thrown);
    }
    let best = (0..fits.len()).min_by(|&i, &j| fits[i].1.total_cmp(&fits[j].1))?;
    let fitted = fits.into_iter().nth(best)?.0;
    log(&format!(
        "spin search: body {b}: refits over {} views, {iters} steps, spin |start| -> |end| (loss per view): {}; kept refit {best}, spin {:.3?} (|{:.3}|)",
        frames.len(),
        each.join(", "),
        fitted.spin.to_array(),
        fitted.spin.norm(),
    ));
    fitted.scatter(&body.members, &mut model.canonical, ctx);
    Some(fitted)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::bodies::GRID;
    use crate::motion::test_support::{rendered_view, static_model, test_context, two_groups};
    use crate::train::step::{ViewData, render_options};
    use evogs_splat::{PinholeCamera, Splats, TiledRasterizer};

    /// The truth of [`thrown_ball`]: from the small group's centroid (0.6, 0, 0), two
    /// bounces (at τ ≈ 0.383 and 0.779) on the floor z = −0.35.
    fn flight() -> Ballistic {
        Ballistic {
            start: Vec3::new(0.6, 0.0, 0.0),
            velocity: Vec3::new(-0.8, 0.0, 1.0),
            accel: Vec3::new(0.0, 0.0, -10.0),
            floor: 0.35,
            restitution: 0.7,
        }
    }

    /// [`two_groups`] with the large group lowered under the floor and the small one (its
    /// radius doubled to 0.12) thrown along [`flight`], seen at times 0.04, 0.08, …, 0.96
    /// from four cameras around the vertical axis in turn.
    fn thrown_ball() -> (Splats<f32>, Vec<ViewData<f32>>) {
        let (mut splats, _) = two_groups();
        for m in &mut splats.means[..200] {
            m.z -= 0.7;
        }
        for m in &mut splats.means[200..] {
            *m = (flight().start + (m.cast::<f64>() - flight().start) * 2.0).cast();
        }
        let opts = render_options([1.0; 3], splats.sh_degree, Par::Seq);
        let mut rast = TiledRasterizer::new();
        let eyes = [(3.5, 0.0), (0.0, 3.5), (-3.5, 0.0), (0.0, -3.5)];
        let views = (1..=24)
            .map(|k| {
                let time = f64::from(k) * 0.04;
                let (x, y) = eyes[k as usize % 4];
                let camera = PinholeCamera::look_at(
                    Vec3::new(x, y, 1.5),
                    Vec3::zero(),
                    Vec3::new(0.0, 0.0, 1.0),
                    30.0_f64.to_radians(),
                    64,
                    64,
                )
                .expect("a valid camera");
                let mut st = splats.clone();
                let c = flight().at(time).0 - flight().start;
                for m in &mut st.means[200..] {
                    *m = (m.cast::<f64>() + c).cast();
                }
                rendered_view(&st, camera, time, &opts, &mut rast)
            })
            .collect();
        (splats, views)
    }

    #[test]
    fn the_cameras_down_is_their_mean_image_down_axis() {
        let (splats, views) = thrown_ball();
        let opts = render_options([1.0; 3], splats.sh_degree, Par::Seq);
        let down = camera_down(&test_context(&views, &splats, opts));
        assert!((down - Vec3::new(0.0, 0.0, -1.0)).norm() < 1e-6, "{down:?}");
    }

    #[test]
    fn a_thrown_body_is_refitted_to_its_flight() {
        let (splats, views) = thrown_ball();
        let opts = render_options([1.0; 3], splats.sh_degree, Par::Seq);
        let mut ctx = test_context(&views, &splats, opts);
        let truth = flight();
        // The learnt path follows half of the flight.
        let samples: Vec<Vec3<f64>> = (0..=GRID)
            .map(|k| {
                let t = Paths::grid_time(0.0, 1.0, k);
                truth.start + (truth.at(t).0 - truth.start) * 0.5
            })
            .collect();
        let body = Body {
            members: (200..splats.len()).collect(),
            moving: 60,
            c0: truth.start,
            radius: 0.12,
            path: CentrePath::Sampled(samples),
            omega: Vec3::zero(),
            rigid_rms: 0.0,
            range: (0.0, 1.0),
        };
        let mut model = static_model(&splats);
        let mut lines = Vec::new();
        let fitted = adopt_body_refit(
            &mut model,
            &mut ctx,
            (&[body], &[None], 0),
            &[Vec3::zero()],
            (&[5.0, 10.0, 20.0], &[0.12, 0.25, 0.5, 1.0]),
            300,
            &mut None,
            &mut |m| lines.push(m.to_string()),
        )
        .expect("refitted");
        let CentrePath::Ballistic(b) = fitted.path else {
            panic!("the flight fits better than the samples: {lines:?}");
        };
        // The fitted flight follows the truth at every view (the ball's radius is 0.12).
        let worst = views
            .iter()
            .map(|v| (b.at(v.time).0 - truth.at(v.time).0).norm())
            .fold(0.0, f64::max);
        assert!(worst < 0.02, "{worst} off: {b:?}, {lines:?}");
        // Its floor, bounce and gravity are the truth's (the learnt path's lowest point is
        // half as deep, and the guesses' gravities are half to twice the truth).
        assert!((b.floor - truth.floor).abs() < 0.02, "{b:?}");
        assert!((b.restitution - truth.restitution).abs() < 0.05, "{b:?}");
        assert!((b.accel - truth.accel).norm() < 1.0, "{b:?}");
    }
}
