//! `raster_*` files: the full chain [`render`] (projection → SH colour → reference
//! compositing, classic or antialiased) and [`render_vjp`] against the dense float64
//! reference (SCHEMA.md, "raster").
//!
//! - intermediate floats (`1e-10·max(1e-3, |r|)`): depths for every Gaussian, the others
//!   where `valid` (the schema compares culled Gaussians nowhere);
//! - integers and booleans exactly: `radii`, `valid`, `depth_order`, `n_contrib`,
//!   `terminated`, and the decision counts;
//! - images and losses: `1e-10·max(1, |r|)`;
//! - both gradient sets (`total`, `rgb_only`) for the parameters (linear scales, activated
//!   opacities, SH, view matrix, left se(3) pose) and the rasterizer inputs:
//!   `1e-8·max(1, |r|)`;
//! - the decision margins (see [`super::decisions`]): `1e-10·max(1e-3, |r|)`.

use super::decisions::{Decisions, decisions};
use super::json::{Malformed, Node, Res, bools_as_ints};
use super::report::{Row, Rule, Tally, index_name};
use super::scene::{
    camera, camera_grads, case_name, flat3, flat4, masked, masked_name, opacity_grads, scale_grads,
    splats,
};
use evogs_math::activation::sigmoid;
use evogs_splat::{
    PinholeCamera, PixelGrad, RadiusMode, RasterMode, Render, RenderGrad, RenderOptions, Splats,
    project, render, render_vjp,
};

const FLOAT: Rule = Rule::Rel {
    tol: 1e-10,
    floor: 1e-3,
};
const IMAGE: Rule = Rule::Rel {
    tol: 1e-10,
    floor: 1.0,
};
const GRAD: Rule = Rule::Rel {
    tol: 1e-8,
    floor: 1.0,
};

struct Setup {
    name: String,
    cam: PinholeCamera<f64>,
    s: Splats<f64>,
    opts: RenderOptions<f64>,
    fwd: Render<f64>,
}

fn setup(case: &Node<'_>) -> Res<Setup> {
    let inputs = case.get("inputs")?;
    let cam = camera(&inputs)?;
    let s = splats(&inputs)?;
    let mode_node = inputs.get("rasterize_mode")?;
    let mode = match mode_node.str()? {
        "classic" => RasterMode::Classic,
        "antialiased" => RasterMode::Antialiased,
        other => {
            return Err(Malformed {
                path: mode_node.path().to_string(),
                expected: format!("\"classic\" or \"antialiased\" (found \"{other}\")"),
            });
        }
    };
    let bg = inputs.get("background")?.vec3()?;
    let opts = RenderOptions {
        eps2d: inputs.get("eps2d")?.f64()?,
        radius: RadiusMode::Plain,
        mode,
        sh_degree: s.sh_degree,
        background: bg,
        ..RenderOptions::default()
    };
    let fwd = render(&s, &cam, &opts);
    Ok(Setup {
        name: case_name(case)?,
        cam,
        s,
        opts,
        fwd,
    })
}

const INTERMEDIATE: [(&str, usize); 10] = [
    ("means2d", 2),
    ("depths", 1),
    ("conics", 3),
    ("cov2d_blurred", 4),
    ("compensations", 1),
    ("colors", 3),
    ("opacities_effective", 1),
    ("radii", 2),
    ("valid", 1),
    ("depth_order", 1),
];

fn intermediate(t: &mut Tally, c: &Setup, im: &Node<'_>) -> Res<()> {
    let n = c.s.len();
    let pre = &c.fwd.pre;
    let valid = im.get("valid")?.bools(&[n])?;
    let popts = c.opts.project_options();
    let blurred: Vec<f64> = (0..n)
        .flat_map(|i| {
            let o = sigmoid(c.s.opacity_logits[i]);
            let p = project(
                c.s.means[i],
                c.s.log_scales[i],
                c.s.quats[i],
                o,
                &c.cam,
                &popts,
            );
            let b = p.cov2d_blurred(c.opts.eps2d);
            [b.xx, b.xy, b.xy, b.yy]
        })
        .collect();
    for (key, w) in INTERMEDIATE {
        let node = im.get(key)?;
        let shape: &[usize] = match w {
            1 => &[n],
            4 => &[n, 2, 2],
            w => &[n, w],
        };
        match key {
            "radii" => {
                let mine: Vec<i64> = pre.radii.iter().flat_map(|r| r.map(i64::from)).collect();
                t.exact(
                    "intermediate.radii",
                    &c.name,
                    &mine,
                    &node.ints(shape)?,
                    &index_name(2),
                );
            }
            "valid" => t.exact(
                "intermediate.valid",
                &c.name,
                &bools_as_ints(&pre.valid),
                &bools_as_ints(&valid),
                &index_name(1),
            ),
            "depth_order" => {
                let mine: Vec<i64> = pre.order.iter().map(|&i| i64::from(i)).collect();
                t.exact(
                    "intermediate.depth_order",
                    &c.name,
                    &mine,
                    &node.ints(&[super::json::ANY])?,
                    &index_name(1),
                );
            }
            _ => {
                let mine: Vec<f64> = match key {
                    "means2d" => pre.means2d.iter().flat_map(|m| m.to_array()).collect(),
                    "depths" => pre.depths.clone(),
                    "conics" => pre.conics.concat(),
                    "cov2d_blurred" => blurred.clone(),
                    "compensations" => pre.compensations.clone(),
                    "colors" => pre.colors.concat(),
                    _ => pre.opacities.clone(),
                };
                let mask = if key == "depths" {
                    vec![true; n]
                } else {
                    valid.clone()
                };
                t.floats(
                    &format!("intermediate.{key}"),
                    FLOAT,
                    &c.name,
                    &masked(&mine, w, &mask),
                    &masked(&node.nums(shape)?, w, &mask),
                    &masked_name(w, &mask),
                );
            }
        }
    }
    Ok(())
}

fn outputs(t: &mut Tally, c: &Setup, case: &Node<'_>) -> Res<(Vec<f64>, Vec<f64>)> {
    let (w, h) = (c.cam.width, c.cam.height);
    let out = case.get("outputs")?;
    let r = &c.fwd.raster;
    let img = |k: usize| index_name(k);
    t.floats(
        "outputs.render_rgb",
        IMAGE,
        &c.name,
        r.rgb.data(),
        &out.get("render_rgb")?.nums(&[h, w, 3])?,
        &move |i| format!("[{}][{}][{}]", i / (3 * w), (i / 3) % w, i % 3),
    );
    t.floats(
        "outputs.render_alpha",
        IMAGE,
        &c.name,
        &r.alpha,
        &out.get("render_alpha")?.nums(&[h, w])?,
        &img(w),
    );
    let nc: Vec<i64> = r.n_contrib.iter().map(|&v| i64::from(v)).collect();
    t.exact(
        "outputs.n_contrib",
        &c.name,
        &nc,
        &out.get("n_contrib")?.ints(&[h, w])?,
        &img(w),
    );
    t.exact(
        "outputs.terminated",
        &c.name,
        &bools_as_ints(&r.terminated),
        &bools_as_ints(&out.get("terminated")?.bools(&[h, w])?),
        &img(w),
    );
    let loss = case.get("loss")?;
    let w_rgb = loss.get("W_rgb")?.nums(&[h, w, 3])?;
    let w_alpha = loss.get("W_alpha")?.nums(&[h, w])?;
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let l_rgb = dot(r.rgb.data(), &w_rgb);
    let l_total = l_rgb + dot(&r.alpha, &w_alpha);
    let none = |_: usize| String::new();
    t.floats(
        "loss.L_rgb",
        IMAGE,
        &c.name,
        &[l_rgb],
        &[loss.get("L_rgb")?.f64()?],
        &none,
    );
    t.floats(
        "loss.L_total",
        IMAGE,
        &c.name,
        &[l_total],
        &[loss.get("L_total")?.f64()?],
        &none,
    );
    Ok((w_rgb, w_alpha))
}

/// The arrays of one `grads.*` object: parameters then rasterizer inputs.
fn grad_arrays(c: &Setup, g: &RenderGrad<f64>) -> Vec<(&'static str, Vec<f64>, usize)> {
    let s = &g.splats;
    let (vm, pose) = camera_grads(&g.camera, &c.cam);
    let k = s.coeffs_per_gaussian();
    vec![
        ("params.means", flat3(&s.means), 3),
        ("params.quats", flat4(&s.quats), 4),
        ("params.scales", scale_grads(&c.s, &s.log_scales), 3),
        (
            "params.opacities",
            opacity_grads(&c.s, &s.opacity_logits),
            1,
        ),
        ("params.sh_coeffs", s.sh.concat(), 3 * k),
        ("params.viewmat", vm, 4),
        ("params.pose_left_se3", pose, 1),
        (
            "raster_inputs.means2d",
            g.raster.means2d.iter().flat_map(|m| m.to_array()).collect(),
            2,
        ),
        ("raster_inputs.conics", g.raster.conics.concat(), 3),
        ("raster_inputs.colors", g.raster.colors.concat(), 3),
        (
            "raster_inputs.opacities_effective",
            g.raster.opacities.clone(),
            1,
        ),
    ]
}

fn gradients(
    t: &mut Tally,
    c: &Setup,
    grads: &Node<'_>,
    w_rgb: &[f64],
    w_alpha: &[f64],
) -> Res<()> {
    let n = c.s.len();
    let k = c.s.coeffs_per_gaussian();
    for (label, with_alpha) in [("total", true), ("rgb_only", false)] {
        let d = PixelGrad {
            rgb: w_rgb,
            alpha: with_alpha.then_some(w_alpha),
            depth: None,
        };
        let g = render_vjp(&c.s, &c.cam, &c.opts, &c.fwd, &d);
        let node = grads.get(label)?;
        for (key, mine, w) in grad_arrays(c, &g) {
            let (group, name) = key.split_once('.').unwrap_or(("params", key));
            let shape: Vec<usize> = match name {
                "viewmat" => vec![4, 4],
                "pose_left_se3" => vec![6],
                "sh_coeffs" => vec![n, k, 3],
                _ if w == 1 => vec![n],
                _ => vec![n, w],
            };
            let reference = node.get(group)?.get(name)?.nums(&shape)?;
            t.floats(
                &format!("grads.{label}.{key}"),
                GRAD,
                &c.name,
                &mine,
                &reference,
                &index_name(w),
            );
        }
    }
    Ok(())
}

fn decision_rows(t: &mut Tally, c: &Setup, case: &Node<'_>) -> Res<()> {
    let d: Decisions = decisions(&c.fwd.pre, &c.s, &c.cam, &c.opts);

    let counts = case.get("decision_counts")?;
    for (key, mine) in [
        ("n_composited", d.n_composited),
        ("n_alpha_clamped", d.n_alpha_clamped),
        ("n_terminations", d.n_terminations),
        ("n_skipped_low_alpha", d.n_skipped_low_alpha),
    ] {
        let mine = i64::try_from(mine).unwrap_or(i64::MAX);
        t.exact(
            &format!("decision_counts.{key}"),
            &c.name,
            &[mine],
            &[i64::try_from(counts.get(key)?.usize()?).unwrap_or(i64::MAX)],
            &|_| String::new(),
        );
    }
    let margins = case.get("decision_margins")?;
    for (key, mine) in [
        ("alpha_threshold_rel", d.alpha_threshold_rel),
        ("alpha_clamp_abs", d.alpha_clamp_abs),
        ("transmittance_rel", d.transmittance_rel),
        ("sh_clamp_abs", d.sh_clamp_abs),
    ] {
        t.floats(
            &format!("decision_margins.{key}"),
            FLOAT,
            &c.name,
            &[mine],
            &[margins.get(key)?.f64()?],
            &|_| String::new(),
        );
    }
    Ok(())
}

/// Recomputes a raster file.
pub(crate) fn verify(root: &Node<'_>) -> Res<(usize, Vec<Row>)> {
    let case = root.get("case")?;
    let c = setup(&case)?;
    let mut t = Tally::default();
    intermediate(&mut t, &c, &case.get("intermediate")?)?;
    let (w_rgb, w_alpha) = outputs(&mut t, &c, &case)?;
    gradients(&mut t, &c, &case.get("grads")?, &w_rgb, &w_alpha)?;
    decision_rows(&mut t, &c, &case)?;
    let im_keys: Vec<&str> = INTERMEDIATE.iter().map(|k| k.0).collect();
    for (obj, known) in [
        ("intermediate", im_keys),
        (
            "outputs",
            vec!["render_rgb", "render_alpha", "n_contrib", "terminated"],
        ),
        ("grads", vec!["total", "rgb_only"]),
    ] {
        for key in case.get(obj)?.keys() {
            if !known.contains(&key) {
                t.fail(
                    &format!("{obj}.{key}"),
                    "unrecognised quantity: not recomputed",
                );
            }
        }
    }
    Ok((1, t.into_rows()))
}
