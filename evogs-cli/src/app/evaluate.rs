//! `evogs eval`: metrics of a trained run on a split, written to `RUN/metrics-<split>.json`.

use super::Reporter;
use super::error::CommandError;
use super::load::load_dataset;
use super::paths::RunFolder;
use evogs::data::{DataFormat, SplitName};
use evogs::eval::{SplitMetrics, evaluate};
use evogs::run::checkpoint;
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

/// Runs `evogs eval` and writes the metrics file (`RUN/metrics-<split>.json`, or
/// `RUN/metrics-<split>-tA-B.json` for a time range, which the file also records); returns
/// the metrics and the file. `data` and `format` override the run's dataset folder and
/// layout.
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
    model.field.set_par(Par::best());
    rep.start(&format!("evaluate {}", split.as_str()), views.len() as u64);
    let mut m = evaluate(
        &mut model,
        views,
        split,
        range,
        l.cfg.data.background,
        Par::best(),
        |d, _| rep.progress(d as u64, ""),
    )
    .map_err(CommandError::new)?;
    rep.finish();
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
    evogs::atomic::write_atomic(&path, json.as_bytes())
        .map_err(|e| CommandError::new(format!("{}: {e}", path.display())))?;
    Ok((m, path))
}
