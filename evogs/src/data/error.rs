//! The one error type of dataset loading: it always names the file.

use super::image_io::ImageIoError;
use super::npy::NpyError;
use super::ply::PlyError;
use crate::bounded::ReadError;

/// Why a dataset could not be loaded: always names the file.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// A required file or folder is missing.
    #[error("{path}: missing ({what})")]
    Missing {
        /// File.
        path: String,
        /// What it should have been.
        what: &'static str,
    },
    /// A value is invalid.
    #[error("{path}: {msg}")]
    Invalid {
        /// File.
        path: String,
        /// What is wrong.
        msg: String,
    },
    /// An image could not be read.
    #[error(transparent)]
    Image(#[from] ImageIoError),
    /// The point cloud could not be read.
    #[error(transparent)]
    Ply(#[from] PlyError),
    /// A `.npy` file could not be read.
    #[error(transparent)]
    Npy(#[from] NpyError),
    /// A file is not a regular file, too large for its format, or not text.
    #[error(transparent)]
    Read(#[from] ReadError),
}
