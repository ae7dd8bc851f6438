//! The properties of the seeded fuzz test, one case per call. Every function panics (with
//! the seed in the message) when a property fails.
//!
//! - [`projection_case`]: one Gaussian, ordinary or extreme (huge and tiny scales, zero
//!   quaternions, behind the camera, at the camera centre, inside the near plane, beyond the
//!   far plane, NaN/∞ components), through `project` in every radius/antialiasing mode and
//!   `project_vjp`: never a NaN or ∞ in the outputs (the documented contract), radii only
//!   for valid Gaussians, a zero VJP for culled ones, a finite VJP for finite inputs.
//! - [`raster_case`]: a small scene of ordinary Gaussians plus a few odd ones through
//!   `preprocess` + `rasterize_ref` and `rasterize_ref_vjp` + `preprocess_vjp`: finite
//!   images; finite gradients for finite inputs; a Gaussian with a NaN/∞ input that is culled
//!   changes nothing (the images and the other Gaussians' gradients equal those of the scene
//!   without it, bit for bit) and the other Gaussians' gradients stay finite in any case.
//! - [`so3_case`]: exp/log maps, Jacobians and exp updates with their VJPs on rotation
//!   vectors from 1e-300 to 1e300 and non-finite ones: finite where the map is defined for
//!   finite input (`|φ| ≤ 1e6` for the exponentials; `|φ| < 2π − 10⁻³` for `Jl⁻¹`, which is
//!   singular at 2π), unit quaternions and orthonormal matrices, `exp(log(R)) = R`.

use crate::Gen;
use evogs_math::so3::{exp_matrix, exp_quat, log_matrix, log_quat};
use evogs_math::so3_jacobians::{
    exp_quat_vjp, jl_inv_mul, jl_inv_mul_vjp, left_jacobian, left_jacobian_inv, right_jacobian,
};
use evogs_math::update::{
    exp_update_left, exp_update_left_vjp, exp_update_right, exp_update_right_vjp,
};
use evogs_math::{Mat3, Quat, Vec2, Vec3};
use evogs_splat::{
    PinholeCamera, PixelGrad, ProjectOptions, Projected, ProjectedGrad, RadiusMode,
    RasterInputGrad, RasterMode, RenderOptions, Splats, preprocess, preprocess_vjp, project,
    project_vjp, rasterize_ref, rasterize_ref_vjp,
};

fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn camera(g: &mut Gen, w: usize, h: usize) -> PinholeCamera<f64> {
    let eye = g.normal3() * 3.0 + Vec3::new(0.0, 0.0, 4.0);
    let target = g.normal3() * 0.3;
    let up = Vec3::new(g.uniform(-0.2, 0.2), 1.0, g.uniform(-0.2, 0.2));
    PinholeCamera::look_at(eye, target, up, g.uniform(0.3, 2.5), w, h)
        .unwrap_or_else(|e| panic!("fuzz camera: {e}"))
}

/// A world point at depth `z` on the camera's viewing ray through normalised image
/// coordinates `(u, v)`.
fn at_depth(cam: &PinholeCamera<f64>, u: f64, v: f64, z: f64) -> Vec3<f64> {
    let p_cam = Vec3::new(u * z, v * z, z);
    cam.rotation.tr_mul_vec(p_cam - cam.translation)
}

/// One Gaussian: mean, log-scale, raw quaternion, opacity logit.
type Raw = (Vec3<f64>, Vec3<f64>, Quat<f64>, f64);

fn odd_gaussian(g: &mut Gen, cam: &PinholeCamera<f64>, non_finite: bool) -> Raw {
    let (u, v) = (g.uniform(-0.6, 0.6), g.uniform(-0.6, 0.6));
    let mean = match g.below(9) {
        0 => at_depth(cam, u, v, -g.uniform(0.1, 5.0)), // behind the camera
        1 => cam.center(),                              // at the camera centre
        2 => at_depth(cam, u, v, 1e-3),                 // inside the near plane
        3 => at_depth(cam, u, v, 1e11),                 // beyond the far plane
        4 => at_depth(cam, 40.0 * u, 40.0 * v, 2.0),    // far outside the field of view
        5 => at_depth(cam, u, v, 1e-12),                // on the camera plane
        _ => at_depth(cam, u, v, g.uniform(1.0, 8.0)),
    };
    let mean = Vec3::from_array(mean.to_array().map(|c| g.maybe_extreme(c, 0.1, non_finite)));
    let mut ls = Vec3::new(
        g.uniform(-4.0, 0.5),
        g.uniform(-4.0, 0.5),
        g.uniform(-4.0, 0.5),
    );
    match g.below(6) {
        0 => ls = Vec3::splat(g.uniform(-40.0, -10.0)), // tiny
        1 => ls = Vec3::splat(g.uniform(5.0, 400.0)),   // huge
        2 => ls.x = g.uniform(3.0, 8.0),                // needle
        _ => {}
    }
    let ls = Vec3::from_array(ls.to_array().map(|c| g.maybe_extreme(c, 0.1, non_finite)));
    let mut q = g.quat();
    if g.chance(0.1) {
        q.x = g.maybe_extreme(q.x, 1.0, non_finite);
    }
    let op = g.uniform(-6.0, 6.0);
    let op = g.maybe_extreme(op, 0.1, non_finite);
    (mean, ls, q, op)
}

fn raw_finite(r: &Raw) -> bool {
    r.0.is_finite() && r.1.is_finite() && r.2.is_finite() && r.3.is_finite()
}

fn projected_floats(p: &Projected<f64>) -> Vec<f64> {
    let mut v = p.mean_cam.to_array().to_vec();
    v.extend(p.means2d.to_array());
    v.extend([p.depth, p.cov2d.xx, p.cov2d.xy, p.cov2d.yy, p.compensation]);
    v.extend(p.conic);
    v
}

/// One projection case (see the module docs).
///
/// # Panics
/// When a property fails.
pub fn projection_case(seed: u64) {
    let mut g = Gen::new(seed);
    let cam = camera(&mut g, 64, 48);
    let non_finite = g.chance(0.3);
    let raw = odd_gaussian(&mut g, &cam, non_finite);
    let (mean, ls, q, op_logit) = raw;
    let op = evogs_math::activation::sigmoid(op_logit);
    let d = ProjectedGrad {
        means2d: Vec2::new(g.normal(), g.normal()),
        depth: g.normal(),
        conic: [g.normal(), g.normal(), g.normal()],
        compensation: g.normal(),
    };
    for radius in [RadiusMode::Plain, RadiusMode::OpacityAware] {
        for antialiased in [false, true] {
            let o = ProjectOptions {
                eps2d: 0.3,
                radius,
                antialiased,
            };
            let p = project(mean, ls, q, op, &cam, &o);
            let what = format!("seed {seed}: {raw:?} {radius:?} aa={antialiased}");
            assert!(
                finite(&projected_floats(&p)),
                "{what}: non-finite projection {p:?}"
            );
            assert!(
                p.valid == (p.radii != [0, 0]),
                "{what}: radii {:?} but valid = {}",
                p.radii,
                p.valid
            );
            if p.valid {
                assert!(
                    p.depth > cam.near && p.depth < cam.far,
                    "{what}: valid depth"
                );
            }
            let gr = project_vjp(mean, ls, q, op, &cam, &o, &d);
            let mut gv = gr.mean.to_array().to_vec();
            gv.extend(gr.log_scale.to_array());
            gv.extend(gr.quat.to_array());
            gv.extend(gr.camera.to_viewmat().concat());
            if !p.valid {
                assert!(
                    gv.iter().all(|&x| x == 0.0),
                    "{what}: culled Gaussian with a non-zero VJP {gv:?}"
                );
            }
            if raw_finite(&raw) {
                assert!(finite(&gv), "{what}: non-finite VJP {gv:?} for {p:?}");
            }
        }
    }
}

/// The images and gradients of one raster run.
struct RasterRun {
    images: Vec<f64>,
    valid: Vec<bool>,
    /// Flat parameter gradient per Gaussian.
    grads: Vec<Vec<f64>>,
    camera: Vec<f64>,
}

fn run_raster(
    s: &Splats<f64>,
    cam: &PinholeCamera<f64>,
    opts: &RenderOptions<f64>,
    d_rgb: &[f64],
    d_alpha: &[f64],
    d_depth: &[f64],
) -> RasterRun {
    let pre = preprocess(s, cam, opts);
    let out = rasterize_ref(&pre, opts.background);
    let mut images = out.rgb.data().to_vec();
    images.extend(&out.alpha);
    images.extend(&out.depth);
    images.extend(&out.final_t);
    let mut rg = RasterInputGrad::zeros(s.len());
    let d = PixelGrad {
        rgb: d_rgb,
        alpha: Some(d_alpha),
        depth: Some(d_depth),
    };
    let d_bg = rasterize_ref_vjp(&pre, opts.background, &out, &d, &mut rg);
    images.extend(d_bg);
    let mut grad = s.zeros_like();
    let cg = preprocess_vjp(s, cam, opts, &pre, &rg, &mut grad);
    let k = grad.coeffs_per_gaussian();
    let grads = (0..s.len())
        .map(|i| {
            let mut v = grad.means[i].to_array().to_vec();
            v.extend(grad.log_scales[i].to_array());
            v.extend(grad.quats[i].to_array());
            v.push(grad.opacity_logits[i]);
            v.extend(grad.sh[i * k..(i + 1) * k].concat());
            v.extend(rg.means2d[i].to_array());
            v.extend(rg.conics[i]);
            v.extend(rg.colors[i]);
            v.push(rg.opacities[i]);
            v
        })
        .collect();
    RasterRun {
        images,
        valid: pre.valid,
        grads,
        camera: cg.to_viewmat().concat(),
    }
}

/// One rasterization case (see the module docs).
///
/// # Panics
/// When a property fails.
pub fn raster_case(seed: u64) {
    let mut g = Gen::new(seed);
    let (w, h) = (16, 12);
    let cam = camera(&mut g, w, h);
    let degree = g.below(4);
    let k = (degree + 1) * (degree + 1);
    let mut s = Splats::new(degree);
    let mut sh = vec![[0.0; 3]; k];
    let mut odd_finite = Vec::new();
    let n_ordinary = 3 + g.below(5);
    let n_odd = 1 + g.below(3);
    let non_finite = g.chance(0.4);
    for i in 0..n_ordinary + n_odd {
        for c in sh.iter_mut().flatten() {
            *c = 0.4 * g.normal();
        }
        let raw = if i < n_ordinary {
            let m = at_depth(
                &cam,
                g.uniform(-0.5, 0.5),
                g.uniform(-0.4, 0.4),
                g.uniform(2.0, 6.0),
            );
            let ls = Vec3::new(
                g.uniform(-3.0, -1.0),
                g.uniform(-3.0, -1.0),
                g.uniform(-3.0, -1.0),
            );
            (
                m,
                ls,
                g.quat() + Quat::new(1.0, 0.0, 0.0, 0.0),
                g.uniform(-2.0, 4.0),
            )
        } else {
            if non_finite && g.chance(0.2) {
                let j = g.below(3 * k);
                sh[j / 3][j % 3] = g.non_finite();
            }
            odd_gaussian(&mut g, &cam, non_finite)
        };
        if i >= n_ordinary {
            odd_finite.push(raw_finite(&raw) && sh.iter().flatten().all(|c| c.is_finite()));
        }
        s.push(raw.0, raw.1, raw.2, raw.3, &sh);
    }
    let opts = RenderOptions {
        radius: if g.chance(0.5) {
            RadiusMode::Plain
        } else {
            RadiusMode::OpacityAware
        },
        mode: if g.chance(0.5) {
            RasterMode::Classic
        } else {
            RasterMode::Antialiased
        },
        sh_degree: g.below(4),
        background: [
            g.uniform(0.0, 1.0),
            g.uniform(0.0, 1.0),
            g.uniform(0.0, 1.0),
        ],
        ..RenderOptions::default()
    };
    let np = w * h;
    let d_rgb: Vec<f64> = (0..3 * np).map(|_| g.normal()).collect();
    let d_alpha: Vec<f64> = (0..np).map(|_| g.normal()).collect();
    let d_depth: Vec<f64> = (0..np).map(|_| g.normal()).collect();
    let r = run_raster(&s, &cam, &opts, &d_rgb, &d_alpha, &d_depth);
    let what = format!("seed {seed}");
    assert!(
        finite(&r.images),
        "{what}: non-finite image or background gradient"
    );
    for i in 0..s.len() {
        let ordinary = i < n_ordinary;
        if ordinary || odd_finite[i - n_ordinary] {
            assert!(
                finite(&r.grads[i]),
                "{what}: non-finite gradient of Gaussian {i} (ordinary: {ordinary}): {:?}",
                r.grads[i]
            );
        }
        if !r.valid[i] {
            assert!(
                r.grads[i].iter().all(|&x| x == 0.0),
                "{what}: culled Gaussian {i} has a gradient"
            );
        }
    }
    let all_finite = odd_finite.iter().all(|&f| f);
    if all_finite {
        assert!(finite(&r.camera), "{what}: non-finite camera gradient");
    }
    // Culled Gaussians with non-finite inputs must not change anything.
    let drop: Vec<bool> = (0..s.len())
        .map(|i| i >= n_ordinary && !odd_finite[i - n_ordinary] && !r.valid[i])
        .collect();
    if drop.iter().any(|&d| d) {
        let kept = s.select((0..s.len()).filter(|&i| !drop[i]));
        let r2 = run_raster(&kept, &cam, &opts, &d_rgb, &d_alpha, &d_depth);
        assert!(
            same_bits(&r.images, &r2.images),
            "{what}: a culled non-finite Gaussian changed the images"
        );
        let others: Vec<&Vec<f64>> = (0..s.len())
            .filter(|&i| !drop[i])
            .map(|i| &r.grads[i])
            .collect();
        assert!(
            others.iter().zip(&r2.grads).all(|(a, b)| same_bits(a, b)),
            "{what}: a culled non-finite Gaussian changed other gradients"
        );
        assert!(
            same_bits(&r.camera, &r2.camera),
            "{what}: a culled non-finite Gaussian changed the camera gradient"
        );
    }
}

/// Bitwise equality (NaN equals NaN; −0 differs from +0 only in sign, compared as equal).
#[allow(clippy::float_cmp, reason = "exact equality is the property")]
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(x, y)| x.to_bits() == y.to_bits() || x == y)
}

fn mat_finite(m: Mat3<f64>) -> bool {
    finite(&m.to_flat())
}

/// One SO(3) case (see the module docs).
///
/// # Panics
/// When a property fails.
pub fn so3_case(seed: u64) {
    let mut g = Gen::new(seed);
    let scales = [
        1e-300,
        1e-150,
        1e-12,
        1e-6,
        1e-3,
        0.5,
        1.0,
        2.5,
        core::f64::consts::PI,
        core::f64::consts::TAU,
        1e3,
        1e6,
    ];
    let dir = g.normal3();
    let mut phi = match g.below(16) {
        0 => Vec3::zero(),
        1 => Vec3::new(core::f64::consts::PI, 0.0, 0.0),
        k if k < 14 => dir * (scales[k - 2] / dir.norm()),
        _ => dir * g.extreme_finite(),
    };
    if g.chance(0.1) {
        phi.y = g.non_finite();
    }
    let what = format!("seed {seed}: φ = {phi:?}");
    // Every map: no panic for any input.
    let q = exp_quat(phi);
    let r = exp_matrix(phi);
    let jl = left_jacobian(phi);
    let jr = right_jacobian(phi);
    let _ = (left_jacobian_inv(phi), jl_inv_mul(phi, dir));
    let norm = phi.norm();
    if phi.is_finite() && norm <= 1e6 {
        assert!(
            (q.norm() - 1.0).abs() < 1e-12,
            "{what}: |exp| = {}",
            q.norm()
        );
        let rrt = r.mul_mat(r.transpose()) - Mat3::identity();
        assert!(rrt.max_abs() < 1e-12, "{what}: R Rᵀ ≠ I");
        assert!(
            mat_finite(jl) && mat_finite(jr),
            "{what}: Jacobians not finite"
        );
        let l = log_quat(q);
        assert!(l.is_finite(), "{what}: log not finite");
        assert!(
            l.norm() <= core::f64::consts::PI + 1e-12,
            "{what}: log angle {}",
            l.norm()
        );
        assert!(
            (exp_quat(l).dot(q).abs() - 1.0).abs() < 1e-12,
            "{what}: exp(log q) ≠ ±q"
        );
        let lm = log_matrix(r);
        assert!(
            lm.is_finite() && (exp_matrix(lm) - r).max_abs() < 1e-11,
            "{what}: exp(log R) ≠ R"
        );
        let gq = Quat::new(g.normal(), g.normal(), g.normal(), g.normal());
        assert!(exp_quat_vjp(phi, gq).is_finite(), "{what}: exp VJP");
        let (q0, dt) = (exp_quat(g.normal3()), g.uniform(-1.0, 1.0));
        let omega = phi * (1.0 / dt.abs().max(1e-3));
        if (omega * dt).norm() <= 1e6 {
            for (u, v) in [
                (
                    exp_update_left(q0, omega, dt),
                    exp_update_left_vjp(q0, omega, dt, gq),
                ),
                (
                    exp_update_right(q0, omega, dt),
                    exp_update_right_vjp(q0, omega, dt, gq),
                ),
            ] {
                assert!((u.norm() - 1.0).abs() < 1e-12, "{what}: update not unit");
                assert!(
                    v.q.is_finite() && v.omega.is_finite() && v.dt.is_finite(),
                    "{what}: update VJP not finite"
                );
            }
        }
    }
    if phi.is_finite() && norm < core::f64::consts::TAU - 1e-3 {
        let ji = left_jacobian_inv(phi);
        assert!(mat_finite(ji), "{what}: Jl⁻¹ not finite");
        let w = g.normal3();
        let (a, b) = jl_inv_mul_vjp(phi, w, g.normal3());
        assert!(
            jl_inv_mul(phi, w).is_finite() && a.is_finite() && b.is_finite(),
            "{what}: Jl⁻¹·ω or its VJP not finite"
        );
        if norm < 3.0 {
            let err = (ji.mul_mat(jl) - Mat3::identity()).max_abs();
            assert!(err < 1e-10, "{what}: Jl⁻¹ Jl ≠ I ({err:e})");
        }
    }
    // log of arbitrary non-zero finite quaternions.
    let p = g.quat();
    if p.is_finite() && p.norm() > 1e-150 {
        let l = log_quat(p);
        assert!(
            l.is_finite() && l.norm() <= core::f64::consts::PI + 1e-12,
            "seed {seed}: log of {p:?} = {l:?}"
        );
    }
}
