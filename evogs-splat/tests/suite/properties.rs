//! Property tests of the rasterizers, the projection and the whole render on the public
//! strategies (`evogs_splat::strategies`, feature `proptest`): invariances (Gaussian order,
//! negligible opacity, rigid motions of camera and scene together), the background rule,
//! tiled vs reference agreement, VJPs against dual-number JVPs, and monotone transmittance.

use evogs_math::diff::vjp_dot_test;
use evogs_math::{Dual, Vec3};
use evogs_splat::raster_ref;
use evogs_splat::strategies::{background, camera, gaussian, permutation, rigid_motion, scene};
use evogs_splat::{
    PinholeCamera, PixelGrad, ProjectedGrad, RenderOptions, TiledRasterizer, project, project_vjp,
    render, render_tiled, render_vjp,
};
use proptest::prelude::*;

fn opts(sh_degree: usize, bg: [f64; 3]) -> RenderOptions<f64> {
    RenderOptions {
        sh_degree,
        background: bg,
        ..RenderOptions::default()
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Compositing follows depth: reordering Gaussians of distinct depths changes no bit.
    #[test]
    fn the_order_of_gaussians_with_distinct_depths_does_not_change_the_image(
        ((s, cam), perm) in scene(2..40, 20).prop_flat_map(|sc| {
            let n = sc.0.len();
            (Just(sc), permutation(n))
        }),
    ) {
        let o = opts(3, [0.2, 0.1, 0.3]);
        let a = render(&s, &cam, &o);
        let mut depths = a.pre.depths.clone();
        depths.sort_by(f64::total_cmp);
        prop_assume!(depths.windows(2).all(|w| w[0] < w[1]));
        let b = render(&s.select(perm.iter().copied()), &cam, &o);
        prop_assert!(a.raster.rgb == b.raster.rgb && a.raster.alpha == b.raster.alpha);
    }

    /// A Gaussian whose opacity is negligible (below the 1/255 alpha threshold everywhere)
    /// changes nothing, wherever it is.
    #[test]
    fn a_gaussian_of_negligible_opacity_changes_nothing(
        (s, cam) in scene(1..30, 20),
        (m, ls, q, _o) in gaussian(),
        logit in -60.0..-8.0f64,
    ) {
        let o = opts(3, [0.5, 0.5, 0.5]);
        let a = render(&s, &cam, &o);
        let mut t = s.clone();
        let sh = vec![[0.7, -0.2, 0.4]; 16];
        t.push(m, ls, q, logit, &sh);
        let b = render(&t, &cam, &o);
        prop_assert!(a.raster.rgb == b.raster.rgb && a.raster.alpha == b.raster.alpha);
        prop_assert!(a.raster.n_contrib == b.raster.n_contrib);
    }

    /// Moving camera and scene by the same rigid motion changes nothing (view-independent
    /// colour: SH degree 0), up to rounding.
    #[test]
    fn a_rigid_motion_of_camera_and_scene_together_changes_nothing(
        (s, _) in scene(1..30, 16),
        cam in camera(18, 14),
        (r, qr, t) in rigid_motion(2.0),
    ) {
        let o = opts(0, [0.1, 0.2, 0.3]);
        let a = render(&s, &cam, &o);
        let mut moved = s.clone();
        for (mu, q) in moved.means.iter_mut().zip(moved.quats.iter_mut()) {
            *mu = r.mul_vec(*mu) + t;
            *q = qr.mul_quat(*q);
        }
        // p_cam = R_c x + t_c with x = Rᵀ(x' − t): R_c' = R_c Rᵀ, t_c' = t_c − R_c Rᵀ t.
        let rc = cam.rotation.mul_mat(r.transpose());
        let moved_cam = PinholeCamera { rotation: rc, translation: cam.translation - rc.mul_vec(t), ..cam };
        let b = render(&moved, &moved_cam, &o);
        for (x, y) in a.raster.rgb.data().iter().zip(b.raster.rgb.data()) {
            prop_assert!((x - y).abs() < 1e-9, "{x} vs {y}");
        }
        for (x, y) in a.raster.alpha.iter().zip(&b.raster.alpha) {
            prop_assert!((x - y).abs() < 1e-9, "{x} vs {y}");
        }
    }

    /// `rgb = C + T_final·background` and `alpha = 1 − T_final`.
    #[test]
    fn the_background_is_composited_with_the_final_transmittance(
        (s, cam) in scene(1..30, 20),
        bg in background(),
    ) {
        let black = render(&s, &cam, &opts(3, [0.0; 3]));
        let with = render(&s, &cam, &opts(3, bg));
        let raster = &with.raster;
        for (p, (&ft, &al)) in raster.final_t.iter().zip(&raster.alpha).enumerate() {
            prop_assert!((al - (1.0 - ft)).abs() < 1e-15);
            for c in 0..3 {
                let d = raster.rgb.data()[3 * p + c] - black.raster.rgb.data()[3 * p + c];
                prop_assert!((d - ft * bg[c]).abs() < 1e-14, "pixel {p} channel {c}");
            }
        }
    }

    /// The tiled rasterizer's images equal the reference's bitwise, for any image size.
    #[test]
    fn tiled_and_reference_rasterizers_agree(
        (s, _) in scene(1..60, 8),
        cam in (5usize..40, 5usize..40).prop_flat_map(|(w, h)| camera(w, h)),
        bg in background(),
    ) {
        let o = opts(3, bg);
        let reference = render(&s, &cam, &o);
        let tiled = render_tiled(&s, &cam, &o, &mut TiledRasterizer::new());
        prop_assert!(reference.raster.rgb == tiled.raster.rgb);
        prop_assert!(reference.raster.alpha == tiled.raster.alpha);
        prop_assert!(reference.raster.n_contrib == tiled.raster.n_contrib);
    }

    /// Adding a Gaussian never increases the final transmittance of a pixel that compositing
    /// did not stop early; alpha stays in [0, 1) and colours non-negative. (A pixel stops
    /// before the Gaussian that would take its transmittance to 1e-4 or below, so one that
    /// stopped ends with T ≤ 1e-4/(1 − 0.999) = 0.1, and an added Gaussian in front can make
    /// it stop sooner, at a higher T: only pixels that ended above 0.1 are compared.)
    #[test]
    fn adding_a_gaussian_never_increases_transmittance(
        (s, cam) in scene(1..30, 20),
        (m, ls, q, op) in gaussian(),
    ) {
        let o = opts(3, [0.0; 3]);
        let a = render(&s, &cam, &o);
        let mut t = s.clone();
        let logit = (op / (1.0 - op)).ln();
        t.push(m, ls, q, logit, &vec![[0.3, 0.1, -0.2]; 16]);
        let b = render(&t, &cam, &o);
        let stopped_below = raster_ref::T_STOP / (1.0 - raster_ref::ALPHA_MAX);
        for (x, y) in a.raster.final_t.iter().zip(&b.raster.final_t) {
            if *x > stopped_below {
                prop_assert!(*y <= *x * (1.0 + 1e-15), "{y} > {x}");
            }
        }
        prop_assert!(b.raster.alpha.iter().all(|a| (0.0..1.0).contains(a)));
        prop_assert!(b.raster.rgb.data().iter().all(|c| *c >= 0.0));
    }

    /// The projection's VJP against a dual-number JVP (mean, log-scale, raw quaternion →
    /// means2d, depth, conic, compensation).
    #[test]
    fn projection_vjp_passes_the_dot_product_test(
        (m, ls, q, op) in gaussian(),
        cam in camera(32, 24),
        seed in 0u64..1000,
    ) {
        let po = RenderOptions::<f64>::default().project_options();
        prop_assume!(project(m, ls, q, op, &cam, &po).valid);
        let camd = cam.cast::<Dual<f64>>();
        let pod = RenderOptions::<Dual<f64>>::default().project_options();
        let r = vjp_dot_test(
            |v: &[f64], out: &mut [f64]| {
                let d = |x: f64, e: f64| Dual::new(x, e);
                let md = Vec3::new(d(m.x, v[0]), d(m.y, v[1]), d(m.z, v[2]));
                let lsd = Vec3::new(d(ls.x, v[3]), d(ls.y, v[4]), d(ls.z, v[5]));
                let qd = evogs_math::Quat::new(d(q.w, v[6]), d(q.x, v[7]), d(q.y, v[8]), d(q.z, v[9]));
                let p = project(md, lsd, qd, Dual::constant(op), &camd, &pod);
                let vals = [p.means2d.x, p.means2d.y, p.depth, p.conic[0], p.conic[1], p.conic[2], p.compensation];
                for (o, x) in out.iter_mut().zip(vals) {
                    *o = x.eps;
                }
            },
            |w: &[f64], out: &mut [f64]| {
                let g = ProjectedGrad {
                    means2d: evogs_math::Vec2::new(w[0], w[1]),
                    depth: w[2],
                    conic: [w[3], w[4], w[5]],
                    compensation: w[6],
                };
                let r = project_vjp(m, ls, q, op, &cam, &po, &g);
                out[..3].copy_from_slice(&r.mean.to_array());
                out[3..6].copy_from_slice(&r.log_scale.to_array());
                out[6..].copy_from_slice(&r.quat.to_array());
            },
            10,
            7,
            seed,
        );
        prop_assert!(r < 1e-12, "residual {r:e}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 16, ..ProptestConfig::default() })]

    /// The whole render's VJP (every Gaussian parameter → every pixel's colour and alpha)
    /// against a dual-number JVP of the same render.
    #[test]
    fn render_vjp_passes_the_dot_product_test(
        (s, cam) in scene(1..6, 10),
        bg in background(),
        seed in 0u64..1000,
    ) {
        let o = opts(3, bg);
        let fwd = render(&s, &cam, &o);
        let np = cam.width * cam.height;
        let mut flat = Vec::new();
        s.write_flat(&mut flat);
        let n_in = flat.len();
        let sd = s.cast::<Dual<f64>>();
        let camd = cam.cast::<Dual<f64>>();
        let od = RenderOptions {
            sh_degree: 3,
            background: bg.map(Dual::constant),
            ..RenderOptions::<Dual<f64>>::default()
        };
        let r = vjp_dot_test(
            |v: &[f64], out: &mut [f64]| {
                let mut t = sd.clone();
                let fd: Vec<Dual<f64>> = flat.iter().zip(v).map(|(&x, &e)| Dual::new(x, e)).collect();
                t.read_flat(&fd);
                let rd = render(&t, &camd, &od);
                for (o, x) in out[..3 * np].iter_mut().zip(rd.raster.rgb.data()) {
                    *o = x.eps;
                }
                for (o, x) in out[3 * np..].iter_mut().zip(&rd.raster.alpha) {
                    *o = x.eps;
                }
            },
            |w: &[f64], out: &mut [f64]| {
                let g = render_vjp(&s, &cam, &o, &fwd, &PixelGrad { rgb: &w[..3 * np], alpha: Some(&w[3 * np..]), depth: None });
                let mut gf = Vec::new();
                g.splats.write_flat(&mut gf);
                out.copy_from_slice(&gf);
            },
            n_in,
            4 * np,
            seed,
        );
        prop_assert!(r < 1e-12, "residual {r:e}");
    }

    /// The camera centre is the origin of camera space, and the origin (which the
    /// strategies' cameras look at) lies in front of the camera on its optical axis.
    #[test]
    fn cameras_look_at_the_origin_from_their_centre(cam in camera(30, 20)) {
        prop_assert!(cam.world_to_camera(cam.center()).norm() < 1e-12);
        let o = cam.world_to_camera(Vec3::zero());
        prop_assert!(o.z > 2.9 && o.x.abs() < 1e-12 && o.y.abs() < 1e-12);
    }
}
