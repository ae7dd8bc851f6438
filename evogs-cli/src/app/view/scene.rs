//! What the page needs to know about a run before its first frame (`scene.json`): the
//! number of Gaussians, the motion, the trained and reachable time ranges, the default
//! time slider range, the dataset's cameras and the world's up direction.

use crate::app::render::{orbit_center, world_up};
use evogs::data::Dataset;
use evogs::model::Model;
use evogs::model::dynamics::MAX_EXTRAPOLATION;

/// One camera of the dataset, as the page places it.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SceneCamera {
    /// A name to show: the frame's file without extension (`test/r_000`) or a rig camera's
    /// folder name (`cam03`).
    pub name: String,
    /// The split it comes from (`test`, `val`, `train`, `rig`).
    pub split: String,
    /// The time of its frame (null for a rig camera, which films every time).
    pub time: Option<f64>,
    /// Camera-to-world matrix, rows, in the D-NeRF / OpenGL convention (the camera looks
    /// down its −z axis, +y up), which is also three.js's.
    pub c2w: [[f64; 4]; 4],
    /// Horizontal field of view in radians.
    pub fov_x: f64,
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
}

/// Precomputed frames of a static export.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SceneFrames {
    /// The time of each frame, increasing.
    pub times: Vec<f64>,
    /// The file of each frame, relative to the page.
    pub files: Vec<String>,
}

/// The content of `scene.json`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SceneInfo {
    /// Number of Gaussians.
    pub gaussians: usize,
    /// How the Gaussians move (`velocity`, `deformation`, `static`).
    pub motion: String,
    /// Storage SH degree of the model (the page gets the degree-0 colour only).
    pub sh_degree: usize,
    /// The time range the model was trained on (its first and last anchor).
    pub train_range: [f64; 2],
    /// The times the model can be evaluated at (`Model::check_time`).
    pub reach: [f64; 2],
    /// The time slider's default range: the trained range and half of it again on either
    /// side (backward and forward rollout), within reach.
    pub slider_range: [f64; 2],
    /// Background colour (RGB in [0, 1]), the one `evogs render` uses.
    pub background: [f32; 3],
    /// The world's up direction (`render::world_up`).
    pub up: [f64; 3],
    /// The point the orbit controls turn around (`render::orbit_center`).
    pub center: [f64; 3],
    /// The dataset's cameras, test cameras first.
    pub cameras: Vec<SceneCamera>,
    /// Index in `cameras` of the start view (the first test camera when there is one).
    pub start_camera: usize,
    /// The precomputed frames of a static export; `None` when a server computes them.
    pub frames: Option<SceneFrames>,
}

fn views_of(ds: &Dataset) -> Vec<SceneCamera> {
    let mut cams = Vec::new();
    for (split, views) in [("test", &ds.test), ("val", &ds.val), ("train", &ds.train)] {
        for v in views {
            let rel = v.file.strip_prefix(&ds.root).unwrap_or(&v.file);
            let name = rel.with_extension("").to_string_lossy().replace('\\', "/");
            cams.push(SceneCamera {
                name,
                split: split.to_string(),
                time: Some(v.time),
                c2w: v.c2w,
                fov_x: v.fov_x,
                width: v.width,
                height: v.height,
            });
        }
    }
    cams
}

impl SceneInfo {
    /// The description of `model` seen through `ds`'s cameras: a multi-view rig's cameras
    /// (one per camera, not per frame) or else every test, validation and training view.
    #[must_use]
    pub fn new(model: &Model<f32>, ds: &Dataset) -> Self {
        let (a, b) = match (model.anchor_times.first(), model.anchor_times.last()) {
            (Some(&a), Some(&b)) => (a, b),
            _ => (0.0, 1.0),
        };
        let span = if b > a { b - a } else { 1.0 };
        let reach = [a - MAX_EXTRAPOLATION * span, b + MAX_EXTRAPOLATION * span];
        let cameras = if ds.rig.is_empty() {
            views_of(ds)
        } else {
            ds.rig
                .iter()
                .map(|c| SceneCamera {
                    name: c.name.clone(),
                    split: "rig".into(),
                    time: None,
                    c2w: c.c2w,
                    fov_x: c.fov_x,
                    width: c.width,
                    height: c.height,
                })
                .collect()
        };
        let up = world_up(ds);
        let c = orbit_center(model, ds);
        Self {
            gaussians: model.len(),
            motion: model.motion.as_str().to_string(),
            sh_degree: model.canonical.sh_degree,
            train_range: [a, b],
            reach,
            slider_range: [
                (a - 0.5 * span).max(reach[0]),
                (b + 0.5 * span).min(reach[1]),
            ],
            background: [1.0, 1.0, 1.0],
            up: [up.x, up.y, up.z],
            center: [c.x, c.y, c.z],
            cameras,
            start_camera: 0,
            frames: None,
        }
    }
}
