//! `evogs study`: the paper's protocols as one command. Every (protocol, motion, seed) is
//! trained with the same preset, configuration, budget and data in a folder of its own,
//! evaluated on the protocol's held-out sets, and summarised in `study.json`, `study.md`
//! (one row per protocol and held-out set, one column per motion, and velocity − deformation
//! in dB; then the same inside the frames' motion masks) and `study.png` (grouped bars), with
//! held-out PSNR against time per protocol in `study-time-<protocol>.png`. Each `future:TAU`
//! protocol with a deformation run also gets the no-training baselines `hold`, `const-vel`
//! and `const-acc` computed from that run (`RUN/baselines.json`), and on a dataset with a
//! `motion.json` (`evogs scenes`) every future run and baseline gets its trajectory error at
//! t = 1.3. A `future:TAU` protocol also gets a contact sheet of frames after the window, the
//! ground truth above each motion's render (`study-contact-<protocol>.png`).
//!
//! ```text
//! OUT/study.json  study.md  study.png  study-time-<protocol>.png  study-contact-<protocol>.png
//! OUT/runs/<protocol>-<motion>-s<k>/   config.toml checkpoint.safetensors log.csv ... study-run.json
//! ```
//!
//! A study is resumable: a run with a `study-run.json` is not trained again (its metrics are
//! reused), a run with only a checkpoint continues from it, and `--force` retrains
//! everything. A folder that holds a run of another configuration is an error, not silently
//! reused. Every input is checked before the first iteration: the protocols and their
//! held-out frames, the configuration of every run, the dataset and the output folder.

mod baselines;
mod contact;
mod progress;
mod protocol;
mod record;
mod report;
mod runner;
mod timeline;

pub use protocol::{HeldOutSet, StudyProtocol};
pub use record::{BaselineRecord, BaselineSets, RunRecord, SetMetrics};
pub use report::{
    BaselineRow, Cell, CostRow, CurvePoint, DynamicRow, MotionCurve, Provenance, Row, Stat,
    StudySummary, Timeline, TrajectoryRow,
};

use super::Reporter;
use super::counts::{positive_count, positive_size};
use super::error::{CommandError, Context as _};
use super::load::load_dataset;
use super::lock::FolderLock;
use super::paths::{RunFolder, shipped_scene};
use super::plot::{BarGroup, save_bars};
use super::train::{TrainArgs, resolve_config};
use evogs::config::{Preset, TrainConfig};
use evogs::data::DataIdentity;
use evogs::model::Motion;
use evogs::train::collective::{Collective, Solo, barrier};
use progress::{ChannelReporter, Message, StudyProgress};
use runner::{PlannedRun, RunState, execute, read_record, write_atomic};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;

/// The arguments of `evogs study`: the command line's flags (clap), each list parsed into
/// its values when the line is read.
#[derive(Clone, Debug, PartialEq, clap::Args)]
pub struct StudyArgs {
    /// Dataset folder (default: data/toys-mini shipped with evogs).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Study folder (runs in OUT/runs/, the summary in OUT/study.*).
    #[arg(long, default_value = "runs/study")]
    pub out: PathBuf,
    /// Protocols, comma-separated: full, sparse:K (K >= 2), future:TAU, backward:TAU
    /// (0 < TAU < 1).
    #[arg(long, default_value = "full,sparse:4,future:0.75", value_parser = StudyProtocol::parse_list)]
    pub protocols: std::vec::Vec<StudyProtocol>,
    /// Motions, comma-separated: velocity, deformation, static.
    #[arg(long, default_value = "velocity,deformation,static", value_parser = parse_motions)]
    pub motions: std::vec::Vec<Motion>,
    /// Preset of every run: fast (default) or paper.
    #[arg(long)]
    pub preset: Option<Preset>,
    /// TOML file overlaid on the preset for every run.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Iterations per run (default: the preset's; shortens warm-up and curriculum to fit).
    #[arg(long, allow_negative_numbers = true, value_parser = positive_count)]
    pub iters: Option<u64>,
    /// Repeats per protocol and motion, with seeds seed, seed+1, ...; the table reports
    /// mean and standard deviation.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true, value_parser = positive_size)]
    pub seeds: usize,
    /// Runs at once; the threads are divided among them.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true, value_parser = positive_size)]
    pub jobs: usize,
    /// Retrain every run, finished or interrupted.
    #[arg(long)]
    pub force: bool,
    /// The command line, recorded in `study.json` (set by the caller, not a flag).
    #[arg(skip)]
    pub command: String,
}

impl Default for StudyArgs {
    fn default() -> Self {
        Self {
            data: None,
            out: PathBuf::from("runs/study"),
            protocols: StudyProtocol::defaults(),
            motions: vec![Motion::Velocity, Motion::Deformation, Motion::Static],
            preset: None,
            config: None,
            iters: None,
            seeds: 1,
            jobs: 1,
            force: false,
            command: String::from("evogs study"),
        }
    }
}

/// What a study produced.
#[derive(Clone, Debug)]
pub struct StudyOutcome {
    /// The summary written to `study.json`.
    pub summary: StudySummary,
    /// `study.json`.
    pub json: PathBuf,
    /// `study.md`.
    pub markdown: PathBuf,
    /// `study.png`.
    pub chart: PathBuf,
    /// `study-time-<protocol>.png`, one per protocol.
    pub time_plots: Vec<PathBuf>,
    /// `study-contact-<protocol>.png`, one per future protocol: frames after the window,
    /// the ground truth above each motion's render.
    pub contact_sheets: Vec<PathBuf>,
    /// Runs trained (or resumed) by this call.
    pub trained: usize,
    /// Runs whose earlier results were reused.
    pub reused: usize,
}

/// The most runs one study plans: far beyond any budget of training runs, small enough that
/// planning (a configuration per run) is instant.
pub const MAX_RUNS: usize = 10_000;

/// Parses a comma-separated list of motions (`velocity,deformation,static`).
///
/// # Errors
/// An unknown motion, an empty list or a repeated motion.
pub fn parse_motions(s: &str) -> Result<Vec<Motion>, String> {
    let mut out: Vec<Motion> = Vec::new();
    for part in s.split(',') {
        let m: Motion = part.trim().parse()?;
        if out.contains(&m) {
            return Err(format!("motion `{}` is listed twice", m.as_str()));
        }
        out.push(m);
    }
    Ok(out)
}

/// FNV-1a (64 bit) of a text, as 16 hex digits: an identity check of configurations.
fn config_hash(text: &str) -> String {
    let mut h = evogs::fnv::Fnv1a::default();
    h.write(text.as_bytes());
    format!("{:016x}", h.finish())
}

/// The CPU model and logical CPU count of this machine.
fn machine() -> String {
    let cpus = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    format!("{model}, {cpus} logical CPUs, {}", std::env::consts::OS)
}

/// Threads available to the study (rayon's global pool, which `RAYON_NUM_THREADS` sets).
fn total_threads() -> usize {
    #[cfg(feature = "rayon")]
    {
        rayon::current_num_threads()
    }
    #[cfg(not(feature = "rayon"))]
    {
        1
    }
}

/// Checks that `dir` can be created and written, leaving nothing behind.
fn check_writable(dir: &Path) -> Result<(), CommandError> {
    if let Some(kind) = evogs::bounded::node_kind(dir).filter(|&k| k != "a folder") {
        return Err(CommandError::at(
            dir,
            format!("this is {kind}; the study's output is a folder"),
        ));
    }
    let fail = |e: std::io::Error| {
        CommandError::new(e)
            .context("the study folder cannot be written")
            .context(dir.display())
    };
    std::fs::create_dir_all(dir).map_err(fail)?;
    let probe = dir.join(format!(".evogs-write-check-{}", std::process::id()));
    std::fs::write(&probe, b"").map_err(fail)?;
    std::fs::remove_file(&probe).map_err(fail)
}

/// The hash of the configuration stored in a run folder, if it has one.
fn stored_config_hash(run_dir: &Path) -> Option<String> {
    let text = evogs::bounded::read_text(
        &run_dir.join("config.toml"),
        evogs::bounded::CONFIG_BYTES,
        "a configuration file",
    )
    .ok()?;
    let cfg = TrainConfig::from_run_toml(&text).ok()?;
    Some(config_hash(&cfg.to_toml()))
}

/// Plans every run, checks its configuration, and finds what is already done.
fn plan(
    args: &StudyArgs,
    data: &Path,
    identity: &DataIdentity,
    base: &TrainConfig,
) -> Result<Vec<PlannedRun>, CommandError> {
    let mut runs = Vec::new();
    for &p in &args.protocols {
        for &m in &args.motions {
            for repeat in 0..args.seeds {
                let seed = base.seed.wrapping_add(repeat as u64);
                let folder = format!("runs/{}-{}-s{repeat}", p.slug(), m.as_str());
                let mut targs = TrainArgs {
                    data: Some(data.to_path_buf()),
                    out: args.out.join(&folder),
                    config: args.config.clone(),
                    preset: args.preset,
                    motion: Some(m),
                    iters: args.iters,
                    seed: Some(seed),
                    skip_outputs: true,
                    ..TrainArgs::default()
                };
                let mut probe = base.data.clone();
                p.apply(&mut probe);
                targs.protocol = Some(probe.protocol);
                targs.stride = Some(probe.stride);
                targs.split_time = Some(probe.split_time);
                let cfg = resolve_config(&targs)
                    .map_err(|e| CommandError::new(format!("{folder}: {e}")))?;
                let hash = config_hash(&cfg.to_toml());
                let mut run = PlannedRun {
                    protocol: p,
                    motion: m,
                    repeat,
                    seed,
                    folder,
                    args: targs,
                    config_hash: hash,
                    data: identity.clone(),
                    iterations: cfg.schedule.iterations,
                    state: RunState::Fresh,
                };
                run.state = state_of(&run, args.force)?;
                runs.push(run);
            }
        }
    }
    Ok(runs)
}

/// What has to happen to `run`, from what its folder holds.
fn state_of(run: &PlannedRun, force: bool) -> Result<RunState, CommandError> {
    if force {
        return Ok(RunState::Fresh);
    }
    let other = |what: &str| {
        CommandError::at(
            &run.args.out,
            format!(
                "holds {what} of another configuration than this study's; pass --force to \
                 retrain it, or choose another --out"
            ),
        )
    };
    let record = run.record_path();
    if record.is_file() {
        let r = read_record(&record)?;
        if r.config_hash != run.config_hash {
            return Err(other("a finished run"));
        }
        return match &r.data {
            Some(d) if !d.same_data(&run.data) => Err(CommandError::at(
                &run.args.out,
                format!(
                    "holds a finished run trained on {}, and --data is {}, other training \
                     views; pass --force to retrain it, or choose another --out",
                    d.describe(),
                    run.data.describe()
                ),
            )),
            Some(_) => Ok(RunState::Done),
            // A record written before the data was recorded: the run folder's dataset path.
            None => match RunFolder::new(&run.args.out).data_dir() {
                Ok(dir)
                    if std::fs::canonicalize(&dir)
                        .is_ok_and(|d| d.display().to_string() == run.data.folder) =>
                {
                    Ok(RunState::Done)
                }
                _ => Err(CommandError::at(
                    &run.args.out,
                    format!(
                        "holds a finished run whose record does not name its training data \
                         and whose dataset record is not {}; pass --force to retrain it, or \
                         choose another --out",
                        run.data.folder
                    ),
                )),
            },
        };
    }
    if RunFolder::new(&run.args.out).checkpoint().is_file() {
        return match stored_config_hash(&run.args.out) {
            Some(h) if h == run.config_hash => Ok(RunState::Resume),
            _ => Err(other("a checkpoint")),
        };
    }
    Ok(RunState::Fresh)
}

/// Runs `evogs study`.
///
/// # Errors
/// Bad arguments, data or configuration (all checked before any training), or a run that
/// failed (finished runs stay reusable).
pub fn run_study(args: &StudyArgs, rep: &mut dyn Reporter) -> Result<StudyOutcome, CommandError> {
    run_study_with(args, rep, &Solo)?
        .ok_or_else(|| CommandError::new("one process is rank 0 and writes the summary"))
}

/// [`run_study`] as one of the processes of `c` (`mpirun -np P evogs study ...`): every rank
/// plans the same runs, rank `r` trains the pending runs `r, r + P, r + 2P, …` (each with the
/// threads of its rank, `--jobs` at a time), and once all have finished rank 0 alone writes
/// `study.json`, `study.md` and the figures from the runs' records (returned as `Some`; the
/// other ranks return `None`). A rerun resumes unfinished runs as in one process.
///
/// # Errors
/// As [`run_study`], or an exchange between the ranks that failed.
pub fn run_study_with(
    args: &StudyArgs,
    rep: &mut dyn Reporter,
    c: &dyn Collective,
) -> Result<Option<StudyOutcome>, CommandError> {
    if args.protocols.is_empty() || args.motions.is_empty() {
        return Err(CommandError::new(
            "a study needs at least one protocol and one motion",
        ));
    }
    if args.seeds == 0 {
        return Err(CommandError::new("--seeds must be at least 1"));
    }
    if args.jobs == 0 {
        return Err(CommandError::new("--jobs must be at least 1"));
    }
    let runs = args
        .protocols
        .len()
        .checked_mul(args.motions.len())
        .and_then(|n| n.checked_mul(args.seeds));
    if runs.is_none_or(|n| n > MAX_RUNS) {
        return Err(CommandError::new(format!(
            "{} protocol(s) × {} motion(s) × --seeds {} is more runs than a study plans (at \
             most {MAX_RUNS}); a study of that size is several studies",
            args.protocols.len(),
            args.motions.len(),
            args.seeds
        )));
    }
    let base = resolve_config(&TrainArgs {
        config: args.config.clone(),
        preset: args.preset,
        iters: args.iters,
        ..TrainArgs::default()
    })?;
    let data = args.data.clone().unwrap_or_else(shipped_scene);
    rep.info(&format!("data: {}", data.display()));
    let ds = load_dataset(&data, &base, true)?;
    let identity = DataIdentity::of(&ds);
    let sets: Vec<Vec<HeldOutSet>> = args
        .protocols
        .iter()
        .map(|p| p.held_out_sets(&ds))
        .collect::<Result<_, _>>()?;
    let writer = c.rank() == 0;
    let _lock = if writer {
        check_writable(&args.out)?;
        Some(FolderLock::acquire(&args.out, "study")?)
    } else {
        None
    };
    let runs = plan(args, &data, &identity, &base)?;
    // Every rank has planned from the folders as they were before rank 0 clears any.
    barrier(c).map_err(CommandError::new)?;
    if args.force && writer {
        for r in &runs {
            if r.args.out.exists() {
                std::fs::remove_dir_all(&r.args.out)
                    .doing(&r.args.out, "cannot clear for --force")?;
            }
        }
    }
    barrier(c).map_err(CommandError::new)?;
    let threads = total_threads();
    let jobs = args.jobs.min(runs.len()).max(1);
    let per_job = (threads / jobs).max(1);
    let pending: Vec<usize> = (0..runs.len())
        .filter(|&i| runs[i].state != RunState::Done)
        .collect();
    // This rank's share of the pending runs (all of them in one process).
    let mine: Vec<usize> = pending
        .iter()
        .copied()
        .enumerate()
        .filter(|&(k, _)| k % c.size() == c.rank())
        .map(|(_, i)| i)
        .collect();
    if c.size() > 1 {
        rep.info(&format!(
            "rank {} of {}: {} of the {} pending runs",
            c.rank(),
            c.size(),
            mine.len(),
            pending.len()
        ));
    }
    rep.info(&format!(
        "{} runs: {} to train, {} to resume, {} finished earlier; {jobs} at a time with {per_job} \
         thread(s) each",
        runs.len(),
        runs.iter().filter(|r| r.state == RunState::Fresh).count(),
        runs.iter().filter(|r| r.state == RunState::Resume).count(),
        runs.iter().filter(|r| r.state == RunState::Done).count(),
    ));
    let failure = train_pending(
        &runs,
        &mine,
        &ds,
        &sets,
        &args.protocols,
        jobs,
        per_job,
        rep,
    );
    let reused = runs.len() - pending.len();
    if let Some(e) = failure {
        return Err(e);
    }
    // Every rank's runs have their records before rank 0 reads them.
    barrier(c).map_err(CommandError::new)?;
    if !writer {
        return Ok(None);
    }
    // The table is built from the records as stored, for reused and new runs alike, so a
    // study that reuses every run reproduces its table exactly.
    let records: Vec<RunRecord> = runs
        .iter()
        .map(|r| read_record(&r.record_path()))
        .collect::<Result<_, _>>()?;
    // Dynamic regions and metrics against time: every run evaluated frame by frame inside
    // the motion masks (the static run of each protocol gives the monocular masks).
    let (dynamic, time_plots) = timeline::dynamic_pass(
        &runs,
        &ds,
        &sets,
        &args.protocols,
        &args.motions,
        &base.data,
        &args.out,
        rep,
    )?;
    let mut contact_sheets = Vec::new();
    for (pi, &p) in args.protocols.iter().enumerate() {
        let sheet = contact::contact_sheet(
            p,
            &runs,
            &ds,
            &sets[pi],
            &args.motions,
            base.data.background,
            &args.out,
        )?;
        contact_sheets.extend(sheet);
    }
    let summary = StudySummary::new(
        Provenance {
            command: args.command.clone(),
            evogs_version: env!("CARGO_PKG_VERSION").to_string(),
            date: humantime::format_rfc3339_seconds(std::time::SystemTime::now()).to_string(),
            data: std::fs::canonicalize(&data)
                .unwrap_or_else(|_| data.clone())
                .display()
                .to_string(),
            preset: base.preset.to_string(),
            config_file: args.config.as_ref().map(|p| p.display().to_string()),
            config_hash: config_hash(&base.to_toml()),
            iterations: base.schedule.iterations,
            seeds: args.seeds,
            jobs,
            threads,
            machine: machine(),
        },
        args.protocols.clone(),
        args.motions.clone(),
        records,
    )
    .with_dynamic(dynamic.rows, dynamic.note, dynamic.timelines);
    let truth = evogs::scenes::GroundTruth::of_dataset(&data).map_err(CommandError::new)?;
    let baseline_records =
        baselines::baselines(&runs, &ds, &sets, &args.protocols, truth.as_ref(), rep)?;
    let summary = summary.with_baselines(&baseline_records);
    let json = args.out.join("study.json");
    let markdown = args.out.join("study.md");
    let chart = args.out.join("study.png");
    let text = serde_json::to_string_pretty(&summary)
        .map_err(|e| CommandError::new(format!("cannot encode the study: {e}")))?;
    write_atomic(&json, text.as_bytes())?;
    write_atomic(&markdown, summary.markdown().as_bytes())?;
    write_chart(&summary, &chart)?;
    Ok(Some(StudyOutcome {
        summary,
        json,
        markdown,
        chart,
        time_plots,
        contact_sheets,
        trained: pending.len(),
        reused,
    }))
}

/// Trains the pending runs, `jobs` at a time, showing their progress on `rep` (each run
/// writes its record). Returns the first failure (the other runs in flight finish, none starts
/// after it).
fn train_pending(
    runs: &[PlannedRun],
    pending: &[usize],
    ds: &evogs::data::Dataset,
    sets: &[Vec<HeldOutSet>],
    protocols: &[StudyProtocol],
    jobs: usize,
    per_job: usize,
    rep: &mut dyn Reporter,
) -> Option<CommandError> {
    if pending.is_empty() {
        return None;
    }
    let labels = pending.iter().map(|&i| runs[i].label()).collect();
    let iters = pending.iter().map(|&i| runs[i].iterations).collect();
    let mut shown = StudyProgress::new(labels, iters, jobs);
    shown.open(rep);
    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let (tx, rx) = mpsc::channel::<Message>();
    let mut failure = None;
    std::thread::scope(|scope| {
        for _ in 0..jobs {
            let tx = tx.clone();
            let (next, stop) = (&next, &stop);
            scope.spawn(move || {
                loop {
                    let k = next.fetch_add(1, Ordering::SeqCst);
                    if k >= pending.len() || stop.load(Ordering::SeqCst) {
                        break;
                    }
                    let run = &runs[pending[k]];
                    let _ = tx.send(Message::Begin(k));
                    let mut reporter = ChannelReporter::new(k, tx.clone());
                    let p = protocols.iter().position(|&q| q == run.protocol);
                    let sets = &sets[p.unwrap_or(0)];
                    let res = execute(run, ds, sets, per_job, &mut reporter);
                    if res.is_err() {
                        stop.store(true, Ordering::SeqCst);
                    }
                    let _ = tx.send(Message::End(k, res.map(|_| ())));
                }
            });
        }
        drop(tx);
        for m in rx {
            match m {
                Message::Begin(k) => shown.begin(k, rep),
                Message::Report(e) => shown.show(e, rep),
                Message::End(k, res) => {
                    shown.end(k, res.is_ok(), rep);
                    if let Err(e) = res {
                        failure.get_or_insert(e);
                    }
                }
            }
        }
    });
    failure
}

/// `study.png`: PSNR bars, a group per row of the table, a bar per motion.
fn write_chart(s: &StudySummary, path: &Path) -> Result<(), CommandError> {
    let groups: Vec<BarGroup> = s
        .rows
        .iter()
        .map(|r| BarGroup {
            label: r.protocol.to_string(),
            sublabel: r.set.clone(),
            values: s
                .motions
                .iter()
                .map(|&m| r.cell(m).map(|c| c.psnr.mean))
                .collect(),
        })
        .collect();
    let names: Vec<&str> = s.motions.iter().map(|&m| m.as_str()).collect();
    save_bars(
        "evogs study: held-out PSNR by protocol and motion",
        "PSNR (dB)",
        &names,
        &groups,
        path,
    )
    .map_err(CommandError::new)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn motions_parse_in_order_without_repeats() {
        assert_eq!(
            parse_motions("velocity,deformation,static").expect("defaults"),
            vec![Motion::Velocity, Motion::Deformation, Motion::Static],
            "the default list"
        );
        assert!(parse_motions("velocity,velocity").is_err(), "repeat");
        assert!(parse_motions("warp").is_err(), "unknown");
    }

    #[test]
    fn the_configuration_hash_tells_configurations_apart() {
        let a = config_hash(&TrainConfig::fast().to_toml());
        let mut c = TrainConfig::fast();
        c.seed += 1;
        assert_eq!(a, config_hash(&TrainConfig::fast().to_toml()), "stable");
        assert_ne!(a, config_hash(&c.to_toml()), "a changed seed");
        assert_eq!(a.len(), 16, "{a}");
    }
}
