//! D-NeRF datasets: `transforms_{train,val,test}.json`, the optional
//! `transforms_future.json`, RGBA PNG frames and an optional `points3d.ply`.
//!
//! Each transforms file holds `camera_angle_x` (horizontal field of view, radians) and
//! `frames[]` with `file_path` (relative to the dataset folder; `.png` appended when there is
//! no extension), `time` and `transform_matrix` (4×4 camera-to-world, OpenGL/Blender axes).
//! Images are composited onto a background (white by default) and optionally box-downscaled.
//! Every problem is reported as one line naming the file ([`DataError`]); nothing panics.

use super::dataset::{Dataset, LoadOptions, SplitName, View, optional_point_cloud};
use super::error::DataError;
use super::format::DataFormat;
use crate::bounded;
use evogs_splat::{Image, PinholeCamera};
use serde::Deserialize;
use std::path::Path;

/// The narrowest and widest horizontal fields of view accepted (radians): about 0.06° to
/// 179.94°.
const MIN_FOV: f64 = 1e-3;
const MAX_FOV: f64 = std::f64::consts::PI - 1e-3;
/// The largest camera coordinate accepted (scenes are metres to kilometres across).
const MAX_COORDINATE: f64 = 1e6;

/// A transforms file as read and checked by [`parse_transforms`].
#[derive(Clone, Debug, Deserialize, PartialEq)]
pub struct TransformsFile {
    /// Horizontal field of view, radians.
    pub camera_angle_x: f64,
    /// The frames (at least one).
    pub frames: Vec<FrameEntry>,
}

/// One frame of a transforms file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
pub struct FrameEntry {
    /// Image path relative to the dataset folder, usually without the `.png`.
    pub file_path: String,
    /// Frame time.
    pub time: f64,
    /// Camera-to-world matrix (Blender/OpenGL axes), rigid.
    pub transform_matrix: [[f64; 4]; 4],
}

/// Parses and checks the text of a `transforms_*.json`: the JSON shape (errors name the key,
/// e.g. `frames[2].time`), a field of view in `[1e-3, π − 1e-3]`, at least one frame, every
/// matrix finite, within ±1e6 and a rigid camera pose, every time finite and, on the
/// training split, in `[0, 1]`.
///
/// # Errors
/// The first problem, as a message naming the key.
pub fn parse_transforms(text: &str, split: SplitName) -> Result<TransformsFile, String> {
    let de = &mut serde_json::Deserializer::from_str(text);
    let file: TransformsFile = serde_path_to_error::deserialize(de).map_err(|e| {
        let at = e.path().to_string();
        if at == "." {
            format!("malformed JSON: {}", e.inner())
        } else {
            format!("malformed JSON at {at}: {}", e.inner())
        }
    })?;
    if !(file.camera_angle_x.is_finite() && (MIN_FOV..=MAX_FOV).contains(&file.camera_angle_x)) {
        return Err(format!(
            "camera_angle_x = {} is not a field of view (radians in [{MIN_FOV}, π − {MIN_FOV}])",
            file.camera_angle_x
        ));
    }
    if file.frames.is_empty() {
        return Err("no frames".into());
    }
    for (i, f) in file.frames.iter().enumerate() {
        if f.file_path.trim().is_empty() {
            return Err(format!(
                "frames[{i}].file_path is empty (it names the frame's image, relative to the \
                 dataset folder)"
            ));
        }
        let last = f.file_path.rsplit(['/', '\\']).next().unwrap_or_default();
        if matches!(last, "" | "." | "..") {
            return Err(format!(
                "frames[{i}].file_path `{}` names a folder, not the frame's image",
                f.file_path
            ));
        }
        if !f
            .transform_matrix
            .iter()
            .flatten()
            .all(|v| v.is_finite() && v.abs() <= MAX_COORDINATE)
        {
            return Err(format!(
                "frames[{i}].transform_matrix has an entry that is not finite or beyond \
                 ±{MAX_COORDINATE:e}"
            ));
        }
        if let Err(e) =
            PinholeCamera::<f64>::from_dnerf(f.transform_matrix, file.camera_angle_x, 1, 1)
        {
            return Err(format!(
                "frames[{i}].transform_matrix is not a camera pose: {e}"
            ));
        }
        if !f.time.is_finite() || (split == SplitName::Train && !(0.0..=1.0).contains(&f.time)) {
            return Err(format!("frames[{i}].time = {} is outside [0, 1]", f.time));
        }
    }
    Ok(file)
}

/// Loads a D-NeRF dataset folder.
///
/// # Errors
/// [`DataError`] naming the file: missing file, malformed JSON, wrong image size,
/// non-finite matrix, a training time outside [0, 1], unsupported PNG, bad PLY.
pub(super) fn load(root: &Path, opts: &LoadOptions) -> Result<Dataset, DataError> {
    if !root.is_dir() {
        return Err(DataError::Missing {
            path: root.display().to_string(),
            what: "dataset folder",
        });
    }
    let mut ds = Dataset {
        root: root.to_path_buf(),
        format: DataFormat::Dnerf,
        train: load_split(root, SplitName::Train, opts)?.ok_or_else(|| DataError::Missing {
            path: root.join("transforms_train.json").display().to_string(),
            what: "training transforms",
        })?,
        val: Vec::new(),
        test: Vec::new(),
        future: Vec::new(),
        rig: Vec::new(),
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
    ds.points = optional_point_cloud(root)?;
    Ok(ds)
}

fn load_split(
    root: &Path,
    split: SplitName,
    opts: &LoadOptions,
) -> Result<Option<Vec<View>>, DataError> {
    let path = root.join(format!("transforms_{}.json", split.as_str()));
    // Absent: no such split. Present as anything but a regular file: an error that says so.
    if !bounded::present(&path) {
        return Ok(None);
    }
    let p = path.display().to_string();
    let text = bounded::read_text(&path, bounded::METADATA_BYTES, "a transforms file")?;
    let file = parse_transforms(&text, split).map_err(|msg| DataError::Invalid {
        path: p.clone(),
        msg,
    })?;
    let mut views = Vec::with_capacity(file.frames.len());
    for f in &file.frames {
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
            decode: opts.frame_decode(),
        });
    }
    load_images(&mut views, opts, &p)?;
    Ok(Some(views))
}

/// Loads (in parallel with rayon) and checks the images: all of one size.
fn load_images(views: &mut [View], opts: &LoadOptions, json: &str) -> Result<(), DataError> {
    let load = |v: &View| -> Result<(usize, usize, Option<Image<f32>>), DataError> {
        if !bounded::present(&v.file) {
            return Err(DataError::Missing {
                path: v.file.display().to_string(),
                what: "image listed in the transforms",
            });
        }
        if !opts.load_images {
            bounded::regular_file_size(&v.file, "a frame")?;
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
        let img = v.decode.decode(&v.file)?;
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
