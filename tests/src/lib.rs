//! Cross-crate tests of evogs (skeleton).
