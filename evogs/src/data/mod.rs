//! Datasets and file formats: D-NeRF scenes, N3DV multi-view videos, PNG/GIF images, PLY
//! tables, `.npy` matrices, and the bounded cache of decoded frames training reads through.

pub mod dataset;
pub mod dnerf;
pub mod error;
pub mod format;
pub mod frame_cache;
pub mod gif_writer;
pub mod identity;
pub mod image_io;
mod load;
pub mod n3dv;
pub mod npy;
pub mod ply;

pub use dataset::{Dataset, LoadOptions, PointCloud, RigCamera, SplitName, View, read_point_cloud};
pub use error::DataError;
pub use format::DataFormat;
pub use frame_cache::{CacheStats, FrameCache};
pub use identity::DataIdentity;
