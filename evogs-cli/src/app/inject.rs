//! `evogs inject`: motion editing by vector-field algebra (`docs/method.md` §9). Inside a mask
//! the learned velocity field is replaced by an injected one:
//!
//! ```text
//! v'(x, t) = λ(x)·v_inj(x, t) + (1 − λ(x))·v_θ(x, t)
//! ```
//!
//! evaluated inside the ODE at every stage, at the Gaussians' current positions (so the mask
//! follows the motion). A rigid rotation injects `ω × (x − c)` on positions **and** ω on the
//! orientations, so the Gaussians turn exactly with the rotation.

use super::Reporter;
use super::paths::RunFolder;
use super::render::{CameraPath, path_cameras};
use super::train::{CommandError, load_dataset};
use crate::data::{DataFormat, image_io};
use crate::field::neural::gaussian_layout;
use crate::model::Motion;
use crate::run::checkpoint;
use crate::train::step::render_options;
use evogs_math::{Par, Vec3};
use evogs_ode::algebra::{Edge, Mask, Mix, ParticleFrame, RigidRotation, Translation};
use evogs_ode::{Stepper, VectorField, integrate};
use evogs_splat::{Splats, TiledRasterizer, render_tiled};
use std::path::PathBuf;

/// The injected field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FieldSpec {
    /// Rotation about `center` with axis·rate `omega` (rad per unit time).
    Rotate {
        /// Axis times rate.
        omega: Vec3<f64>,
        /// Centre (defaults to the mask's centre).
        center: Option<Vec3<f64>>,
    },
    /// Constant velocity.
    Translate(Vec3<f64>),
}

fn numbers(s: &str, what: &str) -> Result<Vec<f64>, String> {
    s.split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .map_err(|_| format!("{what}: `{v}` is not a number"))
        })
        .collect()
}

/// Parses `sphere:CX,CY,CZ,R` or `box:X0,Y0,Z0,X1,Y1,Z1`, with an optional `,soft=W` edge.
///
/// # Errors
/// A malformed specification.
pub fn parse_mask(s: &str) -> Result<Mask<f32>, String> {
    let (kind, rest) = s.split_once(':').ok_or_else(|| {
        format!("mask `{s}`: expected sphere:CX,CY,CZ,R or box:X0,Y0,Z0,X1,Y1,Z1")
    })?;
    let (rest, edge) = match rest.split_once(",soft=") {
        Some((r, w)) => {
            let w: f32 = w
                .trim()
                .parse()
                .map_err(|_| format!("mask `{s}`: bad soft width"))?;
            (r, Edge::Soft { width: w })
        }
        None => (rest, Edge::Hard),
    };
    let v = numbers(rest, "mask")?;
    #[allow(clippy::cast_possible_truncation, reason = "f32 rendering")]
    let f = |i: usize| v[i] as f32;
    match (kind, v.len()) {
        ("sphere", 4) if v[3] > 0.0 => Ok(Mask::Sphere {
            center: Vec3::new(f(0), f(1), f(2)),
            radius: f(3),
            edge,
        }),
        ("box", 6) if v[0] < v[3] && v[1] < v[4] && v[2] < v[5] => Ok(Mask::Box {
            min: Vec3::new(f(0), f(1), f(2)),
            max: Vec3::new(f(3), f(4), f(5)),
            edge,
        }),
        _ => Err(format!(
            "mask `{s}`: expected sphere:CX,CY,CZ,R (R > 0) or box:X0,Y0,Z0,X1,Y1,Z1 (min < max)"
        )),
    }
}

/// Parses `rotate:AX,AY,AZ,RATE[,CX,CY,CZ]` or `translate:UX,UY,UZ`.
///
/// # Errors
/// A malformed specification.
pub fn parse_field(s: &str) -> Result<FieldSpec, String> {
    let (kind, rest) = s.split_once(':').ok_or_else(|| {
        format!("field `{s}`: expected rotate:AX,AY,AZ,RATE[,CX,CY,CZ] or translate:UX,UY,UZ")
    })?;
    let v = numbers(rest, "field")?;
    match (kind, v.len()) {
        ("rotate", 4 | 7) => {
            let axis = Vec3::new(v[0], v[1], v[2]);
            if axis.norm() == 0.0 {
                return Err(format!("field `{s}`: the rotation axis is zero"));
            }
            let center = (v.len() == 7).then(|| Vec3::new(v[4], v[5], v[6]));
            Ok(FieldSpec::Rotate {
                omega: axis * (v[3] / axis.norm()),
                center,
            })
        }
        ("translate", 3) => Ok(FieldSpec::Translate(Vec3::new(v[0], v[1], v[2]))),
        _ => Err(format!(
            "field `{s}`: expected rotate:AX,AY,AZ,RATE[,CX,CY,CZ] or translate:UX,UY,UZ"
        )),
    }
}

/// The arguments of `evogs inject`.
#[derive(Clone, Debug, PartialEq)]
pub struct InjectArgs {
    /// Run folder.
    pub run: PathBuf,
    /// Output folder.
    pub out: PathBuf,
    /// The mask λ(x).
    pub mask: Mask<f32>,
    /// The injected field.
    pub field: FieldSpec,
    /// `(first time, last time, count)`.
    pub times: (f64, f64, usize),
    /// Camera path.
    pub camera: CameraPath,
    /// Also write a GIF.
    pub gif: bool,
    /// Dataset folder (default: the run's).
    pub data: Option<PathBuf>,
    /// Dataset layout override (default: the run's `data.format`).
    pub format: Option<DataFormat>,
}

/// Renders the edited motion; returns the frames written.
///
/// # Errors
/// A run without velocity motion, unreadable run or data, unwritable output.
pub fn inject(args: &InjectArgs, rep: &mut dyn Reporter) -> Result<Vec<PathBuf>, CommandError> {
    let run = RunFolder::new(&args.run);
    let l = checkpoint::load_model(&run.checkpoint()).map_err(CommandError::from_display)?;
    let mut model = l.model;
    if model.motion != Motion::Velocity || !model.dynamics_active {
        return Err(CommandError(format!(
            "{}: injection needs a trained run with velocity motion",
            run.checkpoint().display()
        )));
    }
    let dir = match &args.data {
        Some(d) => d.clone(),
        None => run.data_dir().map_err(CommandError)?,
    };
    let mut cfg = l.cfg.clone();
    if let Some(f) = args.format {
        cfg.data.format = f;
    }
    let ds = load_dataset(&dir, &cfg, false)?;
    let n = model.len();
    let frame =
        ParticleFrame::new(gaussian_layout(n), 0, Some(1)).map_err(CommandError::from_display)?;
    let mask_center = match &args.mask {
        Mask::Sphere { center, .. } => *center,
        Mask::Box { min, max, .. } => (*min + *max) * 0.5,
        Mask::Weights(_) => Vec3::zero(),
    };
    let (a, b, count) = args.times;
    for t in [a, b] {
        model
            .check_time(t)
            .map_err(|e| CommandError(format!("--times: {e}")))?;
    }
    let cams = path_cameras(&args.camera, &ds, &model, count)?;
    std::fs::create_dir_all(&args.out)
        .map_err(|e| CommandError(format!("{}: cannot create: {e}", args.out.display())))?;
    model.field.set_count(n);
    model.field.set_par(Par::best());
    let mut stepper = Stepper::new(model.method, gaussian_layout(n));
    let opts = render_options([1.0, 1.0, 1.0], model.canonical.sh_degree, Par::best());
    let mut splats = Splats::default();
    let mut rasterizer = TiledRasterizer::new();
    let mut images = Vec::with_capacity(count);
    let mut frames = Vec::with_capacity(count);
    rep.start("inject", count as u64);
    for (i, cam) in cams.iter().enumerate() {
        #[allow(clippy::cast_precision_loss, reason = "frame counts are small")]
        let t = if count == 1 {
            a
        } else {
            a + (b - a) * i as f64 / (count - 1) as f64
        };
        let k = model.anchor_for(t);
        let mut y = model.initial_state(k);
        let grid = model.grid_to(k, t);
        let injected: Box<dyn VectorField<f32>> = match args.field {
            FieldSpec::Rotate { omega, center } => Box::new(RigidRotation::new(
                frame,
                omega.cast(),
                center.unwrap_or(mask_center.cast()).cast(),
            )),
            FieldSpec::Translate(u) => Box::new(Translation::new(frame, u.cast())),
        };
        let mut mixed = Mix::new(args.mask.clone(), injected, &mut model.field, frame);
        integrate(&mut mixed, &mut stepper, &grid, &mut y);
        model.splats_from_state(&y, &mut splats);
        let mut img = render_tiled(&splats, cam, &opts, &mut rasterizer)
            .raster
            .rgb;
        for v in img.data_mut() {
            *v = v.clamp(0.0, 1.0);
        }
        let p = args.out.join(format!("frame_{i:04}.png"));
        image_io::save_png(&img, &p).map_err(CommandError::from_display)?;
        frames.push(p);
        images.push(img);
        rep.progress(i as u64 + 1, &format!("t = {t:.3}"));
    }
    rep.finish();
    if args.gif {
        image_io::save_gif(&images, 80, &args.out.join("inject.gif"))
            .map_err(CommandError::from_display)?;
    }
    Ok(frames)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_parse_and_reject() {
        assert!(
            matches!(parse_mask("sphere:0,0,0.5,0.3"), Ok(Mask::Sphere { .. })),
            "sphere"
        );
        assert!(
            matches!(
                parse_mask("box:0,0,0,1,1,1,soft=0.05"),
                Ok(Mask::Box {
                    edge: Edge::Soft { .. },
                    ..
                })
            ),
            "soft box"
        );
        assert!(parse_mask("sphere:0,0,0,-1").is_err(), "negative radius");
        assert!(parse_mask("cube:1,2,3").is_err(), "unknown shape");
        match parse_field("rotate:0,0,2,3.0") {
            Ok(FieldSpec::Rotate {
                omega,
                center: None,
            }) => assert!((omega.z - 3.0).abs() < 1e-12, "axis normalised, times rate"),
            other => panic!("rotate parsed as {other:?}"),
        }
        assert!(parse_field("rotate:0,0,0,1").is_err(), "zero axis");
        assert!(
            matches!(parse_field("translate:1,0,0"), Ok(FieldSpec::Translate(_))),
            "translate"
        );
    }
}
