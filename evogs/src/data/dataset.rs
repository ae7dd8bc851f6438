//! A loaded dataset, whatever its layout: views (an image file at a time from a camera)
//! grouped into splits, the fixed rig of a multi-view capture, an optional initial point
//! cloud. The layouts are read by [`super::dnerf`] and [`super::n3dv`].
//!
//! Images are decoded when the dataset is loaded ([`LoadOptions::load_images`], or later with
//! [`Dataset::decode_images`]) or on demand ([`View::decode_image`]), so a capture larger than
//! memory can be loaded as cameras and times only and its frames decoded as they are used
//! ([`super::frame_cache`]).

use super::error::DataError;
use super::format::DataFormat;
use super::image_io::FrameDecode;
use super::ply::PlyTable;
use evogs_splat::Image;
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// The splits of a dataset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SplitName {
    /// Training views (`transforms_train.json`; the non-held-out cameras of a rig).
    Train,
    /// Validation views (`transforms_val.json`; a rig's `data.val_cameras`).
    Val,
    /// Test views (`transforms_test.json`; a rig's `data.test_cameras`, `cam00` by default).
    Test,
    /// `transforms_future.json` (optional; none for a rig).
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

/// How to load a dataset.
#[derive(Clone, Debug, PartialEq)]
pub struct LoadOptions {
    /// Background the RGBA frames are composited onto (white by default).
    pub background: [f32; 3],
    /// Integer box-downscale factor (1 = full resolution).
    pub downscale: usize,
    /// Decode the images now (false: cameras, times and image sizes only; the images are
    /// decoded on demand by [`View::decode_image`]).
    pub load_images: bool,
    /// D-NeRF splits to load besides `train` (absent optional files are skipped).
    pub splits: Vec<SplitName>,
    /// The layout ([`DataFormat::Auto`]: recognised from the folder).
    pub format: DataFormat,
    /// Multi-view: the cameras held out as the test split (`cam00` by default, as in N3DV).
    pub test_cameras: Vec<String>,
    /// Multi-view: the cameras held out as the validation split (none by default).
    pub val_cameras: Vec<String>,
    /// Multi-view: a file of frame times (one per frame index, relative paths from the
    /// dataset folder). `None`: the folder's `times.txt` if present, else `k / (T − 1)`.
    pub times_file: Option<PathBuf>,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            background: [1.0, 1.0, 1.0],
            downscale: 1,
            load_images: true,
            splits: vec![SplitName::Val, SplitName::Test, SplitName::Future],
            format: DataFormat::Auto,
            test_cameras: vec!["cam00".into()],
            val_cameras: Vec::new(),
            times_file: None,
        }
    }
}

impl LoadOptions {
    /// How this dataset's frames decode at the requested downscale.
    #[must_use]
    pub fn frame_decode(&self) -> FrameDecode {
        FrameDecode {
            background: self.background,
            downscale: self.downscale.max(1),
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
    /// Camera-to-world matrix, OpenGL/Blender axes (x right, y up, looking along −z). A
    /// pinhole camera with square pixels and the principal point at the image centre.
    pub c2w: [[f64; 4]; 4],
    /// Horizontal field of view (radians).
    pub fov_x: f64,
    /// Width in pixels (after downscaling).
    pub width: usize,
    /// Height in pixels (after downscaling).
    pub height: usize,
    /// The decoded RGB image (`None` when images were not loaded: see
    /// [`decode_image`](Self::decode_image)).
    pub image: Option<Image<f32>>,
    /// How the file decodes to the image.
    pub decode: FrameDecode,
}

impl View {
    /// The view's camera, in any precision.
    ///
    /// # Errors
    /// A non-finite or non-rigid camera matrix (named by the view's file).
    pub fn camera<T: evogs_math::Real>(&self) -> Result<evogs_splat::PinholeCamera<T>, String> {
        evogs_splat::PinholeCamera::from_dnerf(self.c2w, self.fov_x, self.width, self.height)
            .map_err(|e| format!("{}: bad camera: {e}", self.file.display()))
    }

    /// Bytes the decoded image takes (RGB f32).
    #[must_use]
    pub fn decoded_bytes(&self) -> usize {
        self.width * self.height * 3 * std::mem::size_of::<f32>()
    }

    /// Decodes the image file (whether or not [`image`](Self::image) is loaded).
    ///
    /// # Errors
    /// An unreadable or unsupported file, or an image whose size is not the view's (the file
    /// changed since the dataset was loaded).
    pub fn decode_image(&self) -> Result<Image<f32>, DataError> {
        let img = self.decode.decode(&self.file)?;
        if (img.width(), img.height()) != (self.width, self.height) {
            return Err(DataError::Invalid {
                path: self.file.display().to_string(),
                msg: format!(
                    "decodes to {}x{}, the dataset expects {}x{} (did the file change since it \
                     was loaded?)",
                    img.width(),
                    img.height(),
                    self.width,
                    self.height
                ),
            });
        }
        Ok(img)
    }

    /// The loaded image, or the file decoded now.
    ///
    /// # Errors
    /// As [`decode_image`](Self::decode_image).
    pub fn image_or_decode(&self) -> Result<Cow<'_, Image<f32>>, DataError> {
        match &self.image {
            Some(img) => Ok(Cow::Borrowed(img)),
            None => self.decode_image().map(Cow::Owned),
        }
    }
}

/// A camera of a fixed multi-view rig (N3DV): every frame of its folder shares it.
#[derive(Clone, Debug, PartialEq)]
pub struct RigCamera {
    /// The camera folder's name (`cam00`, ...).
    pub name: String,
    /// Camera-to-world matrix, OpenGL/Blender axes (as [`View::c2w`]).
    pub c2w: [[f64; 4]; 4],
    /// Horizontal field of view (radians).
    pub fov_x: f64,
    /// Width in pixels (after downscaling).
    pub width: usize,
    /// Height in pixels (after downscaling).
    pub height: usize,
    /// Near and far scene bounds from `poses_bounds.npy` (informative; not used to clip).
    pub bounds: [f64; 2],
}

/// An initial point cloud: positions and optional colours in [0, 1].
#[derive(Clone, Debug, Default)]
pub struct PointCloud {
    /// Positions.
    pub positions: Vec<[f32; 3]>,
    /// Colours (same length as positions), if the file has `red`, `green`, `blue`.
    pub colors: Option<Vec<[f32; 3]>>,
}

/// A loaded dataset.
#[derive(Clone, Debug)]
pub struct Dataset {
    /// The dataset folder.
    pub root: PathBuf,
    /// The layout it was read as (never [`DataFormat::Auto`]).
    pub format: DataFormat,
    /// Training views (times checked to lie in [0, 1]).
    pub train: Vec<View>,
    /// Validation views (if loaded and present).
    pub val: Vec<View>,
    /// Test views (if loaded and present).
    pub test: Vec<View>,
    /// Future views (`transforms_future.json`, optional).
    pub future: Vec<View>,
    /// The cameras of a fixed rig, in folder order (empty for D-NeRF).
    pub rig: Vec<RigCamera>,
    /// `points3d.ply`, if present.
    pub points: Option<PointCloud>,
}

impl Dataset {
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

    /// Every view of every split.
    pub fn all_views(&self) -> impl Iterator<Item = &View> {
        self.train
            .iter()
            .chain(&self.val)
            .chain(&self.test)
            .chain(&self.future)
    }

    /// Bytes the decoded images of every split take (RGB f32).
    #[must_use]
    pub fn decoded_bytes(&self) -> usize {
        self.all_views().map(View::decoded_bytes).sum()
    }

    /// Decodes every view's image that is not loaded yet (in parallel with rayon).
    ///
    /// # Errors
    /// The first view (in split order) whose file cannot be decoded.
    pub fn decode_images(&mut self) -> Result<(), DataError> {
        for split in [
            &mut self.train,
            &mut self.val,
            &mut self.test,
            &mut self.future,
        ] {
            decode_views(split)?;
        }
        Ok(())
    }
}

/// Decodes the views without an image (in parallel with rayon) and checks their sizes.
///
/// # Errors
/// The first view (in order) whose file cannot be decoded or has the wrong size.
pub fn decode_views(views: &mut [View]) -> Result<(), DataError> {
    let decode = |v: &View| -> Result<Option<Image<f32>>, DataError> {
        if v.image.is_some() {
            return Ok(None);
        }
        v.decode_image().map(Some)
    };
    #[cfg(feature = "rayon")]
    let decoded: Vec<_> = {
        use rayon::prelude::*;
        views.par_iter().map(decode).collect()
    };
    #[cfg(not(feature = "rayon"))]
    let decoded: Vec<_> = views.iter().map(decode).collect();
    for (v, d) in views.iter_mut().zip(decoded) {
        if let Some(img) = d? {
            v.image = Some(img);
        }
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

/// `points3d.ply` of `root`, if present.
///
/// # Errors
/// As [`read_point_cloud`].
pub fn optional_point_cloud(root: &Path) -> Result<Option<PointCloud>, DataError> {
    let ply = root.join("points3d.ply");
    // Present as any node: one that is not a regular file is refused by its reader.
    if crate::bounded::present(&ply) {
        read_point_cloud(&ply).map(Some)
    } else {
        Ok(None)
    }
}
