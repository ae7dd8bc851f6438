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
use super::error::CommandError;
use super::frame_writer::{FrameWriter, FramesWritten};
use super::load::load_dataset;
use super::paths::RunFolder;
use super::render::{CameraPath, frame_time, path_cameras};
use evogs::data::DataFormat;
use evogs::field::neural::gaussian_layout;
use evogs::model::Motion;
use evogs::model::render_options;
use evogs::run::checkpoint;
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

/// The comma-separated finite numbers of `s`.
fn numbers(s: &str, what: &str) -> Result<Vec<f64>, String> {
    s.split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("{what}: `{v}` is not a finite number"))
        })
        .collect()
}

/// `v` in `f32` (masks and fields are evaluated in the renderer's precision), if it stays
/// finite.
fn to_f32(v: f64, what: &str, s: &str) -> Result<f32, String> {
    #[allow(clippy::cast_possible_truncation, reason = "f32 rendering")]
    let x = v as f32;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("{what} `{s}`: {v} is beyond the f32 range"))
    }
}

/// Parses `sphere:CX,CY,CZ,R` or `box:X0,Y0,Z0,X1,Y1,Z1`, with an optional `,soft=W` edge
/// (`W > 0`). The numbers must be finite in `f32`, and the shape non-empty there.
///
/// # Errors
/// A malformed specification.
pub fn parse_mask(s: &str) -> Result<Mask<f32>, String> {
    let (kind, rest) = s.split_once(':').ok_or_else(|| {
        format!("mask `{s}`: expected sphere:CX,CY,CZ,R or box:X0,Y0,Z0,X1,Y1,Z1")
    })?;
    if rest.matches("soft=").count() > 1 {
        return Err(format!(
            "mask `{s}`: `soft=` is given more than once; give one edge width"
        ));
    }
    let (rest, edge) = match rest.split_once(",soft=") {
        Some((r, w)) => {
            let w = w
                .trim()
                .parse::<f32>()
                .ok()
                .filter(|w| w.is_finite() && *w > 0.0)
                .ok_or_else(|| format!("mask `{s}`: the soft width must be a number > 0"))?;
            (r, Edge::Soft { width: w })
        }
        None => (rest, Edge::Hard),
    };
    let v = numbers(rest, "mask")?
        .into_iter()
        .map(|x| to_f32(x, "mask", s))
        .collect::<Result<Vec<f32>, _>>()?;
    match (kind, v.len()) {
        ("sphere", 4) if v[3] > 0.0 => Ok(Mask::Sphere {
            center: Vec3::new(v[0], v[1], v[2]),
            radius: v[3],
            edge,
        }),
        ("box", 6) if v[0] < v[3] && v[1] < v[4] && v[2] < v[5] => Ok(Mask::Box {
            min: Vec3::new(v[0], v[1], v[2]),
            max: Vec3::new(v[3], v[4], v[5]),
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
            // Divided by its largest entry first, so that neither a huge nor a tiny axis
            // overflows or underflows its norm.
            let big = v[0].abs().max(v[1].abs()).max(v[2].abs());
            if big == 0.0 {
                return Err(format!("field `{s}`: the rotation axis is zero"));
            }
            let axis = Vec3::new(v[0] / big, v[1] / big, v[2] / big);
            let center = (v.len() == 7).then(|| Vec3::new(v[4], v[5], v[6]));
            let omega = axis * (v[3] / axis.norm());
            for x in omega.to_array().into_iter().chain(v[4..].iter().copied()) {
                to_f32(x, "field", s)?;
            }
            Ok(FieldSpec::Rotate { omega, center })
        }
        ("translate", 3) => {
            for &x in &v {
                to_f32(x, "field", s)?;
            }
            Ok(FieldSpec::Translate(Vec3::new(v[0], v[1], v[2])))
        }
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
    /// Replace the frames of an earlier sequence in `out` (without it, they are refused).
    pub force: bool,
}

/// Renders the edited motion; returns the frames written.
///
/// # Errors
/// A run without velocity motion, unreadable run or data, unwritable output.
pub fn inject(args: &InjectArgs, rep: &mut dyn Reporter) -> Result<FramesWritten, CommandError> {
    let run = RunFolder::new(&args.run);
    let l = checkpoint::load_model(&run.checkpoint()).map_err(CommandError::new)?;
    let mut model = l.model;
    if model.motion != Motion::Velocity || !model.dynamics_active {
        return Err(CommandError::at(
            &run.checkpoint(),
            "injection needs a trained run with velocity motion",
        ));
    }
    if model.waypoint_field.is_some() {
        // Its frames are the waypoint field's states carried over hops; an injected field
        // integrated from the canonical state would show another motion than the run's.
        return Err(CommandError::at(
            &run.checkpoint(),
            "injection is not available for continuous waypoints (dynamics.waypoints = \
             \"continuous\"): the run's frames come from its waypoint field and hops",
        ));
    }
    let dir = match &args.data {
        Some(d) => d.clone(),
        None => run.data_dir().map_err(CommandError::new)?,
    };
    let mut cfg = l.cfg.clone();
    if let Some(f) = args.format {
        cfg.data.format = f;
    }
    let ds = load_dataset(&dir, &cfg, false)?;
    let n = model.len();
    let frame = ParticleFrame::new(gaussian_layout(n), 0, Some(1)).map_err(CommandError::new)?;
    let mask_center = match &args.mask {
        Mask::Sphere { center, .. } => *center,
        Mask::Box { min, max, .. } => (*min + *max) * 0.5,
        Mask::Weights(_) => Vec3::zero(),
    };
    let (a, b, count) = args.times;
    for t in [a, b] {
        model
            .check_time(t)
            .map_err(|e| CommandError::new(format!("--times: {e}")))?;
    }
    let cams = path_cameras(&args.camera, &ds, &model, count)?;
    let mut out = FrameWriter::create(&args.out, args.gif.then_some("inject.gif"), args.force)?;
    model.field.set_count(n);
    model.set_par(Par::best());
    let mut stepper = Stepper::new(model.method, gaussian_layout(n));
    let opts = render_options([1.0, 1.0, 1.0], model.canonical.sh_degree, Par::best());
    let mut splats = Splats::default();
    let mut rasterizer = TiledRasterizer::new();
    rep.start("inject", count as u64);
    // Whether the mask held a Gaussian at any rendered time.
    let mut touched = false;
    for i in 0..count {
        out.check_interrupt(count)?;
        let t = frame_time(args.times, i);
        let k = model.anchor_for(t);
        let mut y = model.initial_state(k);
        let grid = model.grid_to(k, t);
        let injected: Box<dyn VectorField<f32, Record = ()>> = match args.field {
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
        touched = touched
            || splats
                .means
                .iter()
                .enumerate()
                .any(|(p, &x)| args.mask.weight(p, x) > 0.0);
        let mut img = render_tiled(&splats, &cams.get(i)?, &opts, &mut rasterizer)
            .raster
            .rgb;
        for v in img.data_mut() {
            *v = v.clamp(0.0, 1.0);
        }
        out.push(&img, t)?;
        rep.progress(i as u64 + 1, &format!("t = {t:.3}"));
    }
    rep.finish();
    if !touched {
        rep.info(&format!(
            "note: the mask holds no Gaussian at any of the {count} rendered times, so the \
             frames are those of a plain render; move or widen the mask (the run's field box is \
             {})",
            field_box(&model)
        ));
    }
    out.finish()
}

/// The run's field box as `[x0, y0, z0] to [x1, y1, z1]`.
fn field_box(model: &evogs::model::Model<f32>) -> String {
    let (lo, hi) = model.field.hexplane().aabb();
    let r = |v: [f64; 3]| format!("[{:.2}, {:.2}, {:.2}]", v[0], v[1], v[2]);
    format!("{} to {}", r(lo), r(hi))
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

    /// Every number of a mask or field must be finite, also in `f32`, a soft edge
    /// positive, a box non-empty in `f32`, and a rotation axis of any finite scale is
    /// normalised without overflow or underflow.
    #[test]
    fn specs_reject_non_finite_and_degenerate_numbers() {
        for bad in [
            "sphere:nan,0,0,1",
            "sphere:0,inf,0,1",
            "sphere:0,0,0,inf",
            "sphere:1e39,0,0,1",
            "sphere:0,0,0,1,soft=0",
            "sphere:0,0,0,1,soft=0.1,soft=0.2",
            "box:0,0,0,1,1,1,soft=0.1,soft=0.1",
            "sphere:0,0,0,1,soft=-0.1",
            "sphere:0,0,0,1,soft=nan",
            "box:0,0,0,1,1,nan",
            "box:0,0,1,1,1,1.00000000001",
        ] {
            assert!(parse_mask(bad).is_err(), "mask `{bad}` accepted");
        }
        for bad in [
            "rotate:nan,0,1,1",
            "rotate:0,0,1,inf",
            "rotate:0,0,1,1,0,nan,0",
            "translate:1,-inf,0",
            "translate:1e39,0,0",
            "rotate:0,0,1,1e39",
            "rotate:0,0,1,1,0,0,-1e300",
        ] {
            assert!(parse_field(bad).is_err(), "field `{bad}` accepted");
        }
        for (axis, rate) in [
            ("1e300,1e300,0", 2.0),
            ("1e-320,0,0", 1.5),
            ("0,3e-310,4e-310", -1.0),
        ] {
            match parse_field(&format!("rotate:{axis},{rate}")) {
                Ok(FieldSpec::Rotate { omega, .. }) => assert!(
                    (omega.norm() - f64::abs(rate)).abs() < 1e-12,
                    "axis {axis}: |ω| = {} for rate {rate}",
                    omega.norm()
                ),
                other => panic!("axis {axis}: {other:?}"),
            }
        }
    }
}
