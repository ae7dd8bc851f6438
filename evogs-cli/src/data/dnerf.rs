//! D-NeRF datasets: `transforms_{train,val,test}.json`, the optional
//! `transforms_future.json`, RGBA PNG frames and an optional `points3d.ply`.
//!
//! Each transforms file holds `camera_angle_x` (horizontal field of view, radians) and
//! `frames[]` with `file_path` (relative to the dataset folder; `.png` appended when there is
//! no extension), `time` and `transform_matrix` (4×4 camera-to-world, OpenGL/Blender axes).
//! Images are composited onto a background (white by default) and optionally box-downscaled.
//! Every problem is reported as one line naming the file ([`DataError`]); nothing panics.

use super::image_io::{downscale, load_png_rgb};
use super::ply::PlyTable;
use evogs_splat::Image;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The splits of a D-NeRF dataset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SplitName {
    /// `transforms_train.json`.
    Train,
    /// `transforms_val.json`.
    Val,
    /// `transforms_test.json`.
    Test,
    /// `transforms_future.json` (optional).
    Future,
}

impl SplitName {
    /// Lowercase name (`train`, `val`, `test`, `future`).
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Train => "train",
            Self::Val => "val",
            Self::Test => "test",
            Self::Future => "future",
        }
    }
}

impl std::str::FromStr for SplitName {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "train" => Ok(Self::Train),
            "val" => Ok(Self::Val),
            "test" => Ok(Self::Test),
            "future" => Ok(Self::Future),
            _ => Err(format!("unknown split `{s}` (train, val, test, future)")),
        }
    }
}

/// Why a dataset could not be loaded: always names the file.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// A required file or folder is missing.
    #[error("{path}: missing ({what})")]
    Missing {
        /// File.
        path: String,
        /// What it should have been.
        what: &'static str,
    },
    /// The JSON does not parse or lacks a field.
    #[error("{path}: malformed JSON: {msg}")]
    Json {
        /// File.
        path: String,
        /// Parser message.
        msg: String,
    },
    /// A value is invalid.
    #[error("{path}: {msg}")]
    Invalid {
        /// File.
        path: String,
        /// What is wrong.
        msg: String,
    },
    /// An image could not be read.
    #[error(transparent)]
    Image(#[from] super::image_io::ImageIoError),
    /// The point cloud could not be read.
    #[error(transparent)]
    Ply(#[from] super::ply::PlyError),
}

/// How to load a dataset.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadOptions {
    /// Background the RGBA frames are composited onto (white by default).
    pub background: [f32; 3],
    /// Integer box-downscale factor (1 = full resolution).
    pub downscale: usize,
    /// Load the images (false: cameras and times only).
    pub load_images: bool,
    /// Splits to load besides `train` (absent optional files are skipped).
    pub splits: Vec<SplitName>,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            background: [1.0, 1.0, 1.0],
            downscale: 1,
            load_images: true,
            splits: vec![SplitName::Val, SplitName::Test, SplitName::Future],
        }
    }
}

/// One view: an image at a time from a camera.
#[derive(Clone, Debug)]
pub struct View {
    /// The image file.
    pub file: PathBuf,
    /// Frame time.
    pub time: f64,
    /// Camera-to-world matrix, OpenGL/Blender axes (as in the file).
    pub c2w: [[f64; 4]; 4],
    /// Horizontal field of view (radians).
    pub fov_x: f64,
    /// Width in pixels (after downscaling).
    pub width: usize,
    /// Height in pixels (after downscaling).
    pub height: usize,
    /// The composited RGB image (`None` when images were not loaded).
    pub image: Option<Image<f32>>,
}

/// An initial point cloud: positions and optional colours in [0, 1].
#[derive(Clone, Debug, Default)]
pub struct PointCloud {
    /// Positions.
    pub positions: Vec<[f32; 3]>,
    /// Colours (same length as positions), if the file has `red`, `green`, `blue`.
    pub colors: Option<Vec<[f32; 3]>>,
}

/// A loaded D-NeRF dataset.
#[derive(Clone, Debug)]
pub struct Dataset {
    /// The dataset folder.
    pub root: PathBuf,
    /// Training views (times checked to lie in [0, 1]).
    pub train: Vec<View>,
    /// Validation views (if loaded and present).
    pub val: Vec<View>,
    /// Test views (if loaded and present).
    pub test: Vec<View>,
    /// Future views (`transforms_future.json`, optional).
    pub future: Vec<View>,
    /// `points3d.ply`, if present.
    pub points: Option<PointCloud>,
}

#[derive(Deserialize)]
struct TransformsFile {
    camera_angle_x: f64,
    frames: Vec<FrameEntry>,
}

#[derive(Deserialize)]
struct FrameEntry {
    file_path: String,
    time: f64,
    transform_matrix: [[f64; 4]; 4],
}

impl Dataset {
    /// Loads a dataset folder.
    ///
    /// # Errors
    /// [`DataError`] naming the file: missing file, malformed JSON, wrong image size,
    /// non-finite matrix, a training time outside [0, 1], unsupported PNG, bad PLY.
    pub fn load(root: &Path, opts: &LoadOptions) -> Result<Self, DataError> {
        if !root.is_dir() {
            return Err(DataError::Missing {
                path: root.display().to_string(),
                what: "dataset folder",
            });
        }
        let mut ds = Self {
            root: root.to_path_buf(),
            train: load_split(root, SplitName::Train, opts)?.ok_or_else(|| DataError::Missing {
                path: root.join("transforms_train.json").display().to_string(),
                what: "training transforms",
            })?,
            val: Vec::new(),
            test: Vec::new(),
            future: Vec::new(),
            points: None,
        };
        for &s in &opts.splits {
            let views = load_split(root, s, opts)?.unwrap_or_default();
            match s {
                SplitName::Train => {}
                SplitName::Val => ds.val = views,
                SplitName::Test => ds.test = views,
                SplitName::Future => ds.future = views,
            }
        }
        let ply = root.join("points3d.ply");
        if ply.is_file() {
            ds.points = Some(read_point_cloud(&ply)?);
        }
        Ok(ds)
    }

    /// The views of a split.
    #[must_use]
    pub fn split(&self, s: SplitName) -> &[View] {
        match s {
            SplitName::Train => &self.train,
            SplitName::Val => &self.val,
            SplitName::Test => &self.test,
            SplitName::Future => &self.future,
        }
    }

    /// The smallest and largest training time.
    #[must_use]
    pub fn train_time_range(&self) -> (f64, f64) {
        self.train
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v.time), b.max(v.time))
            })
    }
}

fn load_split(
    root: &Path,
    split: SplitName,
    opts: &LoadOptions,
) -> Result<Option<Vec<View>>, DataError> {
    let path = root.join(format!("transforms_{}.json", split.as_str()));
    if !path.is_file() {
        return Ok(None);
    }
    let p = path.display().to_string();
    let text = std::fs::read_to_string(&path).map_err(|e| DataError::Invalid {
        path: p.clone(),
        msg: e.to_string(),
    })?;
    let file: TransformsFile = serde_json::from_str(&text).map_err(|e| DataError::Json {
        path: p.clone(),
        msg: e.to_string(),
    })?;
    if !(file.camera_angle_x.is_finite()
        && file.camera_angle_x > 0.0
        && file.camera_angle_x < std::f64::consts::PI)
    {
        return Err(DataError::Invalid {
            path: p,
            msg: format!(
                "camera_angle_x = {} is not a field of view",
                file.camera_angle_x
            ),
        });
    }
    if file.frames.is_empty() {
        return Err(DataError::Invalid {
            path: p,
            msg: "no frames".into(),
        });
    }
    let mut views = Vec::with_capacity(file.frames.len());
    for (i, f) in file.frames.iter().enumerate() {
        if !f.transform_matrix.iter().flatten().all(|v| v.is_finite()) {
            return Err(DataError::Invalid {
                path: p,
                msg: format!("frame {i}: transform_matrix has a non-finite entry"),
            });
        }
        if !f.time.is_finite() || (split == SplitName::Train && !(0.0..=1.0).contains(&f.time)) {
            return Err(DataError::Invalid {
                path: p,
                msg: format!("frame {i}: time {} outside [0, 1]", f.time),
            });
        }
        let mut file_path = root.join(&f.file_path);
        if file_path.extension().is_none() {
            file_path.set_extension("png");
        }
        views.push(View {
            file: file_path,
            time: f.time,
            c2w: f.transform_matrix,
            fov_x: file.camera_angle_x,
            width: 0,
            height: 0,
            image: None,
        });
    }
    load_images(&mut views, opts, &p)?;
    Ok(Some(views))
}

/// Loads (in parallel with rayon) and checks the images: all of one size.
fn load_images(views: &mut [View], opts: &LoadOptions, json: &str) -> Result<(), DataError> {
    let load = |v: &View| -> Result<(usize, usize, Option<Image<f32>>), DataError> {
        if !v.file.is_file() {
            return Err(DataError::Missing {
                path: v.file.display().to_string(),
                what: "image listed in the transforms",
            });
        }
        if !opts.load_images {
            let (w, h) = image::image_dimensions(&v.file).map_err(|e| DataError::Invalid {
                path: v.file.display().to_string(),
                msg: format!("cannot read image size: {e}"),
            })?;
            return Ok((
                w as usize / opts.downscale.max(1),
                h as usize / opts.downscale.max(1),
                None,
            ));
        }
        let img = downscale(&load_png_rgb(&v.file, opts.background)?, opts.downscale);
        Ok((img.width(), img.height(), Some(img)))
    };
    #[cfg(feature = "rayon")]
    let loaded: Vec<_> = {
        use rayon::prelude::*;
        views.par_iter().map(load).collect()
    };
    #[cfg(not(feature = "rayon"))]
    let loaded: Vec<_> = views.iter().map(load).collect();
    let mut size = None;
    for (v, r) in views.iter_mut().zip(loaded) {
        let (w, h, img) = r?;
        match size {
            None => size = Some((w, h)),
            Some(s) if s != (w, h) => {
                return Err(DataError::Invalid {
                    path: v.file.display().to_string(),
                    msg: format!(
                        "image is {w}x{h}, other frames of {json} are {}x{}",
                        s.0, s.1
                    ),
                });
            }
            Some(_) => {}
        }
        if w == 0 || h == 0 {
            return Err(DataError::Invalid {
                path: v.file.display().to_string(),
                msg: "empty image after downscaling".into(),
            });
        }
        v.width = w;
        v.height = h;
        v.image = img;
    }
    Ok(())
}

/// Reads an initial point cloud (`x`, `y`, `z`, optional `red`, `green`, `blue` as 0–255).
///
/// # Errors
/// Unreadable or malformed PLY, missing coordinates, non-finite positions.
pub fn read_point_cloud(path: &Path) -> Result<PointCloud, DataError> {
    let t = PlyTable::read(path)?;
    let p = path.display().to_string();
    let col = |n: &str| {
        t.column(n).ok_or_else(|| DataError::Invalid {
            path: p.clone(),
            msg: format!("no `{n}` property"),
        })
    };
    let (x, y, z) = (col("x")?, col("y")?, col("z")?);
    #[allow(clippy::cast_possible_truncation, reason = "positions stored as f32")]
    let positions: Vec<[f32; 3]> = (0..t.len)
        .map(|i| [x[i] as f32, y[i] as f32, z[i] as f32])
        .collect();
    if let Some(i) = positions
        .iter()
        .position(|p| !p.iter().all(|v| v.is_finite()))
    {
        return Err(DataError::Invalid {
            path: p,
            msg: format!("vertex {i} has a non-finite position"),
        });
    }
    let colors = match (t.column("red"), t.column("green"), t.column("blue")) {
        (Some(r), Some(g), Some(b)) => {
            #[allow(clippy::cast_possible_truncation, reason = "8-bit colours")]
            let c = (0..t.len)
                .map(|i| {
                    [
                        (r[i] / 255.0) as f32,
                        (g[i] / 255.0) as f32,
                        (b[i] / 255.0) as f32,
                    ]
                })
                .collect();
            Some(c)
        }
        _ => None,
    };
    Ok(PointCloud { positions, colors })
}
