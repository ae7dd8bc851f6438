//! Dynamic-region metrics through the commands: on a rig written by the test (a patch moving
//! over a static backdrop, fixed cameras) the temporal-median mask covers the patch's path
//! and not the backdrop; `evogs eval` writes a per-frame CSV and a plot that agree with its
//! JSON; a monocular run uses the dataset's `X_motion.png` masks, and without them says why
//! it has no dynamic-region metrics.

use evogs::data::image_io::save_png;
use evogs::data::n3dv::{LlffPose, write_poses};
use evogs::data::{Dataset, LoadOptions, SplitName};
use evogs::eval::SplitMetrics;
use evogs::eval::dynamic::{MaskRule, MotionMasks};
use evogs::eval::mask::MOTION_DILATION;
use evogs::eval::table::CSV_HEADER;
use evogs_cli::app::Silent;
use evogs_cli::app::evaluate::evaluate_run;
use evogs_cli::app::paths::shipped_scene;
use evogs_cli::app::train::{TrainArgs, train};
use evogs_math::Vec3;
use evogs_splat::Image;
use std::path::{Path, PathBuf};

use crate::common;

const CAMS: usize = 3;
const FRAMES: usize = 9;
const W: usize = 32;
const H: usize = 24;
const PATCH: usize = 4;

/// The patch's top-left corner in frame `k`: a diagonal path across the image.
fn corner(k: usize) -> (usize, usize) {
    (
        2 + k * (W - PATCH - 4) / (FRAMES - 1),
        2 + k * (H - PATCH - 4) / (FRAMES - 1),
    )
}

/// Frame `k` of camera `c`: a textured backdrop (fixed per camera) and the red patch.
fn frame(c: usize, k: usize) -> Image<f32> {
    let mut img = Image::new(W, H);
    for y in 0..H {
        for x in 0..W {
            let g = 0.3 + 0.1 * (((x / 3 + y / 2 + c) % 4) as f32);
            img.set(x, y, [g, g, 0.5]);
        }
    }
    let (px, py) = corner(k);
    for y in py..py + PATCH {
        for x in px..px + PATCH {
            img.set(x, y, [1.0, 0.0, 0.0]);
        }
    }
    img
}

/// Camera `c` on a ring of radius 4 at height 1.5, looking at the origin (z up).
fn ring_c2w(c: usize) -> [[f64; 4]; 4] {
    let a = std::f64::consts::TAU * c as f64 / CAMS as f64;
    let eye = Vec3::new(4.0 * a.cos(), 4.0 * a.sin(), 1.5);
    evogs::scenes::rig::c2w_looking_at(eye, Vec3::new(0.0, 0.0, 0.0))
}

/// Writes the rig (N3DV layout) into `dir`.
fn write_rig(dir: &Path) {
    let poses: Vec<LlffPose> = (0..CAMS)
        .map(|c| LlffPose::from_c2w_opengl(ring_c2w(c), [H as f64, W as f64, 30.0], [0.5, 10.0]))
        .collect();
    write_poses(&dir.join("poses_bounds.npy"), &poses).expect("poses");
    for c in 0..CAMS {
        let images = dir.join(format!("cam{c:02}/images"));
        std::fs::create_dir_all(&images).expect("camera folder");
        for k in 0..FRAMES {
            save_png(&frame(c, k), &images.join(format!("{k:04}.png"))).expect("png");
        }
    }
}

#[test]
fn the_mask_of_a_rig_covers_the_moving_patch_and_not_the_backdrop() {
    let dir = common::scratch("mask-rig");
    write_rig(&dir);
    let ds = Dataset::load(&dir, &LoadOptions::default()).expect("rig");
    assert_eq!(ds.test.len(), FRAMES, "cam00 at every time");
    let mut masks = MotionMasks::new(ds.all_views());
    let mut union = vec![false; W * H];
    for v in &ds.test {
        let k: usize = v
            .file
            .file_stem()
            .and_then(|s| s.to_str())
            .and_then(|s| s.parse().ok())
            .expect("frame index");
        let gt = v.image.as_ref().expect("decoded");
        let fm = masks.mask(v, gt).expect("mask").expect("a fixed camera");
        assert_eq!(fm.rule, MaskRule::TemporalMedian, "frame {k}");
        let (px, py) = corner(k);
        for y in 0..H {
            for x in 0..W {
                let patch = (px..px + PATCH).contains(&x) && (py..py + PATCH).contains(&y);
                let near = x + MOTION_DILATION >= px
                    && x < px + PATCH + MOTION_DILATION
                    && y + MOTION_DILATION >= py
                    && y < py + PATCH + MOTION_DILATION;
                if patch {
                    assert!(fm.mask.get(x, y), "frame {k}: patch pixel ({x}, {y})");
                }
                if !near {
                    assert!(!fm.mask.get(x, y), "frame {k}: backdrop pixel ({x}, {y})");
                }
                union[y * W + x] |= fm.mask.get(x, y);
            }
        }
    }
    // The path is in the union of the masks; the corners off the diagonal are not.
    assert!(!union[(H - 1) * W] && !union[W - 1], "off-path corners");
    std::fs::remove_dir_all(&dir).ok();
}

/// The CSV's rows: (time, camera, psnr, ssim, dynamic psnr, dynamic ssim, mask fraction).
type Row = (f64, String, f64, f64, Option<f64>, Option<f64>, Option<f64>);

fn read_csv(path: &Path) -> Vec<Row> {
    let text = std::fs::read_to_string(path).expect("CSV");
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some(CSV_HEADER), "header");
    let opt = |s: &str| (!s.is_empty()).then(|| s.parse::<f64>().expect("number"));
    lines
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            assert_eq!(f.len(), 7, "{l}");
            let num = |s: &str| s.parse::<f64>().expect("number");
            (
                num(f[0]),
                f[1].to_string(),
                num(f[2]),
                num(f[3]),
                opt(f[4]),
                opt(f[5]),
                opt(f[6]),
            )
        })
        .collect()
}

fn mean(xs: &[f64]) -> f64 {
    let n = xs.len() as f64;
    xs.iter().sum::<f64>() / n
}

/// The JSON file, the CSV and the plot of an evaluation agree: same frames in the same
/// order, the same values, and the JSON's means are the CSV's.
fn check_outputs(json: &Path) -> SplitMetrics {
    let m: SplitMetrics =
        serde_json::from_str(&std::fs::read_to_string(json).expect("JSON")).expect("metrics");
    let rows = read_csv(&json.with_extension("csv"));
    assert_eq!(rows.len(), m.frames.len(), "a row per frame");
    // serde_json's default float parser may land one ulp off the shortest decimal the
    // CSV writes, so values are compared to a few ulps.
    let same = |a: f64, b: f64| (a - b).abs() <= 1e-14 * b.abs().max(1e-300);
    let same_opt = |a: Option<f64>, b: Option<f64>| match (a, b) {
        (Some(a), Some(b)) => same(a, b),
        (None, None) => true,
        _ => false,
    };
    for (r, f) in rows.iter().zip(&m.frames) {
        assert!(same(r.0, f.time), "time {} vs {}", r.0, f.time);
        assert_eq!(r.1, f.camera, "camera");
        assert!(same(r.2, f.psnr), "psnr at t = {}", f.time);
        assert!(same(r.3, f.ssim), "ssim at t = {}", f.time);
        assert!(
            same_opt(r.4, f.dynamic_psnr),
            "dynamic psnr at t = {}",
            f.time
        );
        assert!(
            same_opt(r.5, f.dynamic_ssim),
            "dynamic ssim at t = {}",
            f.time
        );
        assert!(
            same_opt(r.6, f.mask_fraction),
            "mask fraction at t = {}",
            f.time
        );
    }
    let psnr: Vec<f64> = rows.iter().map(|r| r.2).collect();
    let ssim: Vec<f64> = rows.iter().map(|r| r.3).collect();
    assert!((mean(&psnr) - m.psnr).abs() < 1e-9, "mean PSNR");
    assert!((mean(&ssim) - m.ssim).abs() < 1e-12, "mean SSIM");
    let dyn_psnr: Vec<f64> = rows.iter().filter_map(|r| r.4).collect();
    match &m.dynamic {
        Some(d) => {
            assert_eq!(d.frames, dyn_psnr.len(), "frames with a mask");
            assert!((mean(&dyn_psnr) - d.psnr).abs() < 1e-9, "mean dynamic PSNR");
        }
        None => assert!(dyn_psnr.is_empty(), "no dynamic values without masks"),
    }
    let png = image::open(json.with_extension("png")).expect("the plot");
    assert!(png.width() > 300 && png.height() > 200, "a plot");
    m
}

fn tiny_train(data: &Path, dir: &Path) -> PathBuf {
    let cfg = common::tiny_config(
        dir,
        "[schedule]\nwarmup_iters = 3\niterations = 6\ncurriculum_iters = 0\n",
    );
    let cfg_text = std::fs::read_to_string(&cfg)
        .expect("config")
        .replace("downscale = 8", "downscale = 1");
    std::fs::write(&cfg, cfg_text).expect("config");
    let run = dir.join("run");
    train(
        &TrainArgs {
            data: Some(data.to_path_buf()),
            out: run.clone(),
            config: Some(cfg),
            skip_outputs: true,
            ..TrainArgs::default()
        },
        &mut Silent,
    )
    .expect("a tiny run");
    run
}

#[test]
fn eval_writes_a_csv_and_a_plot_that_agree_with_its_json() {
    let dir = common::scratch("mask-eval");
    let data = dir.join("rig");
    std::fs::create_dir_all(&data).expect("data folder");
    write_rig(&data);
    let run = tiny_train(&data, &dir);
    let (m, json) =
        evaluate_run(&run, SplitName::Test, None, None, None, &mut Silent).expect("eval");
    assert_eq!(
        json.file_name().and_then(|s| s.to_str()),
        Some("metrics-test.json")
    );
    let back = check_outputs(&json);
    assert_eq!(
        back.frames.len(),
        m.frames.len(),
        "the file holds what was returned"
    );
    assert_eq!(m.frames.len(), FRAMES, "cam00's frames");
    let d = m.dynamic.as_ref().expect("fixed cameras give masks");
    assert_eq!(d.frames, FRAMES, "every frame has a mask");
    assert_eq!(d.rules, vec![MaskRule::TemporalMedian], "{d:?}");
    assert!(m.dynamic_note.is_none(), "{:?}", m.dynamic_note);
    for f in &m.frames {
        assert_eq!(f.camera, "cam00", "camera named");
        let frac = f.mask_fraction.expect("fraction");
        let patch = (PATCH * PATCH) as f64 / (W * H) as f64;
        assert!(
            frac >= patch && frac < 0.3,
            "t = {}: fraction {frac}",
            f.time
        );
    }
    // A time range writes its own three files.
    let (_, part) = evaluate_run(
        &run,
        SplitName::Test,
        Some((0.5, 1.0)),
        None,
        None,
        &mut Silent,
    )
    .expect("part");
    let p = check_outputs(&part);
    assert!(p.frames.len() < FRAMES && !p.frames.is_empty(), "a subset");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_monocular_run_reads_shipped_masks_and_without_them_says_why_not() {
    let dir = common::scratch("mask-mono");
    let run = common::tiny_run(&dir);
    let mut infos = common::Infos::default();
    let (m, json) =
        evaluate_run(&run, SplitName::Test, None, None, None, &mut infos).expect("eval");
    check_outputs(&json);
    assert!(m.dynamic.is_none(), "no masks, no static run");
    let note = m.dynamic_note.clone().expect("a note");
    assert!(note.contains("_motion.png"), "{note}");
    assert!(infos.0.contains(&note), "reported: {:?}", infos.0);
    // The same scene with a mask beside every test frame: a 64×64 block at full size, 8×8
    // pixels at the run's 1/8 downscale.
    let data = dir.join("scene");
    common::copy_tree(&shipped_scene(), &data);
    let ds = Dataset::load(
        &data,
        &LoadOptions {
            load_images: false,
            ..LoadOptions::default()
        },
    )
    .expect("scene");
    for v in &ds.test {
        let (fw, fh) = image::image_dimensions(&v.file).expect("frame");
        let mut mask = image::GrayImage::new(fw, fh);
        for y in 64..128 {
            for x in 64..128 {
                mask.put_pixel(x, y, image::Luma([255]));
            }
        }
        let stem = v.file.file_stem().and_then(|s| s.to_str()).expect("stem");
        mask.save(v.file.with_file_name(format!("{stem}_motion.png")))
            .expect("mask");
    }
    let (m, json) =
        evaluate_run(&run, SplitName::Test, None, Some(&data), None, &mut Silent).expect("eval");
    check_outputs(&json);
    let d = m.dynamic.as_ref().expect("shipped masks");
    assert_eq!(d.rules, vec![MaskRule::Shipped], "{d:?}");
    assert_eq!(d.frames, m.frames.len(), "every frame");
    for f in &m.frames {
        let (fw, fh) = image::image_dimensions(&f.file).expect("frame");
        let expect = 64.0 / (f64::from(fw / 8) * f64::from(fh / 8));
        let got = f.mask_fraction.expect("fraction");
        assert!(
            (got - expect).abs() < 1e-12,
            "{}: {got} vs {expect}",
            f.file
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}
