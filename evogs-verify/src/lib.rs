//! # evogs-verify
//!
//! The verification tools of evogs, as a library (the `evogs verify`, `check-grad` and
//! `check-order` commands are thin front ends over it):
//!
//! | module | what |
//! |---|---|
//! | [`verify`] | recomputes a reference-vector file (gsplat, torchdiffeq, scipy, scikit-image, mpmath) in f64 and reports every error against its tolerance |
//! | [`check`] | every VJP of the stack (maths, projection, compositing, steppers, the neural field, the model, a whole training step) against central differences in f64, and the measured convergence order of every stepper |

pub mod check;
pub mod verify;

/// The examples of `README.md`, run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
