//! The whole chain `render` → `render_vjp` against central differences and forward-mode
//! (dual-number) JVPs, in classic and antialiased mode, on small random scenes chosen away
//! from the discontinuities (α thresholds, the 0.999 clamp, termination, SH clamp, depth
//! ties), including scenes with terminated pixels and clamped alphas. Loss: random weights on
//! rgb, alpha and expected depth, with a coloured background. All in f64.

use crate::splat_common;

use evogs_math::activation::logit;
use evogs_math::diff::{GradCheck, central_gradient, dual_jvp, vjp_dot_test};
use evogs_math::rng::SplitMix64;
use evogs_math::sh::{SH_C0, sh_coeff_count, sh_eval};
use evogs_math::{Dual, Quat, Real, Vec3};
use evogs_splat::raster_ref::{ALPHA_MAX, ALPHA_MIN, T_STOP, conic_sigma, pixel_center};
use evogs_splat::{
    PinholeCamera, PixelGrad, RadiusMode, RasterMode, RenderOptions, Splats, render, render_vjp,
};
use splat_common::{perturb_left, pose12, test_camera, with_pose};

const W: usize = 20;
const H: usize = 16;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// Semi-transparent, overlapping Gaussians.
    Regular,
    /// Large, nearly opaque layers: terminated pixels and alphas clamped at 0.999.
    Opaque,
}

struct Scene {
    splats: Splats<f64>,
    cam: PinholeCamera<f64>,
    opts: RenderOptions<f64>,
    w_rgb: Vec<f64>,
    w_alpha: Vec<f64>,
    w_depth: Vec<f64>,
}

fn scene(seed: u64, kind: Kind, mode: RasterMode) -> Scene {
    let mut rng = SplitMix64::new(seed);
    let cam = test_camera(W, H);
    let degree = 3;
    let mut s = Splats::new(degree);
    let n: u32 = match kind {
        Kind::Regular => 9,
        Kind::Opaque => 6,
    };
    for i in 0..n {
        let (x, y, z, ls, o) = match kind {
            Kind::Regular => (
                rng.uniform(-0.45, 0.45),
                rng.uniform(-0.35, 0.35),
                rng.uniform(3.0, 6.0),
                rng.uniform(-2.3, -1.2),
                rng.uniform(0.3, 0.95),
            ),
            // Even layers: huge, nearly opaque, centred 0–0.2 px from a pixel centre, so
            // o'·G exceeds 0.999 there (also in antialiased mode, where ρ ≈ 1 − ε tr(A⁻¹)/2).
            Kind::Opaque if i % 2 == 0 => {
                let z = 3.0 + 0.5 * f64::from(i) + rng.uniform(0.0, 0.3);
                let u = 4.5 + 3.0 * f64::from(i) + rng.uniform(0.0, 0.2);
                let v = 6.5 + rng.uniform(0.0, 0.2);
                (
                    (u - cam.cx) / cam.fx,
                    (v - cam.cy) / cam.fy,
                    z,
                    rng.uniform(1.2, 1.5),
                    rng.uniform(0.99995, 0.99999),
                )
            }
            Kind::Opaque => (
                rng.uniform(-0.1, 0.1),
                rng.uniform(-0.1, 0.1),
                3.0 + 0.5 * f64::from(i) + rng.uniform(0.0, 0.3),
                rng.uniform(-0.2, 0.3),
                rng.uniform(0.96, 0.99),
            ),
        };
        let p_cam = Vec3::new(x * z, y * z, z);
        let mean = cam.rotation.tr_mul_vec(p_cam - cam.translation);
        let spread = if kind == Kind::Opaque && i % 2 == 0 {
            0.1
        } else {
            0.6
        };
        let log_scale = Vec3::new(
            ls,
            ls + spread * rng.uniform(-1.3, 0.5),
            ls + spread * rng.uniform(-0.8, 0.8),
        );
        let quat = Quat::new(rng.normal(), rng.normal(), rng.normal(), rng.normal())
            .scale(rng.uniform(0.6, 1.8));
        let sh: Vec<[f64; 3]> = (0..sh_coeff_count(degree))
            .map(|k| {
                if k == 0 {
                    [0, 1, 2].map(|_| (rng.uniform(-0.1, 1.0) - 0.5) / SH_C0)
                } else {
                    [0, 1, 2].map(|_| 0.15 * rng.normal())
                }
            })
            .collect();
        s.push(mean, log_scale, quat, logit(o), &sh);
    }
    let opts = RenderOptions {
        eps2d: 0.3,
        radius: RadiusMode::Plain,
        mode,
        sh_degree: 3,
        background: [0.2, 0.5, 0.9],
        ..RenderOptions::default()
    };
    let np = W * H;
    let w_rgb = (0..3 * np).map(|_| rng.normal()).collect();
    let w_alpha = (0..np).map(|_| rng.normal()).collect();
    let w_depth = (0..np).map(|_| 0.1 * rng.normal()).collect();
    Scene {
        splats: s,
        cam,
        opts,
        w_rgb,
        w_alpha,
        w_depth,
    }
}

/// Decision statistics of a scene; `Err` if a decision is too close to its threshold for
/// central differences.
#[derive(Debug, Default)]
struct Decisions {
    composited: usize,
    clamped: usize,
    terminated: usize,
    sh_clamped: usize,
}

fn decisions(sc: &Scene) -> Result<Decisions, String> {
    let fwd = render(&sc.splats, &sc.cam, &sc.opts);
    let pre = &fwd.pre;
    let mut d = Decisions::default();
    let center = sc.cam.center();
    for &g in &pre.order {
        let g = g as usize;
        let raw = sh_eval(3, sc.splats.sh_coeffs(g), sc.splats.means[g] - center);
        for v in raw {
            if (v + 0.5).abs() < 1e-4 {
                return Err(format!("SH clamp margin of Gaussian {g}"));
            }
            d.sh_clamped += usize::from(v + 0.5 < 0.0);
        }
    }
    for w in pre.order.windows(2) {
        let (a, b) = (pre.depths[w[0] as usize], pre.depths[w[1] as usize]);
        if b - a < 1e-4 {
            return Err("depth tie".into());
        }
    }
    for row in 0..H {
        for col in 0..W {
            let (px, py) = pixel_center::<f64>(col, row);
            let mut t = 1.0;
            for &g in &pre.order {
                let g = g as usize;
                let m = pre.means2d[g];
                let sigma = conic_sigma(pre.conics[g], m.x - px, m.y - py);
                let v = pre.opacities[g] * (-sigma).exp();
                if (v - ALPHA_MIN).abs() < 1e-3 * ALPHA_MIN {
                    return Err(format!("alpha threshold margin at ({col}, {row})"));
                }
                if (v - ALPHA_MAX).abs() < 1e-4 {
                    return Err(format!("alpha clamp margin at ({col}, {row})"));
                }
                if sigma < 0.0 || v < ALPHA_MIN {
                    continue;
                }
                let alpha = v.min(ALPHA_MAX);
                let next = t * (1.0 - alpha);
                if (next - T_STOP).abs() < 1e-3 * T_STOP {
                    return Err(format!("transmittance margin at ({col}, {row})"));
                }
                if next <= T_STOP {
                    d.terminated += 1;
                    break;
                }
                d.composited += 1;
                d.clamped += usize::from(v > ALPHA_MAX);
                t = next;
            }
        }
    }
    Ok(d)
}

/// The first scene from `seed` on whose decisions have margins.
fn good_scene(seed: u64, kind: Kind, mode: RasterMode) -> (Scene, Decisions) {
    for s in seed..seed + 200 {
        let sc = scene(s, kind, mode);
        if let Ok(d) = decisions(&sc) {
            return (sc, d);
        }
    }
    panic!("no scene with margins");
}

fn loss<T: Real>(
    sc: &Scene,
    splats: &Splats<T>,
    cam: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
) -> T {
    let r = render(splats, cam, opts).raster;
    let c = |v: f64| T::from_f64(v);
    let mut l = T::ZERO;
    for (a, w) in r.rgb.data().iter().zip(&sc.w_rgb) {
        l += *a * c(*w);
    }
    for (a, w) in r.alpha.iter().zip(&sc.w_alpha) {
        l += *a * c(*w);
    }
    for (a, w) in r.depth.iter().zip(&sc.w_depth) {
        l += *a * c(*w);
    }
    l
}

fn check_scene(label: &str, sc: &Scene) {
    let fwd = render(&sc.splats, &sc.cam, &sc.opts);
    let d = PixelGrad {
        rgb: &sc.w_rgb,
        alpha: Some(&sc.w_alpha),
        depth: Some(&sc.w_depth),
    };
    let g = render_vjp(&sc.splats, &sc.cam, &sc.opts, &fwd, &d);
    let tol = GradCheck::new(1e-7, 1e-6);

    // Every raw Gaussian parameter.
    let mut x = Vec::new();
    sc.splats.write_flat(&mut x);
    let mut num = vec![0.0; x.len()];
    let mut s = sc.splats.clone();
    central_gradient(
        |v: &[f64]| {
            s.read_flat(v);
            loss(sc, &s, &sc.cam, &sc.opts)
        },
        &mut x,
        &mut num,
    );
    let mut ana = Vec::new();
    g.splats.write_flat(&mut ana);
    let rep = tol.check(&ana, &num);
    println!("{label}: Gaussian parameters ({} lanes) {rep}", ana.len());
    rep.assert_passed(&format!("{label}: Gaussian parameters"));

    // View-matrix entries, left se(3) pose, background.
    let mut x = pose12(&sc.cam);
    let mut num = vec![0.0; 12];
    central_gradient(
        |v: &[f64]| loss(sc, &sc.splats, &with_pose(&sc.cam, v), &sc.opts),
        &mut x,
        &mut num,
    );
    let mut ana = g.camera.rotation.to_flat().to_vec();
    ana.extend(g.camera.translation.to_array());
    let rep = tol.check(&ana, &num);
    println!("{label}: view matrix {rep}");
    rep.assert_passed(&format!("{label}: view matrix"));
    let mut x = vec![0.0; 6];
    let mut num = vec![0.0; 6];
    central_gradient(
        |v: &[f64]| loss(sc, &sc.splats, &perturb_left(&sc.cam, v), &sc.opts),
        &mut x,
        &mut num,
    );
    let rep = tol.check(&g.camera.to_pose_left_se3(&sc.cam), &num);
    println!("{label}: pose_left_se3 {rep}");
    rep.assert_passed(&format!("{label}: pose"));
    let mut x = sc.opts.background.to_vec();
    let mut num = vec![0.0; 3];
    central_gradient(
        |v: &[f64]| {
            let o = RenderOptions {
                background: [v[0], v[1], v[2]],
                ..sc.opts
            };
            loss(sc, &sc.splats, &sc.cam, &o)
        },
        &mut x,
        &mut num,
    );
    tol.check(&g.background, &num).assert_passed("background");

    // Quaternion gradients are tangential; every contributing Gaussian gets a gradient in
    // every parameter group.
    for i in 0..sc.splats.len() {
        let q = sc.splats.quats[i];
        assert!(
            g.splats.quats[i].dot(q).abs() < 1e-10 * (1.0 + g.splats.quats[i].norm()),
            "dq ⟂ q"
        );
        let contributes = g.raster.colors[i].iter().any(|v| *v != 0.0);
        if contributes {
            let groups = [
                g.splats.means[i].norm(),
                g.splats.log_scales[i].norm(),
                g.splats.quats[i].norm(),
                g.splats.opacity_logits[i].abs(),
                g.splats
                    .sh_coeffs(i)
                    .iter()
                    .flatten()
                    .map(|v| v.abs())
                    .sum::<f64>(),
            ];
            assert!(
                groups.iter().all(|v| *v > 0.0),
                "{label}: Gaussian {i} has a silent lane group {groups:?}"
            );
        }
    }
}

fn dot_test(label: &str, sc: &Scene) {
    let fwd = render(&sc.splats, &sc.cam, &sc.opts);
    let mut x0 = Vec::new();
    sc.splats.write_flat(&mut x0);
    let np_ = x0.len();
    x0.extend(pose12(&sc.cam));
    x0.extend(sc.opts.background);
    let n_in = x0.len();
    let n_px = W * H;
    let cam_d = sc.cam.cast::<Dual<f64>>();
    let mut s_d: Splats<Dual<f64>> = sc.splats.cast();
    let r = vjp_dot_test(
        |v: &[f64], out: &mut [f64]| {
            dual_jvp(
                |x: &[Dual<f64>], y: &mut [Dual<f64>]| {
                    s_d.read_flat(&x[..np_]);
                    let cam = with_pose(&cam_d, &x[np_..]);
                    let bg = &x[np_ + 12..];
                    let opts = RenderOptions {
                        eps2d: Dual::constant(0.3),
                        radius: sc.opts.radius,
                        mode: sc.opts.mode,
                        sh_degree: sc.opts.sh_degree,
                        background: [bg[0], bg[1], bg[2]],
                        par: sc.opts.par,
                    };
                    let r = render(&s_d, &cam, &opts).raster;
                    y[..3 * n_px].copy_from_slice(r.rgb.data());
                    y[3 * n_px..4 * n_px].copy_from_slice(&r.alpha);
                    y[4 * n_px..].copy_from_slice(&r.depth);
                },
                &x0,
                v,
                out,
            );
        },
        |w: &[f64], out: &mut [f64]| {
            let d = PixelGrad {
                rgb: &w[..3 * n_px],
                alpha: Some(&w[3 * n_px..4 * n_px]),
                depth: Some(&w[4 * n_px..]),
            };
            let g = render_vjp(&sc.splats, &sc.cam, &sc.opts, &fwd, &d);
            let mut v = Vec::new();
            g.splats.write_flat(&mut v);
            v.extend(g.camera.rotation.to_flat());
            v.extend(g.camera.translation.to_array());
            v.extend(g.background);
            out.copy_from_slice(&v);
        },
        n_in,
        5 * n_px,
        41,
    );
    println!(
        "{label}: dot test against dual numbers, residual {r:.2e} ({n_in} inputs, {} outputs)",
        5 * n_px
    );
    assert!(r < 1e-12, "{label}: dot test residual {r}");
}

#[test]
fn render_vjp_matches_central_differences() {
    let mut totals = Decisions::default();
    for mode in [RasterMode::Classic, RasterMode::Antialiased] {
        for (kind, seed) in [
            (Kind::Regular, 100),
            (Kind::Regular, 400),
            (Kind::Opaque, 700),
        ] {
            let (sc, d) = good_scene(seed, kind, mode);
            let label = format!("{mode:?}/{kind:?}");
            println!("{label}: {d:?}");
            check_scene(&label, &sc);
            totals.composited += d.composited;
            totals.clamped += d.clamped;
            totals.terminated += d.terminated;
            totals.sh_clamped += d.sh_clamped;
        }
    }
    assert!(
        totals.clamped > 0 && totals.terminated > 0 && totals.sh_clamped > 0,
        "the scenes exercise the clamp, termination and SH clamp: {totals:?}"
    );
}

#[test]
fn render_vjp_passes_the_dot_test_against_dual_numbers() {
    for mode in [RasterMode::Classic, RasterMode::Antialiased] {
        for (kind, seed) in [(Kind::Regular, 100), (Kind::Opaque, 700)] {
            let (sc, _) = good_scene(seed, kind, mode);
            dot_test(&format!("{mode:?}/{kind:?}"), &sc);
        }
    }
}
