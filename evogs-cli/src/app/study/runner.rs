//! One run of a study: train (or resume) in its own folder with its share of the threads,
//! evaluate its held-out sets, and write `RUN/study-run.json`.

use super::protocol::{HeldOutSet, StudyProtocol};
use super::record::{RunRecord, SetMetrics};
use crate::app::Reporter;
use crate::app::error::CommandError;
use crate::app::paths::RunFolder;
use crate::app::train::{TrainArgs, train};
use evogs::data::DataIdentity;
use evogs::data::Dataset;
use evogs::eval::evaluate_views;
use evogs::model::Motion;
use evogs::run::checkpoint;
use evogs::scenes::{GroundTruth, model_trajectory_error};
use evogs_math::Par;
use std::path::{Path, PathBuf};

/// Time the trajectory error is measured at (the end of the future split).
pub(super) const TRAJECTORY_TIME: f64 = 1.3;

/// The record a finished run leaves in its folder.
pub(super) const RECORD_FILE: &str = "study-run.json";

/// What has to happen to a planned run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum RunState {
    /// Finished and evaluated earlier: its record is reused.
    Done,
    /// Interrupted: continue from its checkpoint.
    Resume,
    /// Not started (or `--force`): train from scratch.
    Fresh,
}

/// A run of the study's plan.
#[derive(Clone, Debug)]
pub(super) struct PlannedRun {
    /// The protocol.
    pub(super) protocol: StudyProtocol,
    /// The motion.
    pub(super) motion: Motion,
    /// Index of the repeat.
    pub(super) repeat: usize,
    /// The training seed.
    pub(super) seed: u64,
    /// Folder relative to the study folder.
    pub(super) folder: String,
    /// The arguments `evogs train` gets (`resume` set from the state).
    pub(super) args: TrainArgs,
    /// Hash of the resolved configuration.
    pub(super) config_hash: String,
    /// The study's training data.
    pub(super) data: DataIdentity,
    /// Planned iterations.
    pub(super) iterations: u64,
    /// What has to happen.
    pub(super) state: RunState,
}

impl PlannedRun {
    /// `protocol / motion / seed k`, for progress lines.
    pub(super) fn label(&self) -> String {
        format!(
            "{} / {} / seed {}",
            self.protocol,
            self.motion.as_str(),
            self.repeat
        )
    }

    /// The record file in the run folder.
    pub(super) fn record_path(&self) -> PathBuf {
        self.args.out.join(RECORD_FILE)
    }
}

/// Reads a run record.
///
/// # Errors
/// An unreadable or malformed file (named).
pub(super) fn read_record(path: &Path) -> Result<RunRecord, CommandError> {
    let text =
        evogs::bounded::read_text(path, evogs::bounded::METADATA_BYTES, "a study run record")
            .map_err(CommandError::new)?;
    serde_json::from_str(&text).map_err(|e| {
        CommandError::at(
            path,
            format!("not a study run record ({e}); delete it or pass --force"),
        )
    })
}

/// Writes `bytes` to `path` atomically ([`evogs::atomic`]).
///
/// # Errors
/// I/O failures, naming the file.
pub(super) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), CommandError> {
    evogs::atomic::write_atomic_named(path, bytes).map_err(CommandError::new)
}

/// Trains (or resumes) the run, evaluates its held-out sets and writes its record.
///
/// `threads` is the run's share of the machine: with the `rayon` feature the run's kernels
/// use a pool of that many threads (results do not depend on it: kernels reduce in fixed
/// chunks).
///
/// # Errors
/// Training, checkpoint or evaluation failures, naming the run's folder.
pub(super) fn execute(
    run: &PlannedRun,
    ds: &Dataset,
    sets: &[HeldOutSet],
    threads: usize,
    rep: &mut (dyn Reporter + Send),
) -> Result<RunRecord, CommandError> {
    #[cfg(feature = "rayon")]
    {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| CommandError::new(format!("cannot start {threads} threads: {e}")))?;
        pool.install(|| execute_here(run, ds, sets, threads, rep))
    }
    #[cfg(not(feature = "rayon"))]
    {
        let _ = threads;
        execute_here(run, ds, sets, 1, rep)
    }
}

fn execute_here(
    run: &PlannedRun,
    ds: &Dataset,
    sets: &[HeldOutSet],
    threads: usize,
    rep: &mut dyn Reporter,
) -> Result<RunRecord, CommandError> {
    let mut args = run.args.clone();
    args.resume = run.state == RunState::Resume;
    let at = |e: CommandError| CommandError::new(format!("{} ({}): {e}", run.folder, run.label()));
    let outcome = train(&args, rep).map_err(at)?;
    let folder = RunFolder::new(&args.out);
    let loaded =
        checkpoint::load_model(&folder.checkpoint()).map_err(|e| at(CommandError::new(e)))?;
    let mut model = loaded.model;
    model.set_par(Par::best());
    let mut metrics = Vec::with_capacity(sets.len());
    for set in sets {
        let views = set.views(ds);
        rep.start(&format!("evaluate {}", set.name), views.len() as u64);
        let m = evaluate_views(
            &mut model,
            &views,
            set.split,
            loaded.cfg.data.background,
            Par::best(),
            |d, _| rep.progress(d as u64, ""),
        )
        .map_err(|e| at(CommandError::new(e)))?;
        rep.finish();
        metrics.push(SetMetrics {
            set: set.name.clone(),
            frames: m.frames.len(),
            psnr: m.psnr,
            ssim: m.ssim,
        });
    }
    let trajectory = match run.protocol {
        StudyProtocol::Future(tau) if run.motion != Motion::Static => {
            let truth = GroundTruth::of_dataset(&ds.root).map_err(|e| at(CommandError::new(e)))?;
            truth.and_then(|gt| model_trajectory_error(&mut model, &gt, tau, TRAJECTORY_TIME))
        }
        _ => None,
    };
    let hop_share = hop_share(&mut model);
    let record = RunRecord {
        protocol: run.protocol,
        motion: run.motion,
        repeat: run.repeat,
        seed: run.seed,
        folder: run.folder.clone(),
        config_hash: run.config_hash.clone(),
        data: Some(run.data.clone()),
        iterations: outcome.iterations,
        train_seconds: outcome.seconds,
        gaussians: outcome.gaussians,
        threads,
        sets: metrics,
        trajectory,
        hop_share,
    };
    let json = serde_json::to_string_pretty(&record).map_err(|e| {
        at(CommandError::new(format!(
            "cannot encode the run record: {e}"
        )))
    })?;
    write_atomic(&run.record_path(), json.as_bytes()).map_err(at)?;
    Ok(record)
}

/// The mean [`Model::hop_share`](evogs::model::Model::hop_share) at eight times spread over
/// the window (continuous waypoints; `None` otherwise).
fn hop_share(model: &mut evogs::model::Model<f32>) -> Option<f64> {
    let (a, b) = model.hop.window;
    let shares: Vec<f64> = (0..8)
        .filter_map(|k| {
            let t = a + (f64::from(k) + 0.5) / 8.0 * (b - a);
            model.hop_share(t, evogs::model::HopStart::Before)
        })
        .collect();
    (!shares.is_empty()).then(|| shares.iter().sum::<f64>() / shares.len() as f64)
}
