//! What a study measured, summed up: the study's summary (`study.json`) with its aggregated
//! tables (whole image, dynamic regions) and curves against time, built from the runs' and
//! baselines' records ([`super::record`]), and the tables as Markdown (`study.md`).

use super::protocol::StudyProtocol;
use super::record::{BaselineRecord, BaselineSets, RunRecord, SetMetrics};
use evogs::eval::dynamic::MaskRule;
use evogs::extrapolate::Extrapolation;
use evogs::model::Motion;
use evogs::scenes::TrajectoryError;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

/// A row of the baselines' table: one protocol, held-out set and baseline.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BaselineRow {
    /// The protocol.
    pub protocol: StudyProtocol,
    /// The held-out set.
    pub set: String,
    /// Frames in the set.
    pub frames: usize,
    /// The baseline (`hold`, `const-vel`, `const-acc`).
    pub baseline: Extrapolation,
    /// PSNR over the deformation runs' repeats (dB).
    pub psnr: Stat,
    /// SSIM over repeats.
    pub ssim: Stat,
}

/// Trajectory error at t = 1.3 relative to the distance travelled since the split time, of
/// one motion or baseline of one protocol, over repeats.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrajectoryRow {
    /// The protocol.
    pub protocol: StudyProtocol,
    /// The motion or baseline.
    pub method: String,
    /// Relative error over repeats.
    pub relative: Stat,
    /// Mean absolute error over repeats (scene units).
    pub mean_error: Stat,
}

/// Mean and spread of one metric over repeats.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stat {
    /// Mean.
    pub mean: f64,
    /// Sample standard deviation (0 for a single repeat).
    pub sd: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// Number of repeats.
    pub n: usize,
}

impl Stat {
    /// The statistics of `xs` (`None` when empty).
    #[must_use]
    pub fn of(xs: &[f64]) -> Option<Self> {
        if xs.is_empty() {
            return None;
        }
        let n = xs.len() as f64;
        let mean = xs.iter().sum::<f64>() / n;
        let sd = if xs.len() > 1 {
            (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
        } else {
            0.0
        };
        Some(Self {
            mean,
            sd,
            min: xs.iter().copied().fold(f64::INFINITY, f64::min),
            max: xs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            n: xs.len(),
        })
    }
}

/// One motion's numbers in a row of the table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Cell {
    /// The motion.
    pub motion: Motion,
    /// PSNR over repeats (dB).
    pub psnr: Stat,
    /// SSIM over repeats.
    pub ssim: Stat,
}

/// A row of the table: one protocol and held-out set, a cell per motion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// The protocol.
    pub protocol: StudyProtocol,
    /// The held-out set.
    pub set: String,
    /// Frames in the set.
    pub frames: usize,
    /// One cell per motion, in the study's motion order (motions without a finished run
    /// are left out).
    pub cells: Vec<Cell>,
    /// Mean velocity PSNR minus mean deformation PSNR (dB), when both were run.
    pub velocity_minus_deformation_db: Option<f64>,
}

impl Row {
    /// The cell of `motion`, if any.
    #[must_use]
    pub fn cell(&self, motion: Motion) -> Option<&Cell> {
        self.cells.iter().find(|c| c.motion == motion)
    }
}

/// Training cost of one (protocol, motion) over repeats.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CostRow {
    /// The protocol.
    pub protocol: StudyProtocol,
    /// The motion.
    pub motion: Motion,
    /// Training seconds.
    pub train_seconds: Stat,
    /// Iterations.
    pub iterations: u64,
    /// Gaussians at the end.
    pub gaussians: Stat,
}

/// A row of the dynamic-region table: one protocol and held-out set, a cell per motion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DynamicRow {
    /// The protocol.
    pub protocol: StudyProtocol,
    /// The held-out set.
    pub set: String,
    /// Frames in the set.
    pub frames: usize,
    /// Frames with a non-empty motion mask (the cells' means are over these).
    pub masked_frames: usize,
    /// Mean fraction of the frames' pixels inside the masks.
    pub mask_fraction: f64,
    /// The rules that made the masks.
    pub rules: Vec<MaskRule>,
    /// Dynamic-region PSNR / SSIM per motion (over repeats).
    pub cells: Vec<Cell>,
}

/// One point of a curve: the mean over the frames at one time (and over repeats).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CurvePoint {
    /// The frame time.
    pub time: f64,
    /// Whole-image PSNR (dB).
    pub psnr: f64,
    /// PSNR inside the motion masks (dB), where the frames have masks.
    pub dynamic_psnr: Option<f64>,
}

/// A motion's curve on one protocol.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MotionCurve {
    /// The motion.
    pub motion: Motion,
    /// Points by increasing time.
    pub points: Vec<CurvePoint>,
}

/// One protocol's metrics against time (`study-time-<protocol>.png`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Timeline {
    /// The protocol.
    pub protocol: StudyProtocol,
    /// The plot, relative to the study folder.
    pub plot: String,
    /// The training window (smallest and largest supervised time).
    pub window: Option<[f64; 2]>,
    /// The distinct supervised times.
    pub train_times: Vec<f64>,
    /// A curve per motion, over every frame of the protocol's held-out sets.
    pub curves: Vec<MotionCurve>,
}

/// Where and how the study ran.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// The exact command line.
    pub command: String,
    /// evogs version.
    pub evogs_version: String,
    /// When the summary was written (UTC, RFC 3339).
    pub date: String,
    /// The dataset folder.
    pub data: String,
    /// The preset.
    pub preset: String,
    /// The configuration file, if any.
    pub config_file: Option<String>,
    /// Hash of the base configuration (preset + file + `--iters`, before each run's protocol,
    /// motion and seed).
    pub config_hash: String,
    /// Iterations per run.
    pub iterations: u64,
    /// Repeats per (protocol, motion).
    pub seeds: usize,
    /// Runs at once.
    pub jobs: usize,
    /// Threads in all (divided among the jobs).
    pub threads: usize,
    /// The machine (CPU model and logical CPUs).
    pub machine: String,
}

/// `study.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StudySummary {
    /// Where and how.
    pub provenance: Provenance,
    /// The protocols, in order.
    pub protocols: Vec<StudyProtocol>,
    /// The motions, in order.
    pub motions: Vec<Motion>,
    /// The table: one row per protocol and held-out set.
    pub rows: Vec<Row>,
    /// Training cost per protocol and motion.
    pub costs: Vec<CostRow>,
    /// Every run.
    pub runs: Vec<RunRecord>,
    /// The dynamic-region table: PSNR and SSIM inside the frames' motion masks, one row per
    /// protocol and held-out set that has masks.
    #[serde(default)]
    pub dynamic_rows: Vec<DynamicRow>,
    /// Why some held-out frames have no dynamic-region metrics, if so.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dynamic_note: Option<String>,
    /// Held-out PSNR against time, one per protocol (what `study-time-<protocol>.png` draws).
    #[serde(default)]
    pub timelines: Vec<Timeline>,
    /// The no-training baselines of the future protocols (from the deformation runs).
    #[serde(default)]
    pub baselines: Vec<BaselineRow>,
    /// Trajectory errors, when the dataset has `motion.json`.
    #[serde(default)]
    pub trajectories: Vec<TrajectoryRow>,
}

impl StudySummary {
    /// Aggregates run records into the table (rows in protocol order, then set order as the
    /// runs list them).
    #[must_use]
    pub fn new(
        provenance: Provenance,
        protocols: Vec<StudyProtocol>,
        motions: Vec<Motion>,
        runs: Vec<RunRecord>,
    ) -> Self {
        let mut rows = Vec::new();
        let mut costs = Vec::new();
        for &p in &protocols {
            let of_p: Vec<&RunRecord> = runs.iter().filter(|r| r.protocol == p).collect();
            let mut set_names: Vec<(&str, usize)> = Vec::new();
            for r in &of_p {
                for s in &r.sets {
                    if !set_names.iter().any(|(n, _)| *n == s.set) {
                        set_names.push((&s.set, s.frames));
                    }
                }
            }
            for (name, frames) in set_names {
                let cells: Vec<Cell> = motions
                    .iter()
                    .filter_map(|&m| {
                        let pick = |f: fn(&SetMetrics) -> f64| -> Vec<f64> {
                            of_p.iter()
                                .filter(|r| r.motion == m)
                                .filter_map(|r| r.sets.iter().find(|s| s.set == name))
                                .map(f)
                                .collect()
                        };
                        Some(Cell {
                            motion: m,
                            psnr: Stat::of(&pick(|s| s.psnr))?,
                            ssim: Stat::of(&pick(|s| s.ssim))?,
                        })
                    })
                    .collect();
                let mean = |m: Motion| cells.iter().find(|c| c.motion == m).map(|c| c.psnr.mean);
                let diff = match (mean(Motion::Velocity), mean(Motion::Deformation)) {
                    (Some(v), Some(d)) => Some(v - d),
                    _ => None,
                };
                rows.push(Row {
                    protocol: p,
                    set: name.to_string(),
                    frames,
                    cells,
                    velocity_minus_deformation_db: diff,
                });
            }
            for &m in &motions {
                let of_pm: Vec<&&RunRecord> = of_p.iter().filter(|r| r.motion == m).collect();
                let secs: Vec<f64> = of_pm.iter().map(|r| r.train_seconds).collect();
                let gs: Vec<f64> = of_pm.iter().map(|r| r.gaussians as f64).collect();
                if let (Some(t), Some(g)) = (Stat::of(&secs), Stat::of(&gs)) {
                    costs.push(CostRow {
                        protocol: p,
                        motion: m,
                        train_seconds: t,
                        iterations: of_pm.iter().map(|r| r.iterations).max().unwrap_or(0),
                        gaussians: g,
                    });
                }
            }
        }
        let mut trajectories = Vec::new();
        for &p in &protocols {
            for &m in &motions {
                let errs: Vec<TrajectoryError> = runs
                    .iter()
                    .filter(|r| r.protocol == p && r.motion == m)
                    .filter_map(|r| r.trajectory)
                    .collect();
                if let Some(row) = TrajectoryRow::of(p, m.as_str(), &errs) {
                    trajectories.push(row);
                }
            }
        }
        Self {
            provenance,
            protocols,
            motions,
            rows,
            costs,
            runs,
            dynamic_rows: Vec::new(),
            dynamic_note: None,
            timelines: Vec::new(),
            baselines: Vec::new(),
            trajectories,
        }
    }

    /// This summary with the dynamic-region table, its note and the curves against time.
    #[must_use]
    pub fn with_dynamic(
        mut self,
        rows: Vec<DynamicRow>,
        note: Option<String>,
        timelines: Vec<Timeline>,
    ) -> Self {
        self.dynamic_rows = rows;
        self.dynamic_note = note;
        self.timelines = timelines;
        self
    }

    /// Adds the baselines' rows (and their trajectory errors) from the baseline records.
    #[must_use]
    pub fn with_baselines(mut self, records: &[BaselineRecord]) -> Self {
        for &p in &self.protocols {
            let of_p: Vec<&BaselineRecord> = records.iter().filter(|r| r.protocol == p).collect();
            for kind in Extrapolation::ALL {
                let of_kind: Vec<&BaselineSets> = of_p
                    .iter()
                    .flat_map(|r| r.baselines.iter().filter(|b| b.baseline == kind))
                    .collect();
                let mut names: Vec<(&str, usize)> = Vec::new();
                for b in &of_kind {
                    for s in &b.sets {
                        if !names.iter().any(|(n, _)| *n == s.set) {
                            names.push((&s.set, s.frames));
                        }
                    }
                }
                for (name, frames) in names {
                    let pick = |f: fn(&SetMetrics) -> f64| -> Vec<f64> {
                        of_kind
                            .iter()
                            .filter_map(|b| b.sets.iter().find(|s| s.set == name))
                            .map(f)
                            .collect()
                    };
                    if let (Some(psnr), Some(ssim)) =
                        (Stat::of(&pick(|s| s.psnr)), Stat::of(&pick(|s| s.ssim)))
                    {
                        self.baselines.push(BaselineRow {
                            protocol: p,
                            set: name.to_string(),
                            frames,
                            baseline: kind,
                            psnr,
                            ssim,
                        });
                    }
                }
                let errs: Vec<TrajectoryError> =
                    of_kind.iter().filter_map(|b| b.trajectory).collect();
                if let Some(row) = TrajectoryRow::of(p, kind.as_str(), &errs) {
                    self.trajectories.push(row);
                }
            }
        }
        self
    }

    /// The table as Markdown: a row per protocol and held-out set, PSNR / SSIM per motion
    /// (mean ± sample standard deviation over repeats), and velocity − deformation in dB;
    /// then the training cost.
    #[must_use]
    pub fn markdown(&self) -> String {
        let p = &self.provenance;
        let mut s = String::new();
        let _ = writeln!(s, "# evogs study\n");
        let _ = writeln!(s, "`{}`\n", p.command);
        let _ = writeln!(
            s,
            "{} · evogs {} · data `{}` · preset `{}`{} · config {} · {} iterations per run · \
             {} seed(s) · {} job(s) on {} thread(s) · {}\n",
            p.date,
            p.evogs_version,
            p.data,
            p.preset,
            p.config_file
                .as_ref()
                .map(|f| format!(" + `{f}`"))
                .unwrap_or_default(),
            p.config_hash,
            p.iterations,
            p.seeds,
            p.jobs,
            p.threads,
            p.machine
        );
        let _ = writeln!(
            s,
            "Test-view PSNR (dB) / SSIM{}.\n",
            if p.seeds > 1 {
                ", mean ± sample standard deviation over the seeds"
            } else {
                ""
            }
        );
        let diff = self.has_diff();
        s.push_str("| protocol | held-out set | frames |");
        for m in &self.motions {
            let _ = write!(s, " {} |", m.as_str());
        }
        if diff {
            s.push_str(" velocity − deformation (dB) |");
        }
        s.push_str("\n|---|---|---|");
        for _ in &self.motions {
            s.push_str("---|");
        }
        if diff {
            s.push_str("---|");
        }
        s.push('\n');
        for r in &self.rows {
            let _ = write!(s, "| {} | {} | {} |", r.protocol, r.set, r.frames);
            for m in &self.motions {
                match r.cell(*m) {
                    Some(c) => {
                        let _ = write!(s, " {} / {} |", fmt_stat(c.psnr, 2), fmt_stat(c.ssim, 3));
                    }
                    None => s.push_str(" – |"),
                }
            }
            if diff {
                match r.velocity_minus_deformation_db {
                    Some(d) => {
                        let _ = write!(s, " {d:+.2} |");
                    }
                    None => s.push_str(" – |"),
                }
            }
            s.push('\n');
        }
        self.dynamic_markdown(&mut s);
        s.push_str("\nTraining cost per run: seconds, iterations, Gaussians at the end.\n\n");
        s.push_str("| protocol | motion | train seconds | iterations | Gaussians |\n");
        s.push_str("|---|---|---|---|---|\n");
        for c in &self.costs {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} |",
                c.protocol,
                c.motion.as_str(),
                fmt_stat(c.train_seconds, 1),
                c.iterations,
                fmt_stat(c.gaussians, 0)
            );
        }
        self.markdown_extras(&mut s);
        s
    }

    /// The dynamic-region table (and its note), after the whole-image table.
    fn dynamic_markdown(&self, s: &mut String) {
        if self.dynamic_rows.is_empty() && self.dynamic_note.is_none() {
            return;
        }
        let _ = writeln!(
            s,
            "\nDynamic-region PSNR (dB) / SSIM: inside each frame's motion mask, from the ground \
             truth alone (`shipped`: the dataset's X_motion.png; `temporal_median`: where a fixed \
             camera's frame differs from its temporal median; `static_render`: where the ground \
             truth differs from the static run's render, i.e. where a model that does not move \
             is wrong). Means over the frames with a non-empty mask; `mask` is the mean \
             fraction of their pixels.\n"
        );
        if let Some(n) = &self.dynamic_note {
            let _ = writeln!(s, "Note: {n}.\n");
        }
        if self.dynamic_rows.is_empty() {
            return;
        }
        let diff = self.has_diff();
        s.push_str("| protocol | held-out set | frames with a mask | mask | rule |");
        for m in &self.motions {
            let _ = write!(s, " {} |", m.as_str());
        }
        if diff {
            s.push_str(" velocity − deformation (dB) |");
        }
        s.push_str("\n|---|---|---|---|---|");
        for _ in &self.motions {
            s.push_str("---|");
        }
        if diff {
            s.push_str("---|");
        }
        s.push('\n');
        for r in &self.dynamic_rows {
            let rules: Vec<&str> = r.rules.iter().map(|x| x.as_str()).collect();
            let _ = write!(
                s,
                "| {} | {} | {} of {} | {:.1}% | {} |",
                r.protocol,
                r.set,
                r.masked_frames,
                r.frames,
                100.0 * r.mask_fraction,
                rules.join(", ")
            );
            let cell = |m: Motion| r.cells.iter().find(|c| c.motion == m);
            for m in &self.motions {
                match cell(*m) {
                    Some(c) => {
                        let _ = write!(s, " {} / {} |", fmt_stat(c.psnr, 2), fmt_stat(c.ssim, 3));
                    }
                    None => s.push_str(" – |"),
                }
            }
            if diff {
                match (cell(Motion::Velocity), cell(Motion::Deformation)) {
                    (Some(v), Some(d)) => {
                        let _ = write!(s, " {:+.2} |", v.psnr.mean - d.psnr.mean);
                    }
                    _ => s.push_str(" – |"),
                }
            }
            s.push('\n');
        }
    }

    /// The baselines' and trajectory tables (empty when there are none).
    fn markdown_extras(&self, s: &mut String) {
        if !self.baselines.is_empty() {
            s.push_str(
                "\nNo-training baselines from the deformation run at the split time (hold, \
                 constant velocity, constant acceleration): PSNR (dB) / SSIM.\n\n",
            );
            s.push_str("| protocol | held-out set | frames | baseline | PSNR / SSIM |\n");
            s.push_str("|---|---|---|---|---|\n");
            for b in &self.baselines {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} / {} |",
                    b.protocol,
                    b.set,
                    b.frames,
                    b.baseline.as_str(),
                    fmt_stat(b.psnr, 2),
                    fmt_stat(b.ssim, 3)
                );
            }
        }
        let shares: Vec<&RunRecord> = self.runs.iter().filter(|r| r.hop_share.is_some()).collect();
        if !shares.is_empty() {
            s.push_str(
                "\nContinuous waypoints: the share of the waypoint field's displacement over a \
                 hop that the velocity field carries (1: all of it; mean of eight times across \
                 the window).\n\n",
            );
            s.push_str("| protocol | motion | seed | hop share |\n|---|---|---|---|\n");
            for r in shares {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {:.3} |",
                    r.protocol,
                    r.motion.as_str(),
                    r.seed,
                    r.hop_share.unwrap_or(f64::NAN)
                );
            }
        }
        if !self.trajectories.is_empty() {
            s.push_str(
                "\nTrajectory error at t = 1.3 of the Gaussians on moving bodies (motion.json): \
                 mean error relative to the mean distance travelled since the split time, and \
                 the mean error.\n\n",
            );
            s.push_str("| protocol | motion or baseline | relative error | mean error |\n");
            s.push_str("|---|---|---|---|\n");
            for t in &self.trajectories {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} |",
                    t.protocol,
                    t.method,
                    fmt_stat(t.relative, 3),
                    fmt_stat(t.mean_error, 4)
                );
            }
        }
    }

    fn has_diff(&self) -> bool {
        self.motions.contains(&Motion::Velocity) && self.motions.contains(&Motion::Deformation)
    }
}

impl TrajectoryRow {
    fn of(protocol: StudyProtocol, method: &str, errs: &[TrajectoryError]) -> Option<Self> {
        let rel: Vec<f64> = errs.iter().map(|e| e.relative).collect();
        let abs: Vec<f64> = errs.iter().map(|e| e.mean_error).collect();
        Some(Self {
            protocol,
            method: method.to_string(),
            relative: Stat::of(&rel)?,
            mean_error: Stat::of(&abs)?,
        })
    }
}

fn fmt_stat(s: Stat, decimals: usize) -> String {
    if s.n > 1 {
        format!("{:.*} ± {:.*}", decimals, s.mean, decimals, s.sd)
    } else {
        format!("{:.*}", decimals, s.mean)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(p: StudyProtocol, m: Motion, repeat: usize, psnr: f64) -> RunRecord {
        RunRecord {
            protocol: p,
            motion: m,
            repeat,
            seed: repeat as u64,
            folder: String::new(),
            config_hash: String::new(),
            data: None,
            iterations: 10,
            train_seconds: 1.0,
            gaussians: 100,
            threads: 1,
            sets: vec![SetMetrics {
                set: "test".into(),
                frames: 4,
                psnr,
                ssim: 0.9,
            }],
            trajectory: None,
            hop_share: None,
        }
    }

    fn provenance(seeds: usize) -> Provenance {
        Provenance {
            command: "evogs study".into(),
            evogs_version: "0".into(),
            date: "today".into(),
            data: "d".into(),
            preset: "fast".into(),
            config_file: None,
            config_hash: "h".into(),
            iterations: 10,
            seeds,
            jobs: 1,
            threads: 1,
            machine: "m".into(),
        }
    }

    #[test]
    fn statistics_of_repeats() {
        let s = Stat::of(&[20.0, 22.0, 24.0]).expect("three");
        assert!((s.mean - 22.0).abs() < 1e-12, "{s:?}");
        assert!((s.sd - 2.0).abs() < 1e-12, "{s:?}");
        assert!(s.min.to_bits() == 20.0_f64.to_bits() && s.n == 3, "{s:?}");
        assert!(Stat::of(&[]).is_none(), "empty");
        assert!(
            Stat::of(&[1.0]).expect("one").sd.abs() < 1e-300,
            "one repeat"
        );
    }

    #[test]
    fn the_table_has_a_row_per_set_a_cell_per_motion_and_the_difference() {
        let p = StudyProtocol::Full;
        let runs = vec![
            record(p, Motion::Velocity, 0, 25.0),
            record(p, Motion::Velocity, 1, 27.0),
            record(p, Motion::Deformation, 0, 24.5),
            record(p, Motion::Deformation, 1, 25.5),
            record(p, Motion::Static, 0, 20.0),
        ];
        let s = StudySummary::new(
            provenance(2),
            vec![p],
            vec![Motion::Velocity, Motion::Deformation, Motion::Static],
            runs,
        );
        assert_eq!(s.rows.len(), 1, "{:?}", s.rows);
        let r = &s.rows[0];
        assert_eq!(r.cells.len(), 3, "three motions");
        let d = r.velocity_minus_deformation_db.expect("both motions ran");
        assert!((d - 1.0).abs() < 1e-12, "26 − 25 = {d}");
        let md = s.markdown();
        assert!(
            md.contains("| full | test | 4 | 26.00 ± 1.41 / 0.900 ± 0.000 |"),
            "{md}"
        );
        assert!(md.contains("+1.00 |"), "{md}");
        assert!(md.contains("velocity − deformation"), "{md}");
        assert_eq!(s.costs.len(), 3, "a cost row per motion");
    }

    #[test]
    fn the_dynamic_table_follows_the_whole_image_one() {
        let p = StudyProtocol::Sparse(4);
        let stat = |m: f64| Stat::of(&[m]).expect("one");
        let row = DynamicRow {
            protocol: p,
            set: "test".into(),
            frames: 4,
            masked_frames: 3,
            mask_fraction: 0.042,
            rules: vec![MaskRule::StaticRender],
            cells: vec![
                Cell {
                    motion: Motion::Velocity,
                    psnr: stat(18.5),
                    ssim: stat(0.6),
                },
                Cell {
                    motion: Motion::Deformation,
                    psnr: stat(17.25),
                    ssim: stat(0.5),
                },
            ],
        };
        let s = StudySummary::new(
            provenance(1),
            vec![p],
            vec![Motion::Velocity, Motion::Deformation],
            vec![
                record(p, Motion::Velocity, 0, 25.0),
                record(p, Motion::Deformation, 0, 24.0),
            ],
        )
        .with_dynamic(vec![row], None, Vec::new());
        let md = s.markdown();
        let whole = md
            .find("| sparse:4 | test | 4 | 25.00")
            .expect("whole-image row");
        let dynamic = md
            .find("| sparse:4 | test | 3 of 4 | 4.2% | static_render | 18.50 / 0.600 | 17.25 / 0.500 | +1.25 |")
            .unwrap_or_else(|| panic!("{md}"));
        assert!(whole < dynamic, "the dynamic table comes second");
        assert!(md.contains("Dynamic-region PSNR"), "{md}");
        let plain = StudySummary::new(provenance(1), vec![p], vec![Motion::Velocity], Vec::new());
        assert!(
            !plain.markdown().contains("Dynamic-region"),
            "no table without rows"
        );
    }

    #[test]
    fn without_deformation_there_is_no_difference_column() {
        let p = StudyProtocol::Sparse(4);
        let s = StudySummary::new(
            provenance(1),
            vec![p],
            vec![Motion::Velocity],
            vec![record(p, Motion::Velocity, 0, 25.0)],
        );
        assert!(s.rows[0].velocity_minus_deformation_db.is_none(), "no pair");
        assert!(
            !s.markdown().contains("velocity − deformation"),
            "no column"
        );
    }

    #[test]
    fn baselines_are_rows_of_their_own_with_their_trajectory_errors() {
        let p = StudyProtocol::Future(0.75);
        let mut runs = vec![record(p, Motion::Deformation, 0, 21.0)];
        let err = |relative: f64| TrajectoryError {
            split: 0.75,
            time: 1.3,
            gaussians: 10,
            mean_error: relative * 0.5,
            mean_travel: 0.5,
            relative,
        };
        runs[0].trajectory = Some(err(0.4));
        let sets = |psnr: f64| {
            vec![SetMetrics {
                set: "test t > 0.75".into(),
                frames: 5,
                psnr,
                ssim: 0.8,
            }]
        };
        let base = BaselineRecord {
            protocol: p,
            repeat: 0,
            folder: "runs/future0.75-deformation-s0".into(),
            config_hash: "h".into(),
            end: 0.75,
            step: 0.04,
            baselines: vec![
                BaselineSets {
                    baseline: Extrapolation::Hold,
                    sets: sets(19.0),
                    trajectory: Some(err(1.0)),
                },
                BaselineSets {
                    baseline: Extrapolation::ConstVel,
                    sets: sets(20.5),
                    trajectory: Some(err(0.2)),
                },
                BaselineSets {
                    baseline: Extrapolation::ConstAcc,
                    sets: sets(20.0),
                    trajectory: None,
                },
            ],
        };
        let s = StudySummary::new(provenance(1), vec![p], vec![Motion::Deformation], runs)
            .with_baselines(&[base]);
        let names: Vec<&str> = s.baselines.iter().map(|b| b.baseline.as_str()).collect();
        assert_eq!(names, ["hold", "const-vel", "const-acc"], "rows");
        assert!(
            (s.baselines[1].psnr.mean - 20.5).abs() < 1e-12,
            "{:?}",
            s.baselines[1]
        );
        let methods: Vec<&str> = s.trajectories.iter().map(|t| t.method.as_str()).collect();
        assert_eq!(
            methods,
            ["deformation", "hold", "const-vel"],
            "trajectory rows"
        );
        let md = s.markdown();
        assert!(
            md.contains("| future:0.75 | test t > 0.75 | 5 | const-vel | 20.50 / 0.800 |"),
            "{md}"
        );
        assert!(
            md.contains("| future:0.75 | hold | 1.000 | 0.5000 |"),
            "{md}"
        );
        let back: StudySummary =
            serde_json::from_str(&serde_json::to_string(&s).expect("json")).expect("parse");
        assert_eq!(back, s, "study.json round trip");
    }
}
