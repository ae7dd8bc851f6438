//! The orbit search: a small body circling another faster than gradient descent can follow.
//!
//! A small, fast body (in `toys`, the torus: outer radius 0.15, circling the cube at 6.1 units
//! per unit time) leaves its own footprint within a few hundredths of the time range. Once
//! the learnt motion misses it, no pixel links the body's Gaussians to where the body is, and
//! photometric training fades them out (README, "The torus"). The search needs no gradient.
//! It takes each compact group of the canonical cloud in turn as a body, and each larger group
//! near it as the centre it may circle. The orbit model is a rigid turn about an axis through
//! the centre `p`, perpendicular to `r = c₀ − p` (a circle about `p` through the body's
//! centroid `c₀`):
//!
//! ```text
//! x(t) = p + R(ω·(t − t₀))(x₀ − p),   ω = r × v / |r|²,   v ⊥ r
//! ```
//!
//! so an orbit is fixed by the centre and the body's initial velocity `v`, two numbers in the
//! plane perpendicular to `r`. The search is a continuation in time: a grid over `v` scored
//! by the photometric training loss of the views up to a short horizon (where a wrong rate
//! costs little), then finer grids around the best over longer and longer horizons. The body
//! need not turn with its orbit: its own spin is searched the same way, and a last local
//! search refines every parameter (the private module `orbit_refine`). A body fitted to few
//! views shows little of its spin, so with `refit_iters` set the spin grid's best candidates
//! are each refitted, the body's canonical Gaussians, spin and orbit fitted together by
//! gradient descent, and the best refit is kept (the private module `body_fit`).
//! [`crate::train::trainer::Trainer::orbit_search`] runs it at `[orbit_search] at_iter` and
//! teaches the field the orbits found ([`super::spin::refit`]).

use super::OrbitSearchConfig;
use super::bodies::{Body, CentrePath, components};
use super::orbit_refine::{polish, spin_grid};
use super::orbit_score::pick;
use super::refit_stage::adopt_best_refit;
use super::spin::SearchContext;
use evogs_math::Vec3;
use evogs_math::activation::sigmoid;
use evogs_ode::Stepper;

/// A group of the canonical cloud: its Gaussians, centroid and radius.
#[derive(Clone, Debug)]
pub struct Group {
    /// Its Gaussians.
    pub members: Vec<usize>,
    /// Centroid.
    pub centroid: Vec3<f64>,
    /// Largest distance of a member from the centroid.
    pub radius: f64,
}

/// The groups of at least `cfg.min_body` Gaussians (opacity ≥ `cfg.min_opacity`) linked
/// within `cfg.link` at their canonical positions `p0`, largest first.
#[must_use]
pub fn canonical_groups(p0: &[Vec3<f64>], logits: &[f32], cfg: &OrbitSearchConfig) -> Vec<Group> {
    let kept: Vec<usize> = (0..p0.len())
        .filter(|&i| f64::from(sigmoid(logits[i])) >= cfg.min_opacity)
        .collect();
    let pts: Vec<Vec3<f64>> = kept.iter().map(|&i| p0[i]).collect();
    let mut groups: Vec<Group> = components(&pts, cfg.link)
        .into_iter()
        .filter(|c| c.len() >= cfg.min_body)
        .map(|c| {
            let members: Vec<usize> = c.iter().map(|&j| kept[j]).collect();
            #[allow(clippy::cast_precision_loss, reason = "a count")]
            let inv = 1.0 / members.len() as f64;
            let centroid = members.iter().fold(Vec3::zero(), |a, &i| a + p0[i]) * inv;
            let radius = members
                .iter()
                .map(|&i| (p0[i] - centroid).norm())
                .fold(0.0, f64::max);
            Group {
                members,
                centroid,
                radius,
            }
        })
        .collect();
    groups.sort_by_key(|g| std::cmp::Reverse(g.members.len()));
    groups
}

/// A circular orbit: the body's centroid turns at angular velocity `omega` about the axis
/// through `centre`, while the body turns about its centroid at its own `spin` (both world
/// frame, radians per unit time; `spin = omega` is a rigid turn of the whole body about the
/// axis, as the Moon's about the Earth).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// A point on the axis.
    pub centre: Vec3<f64>,
    /// Angular velocity of the centroid about the axis.
    pub omega: Vec3<f64>,
    /// The body's own angular velocity.
    pub spin: Vec3<f64>,
}

impl Orbit {
    /// The orbit about `centre` that moves the point `c0` at velocity `v` (its component
    /// along `c0 − centre` is ignored), the body turning with it (`spin = omega`).
    #[must_use]
    pub fn through(c0: Vec3<f64>, centre: Vec3<f64>, v: Vec3<f64>) -> Self {
        let r = c0 - centre;
        let omega = r.cross(v) * (1.0 / r.norm_squared());
        Self {
            centre,
            omega,
            spin: omega,
        }
    }

    /// The same orbit with the body's own angular velocity `spin`.
    #[must_use]
    pub fn with_spin(self, spin: Vec3<f64>) -> Self {
        Self { spin, ..self }
    }

    /// The velocity of the point `c0` on the orbit.
    #[must_use]
    pub fn velocity_at(&self, c0: Vec3<f64>) -> Vec3<f64> {
        self.omega.cross(c0 - self.centre)
    }

    /// `group` moving along this orbit from `range.0` over `range` (start, length), as a
    /// [`Body`] (its centroid path the exact circle), for placing its members and for the
    /// field fit.
    #[must_use]
    pub fn body(&self, group: &Group, range: (f64, f64)) -> Body {
        Body {
            members: group.members.clone(),
            moving: group.members.len(),
            c0: group.centroid,
            radius: group.radius,
            path: CentrePath::Circle {
                centre: self.centre,
                omega: self.omega,
            },
            omega: self.spin,
            rigid_rms: 0.0,
            range,
        }
    }
}

/// A unit vector perpendicular to `r` (not zero), and a second one perpendicular to both.
pub(super) fn plane_basis(r: Vec3<f64>) -> (Vec3<f64>, Vec3<f64>) {
    let u = r * (1.0 / r.norm());
    let a = if u.x.abs() < 0.9 {
        Vec3::new(1.0, 0.0, 0.0)
    } else {
        Vec3::new(0.0, 1.0, 0.0)
    };
    let e1 = a - u * a.dot(u);
    let e1 = e1 * (1.0 / e1.norm());
    (e1, u.cross(e1))
}

/// The velocities `v0 + (a·e₁ + c·e₂)·step`, `a, c ∈ −k..=k`, in the plane perpendicular to
/// `r` (basis of [`plane_basis`]).
fn velocity_grid(
    v0: Vec3<f64>,
    r: Vec3<f64>,
    step: f64,
    k: i64,
) -> impl Iterator<Item = Vec3<f64>> {
    let (e1, e2) = plane_basis(r);
    (-k..=k).flat_map(move |a| {
        #[allow(clippy::cast_precision_loss, reason = "small integers")]
        (-k..=k).map(move |c| v0 + (e1 * a as f64 + e2 * c as f64) * step)
    })
}

/// One body's search: the centre and velocity chosen, and the gain.
#[derive(Clone, Debug)]
pub struct Found {
    /// The body's group.
    pub group: Group,
    /// The orbit chosen.
    pub orbit: Orbit,
    /// Initial speed of its centroid.
    pub speed: f64,
    /// Mean loss per view below the model's own motion, over the views to the last horizon.
    pub gain: f64,
}

/// Searches every group of `groups` small enough to be a body (radius ≤ `cfg.max_radius`) for
/// an orbit about a larger group's centroid, over the training range `range` (start, length).
/// Returns the orbits whose gain over the last horizon (`cfg.horizons`) is at least
/// `cfg.min_gain`. A body whose best first-horizon velocity is zero is left as learnt.
pub fn search(
    model: &mut crate::model::Model<f32>,
    ctx: &mut SearchContext<'_>,
    groups: &[Group],
    range: (f64, f64),
    cfg: &OrbitSearchConfig,
    stepper: &mut Option<Stepper<f32>>,
    log: &mut dyn FnMut(&str),
) -> Vec<Found> {
    let mut found = Vec::new();
    for (b, group) in groups.iter().enumerate() {
        if group.radius > cfg.max_radius {
            continue;
        }
        let centres: Vec<Vec3<f64>> = groups
            .iter()
            .enumerate()
            .filter(|&(c, g)| {
                c != b
                    && g.members.len() >= cfg.centre_min_body
                    && g.radius <= cfg.centre_max_radius
                    && g.radius > group.radius
                    && (g.centroid - group.centroid).norm() <= cfg.max_orbit_radius
            })
            .map(|(_, g)| g.centroid)
            .collect();
        if centres.is_empty() {
            continue;
        }
        log(&format!(
            "orbit search: group {b} ({} Gaussians, radius {:.3}) at {:.3?}, {} centres",
            group.members.len(),
            group.radius,
            group.centroid.to_array(),
            centres.len()
        ));
        // The global grid over every centre, at the first horizon.
        #[allow(clippy::cast_possible_truncation, reason = "a small grid")]
        let k = (cfg.max_speed / cfg.speed_step).floor() as i64;
        let orbits: Vec<Orbit> = centres
            .iter()
            .flat_map(|&p| {
                velocity_grid(Vec3::zero(), group.centroid - p, cfg.speed_step, k)
                    .filter(|v| v.norm() <= cfg.max_speed + 1e-9)
                    .map(move |v| Orbit::through(group.centroid, p, v))
            })
            .collect();
        let first = pick(
            model,
            ctx,
            group,
            &orbits,
            (range, cfg.horizons[0]),
            stepper,
        );
        let (mut best, mut gain, views) = (first.orbit, first.gain, first.views);
        let velocity = |o: &Orbit| o.velocity_at(group.centroid);
        log(&format!(
            "orbit search: group {b}: {} orbits about {} centres over {views} views to {:.2}: best about {:.3?}, speed {:.3}, {:+.2e} per view",
            orbits.len(),
            centres.len(),
            cfg.horizons[0],
            best.centre.to_array(),
            velocity(&best).norm(),
            -gain,
        ));
        if velocity(&best).norm() < 1e-12 {
            continue;
        }
        let spins = cfg.max_spin > 0.0;
        let mut spin_step = cfg.spin_step;
        if spins {
            // The body's own spin, globally at the first horizon; turning with the orbit
            // (the velocity grid's assumption) is one of the candidates.
            #[allow(clippy::cast_possible_truncation, reason = "a small grid")]
            let k = (cfg.max_spin / cfg.spin_step).floor() as i64;
            let mut cands = vec![best];
            cands.extend(
                spin_grid(Vec3::zero(), cfg.spin_step, k, cfg.max_spin)
                    .into_iter()
                    .map(|s| best.with_spin(s)),
            );
            let p = pick(model, ctx, group, &cands, (range, cfg.horizons[0]), stepper);
            (best, gain) = (p.orbit, p.gain);
            log(&format!(
                "orbit search: group {b}: {} spins over {} views: spin {:.2?} (|{:.3}|), {:+.2e} per view",
                cands.len(),
                p.views,
                best.spin.to_array(),
                best.spin.norm(),
                -gain
            ));
            if cfg.refit_iters > 0 {
                // The grid's best spins (and turning with the orbit), each refitted.
                let mut order: Vec<usize> = (0..cands.len()).collect();
                order.sort_by(|&i, &j| p.losses[i].total_cmp(&p.losses[j]));
                let mut starts: Vec<Vec3<f64>> = order
                    .iter()
                    .take(cfg.refit_candidates)
                    .map(|&i| cands[i].spin)
                    .collect();
                if !starts.contains(&cands[0].spin) {
                    starts.push(cands[0].spin);
                }
                best = adopt_best_refit(
                    model,
                    ctx,
                    (group, best, range),
                    &starts,
                    (cfg.refit_horizon, cfg.refit_iters),
                    stepper,
                    log,
                );
            }
        }
        let mut step = cfg.speed_step;
        for &h in &cfg.horizons[1..] {
            step *= 0.5;
            #[allow(clippy::cast_possible_wrap, reason = "a few steps")]
            let m = cfg.local_steps as i64;
            let local: Vec<Orbit> =
                velocity_grid(velocity(&best), group.centroid - best.centre, step, m)
                    .map(|v| Orbit::through(group.centroid, best.centre, v).with_spin(best.spin))
                    .collect();
            let p = pick(model, ctx, group, &local, (range, h), stepper);
            let views = p.views;
            (best, gain) = (p.orbit, p.gain);
            if spins {
                spin_step *= 0.5;
                let local: Vec<Orbit> = spin_grid(best.spin, spin_step, 1, f64::INFINITY)
                    .into_iter()
                    .map(|s| best.with_spin(s))
                    .collect();
                let p = pick(model, ctx, group, &local, (range, h), stepper);
                (best, gain) = (p.orbit, p.gain);
            }
            log(&format!(
                "orbit search: group {b}: horizon {h:.2} ({views} views), step {step:.4}: speed {:.3}, |ω| {:.3}, spin {:.2?}, {:+.2e} per view",
                velocity(&best).norm(),
                best.omega.norm(),
                best.spin.to_array(),
                -gain
            ));
        }
        if cfg.polish_rounds > 0 {
            let last = cfg.horizons[cfg.horizons.len() - 1];
            let steps = [cfg.polish_step, step, if spins { spin_step } else { 0.0 }];
            (best, gain) = polish(
                model,
                ctx,
                group,
                best,
                (steps, cfg.polish_rounds),
                (range, last),
                stepper,
                log,
            );
        }
        if spins && cfg.final_refit_iters > 0 {
            let last = cfg.horizons[cfg.horizons.len() - 1];
            best = adopt_best_refit(
                model,
                ctx,
                (group, best, range),
                &[best.spin],
                (last, cfg.final_refit_iters),
                stepper,
                log,
            );
            gain = pick(model, ctx, group, &[best], (range, last), stepper).gain;
        }
        let speed = velocity(&best).norm();
        if gain >= cfg.min_gain {
            log(&format!(
                "orbit search: group {b}: orbit about {:.3?}, radius {:.3}, axis {:.3?}, {:.3} rad per unit time, spin {:.3?}, gain {gain:.2e} per view",
                best.centre.to_array(),
                (group.centroid - best.centre).norm(),
                (best.omega * (1.0 / best.omega.norm())).to_array(),
                best.omega.norm(),
                best.spin.to_array(),
            ));
            found.push(Found {
                group: group.clone(),
                orbit: best,
                speed,
                gain,
            });
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::bodies::Paths;
    use crate::motion::orbit_score::score;
    use crate::motion::test_support::{
        canonical_poses, orbit_test_cfg as cfg, static_model, test_context, turned_view,
        two_camera_views, two_groups,
    };
    use crate::train::step::render_options;
    use evogs_math::Par;
    use evogs_math::Quat;
    use evogs_math::so3::exp_quat;
    use evogs_splat::TiledRasterizer;

    #[test]
    fn an_orbit_turns_its_body_rigidly_about_the_centre() {
        let (c0, centre, v) = (
            Vec3::new(0.6, 0.1, -0.2),
            Vec3::new(0.1, 0.0, 0.3),
            Vec3::new(0.3, 2.0, -1.0),
        );
        let o = Orbit::through(c0, centre, v);
        let r = c0 - centre;
        // The velocity at c0 is v's part perpendicular to r; the axis is perpendicular to r.
        let v_perp = v - r * (v.dot(r) / r.norm_squared());
        assert!((o.omega.cross(r) - v_perp).norm() < 1e-12);
        assert!(o.omega.dot(r).abs() < 1e-12);
        let group = Group {
            members: vec![0, 1],
            centroid: c0,
            radius: 0.1,
        };
        let body = o.body(&group, (0.25, 2.0));
        let (p0, q0) = (
            c0 + Vec3::new(0.05, -0.02, 0.0),
            Quat::new(0.8, 0.6, 0.0, 0.0),
        );
        for k in [0, 7, 32] {
            let t = Paths::grid_time(0.25, 2.0, k);
            let turn = exp_quat(o.omega * (t - 0.25));
            let (x, q) = body.pose(t, 1.0, p0, q0);
            // The pose is exact: distances to the centre are kept.
            assert!(
                (x - (centre + turn.rotate(p0 - centre))).norm() < 1e-12,
                "{k}"
            );
            assert!(((x - centre).norm() - (p0 - centre).norm()).abs() < 1e-12);
            assert!((q.dot(turn.mul_quat(q0)) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn the_search_finds_the_orbit_the_views_show() {
        let (splats, camera) = two_groups();
        let (p0, _) = canonical_poses(&splats);
        let groups = canonical_groups(&p0, &splats.opacity_logits, &cfg());
        assert_eq!(
            groups.iter().map(|g| g.members.len()).collect::<Vec<_>>(),
            vec![200, 60]
        );
        // The small group circles the large one's centroid at 4 rad per unit time about z.
        let (centre, omega) = (groups[0].centroid, Vec3::new(0.0, 0.0, 4.0));
        let opts = render_options([1.0; 3], splats.sh_degree, Par::Seq);
        let mut rast = TiledRasterizer::new();
        let views = two_camera_views(camera, |time, camera| {
            turned_view(
                &splats,
                200..260,
                (centre, omega),
                time,
                camera,
                &opts,
                &mut rast,
            )
        });
        let mut model = static_model(&splats);
        let mut ctx = test_context(&views, &splats, opts);
        let mut lines = Vec::new();
        let found = search(
            &mut model,
            &mut ctx,
            &groups,
            (0.0, 1.0),
            &cfg(),
            &mut None,
            &mut |m| lines.push(m.to_string()),
        );
        assert_eq!(found.len(), 1, "{lines:#?}");
        let f = &found[0];
        assert_eq!(f.group.members.len(), 60);
        // The centre starts at the large group's centroid; the last local search moves it
        // where the views fit better: here by about its first step (0.02).
        assert!((f.orbit.centre - centre).norm() < 0.03, "{f:?}");
        // The last stage's step is 0.125 in speed, 0.21 rad per unit time at radius 0.6.
        assert!((f.orbit.omega - omega).norm() < 0.25, "{lines:#?}");
        // The body turns with its orbit, and the spin search finds that too.
        assert!((f.orbit.spin - omega).norm() < 0.25, "{lines:#?}");
        assert!(f.gain > 0.0 && (f.speed - 2.4).abs() < 0.15, "{f:?}");
        // With the groups' roles taken by a radius limit below the small group's, nothing
        // is searched.
        let none = search(
            &mut model,
            &mut ctx,
            &groups,
            (0.0, 1.0),
            &OrbitSearchConfig {
                max_radius: groups[1].radius * 0.5,
                ..cfg()
            },
            &mut None,
            &mut |_| {},
        );
        assert!(none.is_empty());
        // Scored in parallel, the losses are bitwise those of the sequential scan.
        #[cfg(feature = "rayon")]
        {
            let orbits = [
                f.orbit,
                Orbit::through(f.group.centroid, centre, Vec3::new(0.0, 1.0, 0.0)),
            ];
            let mut scored = |ctx: &SearchContext<'_>| {
                score(
                    &mut model,
                    ctx,
                    &f.group,
                    &orbits,
                    ((0.0, 1.0), 0.6),
                    &mut None,
                )
            };
            let seq = scored(&ctx);
            ctx.par = Par::Rayon;
            let par = scored(&ctx);
            assert_eq!(seq, par);
        }
    }
}
