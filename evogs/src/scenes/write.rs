//! Renders a built scene with evogs's tiled rasterizer and writes it in the D-NeRF layout:
//! `transforms_{train,val,test,future}.json`, RGBA PNG frames, a motion mask
//! `X_motion.png` beside every frame `X.png`, `points3d.ply` and `motion.json`.

use super::build::BuiltScene;
use super::rig::{FOV_X, random_c2w, ring_c2w};
use crate::atomic::{AtomicFile, write_atomic_named};
use crate::data::ply::PlyTable;
use crate::model::render_options;
use evogs_math::Par;
use evogs_math::rng::SplitMix64;
use evogs_splat::{PinholeCamera, Render, Splats, TiledRasterizer, render_tiled};
use serde::Serialize;
use std::path::Path;

/// Alpha of the moving bodies above which a pixel is in the motion mask.
pub const MASK_ALPHA: f32 = 0.05;
/// The suffix of a frame's motion mask (`X.png` → `X_motion.png`).
pub const MASK_SUFFIX: &str = "_motion";

/// How the cameras are laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    /// One random camera per time on the upper hemisphere.
    Monocular,
    /// A fixed ring of cameras, every camera at every training time; one camera is held out
    /// for the test, validation and future splits.
    Multiview,
}

impl Variant {
    /// Folder name (`monocular`, `multiview`).
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Monocular => "monocular",
            Self::Multiview => "multiview",
        }
    }
}

/// Frame counts and image size of a generated scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layout {
    /// Image width and height (pixels).
    pub size: usize,
    /// Training times in `[0, 1]` (monocular: one view each).
    pub train_times: usize,
    /// Test times (between the training times).
    pub test_times: usize,
    /// Validation times (between the training times).
    pub val_times: usize,
    /// Future times in `(1, 1.3]`.
    pub future_times: usize,
    /// Cameras of the multi-view ring (the last one is held out).
    pub ring: usize,
    /// Training times of the multi-view variant.
    pub ring_times: usize,
}

impl Default for Layout {
    fn default() -> Self {
        Self {
            size: 128,
            train_times: 60,
            test_times: 20,
            val_times: 10,
            future_times: 12,
            ring: 6,
            ring_times: 30,
        }
    }
}

impl Layout {
    /// Frames of every split together for `variant`.
    #[must_use]
    pub const fn frame_count(&self, variant: Variant) -> usize {
        let held_out = self.val_times + self.test_times + self.future_times;
        match variant {
            Variant::Monocular => self.train_times + held_out,
            Variant::Multiview => self.ring.saturating_sub(1) * self.ring_times + held_out,
        }
    }
}

/// One frame to render.
#[derive(Clone, Debug, PartialEq, Serialize)]
struct Frame {
    file_path: String,
    time: f64,
    transform_matrix: [[f64; 4]; 4],
}

#[derive(Serialize)]
struct Transforms<'a> {
    camera_angle_x: f64,
    frames: &'a [Frame],
}

fn grid(n: usize) -> impl Iterator<Item = f64> {
    (0..n).map(move |i| {
        if n == 1 {
            0.0
        } else {
            i as f64 / (n - 1) as f64
        }
    })
}

fn between(n: usize) -> impl Iterator<Item = f64> {
    // Midway between `n + 1` grid times, offset so they avoid the training grid.
    (0..n).map(move |i| (i as f64 + 0.5) / n as f64)
}

fn future(n: usize) -> impl Iterator<Item = f64> {
    (0..n).map(move |i| 1.0 + 0.3 * (i as f64 + 1.0) / n as f64)
}

/// The frames of every split (`train`, `val`, `test`, `future`).
fn frames(variant: Variant, layout: &Layout, seed: u64) -> Vec<(&'static str, Vec<Frame>)> {
    let mut rng = SplitMix64::new(seed ^ 0x5eed_ca3e_a5a5_0001);
    let split = |name: &'static str, times: Vec<f64>, rng: &mut SplitMix64| -> Vec<Frame> {
        let mut out = Vec::new();
        for (i, t) in times.into_iter().enumerate() {
            match variant {
                Variant::Monocular => out.push(Frame {
                    file_path: format!("{name}/r_{i:03}"),
                    time: t,
                    transform_matrix: random_c2w(rng),
                }),
                Variant::Multiview if name == "train" => {
                    for c in 0..layout.ring - 1 {
                        out.push(Frame {
                            file_path: format!("{name}/c{c}_{i:03}"),
                            time: t,
                            transform_matrix: ring_c2w(c, layout.ring),
                        });
                    }
                }
                Variant::Multiview => {
                    let c = layout.ring - 1;
                    out.push(Frame {
                        file_path: format!("{name}/c{c}_{i:03}"),
                        time: t,
                        transform_matrix: ring_c2w(c, layout.ring),
                    });
                }
            }
        }
        out
    };
    let train = match variant {
        Variant::Monocular => grid(layout.train_times).collect(),
        Variant::Multiview => grid(layout.ring_times).collect(),
    };
    vec![
        ("train", split("train", train, &mut rng)),
        (
            "val",
            split("val", between(layout.val_times).collect(), &mut rng),
        ),
        (
            "test",
            split("test", between(layout.test_times).collect(), &mut rng),
        ),
        (
            "future",
            split("future", future(layout.future_times).collect(), &mut rng),
        ),
    ]
}

/// What [`write_scene`] wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Written {
    /// Frames per split (`train`, `val`, `test`, `future`).
    pub frames: Vec<(&'static str, usize)>,
    /// Gaussians of the scene.
    pub gaussians: usize,
}

fn rgba8(r: &Render<f32>) -> Vec<u8> {
    let q = |v: f32| -> u8 {
        #[allow(clippy::cast_possible_truncation, reason = "clamped to [0, 255]")]
        let b = (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        b
    };
    let rgb = r.raster.rgb.data();
    let mut out = Vec::with_capacity(r.raster.alpha.len() * 4);
    for (i, &a) in r.raster.alpha.iter().enumerate() {
        // The render is premultiplied (black background): store straight alpha.
        let inv = if a > 1e-6 { 1.0 / a } else { 0.0 };
        for c in 0..3 {
            out.push(q(rgb[3 * i + c] * inv));
        }
        out.push(q(a));
    }
    out
}

fn save_png(
    path: &Path,
    w: usize,
    h: usize,
    bytes: &[u8],
    color: image::ExtendedColorType,
) -> Result<(), String> {
    use image::ImageEncoder as _;
    let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
    let mut file = AtomicFile::create(path).map_err(|e| err(&e))?;
    let (w, h) = (
        u32::try_from(w).map_err(|e| err(&e))?,
        u32::try_from(h).map_err(|e| err(&e))?,
    );
    image::codecs::png::PngEncoder::new(&mut file)
        .write_image(bytes, w, h, color)
        .map_err(|e| err(&e))?;
    file.commit().map_err(|e| err(&e))
}

/// Renders `scene` as `variant` and writes it into `dir` (created), with `motion.json`
/// beside. Deterministic for the scene's seed.
///
/// # Errors
/// I/O failures, naming the file.
pub fn write_scene(
    scene: &BuiltScene,
    variant: Variant,
    layout: &Layout,
    dir: &Path,
    par: Par,
    mut progress: impl FnMut(usize, usize),
) -> Result<Written, String> {
    let splits = frames(variant, layout, scene.seed);
    for (name, _) in &splits {
        std::fs::create_dir_all(dir.join(name))
            .map_err(|e| format!("{}: cannot create: {e}", dir.join(name).display()))?;
    }
    let opts = render_options::<f32>([0.0; 3], 0, par);
    let mut rast = TiledRasterizer::new();
    let total: usize = splits.iter().map(|(_, f)| f.len()).sum();
    let mut done = 0;
    let mut counts = Vec::new();
    let (size, mut all, mut moving): (usize, Splats<f32>, Splats<f32>) =
        (layout.size, Splats::new(0), Splats::new(0));
    for (name, frames) in &splits {
        for f in frames {
            all.clone_from(&scene.splats_at(f.time, false).cast());
            moving.clone_from(&scene.splats_at(f.time, true).cast());
            let cam = PinholeCamera::<f32>::from_dnerf(f.transform_matrix, FOV_X, size, size)
                .map_err(|e| format!("{}: bad camera: {e}", f.file_path))?;
            let img = render_tiled(&all, &cam, &opts, &mut rast);
            save_png(
                &dir.join(format!("{}.png", f.file_path)),
                size,
                size,
                &rgba8(&img),
                image::ExtendedColorType::Rgba8,
            )?;
            let m = render_tiled(&moving, &cam, &opts, &mut rast);
            let mask: Vec<u8> = m
                .raster
                .alpha
                .iter()
                .map(|&a| if a > MASK_ALPHA { 255 } else { 0 })
                .collect();
            save_png(
                &dir.join(format!("{}{MASK_SUFFIX}.png", f.file_path)),
                size,
                size,
                &mask,
                image::ExtendedColorType::L8,
            )?;
            done += 1;
            progress(done, total);
        }
        let text = serde_json::to_string_pretty(&Transforms {
            camera_angle_x: FOV_X,
            frames,
        })
        .map_err(|e| e.to_string())?;
        write_atomic_named(
            &dir.join(format!("transforms_{name}.json")),
            text.as_bytes(),
        )?;
        counts.push((*name, frames.len()));
    }
    write_points(scene, &dir.join("points3d.ply"))?;
    let gt = serde_json::to_string(&scene.ground_truth()).map_err(|e| e.to_string())?;
    write_atomic_named(&dir.join("motion.json"), gt.as_bytes())?;
    Ok(Written {
        frames: counts,
        gaussians: scene.len(),
    })
}

/// `points3d.ply`: the Gaussians' centres at `t = 0` with their colours (0–255).
fn write_points(scene: &BuiltScene, path: &Path) -> Result<(), String> {
    let s = scene.splats_at(0.0, false);
    let mut columns: Vec<Vec<f64>> = (0..6).map(|_| Vec::with_capacity(s.len())).collect();
    for (i, m) in s.means.iter().enumerate() {
        columns[0].push(m.x);
        columns[1].push(m.y);
        columns[2].push(m.z);
        let dc = s.sh_coeffs(i)[0];
        for c in 0..3 {
            let v = (dc[c] * evogs_math::sh::SH_C0 + evogs_splat::SH_OFFSET).clamp(0.0, 1.0);
            columns[3 + c].push((v * 255.0).round());
        }
    }
    let table = PlyTable {
        names: ["x", "y", "z", "red", "green", "blue"]
            .map(String::from)
            .to_vec(),
        columns,
        len: s.len(),
    };
    table
        .write_binary(path)
        .map_err(|e| format!("{}: {e}", path.display()))
}
