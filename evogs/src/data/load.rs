//! Loading a dataset folder: the layout is recognised (or named) and its reader called. Kept
//! apart from the dataset types so that the readers depend on the types and not back.

use super::dataset::{Dataset, LoadOptions};
use super::error::DataError;
use super::format::DataFormat;
use std::path::Path;

impl Dataset {
    /// Loads a dataset folder in the layout `opts.format` names or, by default, the one
    /// recognised from its files.
    ///
    /// # Errors
    /// [`DataError`] naming the file: a missing folder or file, an unrecognised layout, and
    /// every problem the layout's reader reports.
    pub fn load(root: &Path, opts: &LoadOptions) -> Result<Self, DataError> {
        match opts.format.resolve(root)? {
            DataFormat::N3dv => super::n3dv::load(root, opts),
            DataFormat::Dnerf | DataFormat::Auto => super::dnerf::load(root, opts),
        }
    }
}
