//! # evogs-splat (in progress)
//!
//! Differentiable 3D Gaussian splatting on the CPU.
#![cfg_attr(not(feature = "std"), no_std)]

#[cfg(not(any(feature = "std", feature = "libm")))]
compile_error!("evogs-splat needs a float backend: enable the `std` (default) or the `libm` feature");

extern crate alloc;

mod image;
pub mod loss;
pub mod metrics;
pub mod ssim;

pub use image::Image;
