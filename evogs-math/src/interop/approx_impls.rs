//! `approx` trait impls (`AbsDiffEq`, `RelativeEq`, `UlpsEq`) for f32 and f64 types,
//! comparing entry by entry.

use crate::{Mat3, Mat6, Quat, Vec2, Vec3, Vec6};
use approx::{AbsDiffEq, RelativeEq, UlpsEq};

macro_rules! approx_impls {
    ($ty:ident, $t:ty, |$s:ident| $entries:expr) => {
        impl AbsDiffEq for $ty<$t> {
            type Epsilon = $t;
            fn default_epsilon() -> $t {
                <$t>::EPSILON
            }
            fn abs_diff_eq(&self, other: &Self, epsilon: $t) -> bool {
                let a = {
                    let $s = self;
                    $entries
                };
                let b = {
                    let $s = other;
                    $entries
                };
                a.iter()
                    .zip(b.iter())
                    .all(|(x, y)| x.abs_diff_eq(y, epsilon))
            }
        }
        impl RelativeEq for $ty<$t> {
            fn default_max_relative() -> $t {
                <$t>::EPSILON
            }
            fn relative_eq(&self, other: &Self, epsilon: $t, max_relative: $t) -> bool {
                let a = {
                    let $s = self;
                    $entries
                };
                let b = {
                    let $s = other;
                    $entries
                };
                a.iter()
                    .zip(b.iter())
                    .all(|(x, y)| x.relative_eq(y, epsilon, max_relative))
            }
        }
        impl UlpsEq for $ty<$t> {
            fn default_max_ulps() -> u32 {
                4
            }
            fn ulps_eq(&self, other: &Self, epsilon: $t, max_ulps: u32) -> bool {
                let a = {
                    let $s = self;
                    $entries
                };
                let b = {
                    let $s = other;
                    $entries
                };
                a.iter()
                    .zip(b.iter())
                    .all(|(x, y)| x.ulps_eq(y, epsilon, max_ulps))
            }
        }
    };
}

approx_impls!(Vec2, f32, |s| s.to_array());
approx_impls!(Vec2, f64, |s| s.to_array());
approx_impls!(Vec3, f32, |s| s.to_array());
approx_impls!(Vec3, f64, |s| s.to_array());
approx_impls!(Quat, f32, |s| s.to_array());
approx_impls!(Quat, f64, |s| s.to_array());
approx_impls!(Mat3, f32, |s| s.to_flat());
approx_impls!(Mat3, f64, |s| s.to_flat());
approx_impls!(Vec6, f32, |s| s.to_array());
approx_impls!(Vec6, f64, |s| s.to_array());
approx_impls!(Mat6, f32, |s| s.m.as_flattened());
approx_impls!(Mat6, f64, |s| s.m.as_flattened());

#[cfg(test)]
mod tests {
    use crate::Vec3;

    #[test]
    fn approx_macros_work() {
        let a = Vec3::new(1.0_f64, 2.0, 3.0);
        let b = a + Vec3::splat(1e-12);
        approx::assert_relative_eq!(a, b, epsilon = 1e-10);
        assert!(
            approx::relative_ne!(a, b * 2.0),
            "different vectors are not equal"
        );
    }
}
