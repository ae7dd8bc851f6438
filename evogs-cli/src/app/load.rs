//! Loading a run's dataset with the run's data settings.

use super::error::CommandError;
use evogs::config::TrainConfig;
use evogs::data::{Dataset, LoadOptions};
use std::path::Path;

/// The dataset options of a run's data configuration (layout, background, downscale,
/// held-out cameras, times file).
#[must_use]
pub fn load_options(cfg: &TrainConfig, images: bool) -> LoadOptions {
    LoadOptions {
        background: cfg.data.background,
        downscale: cfg.data.downscale,
        load_images: images,
        format: cfg.data.format,
        test_cameras: cfg.data.test_cameras.clone(),
        val_cameras: cfg.data.val_cameras.clone(),
        times_file: cfg.data.times_file.clone(),
        ..LoadOptions::default()
    }
}

/// Loads a dataset with the run's data settings ([`load_options`]). Every frame's file and
/// size is checked. With `images`, the images are decoded now if all of them fit the frame
/// budget (`data.cache_mb`); otherwise (and without `images`) they stay on disk and are
/// decoded when used ([`evogs::data::View::image_or_decode`], the training frame cache).
///
/// # Errors
/// Any data problem, naming the file.
pub fn load_dataset(dir: &Path, cfg: &TrainConfig, images: bool) -> Result<Dataset, CommandError> {
    let mut ds = Dataset::load(dir, &load_options(cfg, false)).map_err(CommandError::new)?;
    if images && ds.decoded_bytes() <= cfg.data.cache_bytes() {
        ds.decode_images().map_err(CommandError::new)?;
    }
    Ok(ds)
}
