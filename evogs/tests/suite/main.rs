//! The integration tests of `evogs`, one binary (one link, one compile of the generic
//! code they share): each module is one file of tests, run as `cargo test -p evogs --test suite`.

mod batch;
mod field_vjp;
mod motion_learning;
mod prediction;
mod scenes;
