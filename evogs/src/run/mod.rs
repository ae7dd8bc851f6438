//! Run folders: checkpoints, logs and resolved configurations.

pub mod archive;
pub mod checkpoint;
