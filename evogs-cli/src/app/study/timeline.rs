//! The study's dynamic-region table and its metrics against time: every finished run is
//! evaluated once more, frame by frame, on its protocol's held-out sets, inside motion masks
//! made from the ground truth alone (the dataset's `X_motion.png`, else a fixed camera's
//! temporal median, else the difference from the protocol's static run, seed 0); the
//! per-frame PSNR gives one plot per protocol, the motions overlaid.

use super::protocol::{HeldOutSet, StudyProtocol};
use super::report::{Cell, CurvePoint, DynamicRow, MotionCurve, Stat, Timeline};
use super::runner::PlannedRun;
use crate::app::Reporter;
use crate::app::error::CommandError;
use crate::app::evaluate::training_marks;
use crate::app::paths::RunFolder;
use crate::app::plot::{TimePanel, TimeSeries, TrainingMarks, save_time_plot};
use evogs::config::DataConfig;
use evogs::data::Dataset;
use evogs::eval::dynamic::{FrameMask, MotionMasks, NO_MASK_NOTE};
use evogs::eval::{SplitMetrics, evaluate_views_masked};
use evogs::model::{Model, Motion};
use evogs::run::checkpoint;
use evogs_math::Par;
use std::path::{Path, PathBuf};

/// Per-frame metrics of one run on its protocol's held-out sets.
#[derive(Clone, Debug)]
pub(super) struct RunFrames {
    protocol: StudyProtocol,
    motion: Motion,
    /// Per set: its name and the metrics.
    sets: Vec<(String, SplitMetrics)>,
}

/// What the study-wide dynamic pass produced.
#[derive(Clone, Debug, Default)]
pub(super) struct DynamicPass {
    /// The dynamic-region table.
    pub(super) rows: Vec<DynamicRow>,
    /// One per protocol.
    pub(super) timelines: Vec<Timeline>,
    /// Why some frames have no dynamic-region metrics, if so.
    pub(super) note: Option<String>,
}

fn load(folder: &Path) -> Result<Model<f32>, CommandError> {
    let l =
        checkpoint::load_model(&RunFolder::new(folder).checkpoint()).map_err(CommandError::new)?;
    let mut model = l.model;
    model.set_par(Par::best());
    Ok(model)
}

/// The masks of every frame of `sets` (per set, in order).
fn masks_of(
    ds: &Dataset,
    sets: &[HeldOutSet],
    reference: Option<&mut Model<f32>>,
    background: [f32; 3],
) -> Result<Vec<Vec<Option<FrameMask>>>, CommandError> {
    let mut masks = MotionMasks::new(ds.all_views());
    if let Some(m) = reference {
        masks = masks.with_static_reference(m, background, Par::best());
    }
    sets.iter()
        .map(|s| {
            s.views(ds)
                .into_iter()
                .map(|v| {
                    let gt = v.image_or_decode().map_err(CommandError::new)?;
                    masks.mask(v, &gt).map_err(CommandError::new)
                })
                .collect()
        })
        .collect()
}

/// Evaluates every run frame by frame inside the motion masks, and aggregates the table and
/// the curves; writes one plot per protocol into `out`.
///
/// # Errors
/// A run that cannot be loaded or evaluated, a mask that cannot be made, a plot that cannot
/// be written.
pub(super) fn dynamic_pass(
    runs: &[PlannedRun],
    ds: &Dataset,
    sets: &[Vec<HeldOutSet>],
    protocols: &[StudyProtocol],
    motions: &[Motion],
    base: &DataConfig,
    out: &Path,
    rep: &mut dyn Reporter,
) -> Result<(DynamicPass, Vec<PathBuf>), CommandError> {
    let mut frames: Vec<RunFrames> = Vec::new();
    let mut pass = DynamicPass::default();
    let mut plots = Vec::new();
    let mut unmasked = 0usize;
    for (pi, &p) in protocols.iter().enumerate() {
        let of_p: Vec<&PlannedRun> = runs.iter().filter(|r| r.protocol == p).collect();
        let mut reference = of_p
            .iter()
            .find(|r| r.motion == Motion::Static && r.repeat == 0)
            .map(|r| load(&r.args.out))
            .transpose()?;
        let masks = masks_of(ds, &sets[pi], reference.as_mut(), base.background)?;
        drop(reference);
        unmasked += masks.iter().flatten().filter(|m| m.is_none()).count();
        for r in &of_p {
            let mut model = load(&r.args.out)?;
            let mut per_set = Vec::new();
            for (set, set_masks) in sets[pi].iter().zip(&masks) {
                let views = set.views(ds);
                rep.start(
                    &format!("{}: dynamic regions of {}", r.label(), set.name),
                    views.len() as u64,
                );
                let mut k = 0usize;
                let m = evaluate_views_masked(
                    &mut model,
                    &views,
                    set.split,
                    &ds.rig,
                    base.background,
                    Par::best(),
                    &mut |_, _| {
                        let m = set_masks.get(k).cloned().flatten();
                        k += 1;
                        Ok(m)
                    },
                    |d, _| rep.progress(d as u64, ""),
                )
                .map_err(CommandError::new)?;
                rep.finish();
                per_set.push((set.name.clone(), m));
            }
            frames.push(RunFrames {
                protocol: p,
                motion: r.motion,
                sets: per_set,
            });
        }
        let mut data = base.clone();
        p.apply(&mut data);
        let marks = training_marks(&ds.train, &data);
        let timeline = timeline(p, motions, &frames, &marks);
        let path = out.join(&timeline.plot);
        save_timeline(&timeline, motions, &marks, &path)?;
        plots.push(path);
        pass.timelines.push(timeline);
        pass.rows.extend(rows(p, motions, &sets[pi], &frames));
    }
    pass.note = (unmasked > 0).then(|| format!("{unmasked} held-out frames: {NO_MASK_NOTE}"));
    Ok((pass, plots))
}

/// The dynamic-region rows of protocol `p`.
fn rows(
    p: StudyProtocol,
    motions: &[Motion],
    sets: &[HeldOutSet],
    frames: &[RunFrames],
) -> Vec<DynamicRow> {
    let of_p: Vec<&RunFrames> = frames.iter().filter(|f| f.protocol == p).collect();
    let mut out = Vec::new();
    for set in sets {
        let metrics = |m: Motion| -> Vec<&SplitMetrics> {
            of_p.iter()
                .filter(|f| f.motion == m)
                .filter_map(|f| f.sets.iter().find(|(n, _)| *n == set.name))
                .map(|(_, s)| s)
                .collect()
        };
        let cells: Vec<Cell> = motions
            .iter()
            .filter_map(|&m| {
                let d: Vec<_> = metrics(m)
                    .into_iter()
                    .filter_map(|s| s.dynamic.as_ref())
                    .collect();
                let psnr: Vec<f64> = d.iter().map(|x| x.psnr).collect();
                let ssim: Vec<f64> = d.iter().map(|x| x.ssim).collect();
                Some(Cell {
                    motion: m,
                    psnr: Stat::of(&psnr)?,
                    ssim: Stat::of(&ssim)?,
                })
            })
            .collect();
        // The masks are the same for every run of the protocol: any run's summary says them.
        let Some(any) = of_p
            .iter()
            .find_map(|f| f.sets.iter().find(|(n, _)| *n == set.name))
            .map(|(_, s)| s)
        else {
            continue;
        };
        let Some(d) = any.dynamic.as_ref() else {
            continue;
        };
        out.push(DynamicRow {
            protocol: p,
            set: set.name.clone(),
            frames: any.frames.len(),
            masked_frames: d.frames,
            mask_fraction: d.mask_fraction,
            rules: d.rules.clone(),
            cells,
        });
    }
    out
}

/// The curves of protocol `p`: per motion, every frame of its sets (a frame in two sets
/// counted once), averaged over the frames at one time and over repeats.
fn timeline(
    p: StudyProtocol,
    motions: &[Motion],
    frames: &[RunFrames],
    marks: &TrainingMarks,
) -> Timeline {
    let curves = motions
        .iter()
        .map(|&m| {
            // (time, psnr sum, count, dynamic sum, dynamic count)
            let mut acc: Vec<(f64, f64, usize, f64, usize)> = Vec::new();
            for f in frames.iter().filter(|f| f.protocol == p && f.motion == m) {
                let mut seen: Vec<&str> = Vec::new();
                for (_, s) in &f.sets {
                    for fm in &s.frames {
                        if seen.contains(&fm.file.as_str()) {
                            continue;
                        }
                        seen.push(&fm.file);
                        let i = match acc.iter().position(|a| a.0.to_bits() == fm.time.to_bits()) {
                            Some(i) => i,
                            None => {
                                acc.push((fm.time, 0.0, 0, 0.0, 0));
                                acc.len() - 1
                            }
                        };
                        acc[i].1 += fm.psnr;
                        acc[i].2 += 1;
                        if let Some(d) = fm.dynamic_psnr {
                            acc[i].3 += d;
                            acc[i].4 += 1;
                        }
                    }
                }
            }
            acc.sort_by(|a, b| a.0.total_cmp(&b.0));
            let points = acc
                .iter()
                .map(|a| CurvePoint {
                    time: a.0,
                    psnr: a.1 / a.2 as f64,
                    dynamic_psnr: (a.4 > 0).then(|| a.3 / a.4 as f64),
                })
                .collect();
            MotionCurve { motion: m, points }
        })
        .collect();
    Timeline {
        protocol: p,
        plot: format!("study-time-{}.png", p.slug()),
        window: marks.window.map(|(a, b)| [a, b]),
        train_times: marks.times.clone(),
        curves,
    }
}

/// Draws a timeline: whole-image PSNR, and below it the dynamic-region PSNR if any, a line
/// per motion in the bar chart's colours.
fn save_timeline(
    t: &Timeline,
    motions: &[Motion],
    marks: &TrainingMarks,
    path: &Path,
) -> Result<(), CommandError> {
    let series = |dynamic: bool| -> Vec<TimeSeries> {
        motions
            .iter()
            .map(|&m| TimeSeries {
                name: m.as_str().to_string(),
                points: t
                    .curves
                    .iter()
                    .filter(|c| c.motion == m)
                    .flat_map(|c| &c.points)
                    .filter_map(|p| {
                        if dynamic {
                            p.dynamic_psnr.map(|d| (p.time, d))
                        } else {
                            Some((p.time, p.psnr))
                        }
                    })
                    .collect(),
            })
            .collect()
    };
    let mut panels = vec![TimePanel {
        y_label: "PSNR (dB)".into(),
        series: series(false),
    }];
    let dynamic = series(true);
    if dynamic.iter().any(|s| !s.points.is_empty()) {
        panels.push(TimePanel {
            y_label: "dynamic-region PSNR (dB)".into(),
            series: dynamic,
        });
    }
    save_time_plot(
        &format!("evogs study, {}: held-out PSNR against time", t.protocol),
        &panels,
        marks,
        path,
    )
    .map_err(CommandError::new)
}
