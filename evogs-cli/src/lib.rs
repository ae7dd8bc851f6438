//! # evogs-cli
//!
//! The composition of evogs-math, evogs-ode and evogs-splat into EvoGS training, evaluation,
//! rendering, motion editing and verification, and the `evogs` command line (a thin clap
//! front end over [`app`]).
//!
//! | module | what |
//! |---|---|
//! | [`data`] | D-NeRF datasets (transforms JSON, RGBA PNGs, `points3d.ply`), PNG/GIF, PLY tables |
//! | [`field`] | the HexPlane encoder and the velocity MLP: [`field::NeuralField`], batched, with an exact VJP; it is an `evogs_ode::VectorField` over all Gaussians |
//! | [`model`] | canonical Gaussians, waypoint anchors, velocity/deformation/static dynamics: the Gaussians at any time and the way back (discrete adjoint) |
//! | [`train`] | one step's loss and exact gradient, Adam with the EvoGS schedules, densification, the training loop |
//! | [`run`] | checkpoints (bit-for-bit resumable) |
//! | [`atomic`] | every output file written under a temporary name and renamed when complete |
//! | [`eval`] | PSNR and SSIM on held-out views |
//! | [`app`] | the commands: train, eval, render, inject, export |
//! | [`verify`], [`check`] | recomputation of reference vectors, gradient and order reports |
//! | [`config`] | the TOML training configuration and its presets |
//!
//! One training iteration, as data flows:
//!
//! ```text
//! view (image, camera, t) → anchor k ≤ t → state_k (Gaussians at τ_k)
//!   → integrate τ_k → t (RK4/RKMK, field = HexPlane + MLP)      [evogs-ode + field]
//!   → Gaussians at t → project → rasterize → image                [evogs-splat]
//!   → loss (L1, D-SSIM) → ∂image → rasterizer VJP → projection VJP
//!   → discrete adjoint through the steps (field VJP)              [evogs-ode]
//!   → gradients of anchors, canonical attributes, field → Adam, densify/prune
//! ```

pub mod app;
pub mod atomic;
pub mod check;
pub mod config;
pub mod data;
pub mod eval;
pub mod field;
pub mod model;
pub mod run;
pub mod train;
pub mod verify;

/// The examples of `README.md`, run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
