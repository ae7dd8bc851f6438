//! `evogs render`: PNG frames at any times (also outside the training range, negative too)
//! from an orbit around the scene, the test cameras, or a multi-view rig's cameras, plus an
//! optional GIF.

use super::Reporter;
use super::error::{CommandError, CommandResult, Context as _};
use super::frame_writer::{FrameWriter, FramesWritten};
use super::load::load_dataset;
use super::paths::RunFolder;
use evogs::data::{DataFormat, Dataset};
use evogs::eval::render_frame;
use evogs::model::Model;
use evogs::run::checkpoint;
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
    /// Replace the frames of an earlier sequence in `out` (without it, they are refused).
    pub force: bool,
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

/// One turn around the scene in `n` poses about the world's up direction ([`world_up`]), at
/// the training cameras' mean distance and height, with their field of view and image
/// size. Each pose is computed when asked for, so a sequence of any length costs nothing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    center: Vec3<f64>,
    up: Vec3<f64>,
    e1: Vec3<f64>,
    e2: Vec3<f64>,
    ring: f64,
    height: f64,
    fov_x: f64,
    width: usize,
    height_px: usize,
    n: usize,
}

impl Orbit {
    /// The orbit of `n` poses around `center`.
    ///
    /// # Errors
    /// No training views, or a degenerate training camera.
    pub fn new(ds: &Dataset, center: Vec3<f64>, n: usize) -> CommandResult<Self> {
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
            .ok_or_else(|| CommandError::new("no training views to place the orbit"))?;
        let cams: Vec<PinholeCamera<f64>> = ds
            .train
            .iter()
            .map(evogs::data::View::camera)
            .collect::<Result<_, _>>()
            .map_err(CommandError::new)?;
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
        Ok(Self {
            center,
            up,
            e1,
            e2,
            ring: (radius * radius - height * height).max(1e-6).sqrt(),
            height,
            fov_x: v0.fov_x,
            width: v0.width,
            height_px: v0.height,
            n: n.max(1),
        })
    }

    /// Pose `i` (of `n`, at angle 2π i / n).
    ///
    /// # Errors
    /// A degenerate pose.
    pub fn camera(&self, i: usize) -> CommandResult<PinholeCamera<f32>> {
        let a = std::f64::consts::TAU * (i % self.n) as f64 / self.n as f64;
        let eye = self.center
            + (self.e1 * (self.ring * a.cos())
                + self.e2 * (self.ring * a.sin())
                + self.up * self.height);
        PinholeCamera::look_at(
            eye,
            self.center,
            self.up,
            self.fov_x,
            self.width,
            self.height_px,
        )
        .map(|c: PinholeCamera<f64>| c.cast())
        .context(format!("orbit camera {i}"))
    }
}

/// The cameras of a frame sequence: computed per frame along an orbit, or a list cycled.
#[derive(Clone, Debug, PartialEq)]
pub enum FrameCameras {
    /// Frame `i` from orbit pose `i`.
    Orbit(Orbit),
    /// Frame `i` from camera `i mod len` (never empty).
    Cycle(Vec<PinholeCamera<f32>>),
}

impl FrameCameras {
    /// The camera of frame `i`.
    ///
    /// # Errors
    /// A degenerate orbit pose.
    pub fn get(&self, i: usize) -> Result<PinholeCamera<f32>, CommandError> {
        match self {
            Self::Orbit(o) => o.camera(i),
            Self::Cycle(c) => Ok(c[i % c.len()]),
        }
    }
}

/// The point the orbit turns around: the Gaussians' mean position, on the ground (z = 0) of
/// the z-up D-NeRF world; for a multi-view rig (whose world has no ground) the mean itself.
#[must_use]
pub fn orbit_center(model: &Model<f32>, ds: &Dataset) -> Vec3<f64> {
    let c = &model.canonical.means;
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
fn rig_cameras(ds: &Dataset, name: Option<&str>) -> CommandResult<Vec<PinholeCamera<f32>>> {
    if ds.rig.is_empty() {
        return Err(CommandError::at(
            &ds.root,
            format!(
                "the dataset has no camera rig ({} layout); use --camera orbit or test",
                ds.format
            ),
        ));
    }
    let picked: Vec<_> = ds
        .rig
        .iter()
        .filter(|c| name.is_none_or(|n| c.name == n))
        .collect();
    if picked.is_empty() {
        let names: Vec<&str> = ds.rig.iter().map(|c| c.name.as_str()).collect();
        return Err(CommandError::at(
            &ds.root,
            format!(
                "no rig camera `{}` (the rig has {})",
                name.unwrap_or_default(),
                names.join(", ")
            ),
        ));
    }
    picked
        .into_iter()
        .map(|c| {
            PinholeCamera::from_dnerf(c.c2w, c.fov_x, c.width, c.height)
                .context(format!("{}: bad camera", c.name))
        })
        .collect()
}

/// The cameras of `count` frames along `path`: an orbit around the model's centre
/// ([`orbit_center`], [`Orbit`]), the test cameras cycled, a rig's cameras cycled, or one rig
/// camera.
///
/// # Errors
/// No training views to place the orbit, no test cameras, no rig or rig camera of that
/// name, or an invalid camera.
pub fn path_cameras(
    path: &CameraPath,
    ds: &Dataset,
    model: &Model<f32>,
    count: usize,
) -> Result<FrameCameras, CommandError> {
    match path {
        CameraPath::Orbit => {
            Orbit::new(ds, orbit_center(model, ds), count).map(FrameCameras::Orbit)
        }
        CameraPath::Rig | CameraPath::Camera(_) => {
            let name = match path {
                CameraPath::Camera(n) => Some(n.as_str()),
                _ => None,
            };
            rig_cameras(ds, name).map(FrameCameras::Cycle)
        }
        CameraPath::Test => {
            let t: Vec<PinholeCamera<f32>> = ds
                .test
                .iter()
                .map(evogs::data::View::camera)
                .collect::<Result<_, _>>()
                .map_err(CommandError::new)?;
            if t.is_empty() {
                return Err(CommandError::new(
                    "the dataset has no test cameras (use --camera orbit)",
                ));
            }
            Ok(FrameCameras::Cycle(t))
        }
    }
}

/// The time of frame `i` of `n` evenly spaced over `[a, b]` (`a` when `n = 1`).
#[must_use]
pub fn frame_time((a, b, n): (f64, f64, usize), i: usize) -> f64 {
    if n <= 1 {
        a
    } else {
        let u = i as f64 / (n - 1) as f64;
        a + (b - a) * u
    }
}

/// Renders the frames one at a time, writing each as it comes (constant memory for any
/// count; an interrupt stops after the current frame) and using an already loaded model and
/// dataset when given.
///
/// # Errors
/// Unreadable run or data, unwritable output.
pub fn render_sequence(
    args: &RenderArgs,
    loaded: Option<(&mut Model<f32>, &Dataset)>,
    rep: &mut dyn Reporter,
) -> Result<FramesWritten, CommandError> {
    let mut own;
    let (model, ds): (&mut Model<f32>, &Dataset) = match loaded {
        Some(x) => x,
        None => {
            let run = RunFolder::new(&args.run);
            let l = checkpoint::load_model(&run.checkpoint()).map_err(CommandError::new)?;
            let dir = match &args.data {
                Some(d) => d.clone(),
                None => run.data_dir().map_err(CommandError::new)?,
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
            .map_err(|e| CommandError::new(format!("--times: {e}")))?;
    }
    let cams = path_cameras(&args.camera, ds, model, n)?;
    let mut out = FrameWriter::create(&args.out, args.gif.then_some("render.gif"), args.force)?;
    rep.start("render", n as u64);
    let mut scratch = Splats::default();
    for i in 0..n {
        out.check_interrupt(n)?;
        let t = frame_time(args.times, i);
        let img = render_frame(
            model,
            &cams.get(i)?,
            t,
            background,
            Par::best(),
            &mut scratch,
        );
        out.push(&img, t)?;
        rep.progress(i as u64 + 1, &format!("t = {t:.3}"));
    }
    rep.finish();
    out.finish()
}
