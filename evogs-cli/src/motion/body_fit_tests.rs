//! Tests of [`super`]: the pose's and the circle's VJPs, refits on a squashed tumbling rod,
//! and the orbit search with refits.

use super::*;
use crate::motion::OrbitSearchConfig;
use crate::motion::ballistic::Ballistic;
use crate::motion::bodies::{GRID, circle_point, circle_point_vjp};
use crate::motion::orbit::canonical_groups;
use crate::motion::refit_stage::refit_spins;
use crate::motion::test_support::{
    orbit_search_logged, orbit_test_cfg, static_model, test_context, tumbling_rod,
};
use crate::train::step::render_options;

#[test]
fn member_pose_vjp_matches_central_differences() {
    let mut rng = SplitMix64::new(5);
    let mut v3 = |s: f64| Vec3::new(rng.normal(), rng.normal(), rng.normal()) * s;
    let (c, c0, spin, p) = (v3(1.0), v3(1.0), v3(3.0), v3(0.5));
    let (gx, gs) = (v3(1.0), v3(1.0));
    let q = Quat::new(0.7, -0.4, 0.9, 0.2);
    let gq = Quat::new(gs.x, -0.3, gs.y, gs.z);
    let tau = 0.37;
    // L = gx·x + gq·q for the pose at (p, q, spin).
    let loss = |p: Vec3<f64>, q: Quat<f64>, s: Vec3<f64>| {
        let (x, qt) = member_pose((c, c0), s, tau, p, q);
        gx.dot(x) + gq.dot(qt)
    };
    let (dp, dq, ds) = member_pose_vjp(c0, spin, tau, (p, q), (gx, gq));
    let h = 1e-6;
    for k in 0..3 {
        let e = Vec3::unit(k) * h;
        let fd_p = (loss(p + e, q, spin) - loss(p - e, q, spin)) / (2.0 * h);
        let fd_s = (loss(p, q, spin + e) - loss(p, q, spin - e)) / (2.0 * h);
        assert!((fd_p - dp[k]).abs() < 1e-8, "p {k}: {fd_p} {}", dp[k]);
        assert!((fd_s - ds[k]).abs() < 1e-8, "spin {k}: {fd_s} {}", ds[k]);
    }
    let dqa = dq.to_array();
    for k in 0..4 {
        let mut e = [0.0; 4];
        e[k] = h;
        let (qp, qm) = (
            Quat::new(q.w + e[0], q.x + e[1], q.y + e[2], q.z + e[3]),
            Quat::new(q.w - e[0], q.x - e[1], q.y - e[2], q.z - e[3]),
        );
        let fd = (loss(p, qp, spin) - loss(p, qm, spin)) / (2.0 * h);
        assert!((fd - dqa[k]).abs() < 1e-8, "q {k}: {fd} {}", dqa[k]);
    }
}

#[test]
fn circle_point_vjp_matches_central_differences() {
    let mut rng = SplitMix64::new(6);
    let mut v3 = |s: f64| Vec3::new(rng.normal(), rng.normal(), rng.normal()) * s;
    let (centre, omega, c0, g) = (v3(1.0), v3(4.0), v3(1.0), v3(1.0));
    let tau = 0.43;
    let loss = |o: Vec3<f64>, w: Vec3<f64>| g.dot(circle_point(o, w, c0, tau));
    let (d_centre, d_omega) = circle_point_vjp(centre, omega, c0, tau, g);
    let h = 1e-6;
    for k in 0..3 {
        let e = Vec3::unit(k) * h;
        let fd_c = (loss(centre + e, omega) - loss(centre - e, omega)) / (2.0 * h);
        let fd_w = (loss(centre, omega + e) - loss(centre, omega - e)) / (2.0 * h);
        assert!((fd_c - d_centre[k]).abs() < 1e-8, "centre {k}");
        assert!((fd_w - d_omega[k]).abs() < 1e-8, "omega {k}");
    }
    // The circle is the orbit's centroid path.
    let o = Orbit {
        centre,
        omega,
        spin: Vec3::zero(),
    };
    let group = Group {
        members: vec![],
        centroid: c0,
        radius: 0.1,
    };
    let (c, _) = o.body(&group, (0.2, 1.0)).centre(0.2 + tau);
    assert!((c - circle_point(centre, omega, c0, tau)).norm() < 1e-12);
}

#[test]
fn path_vjp_matches_central_differences_for_every_kind_of_path() {
    let mut rng = SplitMix64::new(8);
    let mut v3 = |s: f64| Vec3::new(rng.normal(), rng.normal(), rng.normal()) * s;
    let (c0, g) = (v3(1.0), v3(1.0));
    let range = (0.1, 0.8);
    let circle = CentrePath::Circle {
        centre: v3(1.0),
        omega: v3(4.0),
    };
    let sampled = CentrePath::Sampled((0..=GRID).map(|_| v3(1.0)).collect());
    // Bounces at τ ≈ 0.31 and 0.69 (the times below are in the first, second and third
    // flights).
    let thrown = CentrePath::Ballistic(Ballistic {
        start: Vec3::new(0.0, 0.0, 0.5),
        velocity: Vec3::new(1.0, 0.0, 1.0),
        accel: Vec3::new(0.2, -0.1, -30.0),
        floor: 0.6,
        restitution: 0.7,
    });
    let sub = Subject {
        members: &[],
        c0,
        range,
    };
    for path in [circle, sampled, thrown] {
        let params = BodyParams {
            splats: Splats::new(0),
            spin: Vec3::zero(),
            path,
        };
        let (flat, _) = params.path_flat();
        // Times inside a grid interval (the samples' interpolation has kinks at its ends).
        for t in [0.13, 0.377, 0.861] {
            let mut grad = vec![0.0; flat.len()];
            path_vjp(&params.path, sub, t, g, &mut grad);
            let loss = |x: &[f32]| {
                let mut p = params.clone();
                p.set_path_flat(x);
                g.dot(p.path.at(c0, range, t).0)
            };
            for k in 0..flat.len() {
                let h = 1e-2_f32;
                let (mut up, mut down) = (flat.clone(), flat.clone());
                up[k] += h;
                down[k] -= h;
                let fd = (loss(&up) - loss(&down)) / f64::from(up[k] - down[k]);
                let tol = 1e-3 * (1.0 + fd.abs());
                assert!((fd - grad[k]).abs() < tol, "{t} {k}: {fd} {}", grad[k]);
            }
        }
    }
}

/// [`tumbling_rod`]'s splats, views, the rod's group and its true orbit; the canonical rod of the returned splats is squashed
/// along the first camera's axis (z) and shifted, as a fit to one view leaves it.
pub(super) fn squashed_rod() -> (Splats<f32>, Vec<ViewData<f32>>, Group, Orbit) {
    let (mut splats, views, groups, truth) = tumbling_rod();
    let c = Vec3::new(0.6, 0.0, 0.0);
    let mut rng = SplitMix64::new(9);
    for m in &mut splats.means[200..] {
        let d = m.cast::<f64>() - c;
        let jitter = Vec3::new(rng.normal(), rng.normal(), 0.0) * 0.01;
        *m = (c + Vec3::new(d.x, d.y, d.z * 0.2) + jitter).cast();
    }
    (splats, views, groups[1].clone(), truth)
}

#[test]
fn a_refit_tells_the_true_spin_from_a_wrong_one_and_moves_towards_it() {
    let (splats, views, group, truth) = squashed_rod();
    let opts = render_options([1.0; 3], splats.sh_degree, Par::Seq);
    let mut model = static_model(&splats);
    let ctx = test_context(&views, &splats, opts);
    let range = (0.0, 1.0);
    let frames = Frames::new(&mut model, &ctx, (range, 1.0), &mut None);
    assert_eq!(frames.len(), 12);
    let start = BodyParams::orbit(&splats, &group.members, &truth);
    let body = Subject::group(&group, range);
    let (_, before) = refit_body(&ctx, &frames, body, &start, 0, Par::Seq);
    // Truth, turning with the orbit, and the truth off by 1.5 rad per unit time.
    let off = truth.spin + Vec3::new(1.0, -1.0, 0.5);
    let spins = [truth.spin, truth.omega, off];
    let fits = refit_spins(&ctx, &frames, body, &start, &spins, 150);
    let losses: Vec<f64> = fits.iter().map(|f| f.1).collect();
    // The squashed canonical fits worse than a refitted one at the true spin, which
    // fits better than the wrong spins after their own refits.
    assert!(losses[0] < 0.5 * before, "{before} {losses:?}");
    assert!(losses[0] < losses[1] && losses[0] < losses[2], "{losses:?}");
    // The refit's gradient moves a nearby spin towards the truth.
    let moved = (fits[2].0.spin - truth.spin).norm();
    assert!(
        moved < 0.75 * (off - truth.spin).norm(),
        "{:?}",
        fits[2].0.spin
    );
    // Parallel refits are bitwise the sequential ones.
    #[cfg(feature = "rayon")]
    {
        let par_ctx = SearchContext {
            par: Par::Rayon,
            views: ctx.views.clone(),
            p0: ctx.p0.clone(),
            q0: ctx.q0.clone(),
            log_scales: ctx.log_scales.clone(),
            ..ctx
        };
        let par = refit_spins(&par_ctx, &frames, body, &start, &spins[..2], 20);
        let seq = refit_spins(&ctx, &frames, body, &start, &spins[..2], 20);
        assert_eq!(par, seq);
    }
}

#[test]
fn with_refits_the_search_finds_the_tumble_of_a_squashed_body() {
    let (splats, views, group, truth) = squashed_rod();
    let opts = render_options([1.0; 3], splats.sh_degree, Par::Seq);
    let run = |cfg: &OrbitSearchConfig| {
        let mut model = static_model(&splats);
        let mut ctx = test_context(&views, &splats, opts);
        let mut lines = Vec::new();
        let groups = canonical_groups(&ctx.p0, &splats.opacity_logits, cfg);
        assert_eq!(
            groups[1].members.len(),
            group.members.len(),
            "the rod is one group"
        );
        let found = orbit_search_logged(&mut model, &mut ctx, &groups, cfg, &mut lines);
        (found, lines)
    };
    let plain = run(&orbit_test_cfg());
    let refit = run(&OrbitSearchConfig {
        refit_iters: 300,
        refit_candidates: 4,
        final_refit_iters: 300,
        ..orbit_test_cfg()
    });
    let (plain, refit) = (&plain.0[0].orbit, &refit.0[0].orbit);
    // The squashed canonical misleads the plain search: its spin is far from the truth
    // (4.5 rad per unit time off when written). Refitted, the body's shape fits the views
    // and the search gets within about 1 of the tumble and within 0.05 of the orbit's
    // angular velocity.
    let (e_plain, e_refit) = (
        (plain.spin - truth.spin).norm(),
        (refit.spin - truth.spin).norm(),
    );
    assert!(e_plain > 3.0, "{plain:?}");
    assert!(e_refit < 1.0 && e_refit < 0.3 * e_plain, "{refit:?}");
    assert!((refit.omega - truth.omega).norm() < 0.05, "{refit:?}");
}
