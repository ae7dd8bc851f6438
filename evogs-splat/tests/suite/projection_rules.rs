//! The projection's rules at their edges: the FOV clamp and the near and far planes are
//! strict; a dilated 2D covariance whose determinant is zero or negative has a zero conic
//! (and the Gaussian is culled with its other floats kept); floats that overflow (pixel
//! coordinates, an f32 2D covariance) cull the Gaussian with every float of the result
//! finite.

use evogs_math::{Quat, Real, Vec3};
use evogs_splat::project::FOV_CLAMP_MARGIN;
use evogs_splat::{PinholeCamera, ProjectOptions, Projected, project};

/// A camera at the origin looking down +z: 64×48 pixels, fx = 64, fy = 48, the principal
/// point at the centre, near 0.01, far 100.
fn camera<T: Real>() -> PinholeCamera<T> {
    let c = T::from_f64;
    let (o, l) = (T::ZERO, T::ONE);
    let id = [[l, o, o, o], [o, l, o, o], [o, o, l, o], [o, o, o, l]];
    let k = [[c(64.0), o, c(32.0)], [o, c(48.0), c(24.0)], [o, o, l]];
    PinholeCamera::from_viewmat(id, k, 64, 48, c(0.01), c(100.0)).expect("camera")
}

/// Every float of a projection.
fn floats<T: Real>(p: &Projected<T>) -> [T; 13] {
    [
        p.mean_cam.x,
        p.mean_cam.y,
        p.mean_cam.z,
        p.means2d.x,
        p.means2d.y,
        p.depth,
        p.cov2d.xx,
        p.cov2d.xy,
        p.cov2d.yy,
        p.conic[0],
        p.conic[1],
        p.conic[2],
        p.compensation,
    ]
}

/// The FOV clamp is strict, as in gsplat: a ratio exactly at a limit is not clamped (its
/// Jacobian keeps the `t_x`, `t_y` dependence), the next float beyond it is.
#[test]
fn the_fov_clamp_starts_just_beyond_its_limits() {
    // Every limit is 0.5 + 0.3·0.5 for this camera, formed here as project forms it.
    let cam = camera::<f64>();
    let lim = 0.5 + FOV_CLAMP_MARGIN * 0.5;
    let o = ProjectOptions::default();
    for (axis, sign) in [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)] {
        for (ratio, clamped) in [
            (lim, false),
            (lim.next_up(), true),
            (lim.next_down(), false),
        ] {
            let mut mean = Vec3::new(0.0, 0.0, 1.0);
            if axis == 0 {
                mean.x = sign * ratio;
            } else {
                mean.y = sign * ratio;
            }
            let p = project(mean, Vec3::splat(-1.5), Quat::identity(), 0.9, &cam, &o);
            let mut expected = [false; 2];
            expected[axis] = clamped;
            assert_eq!(p.fov_clamped, expected, "{mean:?}");
        }
    }
}

#[test]
fn the_near_and_far_planes_are_strict() {
    let cam = camera::<f64>();
    let o = ProjectOptions::default();
    for (depth, valid) in [
        (cam.near, false),
        (cam.near.next_up(), true),
        (cam.far, false),
        (cam.far.next_down(), true),
    ] {
        let mean = Vec3::new(0.0, 0.0, depth);
        let p = project(mean, Vec3::splat(-3.0), Quat::identity(), 0.9, &cam, &o);
        assert_eq!(p.valid, valid, "depth {depth}");
        assert!(p.depth.to_bits() == depth.to_bits(), "depth {depth}");
    }
}

#[test]
fn a_determinant_of_zero_or_below_zeroes_the_conic_and_keeps_the_plain_formulas() {
    let cam = camera::<f64>();
    // A needle along x (two scales zero): det A = 0 exactly. With ε = 0, det B = 0; with
    // ε = −1 and A_xx = 32² > 1, det B = −(A_xx − 1) < 0.
    let needle = Vec3::new(0.0, f64::NEG_INFINITY, f64::NEG_INFINITY);
    for eps2d in [0.0, -1.0] {
        let o = ProjectOptions {
            eps2d,
            ..ProjectOptions::default()
        };
        let mean = Vec3::new(0.25, 0.5, 2.0);
        let p = project(mean, needle, Quat::identity(), 0.9, &cam, &o);
        assert!(!p.valid && p.radii == [0, 0], "ε = {eps2d}: culled");
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let zero = [p.conic[0], p.conic[1], p.conic[2], p.compensation];
        assert_eq!(bits(&zero), bits(&[0.0; 4]), "ε = {eps2d}");
        // 64·0.25/2 + 32 and 48·0.5/2 + 24; A_xx = (64/2)².
        let kept = [p.means2d.x, p.means2d.y, p.cov2d.xx, p.cov2d.xy, p.cov2d.yy];
        assert_eq!(
            bits(&kept),
            bits(&[40.0, 36.0, 1024.0, 0.0, 0.0]),
            "ε = {eps2d}"
        );
    }
}

#[test]
fn floats_that_overflow_cull_with_every_float_finite() {
    let cam = camera::<f32>();
    let o = ProjectOptions::default();
    // (what, mean, log-scale)
    for (what, mean, log_scale) in [
        // x/z = 1e37: fx·x overflows; the clamped Jacobian and the covariance do not.
        ("pixel x", Vec3::new(1e37, 0.0, 1.0), Vec3::splat(-1.0)),
        ("pixel y", Vec3::new(0.0, -1e37, 1.0), Vec3::splat(-1.0)),
        // One scale of 1e18: A_xx = (64·1e18)² overflows f32, A_xy = 0 and A_yy do not.
        (
            "covariance",
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(41.45, -1.0, -1.0),
        ),
        (
            "covariance",
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(-1.0, 41.45, -1.0),
        ),
    ] {
        let p = project(mean, log_scale, Quat::identity(), 0.9, &cam, &o);
        assert!(!p.valid && p.radii == [0, 0], "{what}: culled");
        assert!(
            floats(&p).iter().all(|v| v.is_finite()),
            "{what}: every float finite: {p:?}"
        );
        assert_eq!(
            p.depth.to_bits(),
            1.0f32.to_bits(),
            "{what}: the depth is kept"
        );
    }
}

/// In antialiased mode the opacity-aware radii follow the opacity times the compensation:
/// `e = min(3.33, sqrt(2 ln(255 o ρ)))`, and `o ρ < 1/255` culls.
#[test]
fn antialiased_radii_follow_the_compensated_opacity() {
    let cam = camera::<f64>();
    let aa = ProjectOptions {
        antialiased: true,
        ..ProjectOptions::default()
    };
    let plain = ProjectOptions::default();
    // A Gaussian of about 0.6 px: ρ ≈ 0.5.
    let (mean, log_scale) = (Vec3::new(0.1, -0.05, 2.0), Vec3::new(-4.0, -4.2, -3.9));
    for opacity in [0.9, 0.2, 0.05, 0.02] {
        let p = project(mean, log_scale, Quat::identity(), opacity, &cam, &aa);
        let rho = p.compensation;
        assert!(rho > 0.3 && rho < 0.7, "ρ = {rho}");
        let extent = f64::min(3.33, (2.0 * (opacity * rho / (1.0 / 255.0)).ln()).sqrt());
        let radius = |a: f64| (extent * (a + 0.3).sqrt()).ceil().to_bits();
        let expected = [radius(p.cov2d.xx), radius(p.cov2d.yy)];
        assert!(p.valid, "o = {opacity}");
        let radii = p.radii.map(|r| f64::from(r).to_bits());
        assert_eq!(radii, expected, "o = {opacity}");
        // Without antialiasing the opacity alone sets them: never smaller.
        let q = project(mean, log_scale, Quat::identity(), opacity, &cam, &plain);
        assert!(q.radii[0] >= p.radii[0] && q.radii[1] >= p.radii[1]);
    }
    // o ≥ 1/255 but o ρ < 1/255: culled only when antialiased.
    let opacity = 1.5 / 255.0;
    let p = project(mean, log_scale, Quat::identity(), opacity, &cam, &aa);
    assert!(!p.valid && p.radii == [0, 0], "{p:?}");
    assert!(project(mean, log_scale, Quat::identity(), opacity, &cam, &plain).valid);
}

/// At an opacity of exactly 1/255 the opacity-aware extent `sqrt(2 ln(255 o))` is zero:
/// both radii are zero and the Gaussian is culled.
#[test]
fn an_opacity_of_exactly_the_threshold_has_no_extent() {
    let cam = camera::<f64>();
    let mean = Vec3::new(0.1, -0.05, 2.0);
    let o = ProjectOptions::default();
    let p = project(
        mean,
        Vec3::splat(-2.0),
        Quat::identity(),
        1.0 / 255.0,
        &cam,
        &o,
    );
    assert!(!p.valid && p.radii == [0, 0], "{p:?}");
    let above = (1.0_f64 / 255.0).next_up();
    assert!(project(mean, Vec3::splat(-2.0), Quat::identity(), above, &cam, &o).valid);
}

/// The box `means2d ± radii` must overlap the image strictly: a box that only touches an
/// edge is culled, one a hair further in is not.
#[test]
fn a_box_that_only_touches_the_image_is_culled() {
    let cam = camera::<f64>();
    let o = ProjectOptions::default();
    // A point Gaussian: A = 0, radius ceil(3.30·sqrt(0.3)) = 2 on both axes. Each mean puts
    // the box's far side exactly on an edge: x = −2 or 66 at depth 2, y = −2 or 50 at
    // depth 1.5 (64·1.0625/2 = 34, 48·0.8125/1.5 = 26).
    let point = Vec3::splat(f64::NEG_INFINITY);
    for (axis, edge) in [(0, -1.0625), (0, 1.0625), (1, -0.8125), (1, 0.8125)] {
        let depth = if axis == 0 { 2.0 } else { 1.5 };
        let inward = edge * (1.0 - 1e-12);
        for (offset, valid) in [(edge, false), (inward, true)] {
            let mut mean = Vec3::new(0.0, 0.0, depth);
            if axis == 0 {
                mean.x = offset;
            } else {
                mean.y = offset;
            }
            let p = project(mean, point, Quat::identity(), 0.9, &cam, &o);
            let touching = if axis == 0 { p.means2d.x } else { p.means2d.y };
            assert_eq!(p.valid, valid, "{mean:?}: {touching}");
            if valid {
                assert_eq!(p.radii, [2, 2]);
            }
        }
    }
}
