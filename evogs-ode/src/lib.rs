//! # evogs-ode (in progress)
//!
//! Fixed-grid ODE integration on vector spaces and SO(3) with exact discrete adjoints.
#![cfg_attr(not(feature = "std"), no_std)]

#[cfg(not(any(feature = "std", feature = "libm")))]
compile_error!("evogs-ode needs a float backend: enable the `std` (default) or the `libm` feature");

extern crate alloc;

mod field;
mod layout;

pub use field::VectorField;
pub use layout::{Block, BlockSpan, MAX_BLOCKS, StateLayout};
