//! Cross-crate tests of evogs: shared fixtures and the property functions of the seeded
//! fuzz test.
//!
//! - [`oracle_files`]: every reference-vector file copied into the repository
//!   (`tests/data/oracle/*.json`), for `tests/suite/verify_oracle.rs`;
//! - [`fuzz`]: one seeded case of each property ([`fuzz::projection_case`],
//!   [`fuzz::raster_case`], [`fuzz::so3_case`]); each panics with a message when a property
//!   fails. `tests/suite/seeded_fuzz.rs` runs thousands of seeds on stable Rust; a cargo-fuzz target
//!   can call the same functions with a seed taken from its input.

pub mod fuzz;
mod inputs;

pub use inputs::Gen;

use std::path::PathBuf;

/// The folder of the reference vectors (`tests/data/oracle`).
#[must_use]
pub fn oracle_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data/oracle")
}

/// Every `*.json` file of [`oracle_dir`], sorted.
///
/// # Panics
/// If the folder cannot be read.
#[must_use]
pub fn oracle_files() -> Vec<PathBuf> {
    let dir = oracle_dir();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", dir.display()))
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    files.sort();
    files
}
