//! The evogs binary.
fn main() {}
