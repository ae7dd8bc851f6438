//! Property tests: the tiled rasterizer against the reference rasterizer on random scenes
//! (random sizes including non-multiples of 16 and tiny images, Gaussians straddling tile
//! and image borders, heavy overlap with early termination, opacities near 1 with alpha
//! clamped at 0.999, both radius rules, classic and antialiased opacities).
//!
//! Measures (`b` the reference):
//! - images: elementwise `|a − b| / max(1, |b|)`;
//! - gradients: normwise per array (2D means, conics, colours, opacities, depths,
//!   background), `max_i |a_i − b_i| / max(1, max_i |b_i|)`. Elementwise bounds do not suit
//!   f32 gradients: a conic gradient is a sum of `½dx²·dσ` over hundreds of pixels with
//!   much cancellation, and the two rasterizers sum in different orders, each with a
//!   rounding error of `ε·Σ|terms|` (the tiled one is the more accurate of the two against an
//!   f64 evaluation, see the printed figures).
//!
//! - f64: the forward output is bitwise equal to the reference's; gradients (also
//!   elementwise) and the densification statistics agree to `1e-12` (they differ only in the
//!   order of the sums over pixels, and in `S/(1 − α)` computed as `S·(1/(1 − α))`).
//! - f32, `ExpMode::Exact`: the forward output is bitwise equal to the reference's (the same
//!   expressions); gradients within `1e-5` (the bound).
//! - f32, `ExpMode::Fast`: images and gradients within `1e-5`; every per-pixel decision
//!   (contributor count, last contributor, termination) equals the reference's except at
//!   pixels where the reference's own values lie within 1e-5 (relative) of a threshold —
//!   those scenes are checked for that and otherwise skipped (counted). The expected depth
//!   is compared as accumulated depth `D = depth·(1 − T)` (see the comment there).
//!
//! The proptest runs use a fixed seed, so they are reproducible.

use crate::tiled_common;

use evogs_math::Par;
use evogs_math::Real;
use evogs_splat::raster_ref::{ALPHA_MAX, ALPHA_MIN, T_STOP, conic_sigma, pixel_center};
use evogs_splat::{
    DensifyStats, ExpMode, PixelGrad, Preprocessed, RadiusMode, RasterInputGrad, RasterMode,
    RasterOutput, RenderOptions, TiledRasterizer, preprocess, rasterize_ref, rasterize_ref_vjp,
};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use std::cell::Cell;
use tiled_common::{cotangents, rel_err, scene, to_f64};

/// Everything the comparisons need from one rasterizer run.
struct Run<T> {
    out: RasterOutput<T>,
    grad: RasterInputGrad<T>,
    d_bg: [T; 3],
    stats: DensifyStats<T>,
}

/// The gradient arrays of a run: 2D means, conics, colours, opacities, depths, background.
fn grad_arrays<T: Real>(r: &Run<T>) -> [Vec<f64>; 6] {
    let g = &r.grad;
    [
        g.means2d
            .iter()
            .flat_map(|m| m.to_array())
            .map(|x| x.to_f64())
            .collect(),
        g.conics.iter().flatten().map(|x| x.to_f64()).collect(),
        g.colors.iter().flatten().map(|x| x.to_f64()).collect(),
        to_f64(&g.opacities),
        to_f64(&g.depths),
        to_f64(&r.d_bg),
    ]
}

/// Normwise relative error per gradient array, `max_i |a_i − b_i| / max(1, max_i |b_i|)`,
/// maximised over the arrays.
fn grad_err<T: Real, U: Real>(a: &Run<T>, b: &Run<U>) -> f64 {
    grad_arrays(a)
        .iter()
        .zip(&grad_arrays(b))
        .map(|(x, y)| {
            let scale = y.iter().fold(1.0_f64, |m, v| m.max(v.abs()));
            x.iter()
                .zip(y)
                .map(|(p, q)| (p - q).abs() / scale)
                .fold(
                    0.0,
                    |m, e| if e.is_nan() { f64::INFINITY } else { m.max(e) },
                )
        })
        .fold(0.0, f64::max)
}

/// The f32 rasterizer inputs in f64 (for an f64 evaluation of the same function).
fn widen(p: &Preprocessed<f32>) -> Preprocessed<f64> {
    let c = |v: &[f32]| -> Vec<f64> { v.iter().map(|&x| f64::from(x)).collect() };
    Preprocessed {
        width: p.width,
        height: p.height,
        means2d: p.means2d.iter().map(|m| m.cast()).collect(),
        conics: p.conics.iter().map(|v| v.map(f64::from)).collect(),
        colors: p.colors.iter().map(|v| v.map(f64::from)).collect(),
        opacities: c(&p.opacities),
        depths: c(&p.depths),
        radii: p.radii.clone(),
        valid: p.valid.clone(),
        compensations: c(&p.compensations),
        order: p.order.clone(),
    }
}

fn flat_grad<T: Real>(g: &RasterInputGrad<T>, d_bg: [T; 3]) -> Vec<f64> {
    let mut v: Vec<f64> = g
        .means2d
        .iter()
        .flat_map(|m| m.to_array())
        .map(|x| x.to_f64())
        .collect();
    v.extend(g.conics.iter().flatten().map(|x| x.to_f64()));
    v.extend(g.colors.iter().flatten().map(|x| x.to_f64()));
    v.extend(to_f64(&g.opacities));
    v.extend(to_f64(&g.depths));
    v.extend(d_bg.iter().map(|x| x.to_f64()));
    v
}

fn run_ref<T: Real>(pre: &Preprocessed<T>, bg: [T; 3], d: &PixelGrad<'_, T>) -> Run<T> {
    let out = rasterize_ref(pre, bg);
    let mut grad = RasterInputGrad::zeros(pre.means2d.len());
    let d_bg = rasterize_ref_vjp(pre, bg, &out, d, &mut grad);
    let stats = DensifyStats::from_grad(pre, &grad);
    Run {
        out,
        grad,
        d_bg,
        stats,
    }
}

fn run_tiled<T: Real>(
    pre: &Preprocessed<T>,
    bg: [T; 3],
    d: &PixelGrad<'_, T>,
    exp: ExpMode,
    par: Par,
) -> Run<T> {
    let mut rast = TiledRasterizer::with_exp(exp);
    let out = rast.forward(pre, bg, par);
    let mut grad = RasterInputGrad::zeros(pre.means2d.len());
    let mut stats = DensifyStats::default();
    let d_bg = rast.backward(pre, bg, &out, d, par, &mut grad, &mut stats);
    Run {
        out,
        grad,
        d_bg,
        stats,
    }
}

/// `true` if the reference's values at pixel `p` come within `rel` of a decision threshold
/// (α = 1/255, o'·G = 0.999, next T = 1e-4).
fn near_threshold(pre: &Preprocessed<f32>, p: usize, rel: f64) -> bool {
    let (col, row) = (p % pre.width, p / pre.width);
    let (px, py) = pixel_center::<f64>(col, row);
    let mut t = 1.0_f64;
    for &g in &pre.order {
        let g = g as usize;
        let m = pre.means2d[g];
        let conic = pre.conics[g].map(f64::from);
        let sigma = conic_sigma(conic, f64::from(m.x) - px, f64::from(m.y) - py);
        if sigma < 0.0 {
            continue;
        }
        let v = f64::from(pre.opacities[g]) * (-sigma).exp();
        if (v - ALPHA_MAX).abs() < rel || (v - ALPHA_MIN).abs() < rel * ALPHA_MIN {
            return true;
        }
        let alpha = v.min(ALPHA_MAX);
        if alpha < ALPHA_MIN {
            continue;
        }
        let next = t * (1.0 - alpha);
        if (next - T_STOP).abs() < rel * T_STOP {
            return true;
        }
        if next <= T_STOP {
            return false;
        }
        t = next;
    }
    false
}

fn same_decisions<T: Real>(a: &RasterOutput<T>, b: &RasterOutput<T>, p: usize) -> bool {
    a.n_contrib[p] == b.n_contrib[p] && a.last[p] == b.last[p] && a.terminated[p] == b.terminated[p]
}

thread_local! {
    static WORST: Cell<[f64; 6]> = const { Cell::new([0.0; 6]) };
    static SKIPPED: Cell<usize> = const { Cell::new(0) };
}

fn record(i: usize, e: f64) {
    WORST.with(|w| {
        let mut v = w.get();
        v[i] = v[i].max(e);
        w.set(v);
    });
}

fn check_scene(w: usize, h: usize, n: usize, mix: u32, seed: u64) {
    let (splats, cam) = scene(w, h, n, mix, seed);
    let np = w * h;
    let (rgb, alpha, depth) = cotangents(np, seed);
    let radius = if seed.is_multiple_of(2) {
        RadiusMode::OpacityAware
    } else {
        RadiusMode::Plain
    };
    let mode = if seed.is_multiple_of(3) {
        RasterMode::Antialiased
    } else {
        RasterMode::Classic
    };

    // f64: bitwise forward, gradients to 1e-12.
    let opts = RenderOptions {
        radius,
        mode,
        background: [0.2, 0.5, 0.9],
        ..RenderOptions::default()
    };
    let pre = preprocess(&splats, &cam, &opts);
    let d = PixelGrad {
        rgb: &rgb,
        alpha: Some(&alpha),
        depth: Some(&depth),
    };
    let r = run_ref(&pre, opts.background, &d);
    let f = run_tiled(&pre, opts.background, &d, ExpMode::Fast, Par::Seq);
    assert!(f.out == r.out, "f64 forward differs from the reference");
    let e = rel_err(&flat_grad(&f.grad, f.d_bg), &flat_grad(&r.grad, r.d_bg));
    record(0, e);
    assert!(e <= 1e-12, "f64 gradients: rel {e:e}");
    assert_eq!(f.stats.radius, r.stats.radius, "radii");
    let e = rel_err(&f.stats.mean2d_grad_norm, &r.stats.mean2d_grad_norm);
    assert!(e <= 1e-12, "f64 densification norms: rel {e:e}");

    // f32.
    let s32 = splats.cast::<f32>();
    let cam32 = cam.cast::<f32>();
    let opts32 = RenderOptions {
        eps2d: 0.3_f32,
        radius,
        mode,
        sh_degree: opts.sh_degree,
        background: [0.2, 0.5, 0.9],
        par: Par::Seq,
    };
    let pre32 = preprocess(&s32, &cam32, &opts32);
    let cast = |v: &[f64]| -> Vec<f32> { v.iter().map(|&x| f32::from_f64(x)).collect() };
    let (rgb32, alpha32, depth32) = (cast(&rgb), cast(&alpha), cast(&depth));
    let d32 = PixelGrad {
        rgb: &rgb32,
        alpha: Some(&alpha32),
        depth: Some(&depth32),
    };
    let r32 = run_ref(&pre32, opts32.background, &d32);
    // The same function in f64, to see which f32 rasterizer is closer to it.
    let widen_v = |v: &[f32]| -> Vec<f64> { v.iter().map(|&x| f64::from(x)).collect() };
    let (rgb_w, alpha_w, depth_w) = (widen_v(&rgb32), widen_v(&alpha32), widen_v(&depth32));
    let truth = run_ref(
        &widen(&pre32),
        [0.2_f32, 0.5, 0.9].map(f64::from),
        &PixelGrad {
            rgb: &rgb_w,
            alpha: Some(&alpha_w),
            depth: Some(&depth_w),
        },
    );

    let exact = run_tiled(&pre32, opts32.background, &d32, ExpMode::Exact, Par::Seq);
    assert!(
        exact.out == r32.out,
        "f32 exact forward differs from the reference"
    );
    let e = grad_err(&exact, &r32);
    record(1, e);
    record(4, grad_err(&r32, &truth));
    record(5, grad_err(&exact, &truth));
    assert!(e <= 1e-5, "f32 exact gradients: rel {e:e}");

    let fast = run_tiled(&pre32, opts32.background, &d32, ExpMode::Fast, Par::Seq);
    let differing: Vec<usize> = (0..np)
        .filter(|&p| !same_decisions(&fast.out, &r32.out, p))
        .collect();
    if !differing.is_empty() {
        for &p in &differing {
            assert!(
                near_threshold(&pre32, p, 1e-5),
                "f32 fast: decision differs at pixel {p} away from any threshold"
            );
        }
        SKIPPED.with(|s| s.set(s.get() + 1));
        return;
    }
    // Expected depth D/(1 − T) is compared through D: the f32 rounding of 1 − T for faint
    // pixels (T ≈ 1) amplifies a one-ulp difference of T by 1/(1 − T) in any rasterizer.
    let acc_depth = |o: &RasterOutput<f32>| -> Vec<f64> {
        o.depth
            .iter()
            .zip(&o.alpha)
            .map(|(&d, &a)| f64::from(d) * f64::from(a).max(1e-10))
            .collect()
    };
    let e_img = rel_err(&to_f64(fast.out.rgb.data()), &to_f64(r32.out.rgb.data()))
        .max(rel_err(&to_f64(&fast.out.alpha), &to_f64(&r32.out.alpha)))
        .max(rel_err(&acc_depth(&fast.out), &acc_depth(&r32.out)));
    record(2, e_img);
    assert!(e_img <= 1e-5, "f32 fast images: rel {e_img:e}");
    let e = grad_err(&fast, &r32);
    record(3, e);
    assert!(e <= 1e-5, "f32 fast gradients: rel {e:e}");
}

fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(20_240_611),
        failure_persistence: None,
        ..Config::default()
    }
}

proptest! {
    #![proptest_config(config(96))]
    #[test]
    fn tiled_matches_reference_on_random_scenes(
        w in 1_usize..72,
        h in 1_usize..56,
        n in 0_usize..70,
        mix in 0_u32..32,
        seed in any::<u64>(),
    ) {
        check_scene(w, h, n, mix, seed);
        report();
    }
}

#[test]
fn tiled_matches_reference_on_dense_opaque_scenes() {
    // Many large, nearly opaque Gaussians: most pixels terminate, alpha clamps at 0.999.
    for (k, seed) in (0..6_u64).enumerate() {
        check_scene(40 + 3 * k, 33, 120, 0b11000, seed);
    }
    report();
}

fn report() {
    let [e64, e32x, img, e32f, ref_truth, exact_truth] = WORST.with(Cell::get);
    println!(
        "worst errors so far: f64 grads {e64:.2e}; f32 exact grads {e32x:.2e}; f32 fast \
         images {img:.2e}, grads {e32f:.2e}; vs f64 truth: reference {ref_truth:.2e}, tiled \
         {exact_truth:.2e}; fast scenes skipped for near-threshold decisions: {}",
        SKIPPED.with(Cell::get)
    );
}
