//! `evogs train`: resolve the configuration, load the data, train with checkpoints and a
//! log, then evaluate on the test split and render a GIF.

pub use super::counts::positive_count;
use super::error::{CommandError, CommandResult, Context as _};
use super::load::load_dataset;
use super::lock::FolderLock;
use super::paths::{RunFolder, shipped_scene};
use super::render::{CameraPath, RenderArgs, render_sequence};
use super::{Reporter, interrupt, plot};
use evogs::config::changes;
use evogs::config::{Preset, Protocol, ScheduleConfig, TrainConfig};
use evogs::data::{DataFormat, DataIdentity, Dataset, SplitName};
use evogs::eval::{SplitMetrics, evaluate};
use evogs::model::Motion;
use evogs::run::checkpoint;
use evogs::train::collective::{self, Collective, Solo};
use evogs::train::trainer::{LogRow, Trainer};
use evogs::train::views::{supervised_indices, training_frames};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The options of `evogs train`: the command line's flags (clap) and a record that can be
/// stored and read back (serde) are this one struct.
#[derive(Clone, Debug, Default, PartialEq, clap::Args, serde::Serialize, serde::Deserialize)]
pub struct TrainArgs {
    /// Dataset folder, D-NeRF or N3DV layout (default: data/toys-mini shipped with evogs).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Run folder (config, checkpoints, log, curve, metrics, renders).
    #[arg(long, default_value = "runs/latest")]
    pub out: PathBuf,
    /// TOML file overlaid on the preset (any subset of the fields of RUN/config.toml).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Preset: fast (default, sized for 2 CPU cores) or paper (the paper's D-NeRF settings).
    #[arg(long)]
    pub preset: Option<Preset>,
    /// Dynamics: velocity (EvoGS, default), deformation (4DGS-style) or static (3DGS).
    #[arg(long)]
    pub motion: Option<Motion>,
    /// Training protocol: full, sparse, future or backward.
    #[arg(long)]
    pub protocol: Option<Protocol>,
    /// Stride of the sparse protocol (every k-th distinct training time).
    #[arg(long)]
    pub stride: Option<usize>,
    /// Split time of the future/backward protocols.
    #[arg(long)]
    pub split_time: Option<f64>,
    /// Total iterations (warm-up included). A new run's warm-up and temporal curriculum
    /// are shortened to fit (a note says so); to stop early with the planned schedule,
    /// set schedule.iterations in a --config file. With --resume: extends the run.
    #[arg(long, allow_negative_numbers = true, value_parser = positive_count)]
    pub iters: Option<u64>,
    /// Random seed.
    #[arg(long, allow_negative_numbers = true)]
    pub seed: Option<u64>,
    /// Dataset layout: auto (default: `transforms_train.json` is D-NeRF,
    /// `poses_bounds.npy` is N3DV), dnerf or n3dv.
    #[arg(long)]
    pub format: Option<DataFormat>,
    /// Continue from the run folder's checkpoint, RUN/checkpoint.safetensors (with --iters to
    /// extend the run).
    #[arg(long, conflicts_with = "force")]
    pub resume: bool,
    /// Replace the run already in the folder (without it, training into a folder that holds
    /// a checkpoint is refused).
    #[arg(long)]
    pub force: bool,
    /// Skip the final evaluation and GIF (tests, studies).
    #[arg(skip)]
    #[serde(default)]
    pub skip_outputs: bool,
}

/// What a training run produced.
#[derive(Clone, Debug)]
pub struct TrainOutcome {
    /// The run folder.
    pub run: RunFolder,
    /// Test metrics (if the dataset has a test split).
    pub test: Option<SplitMetrics>,
    /// The GIF, if rendered.
    pub gif: Option<PathBuf>,
    /// Iterations done.
    pub iterations: u64,
    /// Training seconds.
    pub seconds: f64,
    /// Final number of Gaussians.
    pub gaussians: usize,
}

/// Resolves the configuration: preset, then the file, then the flags.
///
/// # Errors
/// Unknown preset, unreadable or invalid file, invalid values.
pub fn resolve_config(args: &TrainArgs) -> CommandResult<TrainConfig> {
    let mut cfg = TrainConfig::from_preset(args.preset.unwrap_or_default());
    if let Some(p) = &args.config {
        cfg = merge_file(&cfg, p)?;
        // The file's values are checked as the file's, before the flags override them.
        cfg.validate().at(p)?;
    }
    apply_flags(&mut cfg, args, true);
    cfg.validate()?;
    Ok(cfg)
}

/// `cfg` with the TOML file `path` overlaid.
fn merge_file(cfg: &TrainConfig, path: &Path) -> CommandResult<TrainConfig> {
    let text = read_config_text(path)?;
    cfg.merge_toml(&text).at(path)
}

/// The text of a configuration file (at most 1 MiB; a folder, a FIFO or a device is refused).
fn read_config_text(path: &Path) -> CommandResult<String> {
    evogs::bounded::read_text(path, evogs::bounded::CONFIG_BYTES, "a configuration file")
        .map_err(CommandError::new)
}

/// Applies the configuration flags (`--motion`, `--protocol`, `--stride`, `--split-time`,
/// `--iters`, `--seed`, `--format`). With `shorten`, `--iters` also shortens the warm-up and
/// the temporal curriculum to fit (a new run); without, it sets the iteration count alone
/// (a resumed run, whose schedule is its checkpoint's).
fn apply_flags(cfg: &mut TrainConfig, args: &TrainArgs, shorten: bool) {
    if let Some(m) = args.motion {
        cfg.dynamics.motion = m;
    }
    if let Some(p) = args.protocol {
        cfg.data.protocol = p;
    }
    if let Some(s) = args.stride {
        cfg.data.stride = s;
    }
    if let Some(t) = args.split_time {
        cfg.data.split_time = t;
    }
    if let Some(n) = args.iters {
        cfg.schedule.iterations = n;
        if shorten {
            cfg.schedule.warmup_iters = cfg.schedule.warmup_iters.min(n);
            cfg.schedule.curriculum_iters = cfg
                .schedule
                .curriculum_iters
                .min(n - cfg.schedule.warmup_iters);
        }
    }
    if let Some(s) = args.seed {
        cfg.seed = s;
    }
    if let Some(f) = args.format {
        cfg.data.format = f;
    }
}

/// The flag that sets a configuration key ([`apply_flags`]).
fn flag_of(key: &str) -> &'static str {
    match key {
        "dynamics.motion" => "--motion",
        "data.protocol" => "--protocol",
        "data.stride" => "--stride",
        "data.split_time" => "--split-time",
        "schedule.iterations" => "--iters",
        "seed" => "--seed",
        "data.format" => "--format",
        _ => "the command line",
    }
}

/// The configuration a resumed run continues with, checked against its checkpoint's
/// (`ckpt`). What the run is asked for is the folder's `config.toml` (or `--preset`'s
/// values when given), then `--config`, then the flags. A difference a resume may take
/// ([`evogs::config::RESUMABLE_KEYS`]) is applied with a note; any other is refused in one
/// line that names each key, the checkpoint's value, the asked one and where it comes from.
fn resume_config(
    args: &TrainArgs,
    run: &RunFolder,
    ckpt: &TrainConfig,
    rep: &mut dyn Reporter,
) -> CommandResult<TrainConfig> {
    let path = run.config();
    let folder = TrainConfig::from_run_toml(&read_config_text(&path)?).at(&path)?;
    let mut stages: Vec<(String, TrainConfig)> = vec![(path.display().to_string(), folder)];
    if let Some(p) = args.preset {
        stages.push((format!("--preset {p}"), TrainConfig::from_preset(p)));
    }
    if let Some(p) = &args.config {
        let last = &stages[stages.len() - 1].1;
        let cfg = merge_file(last, p)?;
        cfg.validate().at(p)?;
        stages.push((format!("--config {}", p.display()), cfg));
    }
    let mut asked = stages[stages.len() - 1].1.clone();
    // With --preset the configuration is resolved afresh, as a new run's is (its --iters
    // shortens the warm-up and curriculum the same way); without, --iters only sets the
    // count of the folder's configuration.
    apply_flags(&mut asked, args, args.preset.is_some());
    stages.push((String::new(), asked.clone()));
    // Each key is credited to the last stage that set it; the flags by name.
    // The keys each stage changed from the one before it, diffed once.
    let mut prev = ckpt;
    let mut set_by: Vec<(&str, Vec<String>)> = Vec::with_capacity(stages.len());
    for (name, cfg) in &stages {
        set_by.push((
            name,
            changes(prev, cfg).into_iter().map(|c| c.key).collect(),
        ));
        prev = cfg;
    }
    let source = |key: &str| {
        let from = set_by
            .iter()
            .rev()
            .find(|(_, keys)| keys.iter().any(|k| k == key))
            .map_or("", |(name, _)| *name);
        if from.is_empty() {
            flag_of(key).to_string()
        } else {
            from.to_string()
        }
    };
    let all = changes(ckpt, &asked);
    let refused: Vec<String> = all
        .iter()
        .filter(|c| !c.resumable())
        .map(|c| {
            format!(
                "{} is {} in the checkpoint, {} from {}",
                c.key,
                c.from,
                c.to,
                source(&c.key)
            )
        })
        .collect();
    if !refused.is_empty() {
        return Err(CommandError::at(
            &run.checkpoint(),
            format!(
                "cannot resume: {}; a resume continues the checkpoint's model, data and \
                 optimiser exactly, so undo the change, or train a new run (--force, or \
                 another --out)",
                refused.join("; ")
            ),
        ));
    }
    asked.validate()?;
    for c in &all {
        rep.info(&format!(
            "note: resuming with {} = {} (the checkpoint has {}; from {})",
            c.key,
            c.to,
            c.from,
            source(&c.key)
        ));
    }
    Ok(asked)
}

/// How the dataset's frames are held: decoded in memory, or read through the frame cache.
fn frames_note(ds: &Dataset, cfg: &TrainConfig) -> String {
    let mib = |b: usize| b as f64 / (1024.0 * 1024.0);
    let all = ds.decoded_bytes();
    if all <= cfg.data.cache_bytes() {
        format!("frames decoded in memory ({:.0} MiB)", mib(all))
    } else {
        format!(
            "frames decoded as used through a {} MiB cache ({:.0} MiB decoded in all)",
            cfg.data.cache_mb,
            mib(all)
        )
    }
}

/// Where the initial Gaussians come from: the dataset's `points3d.ply`, or random points
/// (and why: no file, an empty one, or `init.use_points = false`).
fn init_note(ds: &Dataset, cfg: &TrainConfig) -> String {
    let ply = ds.root.join("points3d.ply");
    let random = format!(
        "{} random points in [-{e}, {e}]^3 (init.random_points, init.random_extent)",
        cfg.init.random_points,
        e = cfg.init.random_extent
    );
    match &ds.points {
        Some(p) if !p.positions.is_empty() && cfg.init.use_points => format!(
            "initial Gaussians: {} points from {}",
            p.positions.len(),
            ply.display()
        ),
        Some(p) if !p.positions.is_empty() => {
            format!("initial Gaussians: init.use_points = false, so {random}")
        }
        Some(_) => format!(
            "initial Gaussians: {} has no vertices, so {random}",
            ply.display()
        ),
        None => format!(
            "initial Gaussians: no {} in the dataset, so {random}",
            ply.display()
        ),
    }
}

fn write_log(log: &[LogRow], path: &Path) -> CommandResult<()> {
    let mut s =
        String::from("iteration,seconds,loss,l1,psnr,ssim,regularizers,gaussians,lr_position\n");
    for r in log {
        let _ = writeln!(
            s,
            "{},{:.3},{:.6e},{:.6e},{:.4},{:.5},{:.6e},{},{:.4e}",
            r.iteration,
            r.seconds,
            r.loss,
            r.l1,
            r.psnr,
            r.ssim,
            r.regularizers,
            r.gaussians,
            r.lr_position
        );
    }
    evogs::atomic::write_atomic(path, s.as_bytes()).doing(path, "cannot write the log")
}

fn save_all(t: &Trainer, run: &RunFolder) -> CommandResult<()> {
    checkpoint::save(t, &run.checkpoint_to_write()).map_err(CommandError::new)?;
    write_log(t.log(), &run.log())?;
    if t.log().len() >= 2 {
        plot::save_curve(t.log(), &run.curve())?;
    }
    Ok(())
}

/// What `--iters` changed besides the iteration count: a new run's warm-up and temporal
/// curriculum are shortened to fit in it (`asked`: the schedule without the flag), which
/// changes the whole run, not only where it stops.
fn iters_notes(asked: &ScheduleConfig, got: &ScheduleConfig) -> Vec<String> {
    let mut out = Vec::new();
    for (name, a, g) in [
        ("warmup_iters", asked.warmup_iters, got.warmup_iters),
        (
            "curriculum_iters",
            asked.curriculum_iters,
            got.curriculum_iters,
        ),
    ] {
        if a != g {
            out.push(format!(
                "note: --iters {} shortens schedule.{name} from {a} to {g} to fit; set \
                 schedule.iterations in a --config file instead to stop early with the \
                 planned schedule (and resume with --iters to go on)",
                got.iterations
            ));
        }
    }
    out
}

/// The run to train: its folder, the checkpoint it continues (read once), its
/// configuration and its dataset folder.
struct Plan {
    run: RunFolder,
    checkpoint: Option<checkpoint::Loaded>,
    cfg: TrainConfig,
    data_dir: PathBuf,
}

/// Checks the flags against the run folder (`--resume`, `--force`, a trained run already
/// there) and resolves the configuration: when resuming, the checkpoint's, with the changes
/// a resume may take ([`resume_config`]); else the preset, file and flags (with a note for
/// each part of the schedule `--iters` shortened).
fn plan_run(args: &TrainArgs, rep: &mut dyn Reporter) -> CommandResult<Plan> {
    let run = RunFolder::new(&args.out);
    let has_checkpoint = run.checkpoint().is_file();
    if args.resume && !has_checkpoint {
        return Err(CommandError::at(
            &run.checkpoint(),
            "no checkpoint to resume from",
        ));
    }
    if args.resume && args.force {
        return Err(CommandError::new(
            "--resume continues the run in the folder and --force replaces it: pass one",
        ));
    }
    if !args.resume && has_checkpoint && !args.force {
        return Err(CommandError::at(
            &run.dir,
            "the folder holds a trained run (a checkpoint); pass --resume to continue it or \
             --force to replace it",
        ));
    }
    let (cfg, checkpoint) = if args.resume {
        let loaded = checkpoint::load_model(&run.checkpoint()).map_err(CommandError::new)?;
        (resume_config(args, &run, &loaded.cfg, rep)?, Some(loaded))
    } else {
        let cfg = resolve_config(args)?;
        if args.iters.is_some() {
            let asked = resolve_config(&TrainArgs {
                iters: None,
                ..args.clone()
            })?;
            for note in iters_notes(&asked.schedule, &cfg.schedule) {
                rep.info(&note);
            }
        }
        (cfg, None)
    };
    let data_dir = match (&args.data, args.resume) {
        (Some(d), _) => d.clone(),
        (None, true) => run.data_dir()?,
        (None, false) => shipped_scene(),
    };
    Ok(Plan {
        run,
        checkpoint,
        cfg,
        data_dir,
    })
}

/// Checks that the data a resumed run is given is the data its checkpoint was trained on
/// (the fingerprint of the training split, wherever it lies now; a note when it moved, or
/// when the checkpoint predates the record).
fn check_resumed_data(
    recorded: Option<&DataIdentity>,
    now: &DataIdentity,
    args: &TrainArgs,
    run: &RunFolder,
    rep: &mut dyn Reporter,
) -> CommandResult<()> {
    let Some(old) = recorded else {
        rep.info(&DataIdentity::unrecorded_note(&now.folder));
        return Ok(());
    };
    if !old.same_data(now) {
        let given = if args.data.is_some() {
            "--data gives"
        } else {
            "the run's dataset folder now holds"
        };
        return Err(CommandError::at(
            &run.checkpoint(),
            format!(
                "cannot resume: the checkpoint was trained on {}, and {given} {}, other \
                 training views; resume with the checkpoint's data, or train a new run \
                 (--force, or another --out)",
                old.describe(),
                now.describe()
            ),
        ));
    }
    if old.folder != now.folder {
        rep.info(&format!(
            "note: the training data moved from {} to {} (the same views); resuming with it",
            old.folder, now.folder
        ));
    }
    Ok(())
}

/// Prepares the run folder: with `--force` (not resuming) removes the old run's files, then
/// creates the folder and records the configuration and the dataset folder.
fn prepare_folder(args: &TrainArgs, plan: &Plan) -> CommandResult<()> {
    let run = &plan.run;
    if args.force && !args.resume {
        run.clear()?;
    }
    std::fs::create_dir_all(&run.dir).doing(&run.dir, "cannot create the run folder")?;
    evogs::atomic::write_atomic(&run.config(), plan.cfg.to_toml().as_bytes()).at(&run.config())?;
    let abs = std::fs::canonicalize(&plan.data_dir).unwrap_or_else(|_| plan.data_dir.clone());
    evogs::atomic::write_atomic(&run.data_ref(), abs.display().to_string().as_bytes())
        .at(&run.data_ref())
}

/// Loads the dataset, takes the protocol's training views, locks and prepares the run
/// folder (rank 0, only once the data is known to be good), and starts the trainer: continued from the folder's
/// checkpoint, or new from the dataset's initial points (with a note saying where they come
/// from).
fn start(
    args: &TrainArgs,
    plan: &mut Plan,
    rep: &mut dyn Reporter,
    c: &dyn Collective,
) -> CommandResult<(Trainer, Dataset, Option<FolderLock>)> {
    rep.info(&format!("data: {}", plan.data_dir.display()));
    // Over several processes each rank decodes only the frames of its views, when it uses
    // them (through the frame cache).
    let mut ds = load_dataset(&plan.data_dir, &plan.cfg, c.size() == 1)?;
    let identity = DataIdentity::of(&ds);
    if let Some(l) = &plan.checkpoint {
        check_resumed_data(l.meta.data.as_ref(), &identity, args, &plan.run, rep)?;
    }
    let idx = supervised_indices(&ds.train, &plan.cfg.data);
    // The loaded training images move into the training views.
    let views = training_frames(&mut ds.train, &idx, plan.cfg.data.cache_bytes())?;
    rep.info(&format!(
        "{} of {} training views supervised ({:?} protocol); {} layout, {}",
        views.len(),
        ds.train.len(),
        plan.cfg.data.protocol,
        ds.format,
        frames_note(&ds, &plan.cfg)
    ));
    let lock = if c.rank() == 0 {
        let lock = FolderLock::acquire(&plan.run.dir, "train")?;
        // Planned before the lock: a run another process finished meanwhile is not
        // trained over.
        if !args.resume && !args.force && plan.run.checkpoint().is_file() {
            return Err(CommandError::at(
                &plan.run.dir,
                "the folder holds a trained run (a checkpoint); pass --resume to continue it \
                 or --force to replace it",
            ));
        }
        prepare_folder(args, plan)?;
        Some(lock)
    } else {
        None
    };
    let mut t = if let Some(loaded) = plan.checkpoint.take() {
        let mut t = checkpoint::resume_from(loaded, &plan.run.checkpoint(), views)
            .map_err(CommandError::new)?;
        t.continue_with(&plan.cfg).map_err(CommandError::new)?;
        rep.info(&format!("resuming at iteration {}", t.iteration()));
        t
    } else {
        rep.info(&init_note(&ds, &plan.cfg));
        let pts = ds
            .points
            .as_ref()
            .map(|p| (p.positions.as_slice(), p.colors.as_deref()));
        Trainer::new(plan.cfg.clone(), views, pts).map_err(CommandError::new)?
    };
    t.set_data(identity);
    Ok((t, ds, lock))
}

/// Writes a checkpoint and the log (rank 0 of several processes, after every rank has shown
/// that it holds the same parameters).
fn save_checked(t: &Trainer, run: &RunFolder, c: &dyn Collective) -> CommandResult<()> {
    if c.size() > 1 {
        let hash = collective::parameter_hash(t.model());
        collective::agree(c, "parameters", hash)
            .map_err(|e| CommandError::new(format!("iteration {}: {e}", t.iteration())))?;
    }
    if c.rank() == 0 {
        save_all(t, run)?;
    }
    Ok(())
}

/// Trains to the planned iteration count with progress, checkpoints on the schedule's
/// iteration and minute intervals, and a checkpoint at the end. An interrupt stops after the
/// current iteration with a checkpoint, as an error that says how to continue. Over several
/// processes every rank steps together ([`Trainer::step_with`]); a stop or a checkpoint
/// asked for on any rank (a signal, a rank's clock) is taken by all.
fn train_loop(
    t: &mut Trainer,
    run: &RunFolder,
    rep: &mut dyn Reporter,
    c: &dyn Collective,
) -> CommandResult<()> {
    rep.start("train", t.cfg().schedule.iterations);
    rep.progress(t.iteration(), "");
    let mut last_save = std::time::Instant::now();
    let (mut exchange, mut stepping) = (0.0, 0.0);
    let all = |flags: [bool; 2]| -> CommandResult<[bool; 2]> {
        if c.size() == 1 {
            return Ok(flags);
        }
        let got = c
            .all_gather(&flags.map(u8::from))
            .map_err(CommandError::new)?;
        let any = |k: usize| got.iter().skip(k).step_by(2).any(|&b| b != 0);
        Ok([any(0), any(1)])
    };
    while !t.finished() {
        let r = t.step_with(c).map_err(CommandError::new)?;
        exchange += r.losses.timings.exchange;
        stepping += r.seconds;
        if r.dynamics_started {
            rep.info(&format!(
                "iteration {}: dynamics on ({:?} motion, {} Gaussians)",
                r.iteration,
                t.model().motion,
                t.model().len()
            ));
        }
        let psnr = evogs_splat::metrics::psnr_from_mse(r.losses.mse);
        rep.progress(
            t.iteration(),
            &format!(
                "loss {:.4} psnr {:.2} gaussians {}",
                r.losses.total,
                psnr,
                t.model().len()
            ),
        );
        let minutes = t.cfg().schedule.checkpoint_minutes;
        let due = t.schedule().checkpoint_due(t.iteration())
            || (minutes > 0.0 && last_save.elapsed().as_secs_f64() >= 60.0 * minutes);
        let [stop, due] = all([interrupt::requested() && !t.finished(), due])?;
        if due {
            save_checked(t, run, c)?;
            last_save = std::time::Instant::now();
        }
        if stop {
            save_checked(t, run, c)?;
            rep.finish();
            interrupt::clear();
            return Err(CommandError::new(format!(
                "interrupted at iteration {} of {}: checkpoint written to {}; continue with \
                 `evogs train --out {} --resume`",
                t.iteration(),
                t.cfg().schedule.iterations,
                run.checkpoint().display(),
                run.dir.display()
            )));
        }
    }
    save_checked(t, run, c)?;
    rep.finish();
    if c.size() > 1 && stepping > 0.0 {
        rep.info(&format!(
            "exchanging and summing the batches' shares took {exchange:.2} s of {stepping:.2} s \
             of iterations ({:.1} %)",
            100.0 * exchange / stepping
        ));
    }
    Ok(())
}

/// The end of a run: the test metrics (RUN/metrics-test.json, if the dataset has a test
/// split) and the orbit GIF (RUN/render/).
fn finish(
    t: &mut Trainer,
    ds: &Dataset,
    plan: Plan,
    outcome: &mut TrainOutcome,
    rep: &mut dyn Reporter,
) -> CommandResult<()> {
    let run = &plan.run;
    if !ds.test.is_empty() {
        rep.start("evaluate test", ds.test.len() as u64);
        let par = t.par();
        let mut m = evaluate(
            t.model_mut(),
            &ds.test,
            SplitName::Test,
            None,
            plan.cfg.data.background,
            par,
            |d, _| rep.progress(d as u64, ""),
        )?;
        rep.finish();
        m.iterations = t.iteration();
        m.train_seconds = t.train_seconds();
        let json = serde_json::to_string_pretty(&m).unwrap_or_default();
        evogs::atomic::write_atomic(&run.metrics("test"), json.as_bytes())
            .at(&run.metrics("test"))?;
        outcome.test = Some(m);
    }
    let (t0, t1) = t.time_range();
    let rargs = RenderArgs {
        run: run.dir.clone(),
        out: run.dir.join("render"),
        times: (t0, t1, 40),
        camera: CameraPath::Orbit,
        gif: true,
        data: Some(plan.data_dir),
        format: Some(ds.format),
        // The run's own render folder: a resumed run renders over its earlier frames.
        force: true,
    };
    outcome.gif = render_sequence(&rargs, Some((t.model_mut(), ds)), rep)?.gif;
    Ok(())
}

/// Runs `evogs train`: plan the run (flags, configuration), load the data and prepare the
/// run folder, train, then finish with the test metrics and the GIF.
///
/// # Errors
/// Data, configuration, checkpoint or numerical problems (a non-finite loss or gradient stops
/// the run; the last checkpoint stays intact).
pub fn train(args: &TrainArgs, rep: &mut dyn Reporter) -> CommandResult<TrainOutcome> {
    train_with(args, rep, &Solo)
}

/// [`train`] as one of the processes of `c` (`mpirun -np P evogs train ...`): each rank
/// computes its share of every step's `schedule.views_per_step` views and loads only their
/// frames, every rank holds the same parameters (compared at every checkpoint), and rank 0
/// alone writes the run folder, the log, the checkpoints and the outputs. One process with
/// the same batch gives the same bits.
///
/// # Errors
/// As [`train`], a batch that does not split over the ranks, ranks whose parameters differ,
/// or an exchange that failed.
pub fn train_with(
    args: &TrainArgs,
    rep: &mut dyn Reporter,
    c: &dyn Collective,
) -> CommandResult<TrainOutcome> {
    let mut plan = plan_run(args, rep)?;
    let writer = c.rank() == 0;
    // Held to the end: rank 0 is the folder's one writer.
    let (mut t, ds, _lock) = start(args, &mut plan, rep, c)?;
    t.check_collective(c).map_err(CommandError::new)?;
    if c.size() > 1 {
        // Every rank has its data and model (and rank 0 its folder) before the first step.
        collective::barrier(c).map_err(CommandError::new)?;
        rep.info(&format!(
            "{} processes, {} view(s) each per step",
            c.size(),
            t.cfg().schedule.views_per_step / c.size() as u64
        ));
    }
    train_loop(&mut t, &plan.run, rep, c)?;
    let mut outcome = TrainOutcome {
        run: plan.run.clone(),
        test: None,
        gif: None,
        iterations: t.iteration(),
        seconds: t.train_seconds(),
        gaussians: t.model().len(),
    };
    if !args.skip_outputs && writer {
        finish(&mut t, &ds, plan, &mut outcome, rep)?;
    }
    Ok(outcome)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_resume_takes_safe_changes_and_refuses_the_others_by_source() {
        use crate::app::Notes;
        let dir = std::env::temp_dir().join(format!("evogs-resume-rule-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("folder");
        let run = RunFolder::new(&dir);
        let new = TrainArgs {
            preset: Some(Preset::Fast),
            iters: Some(50),
            ..TrainArgs::default()
        };
        let ckpt = resolve_config(&new).expect("config");
        assert!(
            ckpt.schedule.warmup_iters <= 50,
            "--iters shortened the warm-up"
        );
        std::fs::write(run.config(), ckpt.to_toml()).expect("config.toml");
        let resume = |args: TrainArgs| {
            let mut notes = Notes::default();
            let r = resume_config(
                &TrainArgs {
                    resume: true,
                    ..args
                },
                &run,
                &ckpt,
                &mut notes,
            );
            (r.map_err(|e| e.to_string()), notes.0)
        };
        // The same command again: nothing differs.
        let (got, notes) = resume(new.clone());
        assert_eq!(got.expect("same"), ckpt);
        assert!(notes.is_empty(), "{notes:?}");
        // Extending: applied with a note.
        let (got, notes) = resume(TrainArgs {
            iters: Some(80),
            ..TrainArgs::default()
        });
        assert_eq!(got.expect("extended").schedule.iterations, 80);
        assert!(notes[0].contains("schedule.iterations = 80"), "{notes:?}");
        assert!(notes[0].contains("from --iters"), "{notes:?}");
        // Another motion: refused, naming the flag.
        let (got, _) = resume(TrainArgs {
            motion: Some(Motion::Deformation),
            ..TrainArgs::default()
        });
        let e = got.expect_err("another motion");
        assert!(
            e.contains("dynamics.motion") && e.contains("from --motion"),
            "{e}"
        );
        // An edited config.toml: refused, naming the file.
        let edited = ckpt.to_toml().replace(
            &format!("width = {}", ckpt.field.width),
            &format!("width = {}", ckpt.field.width + 8),
        );
        std::fs::write(run.config(), edited).expect("config.toml");
        let (got, _) = resume(TrainArgs::default());
        let e = got.expect_err("another width");
        assert!(
            e.contains("field.width") && e.contains("config.toml"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn iters_that_shorten_the_curriculum_are_reported() {
        let asked = TrainConfig::fast().schedule;
        let mut got = asked.clone();
        got.iterations = 400;
        assert!(iters_notes(&asked, &got).is_empty(), "nothing else changed");
        got.curriculum_iters = 200;
        let notes = iters_notes(&asked, &got);
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            notes[0].contains("curriculum_iters from 1500 to 200"),
            "{}",
            notes[0]
        );
    }

    #[test]
    fn the_flags_and_the_stored_record_are_one_struct() {
        use clap::Parser as _;
        #[derive(clap::Parser)]
        struct Line {
            #[command(flatten)]
            args: TrainArgs,
        }
        let line = "evogs --data scene --out runs/a --preset paper --motion deformation \
                    --protocol sparse --stride 4 --iters 300 --seed 7 --format n3dv --force";
        let args = Line::try_parse_from(line.split_whitespace())
            .expect("parses")
            .args;
        assert_eq!(args.preset, Some(Preset::Paper));
        assert_eq!(
            (args.stride, args.iters, args.seed),
            (Some(4), Some(300), Some(7))
        );
        assert!(args.force && !args.resume && !args.skip_outputs);
        let json = serde_json::to_string(&args).expect("serialises");
        let back: TrainArgs = serde_json::from_str(&json).expect("reads back");
        assert_eq!(back, args, "{json}");
        let defaults = Line::try_parse_from(["evogs"]).expect("defaults").args;
        assert_eq!(defaults.out, PathBuf::from("runs/latest"));
        assert!(Line::try_parse_from(["evogs", "--iters", "0"]).is_err());
    }
}
