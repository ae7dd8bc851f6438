//! The integration tests of `tests`, one binary (one link, one compile of the generic
//! code they share): each module is one file of tests, run as `cargo test -p tests --test suite`.

mod end_to_end_grad;
mod import_cycles;
mod seeded_fuzz;
mod verify_oracle;
