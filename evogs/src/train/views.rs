//! From dataset views to training views: cameras, the training protocol's frame selection,
//! the views with their images in memory or behind a frame cache.

use super::frames::TrainViews;
use super::step::ViewData;
use crate::config::{DataConfig, Protocol};
use crate::data::View;
use crate::data::frame_cache::{FrameCache, FrameSource};
use std::sync::Arc;

/// The indices of the training views the protocol supervises.
#[must_use]
pub fn supervised_indices(views: &[View], cfg: &DataConfig) -> Vec<usize> {
    match cfg.protocol {
        Protocol::Full => (0..views.len()).collect(),
        Protocol::Future => (0..views.len())
            .filter(|&i| views[i].time <= cfg.split_time + 1e-9)
            .collect(),
        Protocol::Backward => (0..views.len())
            .filter(|&i| views[i].time >= cfg.split_time - 1e-9)
            .collect(),
        Protocol::Sparse => {
            // Every k-th distinct training time (by rank among the sorted unique times).
            let mut times: Vec<f64> = views.iter().map(|v| v.time).collect();
            times.sort_by(f64::total_cmp);
            times.dedup();
            (0..views.len())
                .filter(|&i| {
                    let rank = times.partition_point(|&t| t < views[i].time);
                    rank % cfg.stride.max(1) == 0
                })
                .collect()
        }
    }
}

/// Training views (images and cameras in f32) for the given indices, every image in memory
/// (decoded now when the dataset was loaded without images).
///
/// # Errors
/// An image that cannot be decoded, or a bad camera.
pub fn training_views(views: &[View], indices: &[usize]) -> Result<Vec<ViewData<f32>>, String> {
    indices
        .iter()
        .map(|&i| {
            let v = &views[i];
            let image = v.image_or_decode().map_err(|e| e.to_string())?;
            Ok(ViewData {
                camera: v.camera()?,
                time: v.time,
                image: Arc::new(image.into_owned()),
            })
        })
        .collect()
}

/// Training views for the given indices, their images read through a frame cache of
/// `budget_bytes`: images already loaded move into the training views (the dataset's views
/// are left without them, so nothing is held twice), the others are decoded on demand (and
/// ahead of use) by training.
///
/// # Errors
/// A bad camera.
pub fn training_frames(
    views: &mut [View],
    indices: &[usize],
    budget_bytes: usize,
) -> Result<TrainViews, String> {
    let mut cameras = Vec::with_capacity(indices.len());
    let mut times = Vec::with_capacity(indices.len());
    let mut sources = Vec::with_capacity(indices.len());
    for &i in indices {
        let v = &mut views[i];
        cameras.push(v.camera()?);
        times.push(v.time);
        sources.push(match v.image.take() {
            Some(img) => FrameSource::Memory(Arc::new(img)),
            None => FrameSource::File(Box::new(v.clone())),
        });
    }
    Ok(TrainViews::new(
        cameras,
        times,
        FrameCache::new(sources, budget_bytes),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn view(t: f64) -> View {
        View {
            file: PathBuf::from("x.png"),
            time: t,
            c2w: [[0.0; 4]; 4],
            fov_x: 0.7,
            width: 2,
            height: 2,
            image: None,
            decode: crate::data::image_io::FrameDecode::default(),
        }
    }

    #[test]
    fn protocols_select_frames() {
        let views: Vec<View> = [0.0, 0.25, 0.25, 0.5, 0.75, 1.0]
            .iter()
            .map(|&t| view(t))
            .collect();
        let mut cfg = DataConfig {
            protocol: Protocol::Full,
            stride: 2,
            split_time: 0.5,
            ..crate::config::TrainConfig::fast().data
        };
        assert_eq!(supervised_indices(&views, &cfg).len(), 6, "full");
        cfg.protocol = Protocol::Sparse;
        // Distinct times 0, .25, .5, .75, 1 → ranks 0, 2, 4 kept: t = 0, 0.5, 1.
        assert_eq!(
            supervised_indices(&views, &cfg),
            vec![0, 3, 5],
            "every second distinct time"
        );
        cfg.protocol = Protocol::Future;
        assert_eq!(
            supervised_indices(&views, &cfg),
            vec![0, 1, 2, 3],
            "t ≤ 0.5"
        );
        cfg.protocol = Protocol::Backward;
        assert_eq!(supervised_indices(&views, &cfg), vec![3, 4, 5], "t ≥ 0.5");
    }
}
