//! `evogs study` end to end on the shipped scene at 50×50 with a tiny field: the outputs and
//! their rows, reuse of finished runs, resumption of an interrupted run (bit for bit like the
//! uninterrupted one), the dynamic-region table and the plots against time (consistent with
//! study.json), and bad input refused before any training.

use evogs::eval::dynamic::MaskRule;
use evogs::model::Motion;
use evogs::run::checkpoint;
use evogs::train::trainer::Trainer;
use evogs::train::views::{supervised_indices, training_views};
use evogs_cli::app::Silent;
use evogs_cli::app::load::load_dataset;
use evogs_cli::app::paths::shipped_scene;
use evogs_cli::app::study::{StudyArgs, StudyProtocol, StudySummary, run_study};
use evogs_cli::app::train::{TrainArgs, resolve_config};
use std::path::{Path, PathBuf};

const TINY: &str = r"
[data]
downscale = 4

[field]
width = 16

[field.hexplane]
channels = 4
resolution = [8, 8, 8, 6]
multires = [1, 2]

[schedule]
warmup_iters = 10
iterations = 30
curriculum_iters = 10

[densify]
from_iter = 10
until_iter = 20
interval = 10

[loss]
coherence_samples = 64
";

/// A fresh folder under the system's temporary folder, with the tiny configuration in it.
fn workdir(name: &str) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("evogs-study-{name}-{}", std::process::id()));
    std::fs::remove_dir_all(&dir).ok();
    std::fs::create_dir_all(&dir).expect("temp dir");
    let cfg = dir.join("tiny.toml");
    std::fs::write(&cfg, TINY).expect("config");
    (dir, cfg)
}

fn args(out: &Path, cfg: &Path) -> StudyArgs {
    StudyArgs {
        data: Some(shipped_scene()),
        out: out.to_path_buf(),
        config: Some(cfg.to_path_buf()),
        ..StudyArgs::default()
    }
}

fn mtime(p: &Path) -> std::time::SystemTime {
    std::fs::metadata(p)
        .and_then(|m| m.modified())
        .expect("mtime")
}

#[test]
fn a_study_writes_its_table_and_reuses_or_resumes_runs() {
    let (dir, cfg) = workdir("whole");
    let out = dir.join("study");
    let a = args(&out, &cfg);
    let o = run_study(&a, &mut Silent).expect("study");
    assert_eq!((o.trained, o.reused), (9, 0), "3 protocols × 3 motions");

    // study.json: every number, with provenance.
    let s: StudySummary =
        serde_json::from_str(&std::fs::read_to_string(&o.json).expect("json")).expect("schema");
    assert_eq!(s.runs.len(), 9, "a record per run");
    assert_eq!(s.provenance.iterations, 30, "the configuration's budget");
    assert!(
        !s.provenance.machine.is_empty() && s.provenance.threads >= 1,
        "machine"
    );
    let rows: Vec<(String, &str)> = s
        .rows
        .iter()
        .map(|r| (r.protocol.to_string(), r.set.as_str()))
        .collect();
    let expected = [
        ("full", "test"),
        ("sparse:4", "test"),
        ("sparse:4", "train views at dropped times"),
        ("future:0.75", "test t <= 0.75"),
        ("future:0.75", "test t > 0.75"),
        ("future:0.75", "test t in (0.75, 0.85]"),
        ("future:0.75", "test t in (0.85, 1]"),
    ];
    assert_eq!(
        rows.iter()
            .map(|(p, s)| (p.as_str(), *s))
            .collect::<Vec<_>>(),
        expected,
        "one row per protocol and held-out set"
    );
    // toys-mini: 10 test views (8 at t <= 0.75, one in each bin after), 75 training views of
    // which sparse:4 keeps 19.
    let frames: Vec<usize> = s.rows.iter().map(|r| r.frames).collect();
    assert_eq!(frames, [10, 10, 56, 8, 2, 1, 1], "frames per held-out set");
    for r in &s.rows {
        assert_eq!(r.cells.len(), 3, "a cell per motion");
        for c in &r.cells {
            assert!(
                c.psnr.mean.is_finite() && c.psnr.mean > 10.0 && c.ssim.mean > 0.3,
                "{c:?}"
            );
        }
        let d = r.velocity_minus_deformation_db.expect("both motions ran");
        let v = r.cell(Motion::Velocity).expect("velocity").psnr.mean;
        let f = r.cell(Motion::Deformation).expect("deformation").psnr.mean;
        assert!((d - (v - f)).abs() < 1e-12, "the difference column");
    }
    let md = std::fs::read_to_string(&o.markdown).expect("md");
    assert!(
        md.contains("| protocol | held-out set | frames | velocity | deformation | static | velocity − deformation (dB) |"),
        "{md}"
    );
    assert!(
        md.contains("| sparse:4 | train views at dropped times | 56 |"),
        "{md}"
    );
    // The no-training baselines of future:0.75, from its deformation run, beyond 0.75 only
    // (the whole stretch and its two bins).
    let base: Vec<(&str, &str)> = s
        .baselines
        .iter()
        .map(|b| (b.baseline.as_str(), b.set.as_str()))
        .collect();
    let mut want = Vec::new();
    for b in ["hold", "const-vel", "const-acc"] {
        for set in [
            "test t > 0.75",
            "test t in (0.75, 0.85]",
            "test t in (0.85, 1]",
        ] {
            want.push((b, set));
        }
    }
    assert_eq!(base, want, "baseline rows");
    for b in &s.baselines {
        let frames = if b.set == "test t > 0.75" { 2 } else { 1 };
        assert!(b.psnr.mean > 10.0 && b.frames == frames, "{b:?}");
    }
    assert!(
        out.join("runs/future0.75-deformation-s0/baselines.json")
            .is_file(),
        "stored beside the deformation run"
    );
    assert!(
        md.contains("| future:0.75 | test t > 0.75 | 2 | const-acc |"),
        "{md}"
    );
    assert!(s.trajectories.is_empty(), "toys-mini has no motion.json");
    let png = image::open(&o.chart).expect("study.png");
    assert!(png.width() > 300 && png.height() > 300, "a chart");

    // The dynamic regions: monocular frames without mask files, so the masks are where the
    // static run's render is wrong; a row per whole-image row, a cell per motion.
    assert_eq!(s.dynamic_rows.len(), s.rows.len(), "{:?}", s.dynamic_rows);
    for (d, r) in s.dynamic_rows.iter().zip(&s.rows) {
        assert_eq!(
            (d.protocol, &d.set, d.frames),
            (r.protocol, &r.set, r.frames)
        );
        assert_eq!(d.rules, [MaskRule::StaticRender], "{d:?}");
        assert!(d.masked_frames >= 1 && d.masked_frames <= d.frames, "{d:?}");
        assert!(d.mask_fraction > 0.0 && d.mask_fraction < 1.0, "{d:?}");
        assert_eq!(d.cells.len(), 3, "a cell per motion");
        assert!(d.cells.iter().all(|c| c.psnr.mean.is_finite()), "{d:?}");
    }
    assert!(
        md.contains("Dynamic-region PSNR") && md.contains("static_render"),
        "{md}"
    );
    // Metrics against time: a plot per protocol, drawn from the curves in study.json, whose
    // points are the held-out frames (one per time on the full protocol's test set) with the
    // table's means.
    assert_eq!(o.time_plots.len(), 3, "a plot per protocol");
    // The contact sheet of the future protocol: the ground truth above the three motions.
    assert_eq!(o.contact_sheets.len(), 1, "a sheet per future protocol");
    let sheet = image::open(&o.contact_sheets[0]).expect("a contact sheet");
    assert!(
        o.contact_sheets[0].ends_with("study-contact-future0.75.png"),
        "{}",
        o.contact_sheets[0].display()
    );
    assert!(sheet.height() > 4 * 16, "four rows: {}", sheet.height());
    assert_eq!(s.timelines.len(), 3, "a timeline per protocol");
    for (t, plot) in s.timelines.iter().zip(&o.time_plots) {
        assert_eq!(out.join(&t.plot), *plot, "the plot's name");
        let img = image::open(plot).expect("a time plot");
        assert!(
            img.width() > 300 && img.height() > 300,
            "{}",
            plot.display()
        );
        assert_eq!(t.curves.len(), 3, "a curve per motion");
        let [a, b] = t.window.expect("a training window");
        assert!(
            a <= b && t.train_times.iter().all(|x| (a..=b).contains(x)),
            "{t:?}"
        );
    }
    let full = &s.timelines[0];
    let row = &s.rows[0];
    let drow = &s.dynamic_rows[0];
    for c in &full.curves {
        assert_eq!(
            c.points.len(),
            row.frames,
            "{:?}: a point per test frame",
            c.motion
        );
        let mean = c.points.iter().map(|p| p.psnr).sum::<f64>() / c.points.len() as f64;
        let cell = row.cell(c.motion).expect("cell").psnr.mean;
        assert!(
            (mean - cell).abs() < 1e-9,
            "{:?}: {mean} vs {cell}",
            c.motion
        );
        let dynamic: Vec<f64> = c.points.iter().filter_map(|p| p.dynamic_psnr).collect();
        assert_eq!(dynamic.len(), drow.masked_frames, "{:?}", c.motion);
        let dmean = dynamic.iter().sum::<f64>() / dynamic.len() as f64;
        let dcell = drow
            .cells
            .iter()
            .find(|x| x.motion == c.motion)
            .expect("cell");
        assert!((dmean - dcell.psnr.mean).abs() < 1e-9, "{:?}", c.motion);
    }
    assert!(
        s.timelines[1].train_times.len() < full.train_times.len(),
        "sparse:4 trains on fewer times"
    );

    // A second call reuses every finished run: nothing is trained or rewritten.
    let ckpt = out.join("runs/full-velocity-s0/checkpoint.safetensors");
    let before = mtime(&ckpt);
    let again = run_study(&a, &mut Silent).expect("reuse");
    assert_eq!((again.trained, again.reused), (0, 9), "all reused");
    assert_eq!(mtime(&ckpt), before, "the checkpoint was not rewritten");
    assert_eq!(again.summary.rows, o.summary.rows, "the same table");
    assert_eq!(
        again.summary.dynamic_rows, o.summary.dynamic_rows,
        "the same dynamic-region table"
    );
    assert_eq!(
        again.summary.baselines, o.summary.baselines,
        "the same baselines"
    );

    // An interrupted run: the planned configuration and a checkpoint at iteration 12 in its
    // folder, no record. The study resumes it and ends where the uninterrupted run ended.
    let run_dir = out.join("runs/future0.75-velocity-s0");
    let finished = s
        .runs
        .iter()
        .find(|r| r.folder == "runs/future0.75-velocity-s0")
        .expect("run")
        .clone();
    std::fs::remove_dir_all(&run_dir).expect("clear");
    std::fs::create_dir_all(&run_dir).expect("run dir");
    let targs = TrainArgs {
        config: Some(cfg.clone()),
        motion: Some(Motion::Velocity),
        protocol: Some(evogs::config::Protocol::Future),
        stride: Some(2),
        split_time: Some(0.75),
        seed: Some(0),
        ..TrainArgs::default()
    };
    let planned = resolve_config(&targs).expect("config");
    let ds = load_dataset(&shipped_scene(), &planned, true).expect("data");
    let idx = supervised_indices(&ds.train, &planned.data);
    let views = training_views(&ds.train, &idx).expect("views");
    let pts = ds.points.as_ref().expect("points");
    let mut t = Trainer::new(
        planned.clone(),
        views,
        Some((&pts.positions, pts.colors.as_deref())),
    )
    .expect("trainer");
    for _ in 0..12 {
        t.step().expect("step");
    }
    checkpoint::save(&t, &run_dir.join("checkpoint.safetensors")).expect("checkpoint");
    std::fs::write(run_dir.join("config.toml"), planned.to_toml()).expect("config.toml");
    let resumed = run_study(&a, &mut Silent).expect("resume");
    assert_eq!((resumed.trained, resumed.reused), (1, 8), "one run resumed");
    let r = resumed
        .summary
        .runs
        .iter()
        .find(|r| r.folder == finished.folder)
        .expect("resumed record");
    assert_eq!(r.iterations, 30, "trained to the planned end");
    assert_eq!(
        r.sets, finished.sets,
        "bit for bit the uninterrupted run's metrics"
    );

    // --force retrains; two jobs at once (a thread each, where the first study gave each run
    // every thread) give bit for bit the same runs.
    let forced = run_study(
        &StudyArgs {
            force: true,
            jobs: 2,
            protocols: vec![StudyProtocol::Full],
            motions: vec![Motion::Velocity, Motion::Static],
            ..a.clone()
        },
        &mut Silent,
    )
    .expect("force");
    assert_eq!((forced.trained, forced.reused), (2, 0), "retrained");
    for r in &forced.summary.runs {
        let first = s
            .runs
            .iter()
            .find(|f| f.folder == r.folder)
            .expect("same run");
        assert_eq!(r.sets, first.sets, "{}: the same metrics", r.folder);
        assert_eq!(r.gaussians, first.gaussians, "{}: the same model", r.folder);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_input_is_refused_before_any_training() {
    let (dir, cfg) = workdir("bad");
    let out = dir.join("study");
    let cases: Vec<(StudyArgs, &str)> = vec![
        (
            StudyArgs {
                protocols: vec![StudyProtocol::Future(0.95)],
                ..args(&out, &cfg)
            },
            "needs test views with t > 0.95",
        ),
        (
            StudyArgs {
                protocols: vec![StudyProtocol::Backward(0.01)],
                ..args(&out, &cfg)
            },
            "needs test views with t < 0.01",
        ),
        (
            StudyArgs {
                seeds: 0,
                ..args(&out, &cfg)
            },
            "--seeds",
        ),
        (
            StudyArgs {
                jobs: 0,
                ..args(&out, &cfg)
            },
            "--jobs",
        ),
        (
            StudyArgs {
                data: Some(dir.join("nowhere")),
                ..args(&out, &cfg)
            },
            "nowhere",
        ),
        (
            StudyArgs {
                out: cfg.join("under-a-file"),
                ..args(&out, &cfg)
            },
            "cannot be written",
        ),
    ];
    for (a, why) in cases {
        let e = run_study(&a, &mut Silent).expect_err(why).to_string();
        assert!(e.contains(why), "expected `{why}` in: {e}");
        assert!(!out.join("runs").exists(), "no run was started ({why})");
    }
    // A folder holding a run of another configuration is not silently reused.
    let a = StudyArgs {
        protocols: vec![StudyProtocol::Full],
        motions: vec![Motion::Static],
        ..args(&out, &cfg)
    };
    run_study(&a, &mut Silent).expect("first study");
    let e = run_study(
        &StudyArgs {
            iters: Some(20),
            ..a.clone()
        },
        &mut Silent,
    )
    .expect_err("another budget in the same folder")
    .to_string();
    assert!(
        e.contains("another configuration") && e.contains("--force"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn on_a_scene_with_known_motion_every_future_run_and_baseline_has_a_trajectory_error() {
    use evogs::scenes::{BuiltScene, Layout, Spacing, Variant, select, write_scene};
    let (dir, cfg) = workdir("scene");
    let data = dir.join("translate");
    let spec = &select(&["translate".to_string()]).expect("known")[0];
    let layout = Layout {
        size: 64,
        train_times: 16,
        test_times: 4,
        val_times: 1,
        future_times: 2,
        ..Layout::default()
    };
    write_scene(
        &BuiltScene::new(spec, Spacing::default(), 1),
        Variant::Monocular,
        &layout,
        &data,
        evogs_math::Par::Seq,
        |_, _| {},
    )
    .expect("scene");
    let a = StudyArgs {
        data: Some(data),
        protocols: vec![StudyProtocol::Future(0.75)],
        motions: vec![Motion::Velocity, Motion::Deformation],
        ..args(&dir.join("study"), &cfg)
    };
    let o = run_study(&a, &mut Silent).expect("study");
    let methods: Vec<&str> = o
        .summary
        .trajectories
        .iter()
        .map(|t| t.method.as_str())
        .collect();
    assert_eq!(
        methods,
        ["velocity", "deformation", "hold", "const-vel", "const-acc"],
        "a trajectory row per future run and baseline"
    );
    for t in &o.summary.trajectories {
        assert!(
            t.relative.mean.is_finite() && t.relative.mean >= 0.0,
            "{t:?}"
        );
    }
    // Holding the state still is off by exactly the distance the box travels.
    let hold = &o.summary.trajectories[2];
    assert!((hold.relative.mean - 1.0).abs() < 1e-9, "{hold:?}");
    let md = std::fs::read_to_string(&o.markdown).expect("md");
    assert!(md.contains("| future:0.75 | hold | 1.000 |"), "{md}");
    std::fs::remove_dir_all(&dir).ok();
}
