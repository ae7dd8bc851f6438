//! Memory and speed of training on a multi-view capture larger than memory.
//!
//! Generates (once) a synthetic N3DV-layout dataset in `--dir`: `--cams` cameras on a ring
//! looking at the origin, `--frames` frames each of `--width`×`--height` pixels (defaults:
//! N3DV at half resolution, 20 × 300 × 1352×1014, about 25 GB as 8-bit RGB and 99 GB as the
//! f32 images training compares against). The poses give twice that resolution and the frames
//! are stored already halved, read with `data.downscale = 2` (N3DV extracted at half
//! resolution). The content is smooth (gradients and soft moving discs) so the PNG files stay
//! small; it has no 3D meaning, which does not matter for memory and throughput.
//!
//! Then trains `--iters` iterations through the same path as `evogs train` (dataset checked
//! and loaded with `data.cache_mb = --cache-mb`, frames decoded in memory when they fit, else
//! read through the frame cache) and prints one JSON line: load and training time, iterations
//! per second, the frame cache's counters and the process's peak resident memory (`VmHWM`).
//! Run it once on the large dataset and once on a small one of the same resolution (fully
//! cached) to compare: each run is its own process, so each peak is its own.
//!
//! ```text
//! cargo run --release -p evogs-cli --example mv_memory_bench -- --dir /tmp/n3dv-big
//! cargo run --release -p evogs-cli --example mv_memory_bench -- --dir /tmp/n3dv-small \
//!     --cams 3 --frames 10
//! ```

use evogs::config::TrainConfig;
use evogs::data::image_io::save_png;
use evogs::data::n3dv::{LlffPose, write_poses};
use evogs::train::trainer::Trainer;
use evogs::train::views::{supervised_indices, training_frames};
use evogs_cli::app::load::load_dataset;
use evogs_math::Vec3;
use evogs_splat::Image;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(Debug)]
struct Args {
    dir: PathBuf,
    cams: usize,
    frames: usize,
    width: usize,
    height: usize,
    iters: u64,
    cache_mb: usize,
    generate_only: bool,
}

fn parse_args() -> Result<Args, String> {
    let mut a = Args {
        dir: PathBuf::from("/tmp/evogs-n3dv-bench"),
        cams: 20,
        frames: 300,
        width: 1352,
        height: 1014,
        iters: 60,
        cache_mb: 2048,
        generate_only: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        if flag == "--generate-only" {
            a.generate_only = true;
            continue;
        }
        let v = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let num = |v: &str| {
            v.parse::<usize>()
                .map_err(|_| format!("{flag} {v}: not a count"))
        };
        match flag.as_str() {
            "--dir" => a.dir = PathBuf::from(v),
            "--cams" => a.cams = num(&v)?,
            "--frames" => a.frames = num(&v)?,
            "--width" => a.width = num(&v)?,
            "--height" => a.height = num(&v)?,
            "--iters" => a.iters = num(&v)? as u64,
            "--cache-mb" => a.cache_mb = num(&v)?,
            _ => return Err(format!("unknown flag {flag}")),
        }
    }
    if a.cams < 2 || a.frames < 2 || a.width < 8 || a.height < 8 {
        return Err("need at least 2 cameras, 2 frames and 8x8 images".into());
    }
    Ok(a)
}

/// The frame of camera `c` at time `t`: smooth colour gradients and two soft discs moving
/// with time.
#[allow(clippy::cast_possible_truncation, reason = "colours in f32")]
fn frame(c: usize, t: f64, w: usize, h: usize) -> Image<f32> {
    let mut img = Image::new(w, h);
    let (wf, hf) = (w as f64, h as f64);
    let phase = 0.7 * c as f64;
    let discs = [
        (
            0.5 + 0.3 * (std::f64::consts::TAU * t + phase).cos(),
            0.5 + 0.25 * (std::f64::consts::TAU * t).sin(),
            0.12,
        ),
        (0.3 + 0.4 * t, 0.7 - 0.2 * t, 0.08),
    ];
    for (y, row) in img.data_mut().chunks_exact_mut(3 * w).enumerate() {
        let v = y as f64 / hf;
        for (x, px) in row.chunks_exact_mut(3).enumerate() {
            let u = x as f64 / wf;
            let mut rgb = [
                0.5 + 0.3 * (3.0 * u + phase).sin(),
                0.4 + 0.3 * v,
                0.6 - 0.2 * (u - 0.5).abs(),
            ];
            for (k, &(cx, cy, r)) in discs.iter().enumerate() {
                let d2 = ((u - cx) / r).powi(2) + ((v - cy) / r).powi(2);
                let a = (-d2).exp();
                rgb[k] = rgb[k] * (1.0 - a) + a;
            }
            for i in 0..3 {
                px[i] = rgb[i] as f32;
            }
        }
    }
    img
}

fn ring_pose(c: usize, cams: usize, full: (usize, usize)) -> LlffPose {
    let a = std::f64::consts::TAU * c as f64 / cams as f64;
    let eye = Vec3::new(4.0 * a.cos(), 4.0 * a.sin(), 1.5);
    let back = eye * (1.0 / eye.norm());
    let right = Vec3::new(0.0, 0.0, 1.0).cross(back);
    let right = right * (1.0 / right.norm());
    let up = back.cross(right);
    let c2w = [
        [right.x, up.x, back.x, eye.x],
        [right.y, up.y, back.y, eye.y],
        [right.z, up.z, back.z, eye.z],
        [0.0, 0.0, 0.0, 1.0],
    ];
    let (w, h) = (full.0 as f64, full.1 as f64);
    // N3DV's focal length relative to its width (about 1460 px at 2704).
    LlffPose::from_c2w_opengl(c2w, [h, w, 0.54 * w], [1.0, 20.0])
}

fn generate(a: &Args) -> Result<(), Box<dyn std::error::Error>> {
    let start = Instant::now();
    std::fs::create_dir_all(&a.dir)?;
    let full = (2 * a.width, 2 * a.height);
    let poses: Vec<LlffPose> = (0..a.cams).map(|c| ring_pose(c, a.cams, full)).collect();
    for c in 0..a.cams {
        std::fs::create_dir_all(a.dir.join(format!("cam{c:02}/images")))?;
    }
    let jobs: Vec<(usize, usize)> = (0..a.cams)
        .flat_map(|c| (0..a.frames).map(move |k| (c, k)))
        .collect();
    let write = |&(c, k): &(usize, usize)| -> Result<(), String> {
        let t = k as f64 / (a.frames - 1) as f64;
        let p = a.dir.join(format!("cam{c:02}/images/{k:04}.png"));
        save_png(&frame(c, t, a.width, a.height), &p).map_err(|e| e.to_string())
    };
    #[cfg(feature = "rayon")]
    {
        use rayon::prelude::*;
        jobs.par_iter().try_for_each(write)?;
    }
    #[cfg(not(feature = "rayon"))]
    jobs.iter().try_for_each(write)?;
    // poses_bounds.npy last: a dataset interrupted while generating is regenerated.
    write_poses(&a.dir.join("poses_bounds.npy"), &poses)?;
    eprintln!(
        "generated {} frames in {:.0} s",
        jobs.len(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// `VmHWM` (peak resident set) of this process, in MiB.
fn peak_rss_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

fn du_mib(dir: &Path) -> f64 {
    fn walk(p: &Path) -> u64 {
        std::fs::read_dir(p).map_or(0, |rd| {
            rd.flatten()
                .map(|e| {
                    let p = e.path();
                    if p.is_dir() {
                        walk(&p)
                    } else {
                        e.metadata().map_or(0, |m| m.len())
                    }
                })
                .sum()
        })
    }
    walk(dir) as f64 / (1024.0 * 1024.0)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a = parse_args()?;
    if !a.dir.join("poses_bounds.npy").is_file() {
        generate(&a)?;
    }
    if a.generate_only {
        return Ok(());
    }
    let mut cfg = TrainConfig::fast();
    cfg.data.downscale = 2;
    cfg.data.cache_mb = a.cache_mb;
    cfg.schedule.iterations = a.iters;
    cfg.schedule.warmup_iters = a.iters / 3;
    cfg.schedule.curriculum_iters = 0;
    cfg.schedule.log_every = a.iters.max(1);
    let start = Instant::now();
    let mut ds = load_dataset(&a.dir, &cfg, true)?;
    let idx = supervised_indices(&ds.train, &cfg.data);
    let views = training_frames(&mut ds.train, &idx, cfg.data.cache_bytes())?;
    let cached = ds.decoded_bytes() <= cfg.data.cache_bytes();
    drop(ds);
    let load_s = start.elapsed().as_secs_f64();
    let rss_loaded = peak_rss_mib();
    let mut t = Trainer::new(cfg, views, None)?;
    let start = Instant::now();
    let mut last_l1 = 0.0;
    while !t.finished() {
        last_l1 = t.step()?.losses.l1;
    }
    let secs = start.elapsed().as_secs_f64();
    let s = t.views().cache_stats();
    let mib = |b: usize| b as f64 / (1024.0 * 1024.0);
    let v0 = t.views().cameras()[0];
    let line = serde_json::json!({
        "dir": a.dir.display().to_string(),
        "cams": a.cams,
        "frames": a.frames,
        "width": v0.width,
        "height": v0.height,
        "training_views": t.views().len(),
        "decoded_training_mib": mib(t.views().len() * v0.width * v0.height * 12),
        "files_on_disk_mib": du_mib(&a.dir),
        "cache_mb": a.cache_mb,
        "frames_in_memory": cached,
        "load_seconds": load_s,
        "iterations": t.iteration(),
        "train_seconds": secs,
        "iterations_per_second": t.iteration() as f64 / secs,
        "last_l1": last_l1,
        "gaussians": t.model().len(),
        "cache": {
            "hits": s.hits, "misses": s.misses, "waits": s.waits,
            "prefetched": s.prefetched, "evicted": s.evicted,
            "peak_mib": mib(s.peak_bytes),
        },
        "peak_rss_after_load_mib": rss_loaded,
        "peak_rss_mib": peak_rss_mib(),
        "threads": std::thread::available_parallelism().map_or(1, std::num::NonZero::get),
    });
    println!("{line}");
    Ok(())
}
