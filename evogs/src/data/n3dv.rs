//! Multi-view video in the N3DV / `DyNeRF` layout after frame extraction (the layout
//! 4DGaussians and EvoGS read):
//!
//! ```text
//! SCENE/poses_bounds.npy       float64 [N_cams, 17]
//! SCENE/camXX/images/TTTT.png  frame TTTT of camera XX (cam00: the held-out test camera)
//! SCENE/points3d.ply           optional initial cloud (x y z red green blue)
//! SCENE/times.txt              optional frame times (one per frame index)
//! ```
//!
//! A row of `poses_bounds.npy` is an LLFF 3×5 matrix, row-major, then the near and far
//! bounds. The matrix's columns are the camera's **down**, **right** and **back** axes in
//! world coordinates, its centre, and `(H, W, focal)` in pixels at full resolution. Rows
//! belong to the camera folders in sorted order (`cam00`, `cam01`, ...), as in 4DGaussians.
//!
//! # Cameras
//!
//! OpenCV camera axes are right, down, forward; OpenGL axes (what [`View::c2w`] holds) are
//! right, up, back. From the LLFF columns `[c0, c1, c2] = [down, right, back]`:
//!
//! ```text
//! OpenCV  [right, down, forward] = [ c1,  c0, −c2]
//! OpenGL  [right, up,   back   ] = [ c1, −c0,  c2]      (centre: column 3)
//! ```
//!
//! Both are right-handed rotations when the LLFF frame is (`down × right = back`). The
//! pinhole has square pixels and its principal point at the image centre; the focal length
//! `f` is stored as the horizontal field of view `2·atan(W / 2f)`, which
//! [`PinholeCamera::from_dnerf`](evogs_splat::PinholeCamera::from_dnerf) turns back into
//! `f` (to rounding). Downscaling by `d` divides `f` by `d`.
//!
//! # Frames
//!
//! Every camera folder must hold the same frame files (`images/*.png`, sorted by number when
//! every name is one, else by name); frame `k` of `T` is at time `k / (T − 1)` unless a times
//! file gives the times. The frames are RGB (an alpha channel, if any, is composited onto
//! the background like D-NeRF's): the scene's background is part of the images.
//!
//! Frames may be stored at the resolution `poses_bounds.npy` gives (then `data.downscale`
//! box-downscales them) or already reduced by `data.downscale` (e.g. extracted at half
//! resolution with `downscale = 2`): either way the views are `⌊W/d⌋ × ⌊H/d⌋` with focal
//! `f/d`. Any other size is an error naming the frame.
//!
//! The cameras named in `data.test_cameras` (`cam00` by default) form the test split, those
//! in `data.val_cameras` (none by default) the validation split, every other camera the
//! training split; each split lists its cameras' frames camera by camera, in time order.
//! Only image headers are read unless [`LoadOptions::load_images`] is set, so every frame
//! is checked before training starts without decoding a capture larger than memory.

use super::dataset::{Dataset, LoadOptions, RigCamera, View, decode_views, optional_point_cloud};
use super::error::DataError;
use super::format::DataFormat;
use super::image_io::FrameDecode;
use super::npy::NpyMatrix;
use std::path::{Path, PathBuf};

/// Largest deviation from orthonormality accepted in a pose's rotation (as the camera
/// model's own rigidity check).
const ROTATION_TOL: f64 = 1e-4;

/// One camera of `poses_bounds.npy`.
#[derive(Clone, Debug, PartialEq)]
pub struct LlffPose {
    /// The 3×5 matrix, row-major: columns down, right, back, centre, `(H, W, focal)`.
    pub matrix: [[f64; 5]; 3],
    /// Near and far bounds.
    pub bounds: [f64; 2],
}

impl LlffPose {
    /// Full-resolution image height `H` in pixels.
    #[must_use]
    pub fn height(&self) -> f64 {
        self.matrix[0][4]
    }

    /// Full-resolution image width `W` in pixels.
    #[must_use]
    pub fn width(&self) -> f64 {
        self.matrix[1][4]
    }

    /// Focal length in pixels at full resolution.
    #[must_use]
    pub fn focal(&self) -> f64 {
        self.matrix[2][4]
    }

    /// The camera-to-world matrix in OpenGL axes: columns `[right, up, back, centre] =
    /// [c1, −c0, c2, c3]` of the LLFF matrix (see the module documentation).
    #[must_use]
    pub fn c2w_opengl(&self) -> [[f64; 4]; 4] {
        let m = &self.matrix;
        let mut out = [[0.0; 4]; 4];
        for r in 0..3 {
            out[r] = [m[r][1], -m[r][0], m[r][2], m[r][3]];
        }
        out[3] = [0.0, 0.0, 0.0, 1.0];
        out
    }

    /// A pose from a camera-to-world matrix in OpenGL axes and `(H, W, focal)`; the inverse
    /// of [`c2w_opengl`](Self::c2w_opengl) (for writing datasets).
    #[must_use]
    pub fn from_c2w_opengl(c2w: [[f64; 4]; 4], hwf: [f64; 3], bounds: [f64; 2]) -> Self {
        let mut matrix = [[0.0; 5]; 3];
        for r in 0..3 {
            matrix[r] = [-c2w[r][1], c2w[r][0], c2w[r][2], c2w[r][3], hwf[r]];
        }
        Self { matrix, bounds }
    }

    /// The row of `poses_bounds.npy` (17 values).
    #[must_use]
    pub fn to_row(&self) -> [f64; 17] {
        let mut row = [0.0; 17];
        for r in 0..3 {
            row[r * 5..r * 5 + 5].copy_from_slice(&self.matrix[r]);
        }
        row[15] = self.bounds[0];
        row[16] = self.bounds[1];
        row
    }

    /// Checks a pose: finite, a rotation (orthonormal, right-handed), whole positive image
    /// sizes and a positive focal length.
    ///
    /// # Errors
    /// What is wrong, as a message.
    fn check(&self) -> Result<(), String> {
        let m = &self.matrix;
        if !m
            .iter()
            .flatten()
            .chain(&self.bounds)
            .all(|v| v.is_finite())
        {
            return Err("a non-finite value".into());
        }
        let col = |j: usize| [m[0][j], m[1][j], m[2][j]];
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        for i in 0..3 {
            for j in 0..3 {
                let want = if i == j { 1.0 } else { 0.0 };
                if (dot(col(i), col(j)) - want).abs() > ROTATION_TOL {
                    return Err(
                        "the down, right and back columns are not orthonormal (not an LLFF \
                         rotation)"
                            .into(),
                    );
                }
            }
        }
        let (d, r, b) = (col(0), col(1), col(2));
        let cross = [
            d[1] * r[2] - d[2] * r[1],
            d[2] * r[0] - d[0] * r[2],
            d[0] * r[1] - d[1] * r[0],
        ];
        if dot(cross, b) < 0.0 {
            return Err(
                "the down, right and back columns are left-handed (down × right must be back)"
                    .into(),
            );
        }
        for (name, v) in [("H", self.height()), ("W", self.width())] {
            if v.is_nan() || v < 1.0 {
                return Err(format!("{name} = {v} is not a positive number of pixels"));
            }
            if v >= MAX_IMAGE_SIDE {
                return Err(format!(
                    "{name} = {v} pixels is too large (an image side is below {MAX_IMAGE_SIDE})"
                ));
            }
            if (v - v.round()).abs() >= 1e-6 {
                return Err(format!("{name} = {v} is not a whole number of pixels"));
            }
        }
        if self.focal() <= 0.0 {
            return Err(format!("focal = {} is not positive", self.focal()));
        }
        Ok(())
    }
}

/// The bound on an image side in pixels (a million: far beyond any camera).
const MAX_IMAGE_SIDE: f64 = 1e6;

/// Reads and checks `poses_bounds.npy` ([`parse_poses`]).
///
/// # Errors
/// A malformed file, a shape other than `(N, 17)` with `N ≥ 1`, or a camera whose pose is
/// not finite, not a rotation or has bad `(H, W, focal)`.
pub fn read_poses(path: &Path) -> Result<Vec<LlffPose>, DataError> {
    let m = NpyMatrix::read(path)?;
    poses_from_matrix(&m).map_err(|msg| DataError::Invalid {
        path: path.display().to_string(),
        msg,
    })
}

/// Parses and checks the bytes of a `poses_bounds.npy`: a little-endian f64 matrix of shape
/// `(N, 17)`, `N ≥ 1`, each row a valid LLFF pose with its bounds.
///
/// # Errors
/// What is wrong, as a message.
pub fn parse_poses(bytes: &[u8]) -> Result<Vec<LlffPose>, String> {
    poses_from_matrix(&NpyMatrix::parse(bytes)?)
}

fn poses_from_matrix(m: &NpyMatrix) -> Result<Vec<LlffPose>, String> {
    if m.cols != 17 || m.rows == 0 {
        return Err(format!(
            "shape ({}, {}) is not (N_cams, 17): per camera an LLFF 3x5 pose and the near and \
             far bounds",
            m.rows, m.cols
        ));
    }
    (0..m.rows)
        .map(|i| {
            let row = m.row(i);
            let mut matrix = [[0.0; 5]; 3];
            for r in 0..3 {
                matrix[r].copy_from_slice(&row[r * 5..r * 5 + 5]);
            }
            let pose = LlffPose {
                matrix,
                bounds: [row[15], row[16]],
            };
            pose.check()
                .map_err(|e| format!("camera {i} (row {i}): {e}"))?;
            Ok(pose)
        })
        .collect()
}

/// Writes `poses_bounds.npy` for the poses (tests, tools, generated datasets).
///
/// # Errors
/// I/O failures, naming the file.
pub fn write_poses(path: &Path, poses: &[LlffPose]) -> Result<(), DataError> {
    let m = NpyMatrix {
        rows: poses.len(),
        cols: 17,
        data: poses.iter().flat_map(LlffPose::to_row).collect(),
    };
    m.write(path).map_err(DataError::from)
}

/// The camera folders of `root` (`cam` followed by digits), sorted by number.
fn camera_folders(root: &Path) -> Result<Vec<(String, PathBuf)>, DataError> {
    let entries = std::fs::read_dir(root).map_err(|e| DataError::Invalid {
        path: root.display().to_string(),
        msg: format!("cannot list the folder: {e}"),
    })?;
    let mut cams: Vec<(u64, String, PathBuf)> = Vec::new();
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        let Some(num) = name.strip_prefix("cam") else {
            continue;
        };
        if !e.path().is_dir() || num.is_empty() || !num.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        cams.push((num.parse().unwrap_or(u64::MAX), name, e.path()));
    }
    cams.sort();
    Ok(cams.into_iter().map(|(_, n, p)| (n, p)).collect())
}

/// The PNG frame names of a camera's `images/` folder, in frame order: by number when every
/// stem is a whole number, else by name.
fn frame_names(images: &Path) -> Result<Vec<String>, DataError> {
    if !images.is_dir() {
        return Err(DataError::Missing {
            path: images.display().to_string(),
            what: "the camera's frame folder: camXX/images/TTTT.png",
        });
    }
    let entries = std::fs::read_dir(images).map_err(|e| DataError::Invalid {
        path: images.display().to_string(),
        msg: format!("cannot list the folder: {e}"),
    })?;
    let mut names: Vec<String> = entries
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| {
            Path::new(n)
                .extension()
                .is_some_and(|x| x.eq_ignore_ascii_case("png"))
        })
        .collect();
    let number = |n: &str| -> Option<u64> { Path::new(n).file_stem()?.to_str()?.parse().ok() };
    if names.iter().all(|n| number(n).is_some()) {
        names.sort_by_key(|n| (number(n), n.clone()));
    } else {
        names.sort();
    }
    if names.is_empty() {
        return Err(DataError::Invalid {
            path: images.display().to_string(),
            msg: "no PNG frames".into(),
        });
    }
    Ok(names)
}

/// Frame times: from the times file (explicit, or `times.txt` in the folder), else
/// `k / (T − 1)`.
fn frame_times(root: &Path, opts: &LoadOptions, count: usize) -> Result<Vec<f64>, DataError> {
    let file = match &opts.times_file {
        Some(f) => Some(root.join(f)),
        None => Some(root.join("times.txt")).filter(|p| crate::bounded::present(p)),
    };
    let Some(file) = file else {
        let denom = count.saturating_sub(1).max(1) as f64;
        return Ok((0..count).map(|k| k as f64 / denom).collect());
    };
    let p = file.display().to_string();
    let text =
        crate::bounded::read_text(&file, crate::bounded::METADATA_BYTES, "a frame-times file")?;
    parse_frame_times(&text, count).map_err(|msg| DataError::Invalid { path: p, msg })
}

/// Parses a times file: `count` numbers (whitespace-separated, `#` comments), increasing,
/// in `[0, 1]`, one per frame index.
///
/// # Errors
/// What is wrong, as a message.
pub fn parse_frame_times(text: &str, count: usize) -> Result<Vec<f64>, String> {
    let times: Vec<f64> = text
        .lines()
        .map(|l| l.split('#').next().unwrap_or(""))
        .flat_map(str::split_whitespace)
        .map(|t| {
            t.parse::<f64>()
                .map_err(|_| format!("`{t}` is not a number"))
        })
        .collect::<Result<_, _>>()?;
    if times.len() != count {
        return Err(format!(
            "{} times for {count} frames per camera (one time per frame index)",
            times.len()
        ));
    }
    for (k, &t) in times.iter().enumerate() {
        if !(0.0..=1.0).contains(&t) {
            return Err(format!("time {t} of frame {k} is outside [0, 1]"));
        }
        if k > 0 && t <= times[k - 1] {
            return Err(format!(
                "times must increase: frame {k} at {t} follows {}",
                times[k - 1]
            ));
        }
    }
    Ok(times)
}

/// Every camera holds the reference camera's frame names, no more, no fewer.
fn check_same_frames(cams: &[(String, PathBuf)], frames: &[Vec<String>]) -> Result<(), DataError> {
    let (ref_name, ref_frames) = (&cams[0].0, &frames[0]);
    for ((name, dir), list) in cams.iter().zip(frames).skip(1) {
        if list == ref_frames {
            continue;
        }
        let counts = format!(
            "{name}/images has {} frames, {ref_name}/images has {}",
            list.len(),
            ref_frames.len()
        );
        if let Some(missing) = ref_frames.iter().find(|f| !list.contains(f)) {
            return Err(DataError::Invalid {
                path: dir.join("images").join(missing).display().to_string(),
                msg: format!("missing frame ({counts}; every camera must film every frame)"),
            });
        }
        let extra = list
            .iter()
            .find(|f| !ref_frames.contains(f))
            .unwrap_or(&list[0]);
        return Err(DataError::Invalid {
            path: dir.join("images").join(extra).display().to_string(),
            msg: format!(
                "frame not in {ref_name}/images ({counts}; every camera must film every frame)"
            ),
        });
    }
    Ok(())
}

/// The size every frame of a camera has on disk (all checked), and the factor it decodes
/// with: `d` for full-resolution files, 1 for files already reduced by `d`.
fn camera_frame_size(
    files: &[PathBuf],
    pose: &LlffPose,
    d: usize,
    cam: &str,
    poses_file: &Path,
) -> Result<(usize, usize, usize), DataError> {
    let size = |f: &PathBuf| -> Result<(usize, usize), DataError> {
        let (w, h) = image::image_dimensions(f).map_err(|e| DataError::Invalid {
            path: f.display().to_string(),
            msg: format!("cannot read the image size: {e}"),
        })?;
        Ok((w as usize, h as usize))
    };
    #[cfg(feature = "rayon")]
    let sizes: Vec<_> = {
        use rayon::prelude::*;
        files.par_iter().map(size).collect()
    };
    #[cfg(not(feature = "rayon"))]
    let sizes: Vec<_> = files.iter().map(size).collect();
    let mut first = None;
    for (f, s) in files.iter().zip(sizes) {
        let s = s?;
        match first {
            None => first = Some(s),
            Some(f0) if f0 != s => {
                return Err(DataError::Invalid {
                    path: f.display().to_string(),
                    msg: format!(
                        "image is {}x{}, {cam}'s first frame is {}x{} (frames of a camera must \
                         share one size)",
                        s.0, s.1, f0.0, f0.1
                    ),
                });
            }
            Some(_) => {}
        }
    }
    let (w, h) = first.unwrap_or((0, 0));
    #[allow(
        clippy::cast_possible_truncation,
        reason = "checked whole positive sizes"
    )]
    let (full_w, full_h) = (
        pose.width().round() as usize,
        pose.height().round() as usize,
    );
    if (w, h) == (full_w, full_h) {
        return Ok((w, h, d));
    }
    if d > 1 && (w, h) == (full_w / d, full_h / d) {
        return Ok((w, h, 1));
    }
    let also = if d > 1 {
        format!(
            " (or {}x{}, already reduced by data.downscale = {d})",
            full_w / d,
            full_h / d
        )
    } else {
        String::new()
    };
    let hint = if w > 0 && full_w % w == 0 && full_h % h.max(1) == 0 && full_w / w > 1 {
        format!(
            "; if the frames were extracted at 1/{} resolution, set data.downscale = {}",
            full_w / w,
            full_w / w
        )
    } else {
        String::new()
    };
    Err(DataError::Invalid {
        path: files[0].display().to_string(),
        msg: format!(
            "image is {w}x{h}, {} gives {full_w}x{full_h} for {cam}{also}{hint}",
            poses_file.display()
        ),
    })
}

/// Loads an N3DV dataset folder (see the module documentation).
///
/// # Errors
/// [`DataError`] naming the file: a malformed or wrongly shaped `poses_bounds.npy`, a camera
/// count that differs from its rows, a camera folder without `images/`, a missing or extra
/// frame, a frame of the wrong size, a test or validation camera that is not there, a bad
/// times file, a bad `points3d.ply`, and (when decoding) an undecodable frame.
pub(super) fn load(root: &Path, opts: &LoadOptions) -> Result<Dataset, DataError> {
    let poses_file = root.join("poses_bounds.npy");
    if !crate::bounded::present(&poses_file) {
        return Err(DataError::Missing {
            path: poses_file.display().to_string(),
            what: "camera poses of the N3DV layout",
        });
    }
    let poses = read_poses(&poses_file)?;
    let cams = camera_folders(root)?;
    if cams.len() != poses.len() {
        let names: Vec<&str> = cams.iter().map(|(n, _)| n.as_str()).collect();
        return Err(DataError::Invalid {
            path: poses_file.display().to_string(),
            msg: format!(
                "{} cameras (rows), but the folder has {} camera folders [{}]; rows belong to \
                 the camXX folders in sorted order",
                poses.len(),
                cams.len(),
                names.join(", ")
            ),
        });
    }
    let frames: Vec<Vec<String>> = cams
        .iter()
        .map(|(_, dir)| frame_names(&dir.join("images")))
        .collect::<Result<_, _>>()?;
    check_same_frames(&cams, &frames)?;
    let times = frame_times(root, opts, frames[0].len())?;
    let named = |list: &[String], what: &'static str| -> Result<Vec<usize>, DataError> {
        list.iter()
            .map(|n| {
                cams.iter()
                    .position(|(c, _)| c == n)
                    .ok_or_else(|| DataError::Missing {
                        path: root.join(n).display().to_string(),
                        what,
                    })
            })
            .collect()
    };
    let test_cams = named(
        &opts.test_cameras,
        "the held-out test camera; name another in data.test_cameras",
    )?;
    let val_cams = named(
        &opts.val_cameras,
        "a validation camera named in data.val_cameras",
    )?;
    if let Some(&c) = test_cams.iter().find(|c| val_cams.contains(c)) {
        return Err(DataError::Invalid {
            path: cams[c].1.display().to_string(),
            msg: "named as both a test and a validation camera".into(),
        });
    }
    let d = opts.downscale.max(1);
    let mut ds = Dataset {
        root: root.to_path_buf(),
        format: DataFormat::N3dv,
        train: Vec::new(),
        val: Vec::new(),
        test: Vec::new(),
        future: Vec::new(),
        rig: Vec::with_capacity(cams.len()),
        points: None,
    };
    for (c, ((name, dir), pose)) in cams.iter().zip(&poses).enumerate() {
        let files: Vec<PathBuf> = frames[c]
            .iter()
            .map(|f| dir.join("images").join(f))
            .collect();
        let (w, h, factor) = camera_frame_size(&files, pose, d, name, &poses_file)?;
        let (width, height) = (w / factor, h / factor);
        if width == 0 || height == 0 {
            return Err(DataError::Invalid {
                path: files[0].display().to_string(),
                msg: format!("empty image after downscaling by {factor}"),
            });
        }
        let focal = pose.focal() / d as f64;
        let fov_x = 2.0 * (width as f64 / (2.0 * focal)).atan();
        let c2w = pose.c2w_opengl();
        ds.rig.push(RigCamera {
            name: name.clone(),
            c2w,
            fov_x,
            width,
            height,
            bounds: pose.bounds,
        });
        let decode = FrameDecode {
            background: opts.background,
            downscale: factor,
        };
        let views = files.into_iter().zip(&times).map(|(file, &time)| View {
            file,
            time,
            c2w,
            fov_x,
            width,
            height,
            image: None,
            decode,
        });
        if test_cams.contains(&c) {
            ds.test.extend(views);
        } else if val_cams.contains(&c) {
            ds.val.extend(views);
        } else {
            ds.train.extend(views);
        }
    }
    if ds.train.is_empty() {
        return Err(DataError::Invalid {
            path: root.display().to_string(),
            msg: "every camera is held out (data.test_cameras, data.val_cameras): none left to \
                  train on"
                .into(),
        });
    }
    if opts.load_images {
        decode_views(&mut ds.train)?;
        decode_views(&mut ds.val)?;
        decode_views(&mut ds.test)?;
    }
    ds.points = optional_point_cloud(root)?;
    Ok(ds)
}

#[cfg(test)]
mod tests {
    use super::*;
    use evogs_math::Vec3;
    use evogs_splat::PinholeCamera;

    /// A camera at (0, −5, 1) looking along +y (world z up): right = +x, down = −z,
    /// back = −y. Its LLFF columns are [down, right, back] = [(0,0,−1), (1,0,0), (0,−1,0)].
    fn pose() -> LlffPose {
        LlffPose {
            matrix: [
                [0.0, 1.0, 0.0, 0.0, 60.0],
                [0.0, 0.0, -1.0, -5.0, 80.0],
                [-1.0, 0.0, 0.0, 1.0, 100.0],
            ],
            bounds: [0.5, 20.0],
        }
    }

    #[test]
    fn llff_pose_projects_a_point_as_computed_by_hand() {
        let p = pose();
        let c2w = p.c2w_opengl();
        let fov_x = 2.0 * (80.0_f64 / (2.0 * 100.0)).atan();
        let cam = PinholeCamera::<f64>::from_dnerf(c2w, fov_x, 80, 60).expect("camera");
        // World point X = (1, 0, 1.5). Relative to the centre: (1, 5, 0.5). Camera coordinates
        // (OpenCV: right, down, forward) = (x·right, x·down, x·forward) = (1, −0.5, 5).
        let x = cam.world_to_camera(Vec3::new(1.0, 0.0, 1.5));
        assert!(
            (x - Vec3::new(1.0, -0.5, 5.0)).norm() < 1e-12,
            "camera coordinates {x:?}"
        );
        // Pixel: u = f·x/z + W/2 = 100·0.2 + 40 = 60, v = f·y/z + H/2 = 100·(−0.1) + 30 = 20.
        let (u, v) = (cam.fx * x.x / x.z + cam.cx, cam.fy * x.y / x.z + cam.cy);
        assert!((cam.fx - 100.0).abs() < 1e-9, "focal {}", cam.fx);
        assert!(
            (u - 60.0).abs() < 1e-9 && (v - 20.0).abs() < 1e-9,
            "pixel ({u}, {v})"
        );
        assert!(
            (cam.center() - Vec3::new(0.0, -5.0, 1.0)).norm() < 1e-12,
            "centre"
        );
        // The OpenCV rotation's rows are [c1, c0, −c2] of the LLFF matrix.
        let m = p.matrix;
        for r in 0..3 {
            assert!(
                (cam.rotation.m[0][r] - m[r][1]).abs() < 1e-15
                    && (cam.rotation.m[1][r] - m[r][0]).abs() < 1e-15
                    && (cam.rotation.m[2][r] + m[r][2]).abs() < 1e-15,
                "rotation column {r}"
            );
        }
    }

    #[test]
    fn opengl_round_trip_and_rows() {
        let p = pose();
        let back = LlffPose::from_c2w_opengl(p.c2w_opengl(), [60.0, 80.0, 100.0], p.bounds);
        assert_eq!(back, p, "inverse");
        let row = p.to_row();
        assert_eq!(&row[5..10], &p.matrix[1], "row-major");
        assert_eq!(&row[15..], &p.bounds, "bounds last");
    }

    #[test]
    fn bad_poses_are_named() {
        let mut p = pose();
        assert!(p.check().is_ok(), "valid");
        p.matrix[0][0] = 0.3;
        assert!(p.check().expect_err("skew").contains("orthonormal"), "skew");
        let mut p = pose();
        for r in 0..3 {
            p.matrix[r][2] = -p.matrix[r][2];
        }
        assert!(
            p.check().expect_err("mirror").contains("left-handed"),
            "mirror"
        );
        let mut p = pose();
        p.matrix[1][4] = 80.5;
        assert!(p.check().expect_err("W").contains("W = 80.5"), "W");
        let mut p = pose();
        p.matrix[2][4] = 0.0;
        assert!(p.check().expect_err("focal").contains("focal"), "focal");
        let mut p = pose();
        p.bounds[1] = f64::NAN;
        assert!(p.check().expect_err("nan").contains("non-finite"), "nan");
    }
}
