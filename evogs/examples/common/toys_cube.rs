//! The spinning cube of the `toys` scene (`toys/meta.json`, copied in
//! `tools/data/toys-meta.json`), for the `field_fit` example: it turns about `AXIS` through
//! `CENTRE` at one revolution per unit time, `R(t) = Rot(AXIS, 2πt)·Rot([1, 1, 0], TILT)`.

use evogs_math::Vec3;

/// Centre of the cube (fixed).
pub(crate) const CENTRE: Vec3<f64> = Vec3::new(0.45, 0.4, 0.05);
/// Unit rotation axis.
pub(crate) const AXIS: Vec3<f64> = Vec3::new(
    0.268_328_157_299_974_7,
    -0.357_770_876_399_966_35,
    0.894_427_190_999_915_9,
);
/// Half the edge length.
pub(crate) const HALF: f64 = 0.25;
