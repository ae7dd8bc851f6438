//! `projection_*` files: [`project`] and [`project_vjp`] against gsplat 1.5.3's
//! pure-PyTorch reference (SCHEMA.md, "projection").
//!
//! - outputs: `1e-10·max(1e-3, |r|)` (the schema's "1e-10 relative"; the floor keeps exact
//!   zeros comparable). `means_cam`, `covars_world` and `depths` for every Gaussian; the
//!   other float outputs where `valid` (the schema: culled entries are not written by
//!   gsplat's CUDA kernel, and its torch code clamps their determinant);
//! - integer and boolean outputs (`radii`, `radii_opacity_aware`, `valid`, `fov_clamped_x/y`)
//!   exactly, for every Gaussian;
//! - the six VJP variants (`grads`, `grads_with_compensations`, `grads_per_output.*`) for
//!   means, quaternions, linear scales, the view matrix and the left se(3) pose:
//!   `1e-9·max(1, |r|)`.

use super::json::{Node, Res, bools_as_ints};
use super::report::{Row, Rule, Tally, index_name};
use super::scene::{
    camera, camera_grads, case_name, flat3, flat4, masked, masked_name, scale_grads, splats,
};
use evogs_math::Vec2;
use evogs_math::covariance::covariance;
use evogs_splat::{
    CameraGrad, PinholeCamera, ProjectOptions, Projected, ProjectedGrad, RadiusMode, Splats,
    project, project_vjp,
};

const OUT: Rule = Rule::Rel {
    tol: 1e-10,
    floor: 1e-3,
};
const VJP: Rule = Rule::Rel {
    tol: 1e-9,
    floor: 1.0,
};

/// The float outputs: (key, row width, compared for every Gaussian or only where valid).
const FLOAT_OUTPUTS: [(&str, usize, bool); 8] = [
    ("means_cam", 3, true),
    ("covars_world", 9, true),
    ("depths", 1, true),
    ("cov2d", 4, false),
    ("cov2d_blurred", 4, false),
    ("means2d", 2, false),
    ("conics", 3, false),
    ("compensations", 1, false),
];
const EXACT_OUTPUTS: [&str; 5] = [
    "radii",
    "radii_opacity_aware",
    "valid",
    "fov_clamped_x",
    "fov_clamped_y",
];

struct Setup {
    name: String,
    cam: PinholeCamera<f64>,
    s: Splats<f64>,
    op: Vec<f64>,
    eps2d: f64,
}

fn opts(eps2d: f64, radius: RadiusMode) -> ProjectOptions<f64> {
    ProjectOptions {
        eps2d,
        radius,
        antialiased: false,
    }
}

fn project_all(c: &Setup, radius: RadiusMode) -> Vec<Projected<f64>> {
    let o = opts(c.eps2d, radius);
    (0..c.s.len())
        .map(|i| {
            project(
                c.s.means[i],
                c.s.log_scales[i],
                c.s.quats[i],
                c.op[i],
                &c.cam,
                &o,
            )
        })
        .collect()
}

/// Our value of a float output, flattened.
fn float_output(c: &Setup, p: &[Projected<f64>], key: &str) -> Vec<f64> {
    let sym = |b: evogs_math::Sym2<f64>| [b.xx, b.xy, b.xy, b.yy];
    match key {
        "means_cam" => p.iter().flat_map(|p| p.mean_cam.to_array()).collect(),
        "covars_world" => (0..c.s.len())
            .flat_map(|i| {
                covariance(c.s.log_scales[i], c.s.quats[i])
                    .to_mat()
                    .to_flat()
            })
            .collect(),
        "depths" => p.iter().map(|p| p.depth).collect(),
        "cov2d" => p.iter().flat_map(|p| sym(p.cov2d)).collect(),
        "cov2d_blurred" => p
            .iter()
            .flat_map(|p| sym(p.cov2d_blurred(c.eps2d)))
            .collect(),
        "means2d" => p.iter().flat_map(|p| p.means2d.to_array()).collect(),
        "conics" => p.iter().flat_map(|p| p.conic).collect(),
        _ => p.iter().map(|p| p.compensation).collect(),
    }
}

fn outputs(t: &mut Tally, c: &Setup, out: &Node<'_>) -> Res<()> {
    let n = c.s.len();
    let plain = project_all(c, RadiusMode::Plain);
    let aware = project_all(c, RadiusMode::OpacityAware);
    let valid = out.get("valid")?.bools(&[n])?;
    for (key, width, all) in FLOAT_OUTPUTS {
        let shape: &[usize] = match width {
            1 => &[n],
            4 => &[n, 2, 2],
            9 => &[n, 3, 3],
            w => &[n, w],
        };
        let reference = out.get(key)?.nums(shape)?;
        let mask = if all { vec![true; n] } else { valid.clone() };
        let label = if all {
            key.to_string()
        } else {
            format!("{key} (valid)")
        };
        t.floats(
            &label,
            OUT,
            &c.name,
            &masked(&float_output(c, &plain, key), width, &mask),
            &masked(&reference, width, &mask),
            &masked_name(width, &mask),
        );
    }
    let radii = |p: &[Projected<f64>]| -> Vec<i64> {
        p.iter()
            .flat_map(|p| p.radii.map(i64::from))
            .collect::<Vec<_>>()
    };
    for key in EXACT_OUTPUTS {
        let (mine, reference, w) = match key {
            "radii" => (radii(&plain), out.get(key)?.ints(&[n, 2])?, 2),
            "radii_opacity_aware" => (radii(&aware), out.get(key)?.ints(&[n, 2])?, 2),
            "valid" => (
                bools_as_ints(&plain.iter().map(|p| p.valid).collect::<Vec<_>>()),
                bools_as_ints(&valid),
                1,
            ),
            _ => {
                let axis = usize::from(key == "fov_clamped_y");
                (
                    bools_as_ints(
                        &plain
                            .iter()
                            .map(|p| p.fov_clamped[axis])
                            .collect::<Vec<_>>(),
                    ),
                    bools_as_ints(&out.get(key)?.bools(&[n])?),
                    1,
                )
            }
        };
        t.exact(key, &c.name, &mine, &reference, &index_name(w));
    }
    Ok(())
}

/// The cotangents of `vjp.cotangents`, and which of them a gradient variant includes.
struct Cotangents {
    means2d: Vec<f64>,
    depths: Vec<f64>,
    conics: Vec<f64>,
    compensations: Vec<f64>,
}

/// Our VJP summed over the Gaussians with the selected cotangents
/// (`[means2d, depths, conics, compensations]`): the five gradient arrays of the file.
fn vjp_sum(c: &Setup, ct: &Cotangents, on: [bool; 4]) -> [Vec<f64>; 5] {
    let o = opts(c.eps2d, RadiusMode::Plain);
    let pick = |k: usize, x: f64| if on[k] { x } else { 0.0 };
    let n = c.s.len();
    let (mut dm, mut dls, mut dq) = (Vec::new(), Vec::new(), Vec::new());
    let mut cam = CameraGrad::zero();
    for i in 0..n {
        let d = ProjectedGrad {
            means2d: Vec2::new(pick(0, ct.means2d[2 * i]), pick(0, ct.means2d[2 * i + 1])),
            depth: pick(1, ct.depths[i]),
            conic: core::array::from_fn(|k| pick(2, ct.conics[3 * i + k])),
            compensation: pick(3, ct.compensations[i]),
        };
        let g = project_vjp(
            c.s.means[i],
            c.s.log_scales[i],
            c.s.quats[i],
            c.op[i],
            &c.cam,
            &o,
            &d,
        );
        dm.push(g.mean);
        dls.push(g.log_scale);
        dq.push(g.quat);
        cam.add(&g.camera);
    }
    let (vm, pose) = camera_grads(&cam, &c.cam);
    [flat3(&dm), flat4(&dq), scale_grads(&c.s, &dls), vm, pose]
}

const GRAD_KEYS: [(&str, usize); 5] = [
    ("means", 3),
    ("quats", 4),
    ("scales", 3),
    ("viewmat", 4),
    ("pose_left_se3", 1),
];

fn vjps(t: &mut Tally, c: &Setup, vjp: &Node<'_>) -> Res<()> {
    let n = c.s.len();
    let ctn = vjp.get("cotangents")?;
    let ct = Cotangents {
        means2d: ctn.get("means2d")?.nums(&[n, 2])?,
        depths: ctn.get("depths")?.nums(&[n])?,
        conics: ctn.get("conics")?.nums(&[n, 3])?,
        compensations: ctn.get("compensations")?.nums(&[n])?,
    };
    let mut variants = vec![
        (
            "grads".to_string(),
            vjp.get("grads")?,
            [true, true, true, false],
        ),
        (
            "grads_with_compensations".to_string(),
            vjp.get("grads_with_compensations")?,
            [true; 4],
        ),
    ];
    let per = vjp.get("grads_per_output")?;
    for (k, key) in ["means2d", "depths", "conics", "compensations"]
        .into_iter()
        .enumerate()
    {
        let mut on = [false; 4];
        on[k] = true;
        variants.push((format!("grads_per_output.{key}"), per.get(key)?, on));
    }
    for (label, node, on) in variants {
        let mine = vjp_sum(c, &ct, on);
        for ((key, w), ours) in GRAD_KEYS.into_iter().zip(&mine) {
            let shape: &[usize] = match key {
                "viewmat" => &[4, 4],
                "pose_left_se3" => &[6],
                _ => &[n, w],
            };
            let reference = node.get(key)?.nums(shape)?;
            t.floats(
                &format!("{label}.{key}"),
                VJP,
                &c.name,
                ours,
                &reference,
                &index_name(w),
            );
        }
    }
    Ok(())
}

/// Recomputes a projection file.
pub(crate) fn verify(root: &Node<'_>) -> Res<(usize, Vec<Row>)> {
    let case = root.get("case")?;
    let inputs = case.get("inputs")?;
    let s = splats(&inputs)?;
    let n = s.len();
    let c = Setup {
        name: case_name(&case)?,
        cam: camera(&inputs)?,
        op: inputs.get("opacities")?.nums(&[n])?,
        eps2d: inputs.get("eps2d")?.f64()?,
        s,
    };
    let mut t = Tally::default();
    let out = case.get("outputs")?;
    outputs(&mut t, &c, &out)?;
    let known: Vec<&str> = FLOAT_OUTPUTS
        .iter()
        .map(|f| f.0)
        .chain(EXACT_OUTPUTS)
        .collect();
    for key in out.keys() {
        if !known.contains(&key) {
            t.fail(
                &format!("outputs.{key}"),
                "unrecognised output: not recomputed",
            );
        }
    }
    vjps(&mut t, &c, &case.get("vjp")?)?;
    Ok((1, t.into_rows()))
}
