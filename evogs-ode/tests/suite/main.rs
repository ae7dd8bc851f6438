//! The integration tests of `evogs-ode`, one binary (one link, one compile of the generic
//! code they share): each module is one file of tests, run as `cargo test -p evogs-ode --test suite`.

mod adaptive;
mod adaptive_adjoint;
mod adaptive_oracle;
mod adjoint;
mod algebra;
mod common;
mod continuous;
mod fields;
mod oracle;
mod orders;
mod par;
#[cfg(feature = "proptest")]
mod properties;
mod quadrotor_example;
mod tape;
