//! # evogs-math
//!
//! Scalar-generic 3D maths for differentiable rendering and Lie-group integration:
//!
//! - [`Real`]: one scalar trait for `f32`, `f64` and forward-mode [`Dual`] numbers, so every
//!   kernel is written once and checked in `f64` and in dual numbers;
//! - [`Vec2`], [`Vec3`], [`Vec6`], [`Mat2`], [`Mat3`], [`Mat6`] (row-major), [`Sym2`],
//!   [`Sym3`], [`Quat`] (w, x, y, z; Hamilton product), [`So3`], [`Se3`];
//! - [`so3`]: exp and log (quaternion and matrix), hat/vee; [`so3_jacobians`]: left and right
//!   Jacobians and inverses; [`so3_coeffs`]: the per-function small-angle branches, in θ²
//!   (also those of the SE(3) Jacobian's `Q` block);
//! - [`se3`]: rigid transforms [`Se3`] (unit quaternion + translation) with tangents
//!   **ξ = (ρ, φ)** (translation part first, as in sophus): exp and log (angle in [0, π]),
//!   compose, inverse, act, `Ad`, `ad`, hat/vee, and a VJP for each map, with cotangents of
//!   transforms taken for the left perturbation `T ↦ Exp(δ)·T`; [`se3_jacobians`]: `Jl`, `Jr`
//!   and their inverses (Barfoot's `Q` block), applied without forming them, with VJPs
//!   (conventions and formulas: `docs/se3.md` in the repository);
//! - [`update`]: exp-map rotation updates `Exp(ω dt) ⊗ q` and `q ⊗ Exp(ω dt)` with VJPs;
//! - [`covariance`]: `Σ = R diag(exp(2ŝ)) Rᵀ` from log-scale and raw quaternion, with VJP;
//! - [`sh`]: spherical harmonics of degree 0–3 with VJPs (coefficients and direction);
//! - [`activation`]: sigmoid, exp, normalisation with VJPs;
//! - [`diff`]: central differences, [`GradCheck`](diff::GradCheck) reports, the VJP
//!   dot-product test and dual-number JVPs;
//! - [`rng`]: a seeded SplitMix64 for tests and initialisation; [`Par`]: parallelism as a value.
//!
//! Conventions: quaternions are stored **(w, x, y, z)**; matrices are **row-major**
//! (`m[row][col]`); transforms are named `a_from_b`; every differentiable `foo` has a
//! `foo_vjp` beside it taking the same arguments plus the output cotangent.
//!
//! `no_std` (with `alloc`): build with `--no-default-features --features libm`. Features
//! `glam`, `nalgebra` and `approx` add conversions ([`interop`]: vectors, matrices,
//! quaternions, and `Se3` to and from nalgebra's `Isometry3` and glam's `Affine3A`, `Mat4`,
//! `DAffine3`, `DMat4`); `proptest` exports the [`strategies`] the property tests use.
//!
//! ```
//! use evogs_math::{Se3, So3, Vec3, Vec6};
//! let phi = Vec3::new(0.3, -0.2, 1.1);
//! assert!((So3::exp(phi).log() - phi).norm() < 1e-15);
//! // SE(3): ξ = (ρ, φ), translation part first.
//! let xi = Vec6::new(Vec3::new(1.0, 0.5, -2.0), phi);
//! let world_from_body = Se3::exp(xi);
//! assert!((world_from_body.log() - xi).norm() < 1e-15);
//! let p = world_from_body.act(Vec3::new(0.1, 0.2, 0.3));
//! assert!((world_from_body.inverse().act(p) - Vec3::new(0.1, 0.2, 0.3)).norm() < 1e-15);
//! ```
#![cfg_attr(not(feature = "std"), no_std)]

#[cfg(not(any(feature = "std", feature = "libm")))]
compile_error!(
    "evogs-math needs a float backend: enable the `std` (default) or the `libm` feature"
);

extern crate alloc;

pub mod activation;
pub mod covariance;
pub mod diff;
mod dual;
mod mat;
mod par;
pub mod quat;
mod real;
pub mod rng;
pub mod se3;
pub mod se3_jacobians;
pub mod sh;
pub mod so3;
pub mod so3_coeffs;
pub mod so3_jacobians;
mod sym;
pub mod update;
mod vec;

pub mod interop;
#[cfg(feature = "proptest")]
pub mod strategies;

pub use dual::Dual;
pub use mat::{Mat2, Mat3, Mat3d, Mat3f, Mat6, Mat6d, Mat6f};
pub use par::Par;
pub use quat::{Quat, Quatd, Quatf};
pub use real::Real;
pub use se3::{Se3, Se3d, Se3f};
pub use so3::{So3, So3d, So3f};
pub use sym::{Sym2, Sym3};
pub use vec::{Vec2, Vec2d, Vec2f, Vec3, Vec3d, Vec3f, Vec6, Vec6d, Vec6f};
