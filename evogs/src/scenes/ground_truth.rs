//! `motion.json`: the ground-truth motion of a generated scene, for analysis only (nothing
//! in training or in the defaults reads it).
//!
//! Per body: its closed-form [`Law`], its rigid `world_from_body` transform sampled at
//! [`GroundTruth::sample_times`], the indices of its Gaussians (the vertices of
//! `points3d.ply`, which are the Gaussians' centres at `t = 0`) and their body-frame points,
//! so that the position of Gaussian `gaussians[k]` at `t` is `law.position(body_points[k], t)`.

use super::law::Law;
use evogs_math::Vec3;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The format tag of `motion.json`.
pub const FORMAT: &str = "evogs-scene-motion/1";

/// The ground truth of one scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GroundTruth {
    /// [`FORMAT`].
    pub format: String,
    /// The scene's name.
    pub scene: String,
    /// The generator's seed.
    pub seed: u64,
    /// The times the rigid transforms are sampled at (`[−0.3, 1.3]`, every 0.01).
    pub sample_times: Vec<f64>,
    /// Every body, the static floor included.
    pub bodies: Vec<BodyTruth>,
}

/// The ground truth of one body.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BodyTruth {
    /// Name.
    pub name: String,
    /// `false` for the static floor.
    pub moving: bool,
    /// The closed-form law and its parameters.
    pub law: Law,
    /// `world_from_body` at each sample time.
    pub samples: Vec<RigidSample>,
    /// Indices of the body's Gaussians (vertices of `points3d.ply`).
    pub gaussians: Vec<usize>,
    /// The body-frame point of each of those Gaussians (same order).
    pub body_points: Vec<[f64; 3]>,
}

/// A rigid transform `x ↦ R·x + p`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RigidSample {
    /// Rotation `R`, row-major.
    pub rotation: [[f64; 3]; 3],
    /// Translation `p`.
    pub translation: [f64; 3],
}

impl BodyTruth {
    /// Where the body's `k`-th Gaussian is at `t`.
    #[must_use]
    pub fn position(&self, k: usize, t: f64) -> Vec3<f64> {
        let b = self.body_points[k];
        self.law.position(Vec3::new(b[0], b[1], b[2]), t)
    }
}

impl GroundTruth {
    /// Reads `motion.json`.
    ///
    /// # Errors
    /// An unreadable or malformed file, or another format (named).
    pub fn read(path: &Path) -> Result<Self, String> {
        let text =
            crate::bounded::read_text(path, crate::bounded::METADATA_BYTES, "a scene motion file")
                .map_err(|e| e.to_string())?;
        let gt: Self = serde_json::from_str(&text)
            .map_err(|e| format!("{}: not a scene motion file: {e}", path.display()))?;
        if gt.format != FORMAT {
            return Err(format!(
                "{}: format `{}`, expected `{FORMAT}`",
                path.display(),
                gt.format
            ));
        }
        if let Some(b) = gt
            .bodies
            .iter()
            .find(|b| b.gaussians.len() != b.body_points.len())
        {
            return Err(format!(
                "{}: body `{}` has {} Gaussians but {} body points",
                path.display(),
                b.name,
                b.gaussians.len(),
                b.body_points.len()
            ));
        }
        Ok(gt)
    }

    /// `motion.json` of a dataset folder, if it has one.
    ///
    /// # Errors
    /// As [`GroundTruth::read`] for a file that exists.
    pub fn of_dataset(root: &Path) -> Result<Option<Self>, String> {
        let p = root.join("motion.json");
        if p.is_file() {
            Self::read(&p).map(Some)
        } else {
            Ok(None)
        }
    }
}
