//! evogs-splat VJPs: projection (with the camera's left se(3) pose), SH colour, the reference
//! rasterizer's backward, SSIM and L1, and the full `render_vjp` in classic and antialiased
//! mode. Raster scenes are resampled until every per-pixel decision is far from its
//! threshold ([`pixel_decisions`]), as the reference vectors are.

use super::{GradRow, Kernel, check_kernel, uniform};
use crate::verify::decisions::{Decisions, pixel_decisions, sh_decisions};
use evogs_math::activation::logit;
use evogs_math::rng::SplitMix64;
use evogs_math::so3::exp_matrix;
use evogs_math::so3_jacobians::left_jacobian;
use evogs_math::{Quat, Real, Vec2, Vec3};
use evogs_splat::loss::{l1, l1_vjp};
use evogs_splat::ssim::{d_ssim, d_ssim_vjp};
use evogs_splat::{
    Image, PinholeCamera, PixelGrad, Preprocessed, ProjectOptions, ProjectedGrad, RadiusMode,
    RasterInputGrad, RasterMode, RenderOptions, Splats, project, project_vjp, rasterize_ref,
    rasterize_ref_vjp, render, render_vjp, sh_color, sh_color_vjp,
};

/// The camera moved by a left se(3) perturbation `ξ = (ρ, φ)`: `V' = Exp(ξ^)·V`.
fn perturb<T: Real>(cam: &PinholeCamera<f64>, xi: &[T]) -> PinholeCamera<T> {
    let mut c = cam.cast::<T>();
    let (rho, phi) = (Vec3::from_slice(xi), Vec3::from_slice(&xi[3..]));
    let e = exp_matrix(phi);
    c.rotation = e.mul_mat(c.rotation);
    c.translation = e.mul_vec(c.translation) + left_jacobian(phi).mul_vec(rho);
    c
}

fn camera(w: usize, h: usize) -> PinholeCamera<f64> {
    let mut c = PinholeCamera::look_at(
        Vec3::new(0.4, -0.3, 2.6),
        Vec3::new(0.05, 0.0, 0.0),
        Vec3::new(0.05, 1.0, 0.0),
        0.9,
        w,
        h,
    )
    .expect("check camera");
    c.cx += 0.7;
    c.cy -= 0.4;
    c
}

/// `[mean, log-scale, quaternion, ξ] → [means2d, depth, conic, compensation]`.
struct Project {
    cam: PinholeCamera<f64>,
    opacity: f64,
}

fn popts<T: Real>() -> ProjectOptions<T> {
    ProjectOptions {
        eps2d: T::from_f64(0.3),
        radius: RadiusMode::Plain,
        antialiased: false,
    }
}

impl Kernel for Project {
    fn n_in(&self) -> usize {
        16
    }
    fn n_out(&self) -> usize {
        7
    }
    fn eval<T: Real>(&self, x: &[T], out: &mut [T]) {
        let cam = perturb(&self.cam, &x[10..]);
        let p = project(
            Vec3::from_slice(x),
            Vec3::from_slice(&x[3..]),
            Quat::from_slice(&x[6..]),
            T::from_f64(self.opacity),
            &cam,
            &popts(),
        );
        out[..2].copy_from_slice(&p.means2d.to_array());
        out[2] = p.depth;
        out[3..6].copy_from_slice(&p.conic);
        out[6] = p.compensation;
    }
    fn vjp(&self, x: &[f64], w: &[f64], d: &mut [f64]) {
        let g = project_vjp(
            Vec3::from_slice(x),
            Vec3::from_slice(&x[3..]),
            Quat::from_slice(&x[6..]),
            self.opacity,
            &self.cam,
            &popts(),
            &ProjectedGrad {
                means2d: Vec2::new(w[0], w[1]),
                depth: w[2],
                conic: [w[3], w[4], w[5]],
                compensation: w[6],
            },
        );
        d[..3].copy_from_slice(&g.mean.to_array());
        d[3..6].copy_from_slice(&g.log_scale.to_array());
        d[6..10].copy_from_slice(&g.quat.to_array());
        d[10..].copy_from_slice(&g.camera.to_pose_left_se3(&self.cam));
    }
}

/// `[16 RGB coefficients, mean, camera centre] → colour` (degree 3).
struct ShColor;

fn coeffs<T: Real>(x: &[T]) -> Vec<[T; 3]> {
    x[..48].chunks(3).map(|c| [c[0], c[1], c[2]]).collect()
}

impl Kernel for ShColor {
    fn n_in(&self) -> usize {
        54
    }
    fn n_out(&self) -> usize {
        3
    }
    fn eval<T: Real>(&self, x: &[T], out: &mut [T]) {
        let c = sh_color(
            3,
            &coeffs(x),
            Vec3::from_slice(&x[48..]),
            Vec3::from_slice(&x[51..]),
        );
        out.copy_from_slice(&c);
    }
    fn vjp(&self, x: &[f64], w: &[f64], d: &mut [f64]) {
        let mut dc = vec![[0.0; 3]; 16];
        let (dm, dcam) = sh_color_vjp(
            3,
            &coeffs(x),
            Vec3::from_slice(&x[48..]),
            Vec3::from_slice(&x[51..]),
            [w[0], w[1], w[2]],
            &mut dc,
        );
        d[..48].copy_from_slice(&dc.concat());
        d[48..51].copy_from_slice(&dm.to_array());
        d[51..].copy_from_slice(&dcam.to_array());
    }
}

/// The reference rasterizer: `[means2d, conics, colours, opacities, background] → [rgb, alpha]`.
struct Raster {
    w: usize,
    h: usize,
    n: usize,
    depths: Vec<f64>,
}

impl Raster {
    fn pre<T: Real>(&self, x: &[T]) -> (Preprocessed<T>, [T; 3]) {
        let n = self.n;
        let (m, rest) = x.split_at(2 * n);
        let (c, rest) = rest.split_at(3 * n);
        let (col, rest) = rest.split_at(3 * n);
        let (op, bg) = rest.split_at(n);
        let mut order: Vec<u32> = (0..u32::try_from(n).unwrap_or(0)).collect();
        order.sort_by(|&a, &b| self.depths[a as usize].total_cmp(&self.depths[b as usize]));
        let pre = Preprocessed {
            width: self.w,
            height: self.h,
            means2d: m.chunks(2).map(|v| Vec2::new(v[0], v[1])).collect(),
            conics: c.chunks(3).map(|v| [v[0], v[1], v[2]]).collect(),
            colors: col.chunks(3).map(|v| [v[0], v[1], v[2]]).collect(),
            opacities: op.to_vec(),
            depths: self.depths.iter().map(|&d| T::from_f64(d)).collect(),
            radii: vec![[100, 100]; n],
            valid: vec![true; n],
            compensations: vec![T::ONE; n],
            order,
        };
        (pre, [bg[0], bg[1], bg[2]])
    }

    fn n_pixels(&self) -> usize {
        self.w * self.h
    }
}

impl Kernel for Raster {
    fn n_in(&self) -> usize {
        9 * self.n + 3
    }
    fn n_out(&self) -> usize {
        4 * self.n_pixels()
    }
    fn eval<T: Real>(&self, x: &[T], out: &mut [T]) {
        let (pre, bg) = self.pre(x);
        let r = rasterize_ref(&pre, bg);
        let np = 3 * self.n_pixels();
        out[..np].copy_from_slice(r.rgb.data());
        out[np..].copy_from_slice(&r.alpha);
    }
    fn vjp(&self, x: &[f64], w: &[f64], d: &mut [f64]) {
        let (pre, bg) = self.pre(x);
        let fwd = rasterize_ref(&pre, bg);
        let np = 3 * self.n_pixels();
        let mut g = RasterInputGrad::zeros(self.n);
        let d_bg = rasterize_ref_vjp(
            &pre,
            bg,
            &fwd,
            &PixelGrad {
                rgb: &w[..np],
                alpha: Some(&w[np..]),
                depth: None,
            },
            &mut g,
        );
        let flat: Vec<f64> = g
            .means2d
            .iter()
            .flat_map(|v| v.to_array())
            .chain(g.conics.concat())
            .chain(g.colors.concat())
            .chain(g.opacities.iter().copied())
            .chain(d_bg)
            .collect();
        d.copy_from_slice(&flat);
    }
}

/// Every decision margin comfortably above the central-difference step.
fn far_from_thresholds(d: &Decisions) -> bool {
    d.alpha_threshold_rel > 1e-3 && d.transmittance_rel > 1e-3 && d.alpha_clamp_abs > 1e-4
}

/// A raster scene with two nearly opaque Gaussians (clamped alpha, early termination), away
/// from every threshold.
fn raster_scene(seed: u64) -> (Raster, Vec<f64>, Decisions) {
    let (w, h, n) = (12, 10, 7);
    for attempt in 0..1000 {
        let mut rng = SplitMix64::new(seed + attempt);
        let mut x = Vec::new();
        for _ in 0..n {
            x.extend([rng.uniform(2.0, 10.0), rng.uniform(2.0, 8.0)]);
        }
        for _ in 0..n {
            // Inverse of a random covariance with standard deviations of 1.2–3 px.
            let (sx, sy) = (rng.uniform(1.2, 3.0), rng.uniform(1.2, 3.0));
            let rho = rng.uniform(-0.6, 0.6);
            let (a, b, c) = (sx * sx, rho * sx * sy, sy * sy);
            let det = a * c - b * b;
            x.extend([c / det, -b / det, a / det]);
        }
        x.extend(uniform(&mut rng, 3 * n, 0.05, 1.0));
        x.extend(uniform(&mut rng, n - 2, 0.2, 0.9));
        x.extend([0.9995, 0.9997]);
        x.extend([0.1, 0.3, 0.2]);
        let r = Raster {
            w,
            h,
            n,
            depths: uniform(&mut rng, n, 1.0, 5.0),
        };
        let d = pixel_decisions(&r.pre(&x).0);
        if far_from_thresholds(&d) && d.n_terminations > 0 && d.n_alpha_clamped > 0 {
            return (r, x, d);
        }
    }
    panic!("no raster scene away from the thresholds in 1000 attempts");
}

/// `D-SSIM(a, b)` or `L1(a, b)` as a function of `a`.
struct Photometric {
    b: Image<f64>,
    ssim: bool,
}

impl Kernel for Photometric {
    fn n_in(&self) -> usize {
        self.b.data().len()
    }
    fn n_out(&self) -> usize {
        1
    }
    fn eval<T: Real>(&self, x: &[T], out: &mut [T]) {
        let a = Image::from_vec(self.b.width(), self.b.height(), x.to_vec()).expect("size");
        let b = self.b.cast::<T>();
        out[0] = if self.ssim {
            d_ssim(&a, &b)
        } else {
            l1(&a, &b)
        };
    }
    fn vjp(&self, x: &[f64], w: &[f64], d: &mut [f64]) {
        let a = Image::from_vec(self.b.width(), self.b.height(), x.to_vec()).expect("size");
        let mut g = Image::new(a.width(), a.height());
        if self.ssim {
            d_ssim_vjp(&a, &self.b, w[0], &mut g);
        } else {
            l1_vjp(&a, &self.b, w[0], &mut g);
        }
        d.copy_from_slice(g.data());
    }
}

/// The full chain `render`: `[flat Splats parameters, ξ] → [rgb, alpha]`.
struct RenderChain {
    splats: Splats<f64>,
    cam: PinholeCamera<f64>,
    opts: RenderOptions<f64>,
}

impl RenderChain {
    fn opts<T: Real>(&self) -> RenderOptions<T> {
        RenderOptions {
            eps2d: T::from_f64(self.opts.eps2d),
            radius: self.opts.radius,
            mode: self.opts.mode,
            sh_degree: self.opts.sh_degree,
            background: self.opts.background.map(T::from_f64),
            par: self.opts.par,
        }
    }

    fn n_pixels(&self) -> usize {
        self.cam.width * self.cam.height
    }
}

impl Kernel for RenderChain {
    fn n_in(&self) -> usize {
        self.splats.flat_len() + 6
    }
    fn n_out(&self) -> usize {
        4 * self.n_pixels()
    }
    fn eval<T: Real>(&self, x: &[T], out: &mut [T]) {
        let nf = self.splats.flat_len();
        let mut s = self.splats.cast::<T>();
        s.read_flat(&x[..nf]);
        let cam = perturb(&self.cam, &x[nf..]);
        let r = render(&s, &cam, &self.opts());
        let np = 3 * self.n_pixels();
        out[..np].copy_from_slice(r.raster.rgb.data());
        out[np..].copy_from_slice(&r.raster.alpha);
    }
    fn vjp(&self, x: &[f64], w: &[f64], d: &mut [f64]) {
        let nf = self.splats.flat_len();
        let mut s = self.splats.clone();
        s.read_flat(&x[..nf]);
        let fwd = render(&s, &self.cam, &self.opts);
        let np = 3 * self.n_pixels();
        let g = render_vjp(
            &s,
            &self.cam,
            &self.opts,
            &fwd,
            &PixelGrad {
                rgb: &w[..np],
                alpha: Some(&w[np..]),
                depth: None,
            },
        );
        let mut flat = Vec::new();
        g.splats.write_flat(&mut flat);
        d[..nf].copy_from_slice(&flat);
        d[nf..].copy_from_slice(&g.camera.to_pose_left_se3(&self.cam));
    }
}

/// A random scene of `n` Gaussians (SH degree 3) in front of [`camera`].
pub(crate) fn random_splats(rng: &mut SplitMix64, n: usize) -> Splats<f64> {
    let mut s = Splats::new(3);
    for _ in 0..n {
        let mean = Vec3::new(
            rng.uniform(-0.5, 0.5),
            rng.uniform(-0.4, 0.4),
            rng.uniform(-0.4, 0.4),
        );
        let ls = Vec3::new(
            rng.uniform(-2.8, -1.6),
            rng.uniform(-2.8, -1.6),
            rng.uniform(-2.8, -1.6),
        );
        let q = Quat::new(rng.normal(), rng.normal(), rng.normal(), rng.normal());
        let mut sh = [[0.0; 3]; 16];
        for (k, c) in sh.iter_mut().enumerate() {
            for v in c.iter_mut() {
                *v = if k == 0 {
                    rng.uniform(0.2, 1.5)
                } else {
                    0.15 * rng.normal()
                };
            }
        }
        s.push(mean, ls, q, logit(rng.uniform(0.3, 0.9)), &sh);
    }
    s
}

fn render_chain(mode: RasterMode, seed: u64) -> RenderChain {
    let cam = camera(14, 11);
    let opts = RenderOptions {
        mode,
        sh_degree: 3,
        background: [0.2, 0.1, 0.3],
        ..RenderOptions::default()
    };
    for attempt in 0..1000 {
        let mut rng = SplitMix64::new(seed + attempt);
        let splats = random_splats(&mut rng, 8);
        let pre = evogs_splat::preprocess(&splats, &cam, &opts);
        if pre.order.len() == 8
            && far_from_thresholds(&pixel_decisions(&pre))
            && sh_decisions(&pre, &splats, &cam, &opts) > 1e-3
        {
            return RenderChain { splats, cam, opts };
        }
    }
    panic!("no render scene away from the thresholds in 1000 attempts");
}

/// The projection of a point `[mean, log-scale, quaternion, …]` (opacity 0.7).
fn project_point(x: &[f64], cam: &PinholeCamera<f64>) -> evogs_splat::Projected<f64> {
    project(
        Vec3::from_slice(x),
        Vec3::from_slice(&x[3..]),
        Quat::from_slice(&x[6..]),
        0.7,
        cam,
        &popts(),
    )
}

pub(super) fn rows() -> Vec<GradRow> {
    let mut rng = SplitMix64::new(0x7370_6c61);
    let cam = camera(64, 48);
    // Inside the view, a needle, a tiny one, and a large one beyond the FOV clamp (still
    // valid: culled Gaussians have a zero VJP by definition); ξ = 0.
    let mut proj: Vec<Vec<f64>> = [
        ([0.1, -0.1, 0.2], [-1.5, -2.0, -1.8]),
        ([-0.3, 0.2, 0.0], [-0.3, -5.5, -5.3]),
        ([0.3, 0.25, 0.3], [-6.0, -6.2, -5.8]),
    ]
    .iter()
    .map(|(m, ls)| {
        let mut x = m.to_vec();
        x.extend(ls);
        x.extend(uniform(&mut rng, 4, -1.0, 1.0));
        x.extend([0.0; 6]);
        x
    })
    .collect();
    let clamped = (1..200)
        .map(|k| {
            let mut x = vec![0.4 + 0.05 * f64::from(k), 0.2, -0.3, -0.2, -0.4, -0.3];
            x.extend([0.9, 0.1, -0.2, 0.3]);
            x.extend([0.0; 6]);
            x
        })
        .find(|x| {
            let p = project_point(x, &cam);
            p.valid && p.fov_clamped[0]
        })
        .expect("a valid Gaussian beyond the FOV clamp");
    proj.push(clamped);
    for x in &proj {
        assert!(
            project_point(x, &cam).valid,
            "check-grad projection points are valid"
        );
    }
    let sh: Vec<Vec<f64>> = (0..3)
        .map(|_| {
            let mut x = uniform(&mut rng, 48, -0.15, 0.15);
            for v in &mut x[..3] {
                *v = rng.uniform(0.5, 1.5);
            }
            x.extend(uniform(&mut rng, 3, -0.5, 0.5));
            x.extend(cam.center().to_array());
            x
        })
        .collect();
    let (raster, rx, _) = raster_scene(17);
    let (iw, ih) = (14, 12);
    let img = |rng: &mut SplitMix64| {
        Image::from_vec(iw, ih, uniform(rng, iw * ih * 3, 0.0, 1.0)).expect("size")
    };
    let b = img(&mut rng);
    let a = img(&mut rng).data().to_vec();
    let chain = |mode, seed| {
        let c = render_chain(mode, seed);
        let mut x = Vec::new();
        c.splats.write_flat(&mut x);
        x.extend([0.0; 6]);
        (c, x)
    };
    let (classic, xc) = chain(RasterMode::Classic, 100);
    let (aa, xa) = chain(RasterMode::Antialiased, 200);
    vec![
        check_kernel(
            "splat: project_vjp (+ camera pose)",
            &Project { cam, opacity: 0.7 },
            &proj,
            11,
        ),
        check_kernel("splat: sh_color_vjp (degree 3)", &ShColor, &sh, 12),
        check_kernel(
            "splat: rasterize_ref_vjp (clamp, stops)",
            &raster,
            &[rx],
            13,
        ),
        check_kernel(
            "splat: d_ssim_vjp",
            &Photometric {
                b: b.clone(),
                ssim: true,
            },
            core::slice::from_ref(&a),
            14,
        ),
        check_kernel("splat: l1_vjp", &Photometric { b, ssim: false }, &[a], 15),
        check_kernel("splat: render_vjp (classic)", &classic, &[xc], 16),
        check_kernel("splat: render_vjp (antialiased)", &aa, &[xa], 17),
    ]
}
