//! The supervised training views as training reads them: every view's camera and time in
//! memory, the images through a bounded [`FrameCache`] (in memory for a small dataset,
//! decoded on demand and ahead of use for one larger than the budget).

use super::step::ViewData;
use crate::data::frame_cache::{CacheStats, FrameCache, FrameSource};
use evogs_splat::PinholeCamera;
use std::sync::Arc;

/// Training views: cameras and times, images from a frame cache.
#[derive(Clone, Debug)]
pub struct TrainViews {
    cameras: Vec<PinholeCamera<f32>>,
    times: Vec<f64>,
    frames: FrameCache,
}

impl TrainViews {
    /// Views from their cameras, times and frames (one of each per view).
    ///
    /// # Panics
    /// If the three lengths differ.
    #[must_use]
    pub fn new(cameras: Vec<PinholeCamera<f32>>, times: Vec<f64>, frames: FrameCache) -> Self {
        assert!(
            cameras.len() == times.len() && times.len() == frames.len(),
            "one camera, time and frame per view"
        );
        Self {
            cameras,
            times,
            frames,
        }
    }

    /// Number of views.
    #[must_use]
    pub fn len(&self) -> usize {
        self.times.len()
    }

    /// Whether there are no views.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.times.is_empty()
    }

    /// The time of view `i`.
    #[must_use]
    pub fn time(&self, i: usize) -> f64 {
        self.times[i]
    }

    /// Every view's time.
    #[must_use]
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// Every view's camera.
    #[must_use]
    pub fn cameras(&self) -> &[PinholeCamera<f32>] {
        &self.cameras
    }

    /// The frame cache.
    #[must_use]
    pub fn frames(&self) -> &FrameCache {
        &self.frames
    }

    /// The frame cache's counters.
    #[must_use]
    pub fn cache_stats(&self) -> CacheStats {
        self.frames.stats()
    }

    /// View `i` with its image (from memory, the cache, or decoded now).
    ///
    /// # Errors
    /// The frame could not be decoded (the message names the file).
    pub fn view(&self, i: usize) -> Result<ViewData<f32>, String> {
        Ok(ViewData {
            camera: self.cameras[i],
            time: self.times[i],
            image: self.frames.get(i)?,
        })
    }

    /// Starts decoding the frames of the views `upcoming` (soonest first) ahead of use.
    pub fn prefetch(&self, upcoming: &[usize]) {
        self.frames.prefetch(upcoming);
    }

    /// The smallest and largest time.
    #[must_use]
    pub fn time_range(&self) -> (f64, f64) {
        self.times
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &t| {
                (a.min(t), b.max(t))
            })
    }

    /// The scene extent of 3DGS (`getNerfppNorm`): 1.1 × the largest distance of a camera
    /// centre from the mean centre (the `spatial_lr_scale` of the learning rates).
    #[must_use]
    pub fn camera_extent(&self) -> f64 {
        if self.cameras.is_empty() {
            return 1.0;
        }
        let centres: Vec<[f64; 3]> = self
            .cameras
            .iter()
            .map(|c| c.center().cast::<f64>().to_array())
            .collect();
        let n = centres.len() as f64;
        let mean: [f64; 3] =
            core::array::from_fn(|a| centres.iter().map(|c| c[a]).sum::<f64>() / n);
        let far = centres
            .iter()
            .map(|c| (0..3).map(|a| (c[a] - mean[a]).powi(2)).sum::<f64>().sqrt())
            .fold(0.0, f64::max);
        1.1 * far.max(1e-6)
    }
}

impl From<Vec<ViewData<f32>>> for TrainViews {
    /// Views whose images are already in memory.
    fn from(views: Vec<ViewData<f32>>) -> Self {
        let cameras = views.iter().map(|v| v.camera).collect();
        let times = views.iter().map(|v| v.time).collect();
        let sources = views
            .into_iter()
            .map(|v| FrameSource::Memory(Arc::clone(&v.image)))
            .collect();
        Self::new(cameras, times, FrameCache::new(sources, 0))
    }
}
