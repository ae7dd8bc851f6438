//! Public proptest strategies for evogs-math types (feature `proptest`).
//!
//! Random draws alone rarely produce the cases that break SO(3) and SE(3) code, so the
//! rotation strategies mix log-uniform magnitudes (1e-12 … π) with angles just below π, and
//! the SE(3) strategies build on them ([`se3_tangent`], [`se3`], [`se3_perturbation`]).

use crate::{Quat, Se3, Vec3, Vec6};
use proptest::prelude::*;

/// A 3-vector with components in `[-r, r]`.
pub fn vec3(r: f64) -> impl Strategy<Value = Vec3<f64>> {
    (-r..=r, -r..=r, -r..=r).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

/// A unit vector (normalised Gaussian-like draw, never degenerate).
pub fn unit_vec3() -> impl Strategy<Value = Vec3<f64>> {
    vec3(1.0)
        .prop_filter("non-degenerate", |v| v.norm() > 1e-3)
        .prop_map(|v| v * (1.0 / v.norm()))
}

/// A rotation vector with |φ| < `max_angle`, magnitudes log-uniform from 1e-12 and a share
/// of angles within 1e-8…1e-2 of `max_angle`.
pub fn so3_tangent(max_angle: f64) -> impl Strategy<Value = Vec3<f64>> {
    let log_uniform = (-12.0..num_traits::Float::log10(max_angle))
        .prop_map(|e: f64| num_traits::Float::powf(10.0, e));
    let near_max = (-8.0..-2.0f64).prop_map(move |e| max_angle - num_traits::Float::powf(10.0, e));
    let mag = prop_oneof![3 => log_uniform, 1 => near_max];
    (unit_vec3(), mag).prop_map(|(u, m)| u * m)
}

/// A unit quaternion (w, x, y, z).
pub fn unit_quat() -> impl Strategy<Value = Quat<f64>> {
    (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64)
        .prop_filter("non-degenerate", |(w, x, y, z)| {
            w * w + x * x + y * y + z * z > 1e-4
        })
        .prop_map(|(w, x, y, z)| Quat::new(w, x, y, z).normalize())
}

/// A raw (unnormalised) quaternion with norm in roughly [0.3, 2].
pub fn raw_quat() -> impl Strategy<Value = Quat<f64>> {
    (unit_quat(), 0.3..2.0f64).prop_map(|(q, s)| q.scale(s))
}

/// A 6-vector with components in `[-r, r]`.
pub fn vec6(r: f64) -> impl Strategy<Value = Vec6<f64>> {
    (vec3(r), vec3(r)).prop_map(|(a, b)| Vec6::new(a, b))
}

/// An SE(3) tangent ξ = (ρ, φ): a translation part with components in `[-r, r]` and a
/// rotation part from [`so3_tangent`]`(max_angle)` (log-uniform angles from 1e-12, a share
/// just below `max_angle`). With `max_angle > π` it also draws rotations that `Log` wraps.
pub fn se3_tangent(max_angle: f64, r: f64) -> impl Strategy<Value = Vec6<f64>> {
    (vec3(r), so3_tangent(max_angle)).prop_map(|(rho, phi)| Vec6::new(rho, phi))
}

/// A rigid transform: half from a uniform unit quaternion, half from [`se3_tangent`]`(π, r)`
/// (so angles near 0 and near π both occur), with translations in `[-r, r]`³.
pub fn se3(r: f64) -> impl Strategy<Value = Se3<f64>> {
    prop_oneof![
        (unit_quat(), vec3(r)).prop_map(|(q, t)| Se3::from_quat_translation(q, t)),
        se3_tangent(core::f64::consts::PI, r).prop_map(Se3::exp),
    ]
}

/// A small tangent perturbation: a uniformly oriented 6-vector of norm `size`.
pub fn se3_perturbation(size: f64) -> impl Strategy<Value = Vec6<f64>> {
    (unit_vec3(), unit_vec3(), 0.0..core::f64::consts::FRAC_PI_2).prop_map(move |(a, b, t)| {
        let (s, c) = num_traits::Float::sin_cos(t);
        Vec6::new(a * (c * size), b * (s * size))
    })
}

/// `count` values of `strategy` from proptest's fixed-seed runner (`TestRunner::deterministic`):
/// the same values on every run, for tests that look at a strategy's spread rather than at
/// one property.
///
/// # Panics
/// If the strategy cannot produce a value (its filters reject too many draws).
///
/// ```
/// use evogs_math::strategies::{sample, vec3};
/// let vs = sample(&vec3(1.0), 10);
/// assert_eq!(vs.len(), 10);
/// assert_eq!(vs, sample(&vec3(1.0), 10), "the same values every time");
/// ```
pub fn sample<S: Strategy>(strategy: &S, count: usize) -> alloc::vec::Vec<S::Value> {
    use proptest::strategy::ValueTree;
    let mut runner = proptest::test_runner::TestRunner::deterministic();
    (0..count)
        .map(|_| strategy.new_tree(&mut runner).expect("a draw").current())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vec3_fills_the_whole_cube_in_every_component() {
        let vs = sample(&vec3(2.0), 400);
        for k in 0..3 {
            let c: Vec<f64> = vs.iter().map(|v| [v.x, v.y, v.z][k]).collect();
            assert!(
                c.iter().all(|x| (-2.0..=2.0).contains(x)),
                "component {k} in [-2, 2]"
            );
            let (lo, hi) = c
                .iter()
                .fold((f64::MAX, f64::MIN), |(lo, hi), &x| (lo.min(x), hi.max(x)));
            assert!(lo < -1.5 && hi > 1.5, "component {k} spans [{lo}, {hi}]");
        }
    }

    #[test]
    fn unit_vectors_and_quaternions_have_norm_one() {
        for v in sample(&unit_vec3(), 200) {
            assert!((v.norm() - 1.0).abs() < 1e-12, "|v| = {}", v.norm());
        }
        for q in sample(&unit_quat(), 200) {
            assert!((q.norm() - 1.0).abs() < 1e-12, "|q| = {}", q.norm());
        }
    }

    #[test]
    fn unit_quaternions_reach_every_corner_of_the_sphere() {
        // Only near-zero raw draws are filtered out: each component is at times the largest
        // by far, with either sign, and at times close to zero.
        let qs = sample(&unit_quat(), 2000);
        for k in 0..4 {
            let c = |q: &Quat<f64>| [q.w, q.x, q.y, q.z][k];
            for sign in [1.0, -1.0] {
                let dominant = qs
                    .iter()
                    .any(|q| sign * c(q) > core::f64::consts::FRAC_1_SQRT_2);
                assert!(dominant, "component {k} never dominant with sign {sign}");
            }
            let near_zero = qs.iter().any(|q| c(q).abs() < 0.01);
            assert!(near_zero, "component {k} never near zero");
        }
    }
}
