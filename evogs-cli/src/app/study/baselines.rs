//! The no-training baselines of the `future:TAU` protocols (`hold`, `const-vel`,
//! `const-acc`, [`evogs::extrapolate`]): computed from each deformation run of the study at
//! the split time, evaluated on the same held-out sets beyond it, and stored beside the run
//! (`RUN/baselines.json`, reused while the run's configuration is unchanged).

use super::protocol::{HeldOutSet, StudyProtocol};
use super::record::{BaselineRecord, BaselineSets, SetMetrics};
use super::runner::{PlannedRun, TRAJECTORY_TIME, write_atomic};
use crate::app::Reporter;
use crate::app::error::CommandError;
use crate::app::paths::RunFolder;
use evogs::data::Dataset;
use evogs::extrapolate::{Extrapolation, Extrapolator};
use evogs::model::Motion;
use evogs::run::checkpoint;
use evogs::scenes::{GroundTruth, trajectory_error};
use evogs_math::Par;

/// The baselines' file in a deformation run's folder.
const FILE: &str = "baselines.json";
/// Finite-difference step in frame spacings.
const STEPS: f64 = 2.0;
/// Slack on time comparisons.
const TIME_EPS: f64 = 1e-9;

/// The finite-difference step: [`STEPS`] mean spacings of the distinct training times up to
/// `tau`.
pub(super) fn difference_step(ds: &Dataset, tau: f64) -> Option<f64> {
    let mut times: Vec<f64> = ds
        .train
        .iter()
        .map(|v| v.time)
        .filter(|&t| t <= tau + TIME_EPS)
        .collect();
    times.sort_by(f64::total_cmp);
    times.dedup_by(|a, b| (*a - *b).abs() < TIME_EPS);
    if times.len() < 3 {
        return None;
    }
    let spacing = (times[times.len() - 1] - times[0]) / (times.len() - 1) as f64;
    Some(STEPS * spacing)
}

/// The baseline records of every finished deformation run of a `future` protocol (computed,
/// or reused from `RUN/baselines.json`).
///
/// # Errors
/// A checkpoint that cannot be read or a frame that cannot be evaluated, naming the run.
pub(super) fn baselines(
    runs: &[PlannedRun],
    ds: &Dataset,
    sets: &[Vec<HeldOutSet>],
    protocols: &[StudyProtocol],
    truth: Option<&GroundTruth>,
    rep: &mut dyn Reporter,
) -> Result<Vec<BaselineRecord>, CommandError> {
    let mut out = Vec::new();
    for run in runs {
        let StudyProtocol::Future(tau) = run.protocol else {
            continue;
        };
        if run.motion != Motion::Deformation {
            continue;
        }
        let path = run.args.out.join(FILE);
        if let Ok(text) = evogs::bounded::read_text(&path, evogs::bounded::METADATA_BYTES, FILE)
            && let Ok(r) = serde_json::from_str::<BaselineRecord>(&text)
            && r.config_hash == run.config_hash
        {
            out.push(r);
            continue;
        }
        let Some(h) = difference_step(ds, tau) else {
            rep.info(&format!(
                "{}: fewer than 3 training times up to {tau}, no baselines",
                run.folder
            ));
            continue;
        };
        let at = |e: String| CommandError::new(format!("{} (baselines): {e}", run.folder));
        let loaded = checkpoint::load_model(&RunFolder::new(&run.args.out).checkpoint())
            .map_err(|e| at(e.to_string()))?;
        let mut model = loaded.model;
        model.set_par(Par::best());
        let p = protocols
            .iter()
            .position(|&q| q == run.protocol)
            .unwrap_or(0);
        let beyond: Vec<&HeldOutSet> = sets[p]
            .iter()
            .filter(|s| s.views(ds).iter().all(|v| v.time > tau + TIME_EPS))
            .collect();
        let mut kinds = Vec::new();
        for kind in Extrapolation::ALL {
            let e = Extrapolator::from_model(&mut model, kind, tau, h);
            let mut metrics = Vec::new();
            for set in &beyond {
                let views = set.views(ds);
                rep.info(&format!(
                    "{}: {} on {}",
                    run.folder,
                    kind.as_str(),
                    set.name
                ));
                let m = e
                    .evaluate(&views, set.split, loaded.cfg.data.background, Par::best())
                    .map_err(at)?;
                metrics.push(SetMetrics {
                    set: set.name.clone(),
                    frames: m.frames.len(),
                    psnr: m.psnr,
                    ssim: m.ssim,
                });
            }
            let trajectory = truth.and_then(|gt| {
                let mut end = evogs_splat::Splats::default();
                let mut later = evogs_splat::Splats::default();
                e.splats_at(tau, &mut end);
                e.splats_at(TRAJECTORY_TIME, &mut later);
                trajectory_error(gt, &end.means, &later.means, tau, TRAJECTORY_TIME)
            });
            kinds.push(BaselineSets {
                baseline: kind,
                sets: metrics,
                trajectory,
            });
        }
        let record = BaselineRecord {
            protocol: run.protocol,
            repeat: run.repeat,
            folder: run.folder.clone(),
            config_hash: run.config_hash.clone(),
            end: tau,
            step: h,
            baselines: kinds,
        };
        let json = serde_json::to_string_pretty(&record)
            .map_err(|e| at(format!("cannot encode the baselines: {e}")))?;
        write_atomic(&path, json.as_bytes())?;
        // The table is built from the record as stored (as a reused one is read), so a study
        // that reuses it reproduces its table exactly.
        let stored: BaselineRecord = serde_json::from_str(&json)
            .map_err(|e| at(format!("cannot read back the baselines: {e}")))?;
        out.push(stored);
    }
    Ok(out)
}
