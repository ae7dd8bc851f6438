#![doc = include_str!("../README.md")]
#![cfg_attr(not(feature = "std"), no_std)]

#[cfg(not(any(feature = "std", feature = "libm")))]
compile_error!("evogs-ode needs a float backend: enable the `std` (default) or the `libm` feature");

extern crate alloc;

pub mod adaptive;
mod adjoint;
pub mod algebra;
mod chunks;
mod continuous;
mod field;
pub mod fields;
mod grid;
mod integrate;
mod layout;
mod method;
pub mod order;
pub mod problems;
mod rational;
mod stepper;
#[cfg(feature = "proptest")]
pub mod strategies;
mod tableau;
mod tape;

pub use adjoint::{discrete_adjoint, discrete_adjoint_observed};
pub use continuous::{AdjointError, ContinuousAdjoint, ContinuousVariant, continuous_adjoint};
pub use field::VectorField;
pub use grid::TimeGrid;
pub use integrate::{Checkpointing, Trajectory, integrate, integrate_steps, integrate_trajectory};
pub use layout::{Block, BlockSpan, MAX_BLOCKS, StateLayout};
pub use method::{Method, ParseMethodError};
pub use rational::Rational;
pub use stepper::Stepper;
pub use tableau::{MAX_STAGES, OrderCondition, Tableau};
pub use tape::{StageTape, discrete_adjoint_recorded, integrate_recorded};
