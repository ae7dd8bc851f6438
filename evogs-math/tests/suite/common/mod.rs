//! Helpers shared by the property tests: the dot-product test of a VJP against the
//! dual-number JVP of the same map, and lifting f64 values into dual numbers.
#![allow(dead_code, reason = "each test binary uses a subset of the helpers")]

use evogs_math::diff::{dual_jvp, vjp_dot_test};
use evogs_math::{Dual, Quat, Se3, So3, Vec3};

/// `⟨J v, w⟩ = ⟨v, Jᵀ w⟩` for random v, w, with `J v` from forward mode: `f` evaluates the
/// map on dual numbers at `x0 + v ε`; `vjp(w, out)` writes `Jᵀ w`. Returns the relative
/// residual (~1e-16 for a correct VJP).
pub(crate) fn dot_residual(
    f: impl Fn(&[Dual<f64>], &mut [Dual<f64>]),
    x0: &[f64],
    vjp: impl Fn(&[f64], &mut [f64]),
    n_out: usize,
) -> f64 {
    vjp_dot_test(
        |v: &[f64], out: &mut [f64]| dual_jvp(&f, x0, v, out),
        |w: &[f64], out: &mut [f64]| vjp(w, out),
        x0.len(),
        n_out,
        19,
    )
}

/// A constant (zero-derivative) dual 3-vector.
pub(crate) fn d3(v: Vec3<f64>) -> Vec3<Dual<f64>> {
    Vec3::new(
        Dual::constant(v.x),
        Dual::constant(v.y),
        Dual::constant(v.z),
    )
}

/// A constant dual quaternion.
pub(crate) fn dq(q: Quat<f64>) -> Quat<Dual<f64>> {
    Quat::new(
        Dual::constant(q.w),
        Dual::constant(q.x),
        Dual::constant(q.y),
        Dual::constant(q.z),
    )
}

/// A constant dual transform (same bits).
pub(crate) fn dse3(x: Se3<f64>) -> Se3<Dual<f64>> {
    Se3::from_parts(So3::from_unit_quat(dq(x.quat())), d3(x.translation()))
}

/// The largest |entry| of a difference of two 4×4 matrices.
pub(crate) fn mat4_diff(a: [[f64; 4]; 4], b: [[f64; 4]; 4]) -> f64 {
    a.as_flattened()
        .iter()
        .zip(b.as_flattened())
        .fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}
