//! # evogs-cli
//!
//! The composition of evogs-math, evogs-ode and evogs-splat into EvoGS training, evaluation,
//! rendering, motion editing and verification, and the `evogs` command line.

pub mod app;
pub mod check;
pub mod config;
pub mod data;
pub mod eval;
pub mod field;
pub mod model;
pub mod run;
pub mod train;
pub mod verify;
