//! Datasets and file formats: D-NeRF scenes, PNG/GIF images, PLY tables.

pub mod dnerf;
pub mod image_io;
pub mod ply;

pub use dnerf::{DataError, Dataset, LoadOptions, PointCloud, SplitName, View};
