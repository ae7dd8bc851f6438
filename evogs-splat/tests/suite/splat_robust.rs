//! Robustness of the reference chain: empty scenes, NaN/Inf and degenerate Gaussians,
//! Gaussians behind or at the camera, stacked opaque splats, extreme scales, and
//! determinism across `Par` values.

use evogs_math::activation::logit;
use evogs_math::{Par, Quat, Vec3};
use evogs_splat::{
    PinholeCamera, PixelGrad, RenderOptions, Splats, benchmark_scene, render, render_vjp,
};

fn cam() -> PinholeCamera<f64> {
    PinholeCamera::look_at(
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::zero(),
        Vec3::new(0.0, 1.0, 0.0),
        0.8,
        24,
        20,
    )
    .expect("camera")
}

fn ones(n: usize) -> Vec<f64> {
    vec![1.0; n]
}

fn all_finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

#[test]
fn empty_scene_renders_the_background() {
    let cam = cam();
    let opts = RenderOptions {
        background: [0.1, 0.2, 0.3],
        ..RenderOptions::default()
    };
    let s = Splats::<f64>::new(3);
    let fwd = render(&s, &cam, &opts);
    assert!(
        fwd.raster
            .rgb
            .data()
            .chunks(3)
            .all(|p| p == [0.1, 0.2, 0.3]),
        "background only"
    );
    assert!(fwd.raster.alpha.iter().all(|&a| a == 0.0), "transparent");
    let d_rgb = ones(24 * 20 * 3);
    let g = render_vjp(
        &s,
        &cam,
        &opts,
        &fwd,
        &PixelGrad {
            rgb: &d_rgb,
            alpha: None,
            depth: None,
        },
    );
    assert!(
        g.splats.is_empty() && g.camera.translation.norm() == 0.0,
        "no gradients"
    );
    assert!((g.background[0] - 480.0).abs() < 1e-12, "d bg = Σ T_final");
}

#[test]
fn degenerate_gaussians_are_culled_without_poisoning_the_image() {
    let cam = cam();
    let opts = RenderOptions::<f64>::default();
    let mut good = Splats::new(1);
    let sh = [
        [0.4, -0.2, 0.1],
        [0.1, 0.0, -0.1],
        [0.0, 0.2, 0.1],
        [0.05, 0.05, 0.0],
    ];
    good.push(
        Vec3::new(0.1, 0.0, 0.0),
        Vec3::splat(-1.5),
        Quat::new(1.0, 0.2, 0.0, 0.1),
        logit(0.7),
        &sh,
    );
    good.push(
        Vec3::new(-0.2, 0.1, 0.3),
        Vec3::new(-1.0, -2.0, -1.5),
        Quat::new(0.3, 0.2, 0.9, 0.1),
        logit(0.5),
        &sh,
    );
    let mut bad = good.clone();
    let nan = f64::NAN;
    let inf = f64::INFINITY;
    let mut sh_nan = sh;
    sh_nan[2][1] = nan;
    for (mean, ls, q, o, c) in [
        (
            Vec3::new(nan, 0.0, 0.0),
            Vec3::splat(-1.0),
            Quat::identity(),
            0.0,
            sh,
        ),
        (Vec3::zero(), Vec3::splat(inf), Quat::identity(), 0.0, sh),
        (Vec3::zero(), Vec3::splat(-1.0), Quat::zero(), 0.0, sh),
        (Vec3::zero(), Vec3::splat(-1.0), Quat::identity(), nan, sh),
        (
            Vec3::zero(),
            Vec3::splat(-1.0),
            Quat::identity(),
            0.0,
            sh_nan,
        ),
        (
            Vec3::new(0.0, 0.0, 6.0),
            Vec3::splat(-1.0),
            Quat::identity(),
            0.0,
            sh,
        ), // behind
        (
            Vec3::new(0.0, 0.0, 4.0),
            Vec3::splat(-1.0),
            Quat::identity(),
            0.0,
            sh,
        ), // at the eye
        (Vec3::zero(), Vec3::splat(-400.0), Quat::identity(), 0.0, sh), // tiny
        (Vec3::zero(), Vec3::splat(40.0), Quat::identity(), 0.0, sh),   // huge
    ] {
        bad.push(mean, ls, q, o, &c);
    }
    let f_good = render(&good, &cam, &opts);
    let f_bad = render(&bad, &cam, &opts);
    for r in [&f_good.raster, &f_bad.raster] {
        assert!(
            all_finite(r.rgb.data()) && all_finite(&r.alpha) && all_finite(&r.depth),
            "finite images"
        );
    }
    // NaN/Inf/zero-quaternion/behind/at-the-eye Gaussians are culled; the zero-size one is
    // valid (the 0.3 px² low-pass gives it a footprint), as is the huge one.
    assert!(
        f_bad.pre.valid[2..9].iter().all(|v| !v),
        "degenerate ones culled: {:?}",
        f_bad.pre.valid
    );
    assert!(
        f_bad.pre.valid[9] && f_bad.pre.valid[10],
        "tiny and huge ones are valid"
    );
    let np = 24 * 20;
    let (d_rgb, d_a, d_d) = (ones(3 * np), ones(np), ones(np));
    let d = PixelGrad {
        rgb: &d_rgb,
        alpha: Some(&d_a),
        depth: Some(&d_d),
    };
    let g = render_vjp(&bad, &cam, &opts, &f_bad, &d);
    let mut flat = Vec::new();
    g.splats.write_flat(&mut flat);
    assert!(all_finite(&flat), "finite gradients");
    assert!(
        all_finite(&g.camera.rotation.to_flat()) && g.camera.translation.is_finite(),
        "finite camera gradient"
    );
}

#[test]
fn stacked_opaque_splats_stop_before_the_threshold() {
    let cam = cam();
    let opts = RenderOptions::<f64>::default();
    let mut s = Splats::new(0);
    for k in 0..12 {
        s.push(
            Vec3::new(0.0, 0.0, -0.1 * f64::from(k)),
            Vec3::splat(0.5),
            Quat::identity(),
            logit(0.995),
            &[[0.3, 0.1, -0.2]],
        );
    }
    let fwd = render(&s, &cam, &opts);
    let r = &fwd.raster;
    assert!(
        r.final_t.iter().all(|&t| t > 1e-4),
        "exclusive stop keeps T_final > 1e-4"
    );
    assert!(r.terminated.iter().any(|&t| t), "pixels terminate");
    // At the centre α ≈ 0.993: the second layer would bring T below 1e-4, so it stops first.
    let centre = 10 * 24 + 12;
    assert!(
        r.terminated[centre] && r.n_contrib[centre] == 1,
        "centre pixel: {}",
        r.n_contrib[centre]
    );
    let np = 24 * 20;
    let (d_rgb, d_a) = (ones(3 * np), ones(np));
    let g = render_vjp(
        &s,
        &cam,
        &opts,
        &fwd,
        &PixelGrad {
            rgb: &d_rgb,
            alpha: Some(&d_a),
            depth: Some(&d_a),
        },
    );
    let mut flat = Vec::new();
    g.splats.write_flat(&mut flat);
    assert!(all_finite(&flat), "finite gradients with saturated alpha");
}

#[test]
fn rendering_is_deterministic_for_every_par() {
    let (s, cam) = benchmark_scene::<f32>(1500, 48, 9);
    let mut pars = vec![Par::Seq];
    #[cfg(feature = "rayon")]
    pars.push(Par::Rayon);
    let mut first = None;
    for par in pars {
        for _ in 0..2 {
            let opts = RenderOptions {
                par,
                ..RenderOptions::default()
            };
            let fwd = render(&s, &cam, &opts);
            let d_rgb: Vec<f32> = (0..48 * 48 * 3)
                .map(|i| ((i % 7) as f32 - 3.0) * 0.1)
                .collect();
            let g = render_vjp(
                &s,
                &cam,
                &opts,
                &fwd,
                &PixelGrad {
                    rgb: &d_rgb,
                    alpha: None,
                    depth: None,
                },
            );
            let mut flat = Vec::new();
            g.splats.write_flat(&mut flat);
            let bits: Vec<u32> = fwd
                .raster
                .rgb
                .data()
                .iter()
                .chain(&flat)
                .chain(&g.camera.rotation.to_flat())
                .map(|v| v.to_bits())
                .collect();
            match &first {
                None => first = Some(bits),
                Some(b) => assert!(*b == bits, "bitwise identical across runs and {par:?}"),
            }
        }
    }
}
