#![doc = include_str!("../README.md")]
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
pub mod lie;
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
