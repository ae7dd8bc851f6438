//! Conversions to and from other maths crates, each behind its feature.
//!
//! These crates never appear in the signatures of the rest of evogs; convert at the edges.
//! Every conversion has a round-trip test. Watch the storage orders: evogs quaternions are
//! (w, x, y, z) like nalgebra's `Quaternion::new(w, i, j, k)`, while glam's
//! `Quat::from_xyzw` puts w last; evogs matrices are row-major, glam's and nalgebra's
//! storage is column-major (the conversions go entry by entry, so this is handled here).

#[cfg(feature = "approx")]
mod approx_impls;
#[cfg(feature = "glam")]
mod glam_impls;
#[cfg(feature = "nalgebra")]
mod nalgebra_impls;
