//! `evogs eval`: metrics of a trained run on a split, whole-image and inside each frame's
//! motion mask, written to `RUN/metrics-<split>.json`, the per-frame values to
//! `RUN/metrics-<split>.csv`, and PSNR against time to `RUN/metrics-<split>.png` (the
//! training window and times marked).

use super::error::{CommandError, Context};
use super::load::load_dataset;
use super::paths::RunFolder;
use super::plot::{TimePanel, TimeSeries, TrainingMarks, save_time_plot};
use super::{Reporter, interrupt};
use evogs::config::DataConfig;
use evogs::data::{DataFormat, DataIdentity, SplitName, View};
use evogs::eval::dynamic::MotionMasks;
use evogs::eval::table::frames_csv;
use evogs::eval::{SplitMetrics, evaluate_views_masked};
use evogs::run::checkpoint;
use evogs::train::views::supervised_indices;
use evogs_math::Par;
use std::path::{Path, PathBuf};

/// Parses `A:B` into a closed time range.
///
/// # Errors
/// A malformed range.
pub fn parse_range(s: &str) -> Result<(f64, f64), String> {
    let p: Vec<&str> = s.split(':').collect();
    let bad = || format!("`{s}` is not A:B (e.g. 0.75:1)");
    if p.len() != 2 {
        return Err(bad());
    }
    let a: f64 = p[0].trim().parse().map_err(|_| bad())?;
    let b: f64 = p[1].trim().parse().map_err(|_| bad())?;
    if !a.is_finite() || !b.is_finite() || a > b {
        return Err(bad());
    }
    Ok((a, b))
}

/// What a run trained on: the window and the distinct times of the training views its
/// protocol supervises.
#[must_use]
pub fn training_marks(train: &[View], data: &DataConfig) -> TrainingMarks {
    let mut times: Vec<f64> = supervised_indices(train, data)
        .into_iter()
        .map(|i| train[i].time)
        .collect();
    times.sort_by(f64::total_cmp);
    times.dedup();
    TrainingMarks {
        window: times.first().zip(times.last()).map(|(&a, &b)| (a, b)),
        times,
    }
}

/// The per-frame PSNR of `m` against time: the whole image, and inside the motion masks
/// where there are any.
#[must_use]
pub fn psnr_series(m: &SplitMetrics) -> Vec<TimeSeries> {
    let mut out = vec![TimeSeries {
        name: "whole image".into(),
        points: m.frames.iter().map(|f| (f.time, f.psnr)).collect(),
    }];
    let dynamic: Vec<(f64, f64)> = m
        .frames
        .iter()
        .filter_map(|f| Some((f.time, f.dynamic_psnr?)))
        .collect();
    if !dynamic.is_empty() {
        out.push(TimeSeries {
            name: "dynamic region".into(),
            points: dynamic,
        });
    }
    out
}

/// Runs `evogs eval` and writes the metrics file (`RUN/metrics-<split>.json`, or
/// `RUN/metrics-<split>-tA-B.json` for a time range, which the file also records), the
/// per-frame CSV and the plot beside it (same name, `.csv` and `.png`); returns the metrics
/// and the JSON file. `data` and `format` override the run's dataset folder and layout.
///
/// Each frame's motion mask is the dataset's `X_motion.png`, else (a camera pose shared over
/// time) the difference from that pose's temporal median; a lone monocular run without mask
/// files has no dynamic-region metrics, which the metrics' `dynamic_note` (and a line on
/// `rep`) says.
///
/// # Errors
/// Unreadable run or data, an empty split, a time range that selects no frame.
pub fn evaluate_run(
    run: &Path,
    split: SplitName,
    range: Option<(f64, f64)>,
    data: Option<&Path>,
    format: Option<DataFormat>,
    rep: &mut dyn Reporter,
) -> Result<(SplitMetrics, PathBuf), CommandError> {
    let folder = RunFolder::new(run);
    let l = checkpoint::load_model(&folder.checkpoint()).map_err(CommandError::new)?;
    let dir = match data {
        Some(d) => d.to_path_buf(),
        None => folder.data_dir().map_err(CommandError::new)?,
    };
    let mut cfg = l.cfg.clone();
    if let Some(f) = format {
        cfg.data.format = f;
    }
    // Images are decoded as each view is evaluated (one frame in memory at a time).
    let ds = load_dataset(&dir, &cfg, false)?;
    let now = DataIdentity::of(&ds);
    match &l.meta.data {
        Some(trained) if !trained.same_data(&now) => {
            return Err(CommandError::at(
                &folder.checkpoint(),
                format!(
                    "the run was trained on {}, and {} holds other training views ({}): its \
                     metrics would describe another scene than the run's own; evaluate with \
                     the run's data (a moved copy of it is accepted)",
                    trained.describe(),
                    dir.display(),
                    now.describe()
                ),
            ));
        }
        Some(_) => {}
        None => rep.info(&DataIdentity::unrecorded_note(&dir.display().to_string())),
    }
    let views = ds.split(split);
    if views.is_empty() {
        return Err(CommandError::new(format!(
            "{}: the dataset has no `{}` split",
            dir.display(),
            split.as_str()
        )));
    }
    if let Some((a, b)) = range
        && !views.iter().any(|v| v.time >= a && v.time <= b)
    {
        let (lo, hi) = views
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(x, y), v| {
                (x.min(v.time), y.max(v.time))
            });
        return Err(CommandError::new(format!(
            "--time-range {a}:{b} selects none of the {} `{}` frames (their times lie in \
             [{lo}, {hi}])",
            views.len(),
            split.as_str()
        )));
    }
    let mut model = l.model;
    model.set_par(Par::best());
    let selected: Vec<&View> = views
        .iter()
        .filter(|v| range.is_none_or(|(a, b)| v.time >= a && v.time <= b))
        .collect();
    rep.start(
        &format!("evaluate {}", split.as_str()),
        selected.len() as u64,
    );
    // The masks come from the ground truth alone: the temporal median of a pose is taken over
    // its frames in every split, whatever the time range.
    let mut masks = MotionMasks::new(ds.all_views());
    // An interrupt stops before the next frame's metrics; nothing is written. (The mask
    // source is asked once per frame, so it is where the request is seen.)
    let mut done = 0usize;
    let mut interrupted = false;
    let result = evaluate_views_masked(
        &mut model,
        &selected,
        split,
        &ds.rig,
        l.cfg.data.background,
        Par::best(),
        &mut |v, gt| {
            if interrupt::take() {
                interrupted = true;
                return Err(String::from("interrupted"));
            }
            masks.mask(v, gt)
        },
        |d, _| {
            done = d;
            rep.progress(d as u64, "");
        },
    );
    if interrupted {
        rep.finish();
        return Err(CommandError::new(format!(
            "interrupted after {done} of {} frames: no metrics written",
            selected.len()
        )));
    }
    let mut m = result.map_err(CommandError::new)?;
    rep.finish();
    if let Some(note) = &m.dynamic_note {
        rep.info(note);
    }
    m.iterations = l.archive.meta["iteration"].as_u64().unwrap_or(0);
    m.train_seconds = l.archive.meta["train_seconds"].as_f64().unwrap_or(0.0);
    m.time_range = range.map(|(a, b)| [a, b]);
    // A restricted evaluation gets its own file, beside (not over) the whole split's.
    let name = match range {
        Some((a, b)) => format!("{}-t{a}-{b}", split.as_str()),
        None => split.as_str().to_string(),
    };
    let path = folder.metrics(&name);
    let json = serde_json::to_string_pretty(&m).unwrap_or_default();
    evogs::atomic::write_atomic(&path, json.as_bytes()).doing(&path, "cannot write the metrics")?;
    let csv = path.with_extension("csv");
    evogs::atomic::write_atomic(&csv, frames_csv(&m.frames).as_bytes())
        .doing(&csv, "cannot write the per-frame metrics")?;
    let panel = TimePanel {
        y_label: "PSNR (dB)".into(),
        series: psnr_series(&m),
    };
    save_time_plot(
        &format!(
            "{}: {name} PSNR against time",
            run.file_name().map_or_else(
                || run.display().to_string(),
                |n| n.to_string_lossy().into_owned()
            )
        ),
        &[panel],
        &training_marks(&ds.train, &l.cfg.data),
        &path.with_extension("png"),
    )?;
    Ok((m, path))
}
