//! # evogs
//!
//! EvoGS as a library: the composition of evogs-math, evogs-ode and evogs-splat into a dynamic
//! Gaussian scene whose Gaussians move under a learned velocity field, trained from images.
//!
//! | module | what |
//! |---|---|
//! | [`data`] | D-NeRF and N3DV datasets, PNG/GIF, PLY tables, `.npy`, the frame cache |
//! | [`field`] | the HexPlane encoder and the velocity MLP: [`field::NeuralField`], batched, with an exact VJP; it is an `evogs_ode::VectorField` over all Gaussians |
//! | [`model`] | canonical Gaussians, waypoint anchors, velocity/deformation/static dynamics: the Gaussians at any time and the way back (discrete adjoint) |
//! | [`train`] | one step's loss and exact gradient, Adam with the EvoGS schedules, densification, the trainer |
//! | [`run`] | checkpoints (bit-for-bit resumable) |
//! | [`eval`] | PSNR and SSIM on held-out views, whole and inside motion masks |
//! | [`extrapolate`] | no-training baselines: hold, constant-velocity and constant-acceleration extrapolation |
//! | [`scenes`] | procedural scenes with closed-form motion and their ground truth (`motion.json`) |
//! | [`config`] | the TOML training configuration and its presets |
//! | [`atomic`] | every output file written under a temporary name and renamed when complete |
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
//!
//! The library never prints: long work reports through callbacks, and errors are typed.

pub mod aligned;
pub mod atomic;
pub mod awake;
pub mod bounded;
pub mod config;
pub mod data;
pub mod eval;
pub mod extrapolate;
pub mod field;
pub mod fnv;
pub mod model;
pub mod run;
pub mod scenes;
pub mod train;

/// The examples of `README.md`, run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
