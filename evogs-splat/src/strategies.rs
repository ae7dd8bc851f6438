//! Public proptest strategies for evogs-splat (feature `proptest`): seeded random scenes
//! with their camera, look-at cameras around the origin, rigid motions, single Gaussians in
//! front of a camera, background colours and permutations.

use crate::{PinholeCamera, Splats, random_scene};
use alloc::vec::Vec;
use evogs_math::strategies::{so3_tangent, unit_quat, vec3};
use evogs_math::{Mat3, Quat, Vec3};
use proptest::prelude::*;

/// A random scene of `n` Gaussians (SH degree 3, means in `[−½, ½]³`) with the scene's
/// camera at distance 4 rendering `size × size` pixels: [`random_scene`] with a drawn seed,
/// log-scale range within `[0.01, 0.2]` and opacities within `[0.05, 0.99]`.
pub fn scene(
    n: core::ops::Range<usize>,
    size: usize,
) -> impl Strategy<Value = (Splats<f64>, PinholeCamera<f64>)> {
    (n, any::<u64>(), 0.01..0.08f64, 0.0..1.0f64, 0.05..0.9f64).prop_map(
        move |(n, seed, s_lo, s_span, o_lo)| {
            let s_hi = (s_lo * (1.0 + 2.0 * s_span)).min(0.2);
            let o_hi = (o_lo + 0.5).min(0.99);
            random_scene(n, size, seed, [s_lo, s_hi], [o_lo, o_hi])
        },
    )
}

/// A look-at camera on a sphere of radius `[3, 5]` around the origin, looking at it with a
/// 50–70° horizontal field of view (`width × height` pixels).
pub fn camera(width: usize, height: usize) -> impl Strategy<Value = PinholeCamera<f64>> {
    (vec3(1.0), 3.0..5.0f64, 0.9..1.2f64)
        .prop_filter("a direction away from the up axis", |(d, _, _)| {
            let n = d.norm();
            n > 0.2 && d.y.abs() < 0.9 * n
        })
        .prop_map(move |(d, r, fov)| {
            let eye = d * (r / d.norm());
            PinholeCamera::look_at(
                eye,
                Vec3::zero(),
                Vec3::new(0.0, 1.0, 0.0),
                fov,
                width,
                height,
            )
            .expect("valid look-at")
        })
}

/// A rigid motion `x ↦ R x + t`: a rotation (any angle below π) and a translation in
/// `[−r, r]³`, as `(R, its quaternion, t)`.
pub fn rigid_motion(r: f64) -> impl Strategy<Value = (Mat3<f64>, Quat<f64>, Vec3<f64>)> {
    (so3_tangent(3.0), vec3(r)).prop_map(|(phi, t)| {
        (
            evogs_math::so3::exp_matrix(phi),
            evogs_math::so3::exp_quat(phi),
            t,
        )
    })
}

/// One Gaussian `(mean, log_scale, raw quaternion, opacity)` near the origin (seen by
/// [`camera`]s): means in `[−½, ½]³`, log-scales in `[ln 0.02, ln 0.3]`, raw quaternions of
/// norm 0.5–2, opacities in `[0.05, 0.95]`.
pub fn gaussian() -> impl Strategy<Value = (Vec3<f64>, Vec3<f64>, Quat<f64>, f64)> {
    let ls = (0.02f64.ln())..(0.3f64.ln());
    (
        vec3(0.5),
        (ls.clone(), ls.clone(), ls),
        unit_quat(),
        0.5..2.0f64,
        0.05..0.95f64,
    )
        .prop_map(|(m, (a, b, c), q, s, o)| (m, Vec3::new(a, b, c), q.scale(s), o))
}

/// A background colour in `[0, 1]³`.
pub fn background() -> impl Strategy<Value = [f64; 3]> {
    (0.0..=1.0f64, 0.0..=1.0f64, 0.0..=1.0f64).prop_map(|(r, g, b)| [r, g, b])
}

/// A permutation of `0..n`.
pub fn permutation(n: usize) -> impl Strategy<Value = Vec<usize>> {
    Just((0..n).collect::<Vec<usize>>()).prop_shuffle()
}

#[cfg(test)]
mod tests {
    use super::*;
    use evogs_math::strategies::sample;

    #[test]
    fn scenes_span_their_documented_scale_and_opacity_ranges() {
        let scenes = sample(&scene(20..21, 16), 300);
        let (mut widest_scale, mut widest_opacity) = (0.0_f64, 0.0_f64);
        let mut narrowest_spread = f64::MAX;
        for (s, _) in &scenes {
            let scales: Vec<f64> = s
                .log_scales
                .iter()
                .flat_map(|l| [l.x.exp(), l.y.exp(), l.z.exp()])
                .collect();
            let (lo, hi) = scales
                .iter()
                .fold((f64::MAX, 0.0_f64), |(lo, hi), &x| (lo.min(x), hi.max(x)));
            assert!(
                lo >= 0.01 * (1.0 - 1e-12) && hi <= 0.2 * (1.0 + 1e-12),
                "scales in [{lo}, {hi}]"
            );
            widest_scale = widest_scale.max(hi);
            narrowest_spread = narrowest_spread.min(hi / lo);
            for &logit in &s.opacity_logits {
                let o = 1.0 / (1.0 + (-logit).exp());
                assert!((0.05 - 1e-12..=0.99 + 1e-12).contains(&o), "opacity {o}");
                widest_opacity = widest_opacity.max(o);
            }
        }
        // The upper ends are reached, and a scene's scale range can be narrow (s_span near
        // 0) as well as wide.
        assert!(widest_scale > 0.17, "largest scale {widest_scale}");
        assert!(widest_opacity > 0.92, "largest opacity {widest_opacity}");
        assert!(
            narrowest_spread < 1.3,
            "narrowest scale spread ×{narrowest_spread}"
        );
    }

    #[test]
    fn cameras_sit_on_their_sphere_away_from_the_up_axis() {
        for cam in sample(&camera(32, 24), 500) {
            let c = cam.center();
            let r = c.norm();
            assert!((3.0 - 1e-9..=5.0 + 1e-9).contains(&r), "distance {r}");
            assert!(c.y.abs() < 0.9 * r, "centre {c:?} too close to the up axis");
        }
    }
}
