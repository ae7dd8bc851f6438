//! `evogs render`: PNG frames at any times (also outside the training range, negative too)
//! from an orbit around the scene, the test cameras, or a multi-view rig's cameras, plus an
//! optional GIF.

use super::Reporter;
use super::paths::RunFolder;
use super::train::{CommandError, load_dataset};
use crate::data::{DataFormat, Dataset, image_io};
use crate::eval::render_frame;
use crate::model::Model;
use crate::run::checkpoint;
use crate::train::views::view_camera;
use evogs_math::{Par, Vec3};
use evogs_splat::{PinholeCamera, Splats};
use std::path::PathBuf;

/// Which cameras the frames use.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CameraPath {
    /// One turn around the scene at the training cameras' mean distance and elevation.
    Orbit,
    /// The test cameras, cycled.
    Test,
    /// A multi-view rig's cameras, cycled (frame `i` from camera `i mod N`).
    Rig,
    /// One camera of a multi-view rig, by folder name (`cam03`).
    Camera(String),
}

impl std::str::FromStr for CameraPath {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "orbit" => Ok(Self::Orbit),
            "test" => Ok(Self::Test),
            "rig" => Ok(Self::Rig),
            _ if s.len() > 3
                && s.starts_with("cam")
                && s.bytes().skip(3).all(|b| b.is_ascii_digit()) =>
            {
                Ok(Self::Camera(s.to_string()))
            }
            _ => Err(format!(
                "unknown camera path `{s}` (orbit, test, rig, or a rig camera such as cam03)"
            )),
        }
    }
}

/// The arguments of `evogs render`.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderArgs {
    /// Run folder.
    pub run: PathBuf,
    /// Output folder for the frames.
    pub out: PathBuf,
    /// `(first time, last time, count)`.
    pub times: (f64, f64, usize),
    /// Camera path.
    pub camera: CameraPath,
    /// Also write `out/render.gif`.
    pub gif: bool,
    /// Dataset folder (default: the one recorded in the run).
    pub data: Option<PathBuf>,
    /// Dataset layout override (default: the run's `data.format`).
    pub format: Option<DataFormat>,
}

/// What was written.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderOutcome {
    /// The PNG frames.
    pub frames: Vec<PathBuf>,
    /// The GIF.
    pub gif: Option<PathBuf>,
}

/// Parses `A:B:N` (N ≥ 1).
///
/// # Errors
/// A malformed specification.
pub fn parse_times(s: &str) -> Result<(f64, f64, usize), String> {
    let p: Vec<&str> = s.split(':').collect();
    let bad = || format!("`{s}` is not A:B:N (e.g. 0:1:30 or -0.5:1.5:60)");
    if p.len() != 3 {
        return Err(bad());
    }
    let a: f64 = p[0].trim().parse().map_err(|_| bad())?;
    let b: f64 = p[1].trim().parse().map_err(|_| bad())?;
    let n: usize = p[2].trim().parse().map_err(|_| bad())?;
    if n == 0 || !a.is_finite() || !b.is_finite() {
        return Err(bad());
    }
    Ok((a, b, n))
}

/// The world's up direction: +z for D-NeRF scenes (Blender worlds); for a multi-view rig the
/// mean of its cameras' up axes (LLFF worlds have no fixed up), +z if they cancel out.
#[must_use]
pub fn world_up(ds: &Dataset) -> Vec3<f64> {
    let z = Vec3::new(0.0, 0.0, 1.0);
    if ds.format != DataFormat::N3dv || ds.rig.is_empty() {
        return z;
    }
    let sum = ds.rig.iter().fold(Vec3::zero(), |s, c| {
        s + Vec3::new(c.c2w[0][1], c.c2w[1][1], c.c2w[2][1])
    });
    let n = sum.norm();
    if n > 1e-6 { sum * (1.0 / n) } else { z }
}

/// Orbit cameras: `n` poses around the centre of the scene about the world's up direction
/// ([`world_up`]), at the training cameras' mean distance and height, with their field of
/// view and image size.
///
/// # Errors
/// No training views, or a degenerate pose.
pub fn orbit_cameras(
    ds: &Dataset,
    center: Vec3<f64>,
    n: usize,
) -> Result<Vec<PinholeCamera<f32>>, String> {
    let up = world_up(ds);
    // A basis of the orbit's plane: x and y for the z-up D-NeRF world, else any
    // orthonormal pair perpendicular to up.
    let (e1, e2) = if up == Vec3::new(0.0, 0.0, 1.0) {
        (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0))
    } else {
        let seed = if up.x.abs() < 0.9 {
            Vec3::new(1.0, 0.0, 0.0)
        } else {
            Vec3::new(0.0, 1.0, 0.0)
        };
        let e1 = seed - up * seed.dot(up);
        let e1 = e1 * (1.0 / e1.norm());
        (e1, up.cross(e1))
    };
    let v0 = ds
        .train
        .first()
        .ok_or("no training views to place the orbit")?;
    let cams: Vec<PinholeCamera<f64>> =
        ds.train.iter().map(view_camera).collect::<Result<_, _>>()?;
    #[allow(clippy::cast_precision_loss, reason = "view counts are small")]
    let m = cams.len() as f64;
    let radius = cams
        .iter()
        .map(|c| (c.center() - center).norm())
        .sum::<f64>()
        / m;
    let height = cams
        .iter()
        .map(|c| (c.center() - center).dot(up))
        .sum::<f64>()
        / m;
    let ring = (radius * radius - height * height).max(1e-6).sqrt();
    (0..n)
        .map(|i| {
            #[allow(clippy::cast_precision_loss, reason = "frame counts are small")]
            let a = std::f64::consts::TAU * i as f64 / n as f64;
            let eye = center + (e1 * (ring * a.cos()) + e2 * (ring * a.sin()) + up * height);
            PinholeCamera::look_at(eye, center, up, v0.fov_x, v0.width, v0.height)
                .map(|c: PinholeCamera<f64>| c.cast())
                .map_err(|e| format!("orbit camera {i}: {e}"))
        })
        .collect()
}

/// The point the orbit turns around: the Gaussians' mean position, on the ground (z = 0) of
/// the z-up D-NeRF world; for a multi-view rig (whose world has no ground) the mean itself.
#[must_use]
pub fn orbit_center(model: &Model<f32>, ds: &Dataset) -> Vec3<f64> {
    let c = &model.canonical.means;
    #[allow(clippy::cast_precision_loss, reason = "counts")]
    let k = c.len().max(1) as f64;
    let m = c.iter().fold(Vec3::zero(), |s, v| s + v.cast::<f64>()) * (1.0 / k);
    if ds.format == DataFormat::N3dv {
        m
    } else {
        Vec3::new(m.x, m.y, 0.0)
    }
}

/// The cameras of a multi-view rig, by name or all of them.
///
/// # Errors
/// A dataset without a rig, or no camera of that name.
fn rig_cameras(ds: &Dataset, name: Option<&str>) -> Result<Vec<PinholeCamera<f32>>, String> {
    if ds.rig.is_empty() {
        return Err(format!(
            "{}: the dataset has no camera rig ({} layout); use --camera orbit or test",
            ds.root.display(),
            ds.format
        ));
    }
    let picked: Vec<_> = ds
        .rig
        .iter()
        .filter(|c| name.is_none_or(|n| c.name == n))
        .collect();
    if picked.is_empty() {
        let names: Vec<&str> = ds.rig.iter().map(|c| c.name.as_str()).collect();
        return Err(format!(
            "{}: no rig camera `{}` (the rig has {})",
            ds.root.display(),
            name.unwrap_or_default(),
            names.join(", ")
        ));
    }
    picked
        .into_iter()
        .map(|c| {
            PinholeCamera::from_dnerf(c.c2w, c.fov_x, c.width, c.height)
                .map_err(|e| format!("{}: bad camera: {e}", c.name))
        })
        .collect()
}

/// The cameras of `count` frames along `path`: an orbit around the model's centre
/// ([`orbit_center`], [`orbit_cameras`]), the test cameras cycled, a rig's cameras cycled, or
/// one rig camera.
///
/// # Errors
/// No training views to place the orbit, no test cameras, no rig or rig camera of that
/// name, or an invalid camera.
pub fn path_cameras(
    path: &CameraPath,
    ds: &Dataset,
    model: &Model<f32>,
    count: usize,
) -> Result<Vec<PinholeCamera<f32>>, CommandError> {
    match path {
        CameraPath::Orbit => {
            orbit_cameras(ds, orbit_center(model, ds), count).map_err(CommandError)
        }
        CameraPath::Rig | CameraPath::Camera(_) => {
            let name = match path {
                CameraPath::Camera(n) => Some(n.as_str()),
                _ => None,
            };
            let rig = rig_cameras(ds, name).map_err(CommandError)?;
            Ok((0..count).map(|i| rig[i % rig.len()]).collect())
        }
        CameraPath::Test => {
            let t: Vec<PinholeCamera<f32>> = ds
                .test
                .iter()
                .map(view_camera)
                .collect::<Result<_, _>>()
                .map_err(CommandError)?;
            if t.is_empty() {
                return Err(CommandError(
                    "the dataset has no test cameras (use --camera orbit)".into(),
                ));
            }
            Ok((0..count).map(|i| t[i % t.len()]).collect())
        }
    }
}

/// Renders the frames (using an already loaded model and dataset when given).
///
/// # Errors
/// Unreadable run or data, unwritable output.
pub fn render_sequence(
    args: &RenderArgs,
    loaded: Option<(&mut Model<f32>, &Dataset)>,
    rep: &mut dyn Reporter,
) -> Result<RenderOutcome, CommandError> {
    let mut own;
    let (model, ds): (&mut Model<f32>, &Dataset) = match loaded {
        Some(x) => x,
        None => {
            let run = RunFolder::new(&args.run);
            let l =
                checkpoint::load_model(&run.checkpoint()).map_err(CommandError::from_display)?;
            let dir = match &args.data {
                Some(d) => d.clone(),
                None => run.data_dir().map_err(CommandError)?,
            };
            let mut cfg = l.cfg.clone();
            if let Some(f) = args.format {
                cfg.data.format = f;
            }
            let ds = load_dataset(&dir, &cfg, false)?;
            own = (l.model, ds);
            (&mut own.0, &own.1)
        }
    };
    let background = [1.0, 1.0, 1.0];
    let (a, b, n) = args.times;
    for t in [a, b] {
        model
            .check_time(t)
            .map_err(|e| CommandError(format!("--times: {e}")))?;
    }
    let cams = path_cameras(&args.camera, ds, model, n)?;
    std::fs::create_dir_all(&args.out)
        .map_err(|e| CommandError(format!("{}: cannot create: {e}", args.out.display())))?;
    rep.start("render", n as u64);
    let mut out = RenderOutcome::default();
    let mut frames = Vec::with_capacity(n);
    let mut scratch = Splats::default();
    for (i, cam) in cams.iter().enumerate() {
        #[allow(clippy::cast_precision_loss, reason = "frame counts are small")]
        let t = if n == 1 {
            a
        } else {
            a + (b - a) * i as f64 / (n - 1) as f64
        };
        let img = render_frame(model, cam, t, background, Par::best(), &mut scratch);
        let p = args.out.join(format!("frame_{i:04}.png"));
        image_io::save_png(&img, &p).map_err(CommandError::from_display)?;
        out.frames.push(p);
        frames.push(img);
        rep.progress(i as u64 + 1, &format!("t = {t:.3}"));
    }
    rep.finish();
    if args.gif {
        let p = args.out.join("render.gif");
        image_io::save_gif(&frames, 80, &p).map_err(CommandError::from_display)?;
        out.gif = Some(p);
    }
    Ok(out)
}
