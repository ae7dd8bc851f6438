//! Seeded fuzz test on stable Rust (SplitMix64 seeds, reproducible): thousands of random and
//! extreme inputs through the projection and its VJP, preprocessing + the reference
//! rasterizer and their VJPs, and the SO(3) maps. The properties are in
//! `evogs_tests::fuzz`; a failure names its seed (rerun one case with that seed).

use evogs_tests::fuzz::{projection_case, raster_case, so3_case};

#[test]
fn projection_never_panics_and_stays_finite() {
    for seed in 0..20_000 {
        projection_case(seed);
    }
}

#[test]
fn rasterization_never_panics_and_is_not_poisoned() {
    for seed in 0..3_000 {
        raster_case(seed);
    }
}

#[test]
fn so3_maps_never_panic_and_stay_finite() {
    for seed in 0..20_000 {
        so3_case(seed);
    }
}

/// Regression for what seed 15156 of the projection property found: a Gaussian with finite
/// but huge scales whose 2D covariance is finite while its determinant overflows must be
/// culled (or kept with a usable conic), never kept with a zero conic and a NaN VJP.
#[test]
fn a_gaussian_whose_covariance_determinant_overflows_is_culled() {
    use evogs_math::{Quat, Vec2, Vec3};
    use evogs_splat::{PinholeCamera, ProjectOptions, ProjectedGrad, project, project_vjp};
    let cam = PinholeCamera::look_at(
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::zero(),
        Vec3::new(0.0, 1.0, 0.0),
        0.8,
        64,
        48,
    )
    .expect("camera");
    let (mean, ls, q) = (
        Vec3::zero(),
        Vec3::splat(345.0),
        Quat::new(0.9, 0.1, -0.2, 0.3),
    );
    let o = ProjectOptions::default();
    let p = project(mean, ls, q, 0.8, &cam, &o);
    let d = ProjectedGrad {
        means2d: Vec2::new(0.3, -0.2),
        depth: 0.1,
        conic: [0.5, -0.1, 0.2],
        compensation: 0.4,
    };
    let g = project_vjp(mean, ls, q, 0.8, &cam, &o, &d);
    let finite = g.mean.is_finite() && g.log_scale.is_finite() && g.quat.is_finite();
    assert!(
        !p.valid || (p.conic.iter().any(|&c| c != 0.0) && finite),
        "valid with conic {:?} and VJP {g:?} (cov2d {:?})",
        p.conic,
        p.cov2d
    );
}
