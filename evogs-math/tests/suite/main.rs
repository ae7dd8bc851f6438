//! The integration tests of `evogs-math`, one binary (one link, one compile of the generic
//! code they share): each module is one file of tests, run as `cargo test -p evogs-math --test suite`.

mod common;
#[cfg(feature = "proptest")]
mod lie_axioms;
#[cfg(feature = "proptest")]
mod properties;
mod se3_oracle;
#[cfg(feature = "proptest")]
mod se3_properties;
mod so3_oracle;
mod so3_sweep;
