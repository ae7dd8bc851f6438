//! The integration tests of `evogs-cli`, one binary (one link, one compile of the generic
//! code they share): each module is one file of tests, run as `cargo test -p evogs-cli --test suite`.

mod bad_times;
mod bench;
mod checkpoint_format;
mod common;
mod dataset_errors;
mod hostile;
mod init_note;
mod interrupt;
mod lock;
mod motion_metrics;
mod mpi;
mod multiview;
mod render_output;
mod shipped_scene;
mod study;
mod training;
mod viewer;
