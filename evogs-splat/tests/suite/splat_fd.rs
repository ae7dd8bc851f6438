//! Central-difference, forward-mode and dot-product checks of the per-Gaussian VJPs:
//! projection (both FOV-clamp branches, compensation, view matrix, se(3) pose) and SH colour
//! (degrees 0–3, clamped channels, camera centre). All in f64.

use crate::splat_common;

use evogs_math::diff::{GradCheck, central_gradient, dual_jvp, vjp_dot_test};
use evogs_math::rng::SplitMix64;
use evogs_math::sh::{sh_coeff_count, sh_eval};
use evogs_math::{Dual, Quat, Vec2, Vec3};
use evogs_splat::{
    PinholeCamera, ProjectOptions, ProjectedGrad, RadiusMode, project, project_vjp, sh_color,
    sh_color_vjp,
};
use splat_common::{perturb_left, pose12, test_camera, with_pose};

/// One Gaussian for the projection tests.
#[derive(Clone, Copy, Debug)]
struct G {
    mean: Vec3<f64>,
    log_scale: Vec3<f64>,
    quat: Quat<f64>,
    opacity: f64,
}

/// Gaussians placed in camera space at ratios `x/z`, `y/z` given as multiples of the FOV
/// clamp limits (|k| > 1 is clamped), mapped to the world.
fn gaussians(cam: &PinholeCamera<f64>, rng: &mut SplitMix64) -> Vec<(&'static str, G)> {
    let (w, h) = (cam.width as f64, cam.height as f64);
    let lim = |size: f64, c: f64, f: f64| {
        let tan = 0.5 * size / f;
        ((size - c) / f + 0.3 * tan, c / f + 0.3 * tan)
    };
    let (lxp, lxn) = lim(w, cam.cx, cam.fx);
    let (lyp, lyn) = lim(h, cam.cy, cam.fy);
    let kinds: [(&str, f64, f64, f64); 8] = [
        ("inside", 0.2, -0.1, -2.0),
        ("inside", -0.5, 0.4, -1.2),
        ("inside", 0.7, 0.6, -1.6),
        ("inside", -0.3, -0.8, -0.8),
        ("clamped_x+", 1.3, 0.2, 0.4),
        ("clamped_x-", -1.25, -0.3, 0.4),
        ("clamped_y+", 0.1, 1.3, 0.4),
        ("clamped_xy", -1.3, -1.3, 0.6),
    ];
    kinds
        .iter()
        .map(|&(name, kx, ky, ls)| {
            let z = rng.uniform(3.0, 6.0);
            let rx = if kx >= 0.0 { kx * lxp } else { kx * lxn };
            let ry = if ky >= 0.0 { ky * lyp } else { ky * lyn };
            let p_cam = Vec3::new(rx * z, ry * z, z);
            let mean = cam.rotation.tr_mul_vec(p_cam - cam.translation);
            let log_scale = Vec3::new(
                ls + rng.uniform(-0.3, 0.3),
                ls - 0.5 + rng.uniform(-0.3, 0.3),
                ls - 0.2 + rng.uniform(-0.3, 0.3),
            );
            let quat = Quat::new(rng.normal(), rng.normal(), rng.normal(), rng.normal())
                .scale(rng.uniform(0.5, 2.0));
            (
                name,
                G {
                    mean,
                    log_scale,
                    quat,
                    opacity: rng.uniform(0.2, 0.9),
                },
            )
        })
        .collect()
}

fn cotangent(rng: &mut SplitMix64) -> ProjectedGrad<f64> {
    ProjectedGrad {
        means2d: Vec2::new(rng.normal(), rng.normal()),
        depth: rng.normal(),
        conic: [rng.normal(), rng.normal(), rng.normal()],
        compensation: rng.normal(),
    }
}

fn loss(g: &G, cam: &PinholeCamera<f64>, o: &ProjectOptions<f64>, d: &ProjectedGrad<f64>) -> f64 {
    let p = project(g.mean, g.log_scale, g.quat, g.opacity, cam, o);
    p.means2d.dot(d.means2d)
        + p.depth * d.depth
        + p.compensation * d.compensation
        + (0..3).map(|k| p.conic[k] * d.conic[k]).sum::<f64>()
}

#[test]
fn project_vjp_matches_central_differences() {
    let cam = test_camera(40, 30);
    let mut rng = SplitMix64::new(11);
    let o = ProjectOptions {
        eps2d: 0.3,
        radius: RadiusMode::Plain,
        antialiased: false,
    };
    let tol = GradCheck::new(1e-8, 1e-6);
    let mut n_clamped = [0; 2];
    for (kind, g) in gaussians(&cam, &mut rng) {
        let p = project(g.mean, g.log_scale, g.quat, g.opacity, &cam, &o);
        assert!(p.valid, "{kind} Gaussian must be valid");
        n_clamped[0] += usize::from(p.fov_clamped[0]);
        n_clamped[1] += usize::from(p.fov_clamped[1]);
        assert_eq!(kind.contains('x'), p.fov_clamped[0], "{kind}: x clamp");
        assert_eq!(kind.contains('y'), p.fov_clamped[1], "{kind}: y clamp");
        let d = cotangent(&mut rng);
        let a = project_vjp(g.mean, g.log_scale, g.quat, g.opacity, &cam, &o, &d);

        // Gaussian parameters.
        let mut x: Vec<f64> = [g.mean.to_array(), g.log_scale.to_array()].concat();
        x.extend(g.quat.to_array());
        let mut num = vec![0.0; 10];
        central_gradient(
            |v: &[f64]| {
                let gg = G {
                    mean: Vec3::from_slice(v),
                    log_scale: Vec3::from_slice(&v[3..]),
                    quat: Quat::from_slice(&v[6..]),
                    opacity: g.opacity,
                };
                loss(&gg, &cam, &o, &d)
            },
            &mut x,
            &mut num,
        );
        let mut ana: Vec<f64> = [a.mean.to_array(), a.log_scale.to_array()].concat();
        ana.extend(a.quat.to_array());
        let rep = tol.check(&ana, &num);
        println!("{kind:<11} params  {rep}");
        rep.assert_passed(kind);
        assert!(
            a.quat.dot(g.quat).abs() < 1e-12 * (1.0 + a.quat.norm()),
            "dq ⟂ q"
        );

        // View-matrix entries (R, t as 12 independent numbers).
        let mut x = pose12(&cam);
        let mut num = vec![0.0; 12];
        central_gradient(
            |v: &[f64]| loss(&g, &with_pose(&cam, v), &o, &d),
            &mut x,
            &mut num,
        );
        let mut ana = a.camera.rotation.to_flat().to_vec();
        ana.extend(a.camera.translation.to_array());
        let rep = tol.check(&ana, &num);
        println!("{kind:<11} viewmat {rep}");
        rep.assert_passed("viewmat");

        // Left se(3) perturbation.
        let mut x = vec![0.0; 6];
        let mut num = vec![0.0; 6];
        central_gradient(
            |v: &[f64]| loss(&g, &perturb_left(&cam, v), &o, &d),
            &mut x,
            &mut num,
        );
        let rep = tol.check(&a.camera.to_pose_left_se3(&cam), &num);
        println!("{kind:<11} pose    {rep}");
        rep.assert_passed("pose_left_se3");
    }
    assert!(
        n_clamped[0] >= 3 && n_clamped[1] >= 2,
        "both clamp branches exercised"
    );
}

#[test]
fn project_vjp_passes_the_dot_test_against_dual_numbers() {
    let cam = test_camera(40, 30);
    let mut rng = SplitMix64::new(5);
    let o = ProjectOptions {
        eps2d: 0.3,
        radius: RadiusMode::Plain,
        antialiased: false,
    };
    for (kind, g) in gaussians(&cam, &mut rng) {
        let mut x0: Vec<f64> = [g.mean.to_array(), g.log_scale.to_array()].concat();
        x0.extend(g.quat.to_array());
        x0.extend(pose12(&cam));
        let cam_d = cam.cast::<Dual<f64>>();
        let od = ProjectOptions {
            eps2d: Dual::constant(0.3),
            radius: RadiusMode::Plain,
            antialiased: false,
        };
        let r = vjp_dot_test(
            |v: &[f64], out: &mut [f64]| {
                dual_jvp(
                    |x: &[Dual<f64>], y: &mut [Dual<f64>]| {
                        let c = with_pose(&cam_d, &x[10..]);
                        let p = project(
                            Vec3::from_slice(x),
                            Vec3::from_slice(&x[3..]),
                            Quat::from_slice(&x[6..]),
                            Dual::constant(g.opacity),
                            &c,
                            &od,
                        );
                        y.copy_from_slice(&[
                            p.means2d.x,
                            p.means2d.y,
                            p.depth,
                            p.conic[0],
                            p.conic[1],
                            p.conic[2],
                            p.compensation,
                        ]);
                    },
                    &x0,
                    v,
                    out,
                );
            },
            |w: &[f64], out: &mut [f64]| {
                let d = ProjectedGrad {
                    means2d: Vec2::new(w[0], w[1]),
                    depth: w[2],
                    conic: [w[3], w[4], w[5]],
                    compensation: w[6],
                };
                let a = project_vjp(g.mean, g.log_scale, g.quat, g.opacity, &cam, &o, &d);
                let mut v: Vec<f64> = [a.mean.to_array(), a.log_scale.to_array()].concat();
                v.extend(a.quat.to_array());
                v.extend(a.camera.rotation.to_flat());
                v.extend(a.camera.translation.to_array());
                out.copy_from_slice(&v);
            },
            22,
            7,
            17,
        );
        println!("{kind:<11} dot-test residual {r:.2e}");
        assert!(r < 1e-13, "{kind}: dot test residual {r}");
    }
}

#[test]
fn culled_gaussians_get_no_gradient_and_no_nan() {
    let cam = test_camera(40, 30);
    let o = ProjectOptions::<f64>::default();
    let d = ProjectedGrad {
        means2d: Vec2::new(1.0, 1.0),
        depth: 1.0,
        conic: [1.0; 3],
        compensation: 1.0,
    };
    let behind = cam
        .rotation
        .tr_mul_vec(Vec3::new(0.0, 0.0, -2.0) - cam.translation);
    let at_eye = cam.center();
    for (what, mean, q) in [
        ("behind", behind, Quat::identity()),
        ("at the camera centre", at_eye, Quat::identity()),
        ("zero quaternion", Vec3::zero(), Quat::zero()),
        ("NaN mean", Vec3::new(f64::NAN, 0.0, 0.0), Quat::identity()),
    ] {
        let p = project(mean, Vec3::splat(-1.0), q, 0.5, &cam, &o);
        assert!(!p.valid, "{what}: culled");
        let floats = [
            p.means2d.x,
            p.means2d.y,
            p.conic[0],
            p.conic[1],
            p.conic[2],
            p.compensation,
        ];
        assert!(
            floats.iter().all(|v| v.is_finite()),
            "{what}: finite outputs"
        );
        let g = project_vjp(mean, Vec3::splat(-1.0), q, 0.5, &cam, &o, &d);
        assert!(
            g.mean.norm() == 0.0 && g.camera.translation.norm() == 0.0,
            "{what}: zero gradient"
        );
    }
}

fn coeffs(rng: &mut SplitMix64, degree: usize) -> Vec<[f64; 3]> {
    (0..sh_coeff_count(degree))
        .map(|k| {
            let s = if k == 0 { 1.0 } else { 0.4 };
            [s * rng.normal(), s * rng.normal(), s * rng.normal()]
        })
        .collect()
}

#[test]
fn sh_color_vjp_matches_central_differences_and_dual_numbers() {
    let cam = test_camera(40, 30);
    let center = cam.center();
    let mut rng = SplitMix64::new(23);
    let tol = GradCheck::new(1e-9, 1e-7);
    let mut clamped_channels = 0;
    for degree in 0..=3 {
        for trial in 0..6 {
            let mut c = coeffs(&mut rng, degree);
            if trial == 0 {
                c[0][1] = -4.0; // a clamped channel
            }
            let mean = Vec3::new(
                rng.uniform(-1.0, 1.0),
                rng.uniform(-1.0, 1.0),
                rng.uniform(-1.0, 1.0),
            );
            let raw = sh_eval(degree, &c, mean - center);
            if raw.iter().any(|v| (v + 0.5).abs() < 1e-3) {
                continue; // too close to the clamp for central differences
            }
            clamped_channels += raw.iter().filter(|v| **v + 0.5 < 0.0).count();
            let g = [rng.normal(), rng.normal(), rng.normal()];
            let dot = |col: [f64; 3]| col[0] * g[0] + col[1] * g[1] + col[2] * g[2];
            let k = c.len();
            let mut d_coeffs = vec![[0.0; 3]; k];
            let (d_mean, d_center) = sh_color_vjp(degree, &c, mean, center, g, &mut d_coeffs);
            // Mean and centre.
            let mut x: Vec<f64> = [mean.to_array(), center.to_array()].concat();
            let mut num = vec![0.0; 6];
            central_gradient(
                |v: &[f64]| {
                    dot(sh_color(
                        degree,
                        &c,
                        Vec3::from_slice(v),
                        Vec3::from_slice(&v[3..]),
                    ))
                },
                &mut x,
                &mut num,
            );
            let ana = [d_mean.to_array(), d_center.to_array()].concat();
            tol.check(&ana, &num)
                .assert_passed("colour: mean and centre");
            // Coefficients.
            let mut x: Vec<f64> = c.iter().flatten().copied().collect();
            let mut num = vec![0.0; 3 * k];
            central_gradient(
                |v: &[f64]| {
                    let cc: Vec<[f64; 3]> = v.chunks(3).map(|s| [s[0], s[1], s[2]]).collect();
                    dot(sh_color(degree, &cc, mean, center))
                },
                &mut x,
                &mut num,
            );
            let ana: Vec<f64> = d_coeffs.iter().flatten().copied().collect();
            tol.check(&ana, &num).assert_passed("colour: coefficients");
            // Through the camera pose: centre = inverse(V)[:3, 3].
            let cg = cam.center_vjp(d_center);
            let mut x = pose12(&cam);
            let mut num = vec![0.0; 12];
            central_gradient(
                |v: &[f64]| dot(sh_color(degree, &c, mean, with_pose(&cam, v).center())),
                &mut x,
                &mut num,
            );
            let mut ana = cg.rotation.to_flat().to_vec();
            ana.extend(cg.translation.to_array());
            tol.check(&ana, &num).assert_passed("colour: view matrix");
            // Dot test with forward mode over (mean, centre, coefficients).
            let mut x0: Vec<f64> = [mean.to_array(), center.to_array()].concat();
            x0.extend(c.iter().flatten());
            let n_in = x0.len();
            let r = vjp_dot_test(
                |v: &[f64], out: &mut [f64]| {
                    dual_jvp(
                        |x: &[Dual<f64>], y: &mut [Dual<f64>]| {
                            let cc: Vec<[Dual<f64>; 3]> =
                                x[6..].chunks(3).map(|s| [s[0], s[1], s[2]]).collect();
                            y.copy_from_slice(&sh_color(
                                degree,
                                &cc,
                                Vec3::from_slice(x),
                                Vec3::from_slice(&x[3..]),
                            ));
                        },
                        &x0,
                        v,
                        out,
                    );
                },
                |w: &[f64], out: &mut [f64]| {
                    let mut dc = vec![[0.0; 3]; k];
                    let (dm, dcen) =
                        sh_color_vjp(degree, &c, mean, center, [w[0], w[1], w[2]], &mut dc);
                    dm.write_to(out);
                    dcen.write_to(&mut out[3..]);
                    for (o, v) in out[6..].iter_mut().zip(dc.iter().flatten()) {
                        *o = *v;
                    }
                },
                n_in,
                3,
                29,
            );
            assert!(r < 1e-13, "degree {degree}: dot test {r}");
        }
    }
    println!("clamped channels exercised: {clamped_channels}");
    assert!(clamped_channels >= 4, "clamp branch exercised");
}

#[test]
fn pose_gradient_of_the_camera_centre_is_a_pure_translation() {
    // A left perturbation rotates about the camera centre: the centre path contributes
    // nothing to dL/dφ, and dL/dρ = −R d_c.
    let cam = test_camera(40, 30);
    let dc = Vec3::new(0.3, -1.2, 0.7);
    let pose = cam.center_vjp(dc).to_pose_left_se3(&cam);
    let want = -cam.rotation.mul_vec(dc);
    for k in 0..3 {
        assert!((pose[k] - want[k]).abs() < 1e-13, "ρ component {k}");
        assert!(
            pose[3 + k].abs() < 1e-13,
            "φ component {k}: {}",
            pose[3 + k]
        );
    }
}
