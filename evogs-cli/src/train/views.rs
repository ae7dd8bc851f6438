//! From dataset views to training views: cameras, the training protocol's frame selection,
//! the time range and the scene extent.

use super::step::ViewData;
use crate::config::{DataConfig, Protocol};
use crate::data::View;
use evogs_splat::{CameraError, PinholeCamera};

/// The camera of a dataset view, in any precision.
///
/// # Errors
/// A non-finite or non-rigid camera matrix (named by the view's file).
pub fn view_camera<T: evogs_math::Real>(v: &View) -> Result<PinholeCamera<T>, String> {
    PinholeCamera::from_dnerf(v.c2w, v.fov_x, v.width, v.height)
        .map_err(|e: CameraError| format!("{}: bad camera: {e}", v.file.display()))
}

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

/// Training views (images and cameras in f32) for the given indices.
///
/// # Errors
/// A view without an image, or a bad camera.
pub fn training_views(views: &[View], indices: &[usize]) -> Result<Vec<ViewData<f32>>, String> {
    indices
        .iter()
        .map(|&i| {
            let v = &views[i];
            let image = v
                .image
                .clone()
                .ok_or_else(|| format!("{}: image not loaded", v.file.display()))?;
            Ok(ViewData {
                camera: view_camera(v)?,
                time: v.time,
                image,
            })
        })
        .collect()
}

/// The scene extent of 3DGS (`getNerfppNorm`): 1.1 × the largest distance of a camera centre
/// from the mean centre (the `spatial_lr_scale` of the learning rates).
#[must_use]
pub fn camera_extent(views: &[ViewData<f32>]) -> f64 {
    if views.is_empty() {
        return 1.0;
    }
    let centres: Vec<[f64; 3]> = views
        .iter()
        .map(|v| v.camera.center().cast::<f64>().to_array())
        .collect();
    #[allow(clippy::cast_precision_loss, reason = "view counts are small")]
    let n = centres.len() as f64;
    let mean: [f64; 3] = core::array::from_fn(|a| centres.iter().map(|c| c[a]).sum::<f64>() / n);
    let far = centres
        .iter()
        .map(|c| (0..3).map(|a| (c[a] - mean[a]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    1.1 * far.max(1e-6)
}

/// The smallest and largest time of a set of views.
#[must_use]
pub fn time_range(views: &[ViewData<f32>]) -> (f64, f64) {
    views
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v.time), b.max(v.time))
        })
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
        }
    }

    #[test]
    fn protocols_select_frames() {
        let views: Vec<View> = [0.0, 0.25, 0.25, 0.5, 0.75, 1.0]
            .iter()
            .map(|&t| view(t))
            .collect();
        let mut cfg = DataConfig {
            background: [1.0; 3],
            downscale: 1,
            protocol: Protocol::Full,
            stride: 2,
            split_time: 0.5,
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
