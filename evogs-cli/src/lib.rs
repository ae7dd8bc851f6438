//! # evogs-cli
//!
//! The commands of the `evogs` binary as library functions ([`app`]): train, study, eval,
//! render, inject, export, bench. `main.rs` is a thin clap front end over them. The method
//! itself lives in the `evogs` crate, the verification tools in `evogs-verify`.

pub mod app;

/// The examples of `README.md`, run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
