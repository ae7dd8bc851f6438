//! evogs-cli library (skeleton).
