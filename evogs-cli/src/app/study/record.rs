//! What a study stores per run and per baseline: the record a finished run writes
//! (`RUN/study-run.json`) and the baselines computed from a deformation run
//! (`RUN/baselines.json`), read back to build the study's tables (`super::report`).

use super::protocol::StudyProtocol;
use evogs::extrapolate::Extrapolation;
use evogs::model::Motion;
use evogs::scenes::TrajectoryError;
use serde::{Deserialize, Serialize};

/// Metrics of one held-out set of one run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SetMetrics {
    /// The set's name (a row of the table).
    pub set: String,
    /// Number of frames evaluated.
    pub frames: usize,
    /// Mean PSNR (dB).
    pub psnr: f64,
    /// Mean SSIM.
    pub ssim: f64,
}

/// What one (protocol, motion, seed) run produced: `RUN/study-run.json`, written when the
/// run is finished and evaluated.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// The protocol.
    pub protocol: StudyProtocol,
    /// The motion.
    pub motion: Motion,
    /// Index of the repeat (0-based).
    pub repeat: usize,
    /// The training seed.
    pub seed: u64,
    /// The run folder, relative to the study folder.
    pub folder: String,
    /// Hash of the run's resolved configuration.
    pub config_hash: String,
    /// The training data (absent in records written before it was recorded).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub data: Option<evogs::data::DataIdentity>,
    /// Iterations trained.
    pub iterations: u64,
    /// Training seconds (resumed runs: the sum over their sessions).
    pub train_seconds: f64,
    /// Gaussians at the end.
    pub gaussians: usize,
    /// Threads the run trained with.
    pub threads: usize,
    /// Metrics per held-out set.
    pub sets: Vec<SetMetrics>,
    /// Trajectory error at t = 1.3 against the dataset's `motion.json` (future protocols of
    /// datasets that have one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectory: Option<TrajectoryError>,
    /// Continuous waypoints: the mean share of the waypoint field's displacement over a hop
    /// that the velocity field carries (`Model::hop_share`, eight times across the window).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hop_share: Option<f64>,
}

/// One baseline's metrics in a [`BaselineRecord`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BaselineSets {
    /// The baseline.
    pub baseline: Extrapolation,
    /// Metrics per held-out set beyond the split time.
    pub sets: Vec<SetMetrics>,
    /// Trajectory error at t = 1.3, when the dataset has `motion.json`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectory: Option<TrajectoryError>,
}

/// The no-training baselines computed from one deformation run (`RUN/baselines.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BaselineRecord {
    /// The protocol (a `future:TAU`).
    pub protocol: StudyProtocol,
    /// Index of the repeat of the deformation run.
    pub repeat: usize,
    /// The deformation run's folder, relative to the study folder.
    pub folder: String,
    /// Hash of the deformation run's configuration.
    pub config_hash: String,
    /// The end of the window the baselines extrapolate from (`TAU`).
    pub end: f64,
    /// The finite-difference step.
    pub step: f64,
    /// Every baseline.
    pub baselines: Vec<BaselineSets>,
}
