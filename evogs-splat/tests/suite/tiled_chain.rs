//! The tiled rasterizer as a whole: `Par::Rayon` equals `Par::Seq` bitwise, an empty scene
//! renders the background, the radius rule does not change the image, the densification
//! statistics are the norms of the reference 2D-mean gradients, the backward is the adjoint
//! of a dual-number forward, and `render_tiled_vjp` matches `render_vjp` on the parameters.

use crate::tiled_common;

use evogs_math::diff::vjp_dot_test;
use evogs_math::{Dual, Par, Real, Vec2};
use evogs_splat::{
    DensifyStats, ExpMode, PixelGrad, Preprocessed, RadiusMode, RasterInputGrad, RenderOptions,
    Splats, TiledRasterizer, benchmark_scene, preprocess, render, render_tiled, render_tiled_vjp,
    render_vjp,
};
use tiled_common::{camera, cotangents, rel_err, scene};

/// `Par::Seq`, and `Par::Rayon` with the `rayon` feature.
fn pars() -> Vec<Par> {
    let mut p = vec![Par::Seq, Par::best()];
    p.dedup();
    p
}

#[test]
fn rayon_equals_sequential_bitwise() {
    let (splats, cam) = benchmark_scene::<f32>(3000, 150, 11);
    let (splats2, cam2) = scene(97, 61, 300, 0, 5);
    for (splats, cam) in [(splats, cam), (splats2.cast(), cam2.cast())] {
        let np = cam.width * cam.height;
        let (rgb, alpha, depth) = cotangents(np, 3);
        let c = |v: &[f64]| -> Vec<f32> { v.iter().map(|&x| f32::from_f64(x)).collect() };
        let (rgb, alpha, depth) = (c(&rgb), c(&alpha), c(&depth));
        let d = PixelGrad {
            rgb: &rgb,
            alpha: Some(&alpha),
            depth: Some(&depth),
        };
        for exp in [ExpMode::Fast, ExpMode::Exact] {
            let runs: Vec<_> = pars()
                .into_iter()
                .map(|par| {
                    let opts = RenderOptions {
                        par,
                        ..RenderOptions::default()
                    };
                    let mut rast = TiledRasterizer::with_exp(exp);
                    let fwd = render_tiled(&splats, &cam, &opts, &mut rast);
                    // A second call reuses the work memory and must give the same result.
                    let again = render_tiled(&splats, &cam, &opts, &mut rast);
                    assert!(fwd == again, "repeated forward differs");
                    let g = render_tiled_vjp(&splats, &cam, &opts, &mut rast, &fwd, &d);
                    (fwd, g)
                })
                .collect();
            for r in &runs[1..] {
                assert!(r.0 == runs[0].0, "forward differs across Par");
                assert!(r.1 == runs[0].1, "gradients differ across Par");
            }
        }
    }
}

#[test]
fn empty_scene_renders_the_background() {
    let cam = camera(37, 21);
    let opts = RenderOptions {
        background: [0.1, 0.2, 0.3],
        ..RenderOptions::default()
    };
    let s = Splats::<f64>::new(2);
    let mut rast = TiledRasterizer::new();
    let fwd = render_tiled(&s, &cam, &opts, &mut rast);
    assert!(fwd == render(&s, &cam, &opts), "same as the reference");
    assert!(
        fwd.raster
            .rgb
            .data()
            .chunks(3)
            .all(|p| p == [0.1, 0.2, 0.3]),
        "background only"
    );
    let d_rgb = vec![1.0; 37 * 21 * 3];
    let d = PixelGrad {
        rgb: &d_rgb,
        alpha: None,
        depth: None,
    };
    let g = render_tiled_vjp(&s, &cam, &opts, &mut rast, &fwd, &d);
    assert!(
        g.splats.is_empty() && g.densify.radius.is_empty(),
        "no Gaussians"
    );
    assert!(
        g.background.iter().all(|&b| (b - 777.0).abs() < 1e-12),
        "d bg = Σ T_final"
    );
}

#[test]
fn the_radius_rule_does_not_change_the_image() {
    // Opacity-aware boxes are tighter (fewer tile entries) but exact: same image, same
    // gradients (the extra entries of the plain boxes only add zeros).
    for seed in 0..6_u64 {
        let (splats, cam) = scene(70, 45, 80, 0, seed);
        let np = 70 * 45;
        let (rgb, alpha, depth) = cotangents(np, seed);
        let d = PixelGrad {
            rgb: &rgb,
            alpha: Some(&alpha),
            depth: Some(&depth),
        };
        let mut out = Vec::new();
        for radius in [RadiusMode::Plain, RadiusMode::OpacityAware] {
            let opts = RenderOptions {
                radius,
                ..RenderOptions::default()
            };
            let mut rast = TiledRasterizer::new();
            let fwd = render_tiled(&splats, &cam, &opts, &mut rast);
            let entries = rast.binning().n_entries();
            let g = render_tiled_vjp(&splats, &cam, &opts, &mut rast, &fwd, &d);
            out.push((fwd.raster, g.raster, entries));
        }
        // `last` indexes `Preprocessed::order`, which loses the Gaussians that the tighter
        // boxes cull (entirely off the image, or o' < 1/255): compare everything else.
        let (a, b) = (&out[0].0, &out[1].0);
        assert!(
            a.rgb == b.rgb
                && a.alpha == b.alpha
                && a.depth == b.depth
                && a.n_contrib == b.n_contrib
                && a.final_t == b.final_t
                && a.terminated == b.terminated,
            "images differ between radius rules"
        );
        assert!(
            out[0].1 == out[1].1,
            "gradients differ between radius rules"
        );
        assert!(out[1].2 <= out[0].2, "opacity-aware boxes are not larger");
    }
}

#[test]
fn densification_statistics_are_the_reference_mean_gradient_norms() {
    let (splats, cam) = benchmark_scene::<f64>(400, 64, 9);
    let opts = RenderOptions::<f64>::default();
    let (rgb, _, _) = cotangents(64 * 64, 9);
    let d = PixelGrad {
        rgb: &rgb,
        alpha: None,
        depth: None,
    };
    let reference = render_vjp(&splats, &cam, &opts, &render(&splats, &cam, &opts), &d);
    let mut rast = TiledRasterizer::new();
    let fwd = render_tiled(&splats, &cam, &opts, &mut rast);
    let tiled = render_tiled_vjp(&splats, &cam, &opts, &mut rast, &fwd, &d);
    let norms: Vec<f64> = reference.raster.means2d.iter().map(|m| m.norm()).collect();
    let e = rel_err(&tiled.densify.mean2d_grad_norm, &norms);
    assert!(e < 1e-12, "norms: rel {e:e}");
    let radii: Vec<u32> = fwd.pre.radii.iter().map(|r| r[0].max(r[1])).collect();
    assert_eq!(tiled.densify.radius, radii, "radii");
    assert!(
        tiled
            .densify
            .radius
            .iter()
            .zip(&fwd.pre.valid)
            .all(|(&r, &v)| v || r == 0),
        "culled Gaussians have radius 0"
    );
    // The parameter gradients of the whole chain agree as well.
    let (mut a, mut b) = (Vec::new(), Vec::new());
    tiled.splats.write_flat(&mut a);
    reference.splats.write_flat(&mut b);
    let e = rel_err(&a, &b);
    assert!(e < 1e-11, "parameter gradients: rel {e:e}");
    let e = rel_err(
        &tiled.camera.to_viewmat().concat(),
        &reference.camera.to_viewmat().concat(),
    );
    assert!(e < 1e-11, "camera gradient: rel {e:e}");
}

/// The rasterizer inputs as one flat vector: means2d, conics, colours, opacities, depths.
fn flatten<T: Real>(p: &Preprocessed<T>) -> Vec<T> {
    let mut v: Vec<T> = p.means2d.iter().flat_map(|m| m.to_array()).collect();
    v.extend(p.conics.iter().flatten());
    v.extend(p.colors.iter().flatten());
    v.extend(&p.opacities);
    v.extend(&p.depths);
    v
}

/// `p` with its rasterizer inputs replaced by `x` (the layout of [`flatten`]).
fn with_inputs<T: Real, U: Real>(p: &Preprocessed<T>, x: &[U]) -> Preprocessed<U> {
    let n = p.means2d.len();
    let c = |v: T| U::from_f64(v.to_f64());
    Preprocessed {
        width: p.width,
        height: p.height,
        means2d: (0..n).map(|i| Vec2::new(x[2 * i], x[2 * i + 1])).collect(),
        conics: (0..n)
            .map(|i| std::array::from_fn(|k| x[2 * n + 3 * i + k]))
            .collect(),
        colors: (0..n)
            .map(|i| std::array::from_fn(|k| x[5 * n + 3 * i + k]))
            .collect(),
        opacities: x[8 * n..9 * n].to_vec(),
        depths: x[9 * n..10 * n].to_vec(),
        radii: p.radii.clone(),
        valid: p.valid.clone(),
        compensations: p.compensations.iter().map(|&v| c(v)).collect(),
        order: p.order.clone(),
    }
}

#[test]
fn backward_is_the_adjoint_of_the_dual_number_forward() {
    for seed in [1_u64, 2, 3] {
        let (splats, cam) = scene(35, 29, 25, 0b00111, seed);
        let opts = RenderOptions {
            background: [0.3, 0.1, 0.7],
            ..RenderOptions::default()
        };
        let pre = preprocess(&splats, &cam, &opts);
        let x0 = flatten(&pre);
        let np = 35 * 29;
        let n_out = 5 * np;
        let bg = opts.background;
        // Outputs: rgb, alpha, expected depth.
        let jvp = |v: &[f64], out: &mut [f64]| {
            let x: Vec<Dual<f64>> = x0
                .iter()
                .zip(v)
                .map(|(&a, &b)| Dual { re: a, eps: b })
                .collect();
            let pd = with_inputs(&pre, &x);
            let o = TiledRasterizer::new().forward(&pd, bg.map(Dual::constant), Par::Seq);
            let tangents = o
                .rgb
                .data()
                .iter()
                .chain(&o.alpha)
                .chain(&o.depth)
                .map(|d| d.eps);
            for (slot, t) in out.iter_mut().zip(tangents) {
                *slot = t;
            }
        };
        let fwd = TiledRasterizer::new().forward(&pre, bg, Par::Seq);
        let vjp = |w: &[f64], out: &mut [f64]| {
            let d = PixelGrad {
                rgb: &w[..3 * np],
                alpha: Some(&w[3 * np..4 * np]),
                depth: Some(&w[4 * np..]),
            };
            let mut g = RasterInputGrad::zeros(pre.means2d.len());
            let mut stats = DensifyStats::default();
            let _ =
                TiledRasterizer::new().backward(&pre, bg, &fwd, &d, Par::Seq, &mut g, &mut stats);
            let flat = flatten(&Preprocessed {
                means2d: g.means2d,
                conics: g.conics,
                colors: g.colors,
                opacities: g.opacities,
                depths: g.depths,
                ..Preprocessed::default()
            });
            out.copy_from_slice(&flat);
        };
        let mismatch = vjp_dot_test(jvp, vjp, x0.len(), n_out, seed);
        assert!(
            mismatch < 1e-10,
            "seed {seed}: dot-test mismatch {mismatch:e}"
        );
    }
}

#[test]
fn backward_rebins_when_the_inputs_change() {
    // The backward reuses the forward's binning only for identical inputs: a backward for
    // another scene (or after moving one Gaussian) must equal a fresh rasterizer's.
    let (splats, cam) = scene(50, 40, 60, 0, 21);
    let opts = RenderOptions::<f64>::default();
    let pre_a = preprocess(&splats, &cam, &opts);
    let mut moved = splats.clone();
    moved.means[7].x += 0.05;
    let pre_b = preprocess(&moved, &cam, &opts);
    let (rgb, alpha, depth) = cotangents(50 * 40, 21);
    let d = PixelGrad {
        rgb: &rgb,
        alpha: Some(&alpha),
        depth: Some(&depth),
    };
    let out_b = TiledRasterizer::new().forward(&pre_b, opts.background, Par::Seq);
    let run = |rast: &mut TiledRasterizer<f64>| {
        let mut g = RasterInputGrad::zeros(60);
        let mut s = DensifyStats::default();
        let bg = rast.backward(
            &pre_b,
            opts.background,
            &out_b,
            &d,
            Par::Seq,
            &mut g,
            &mut s,
        );
        (g, s, bg)
    };
    let fresh = run(&mut TiledRasterizer::new());
    let mut stale = TiledRasterizer::new();
    let _ = stale.forward(&pre_a, opts.background, Par::Seq);
    assert!(run(&mut stale) == fresh, "stale binning reused");
    // And the same inputs twice reuse it with identical results.
    let mut warm = TiledRasterizer::new();
    let _ = warm.forward(&pre_b, opts.background, Par::Seq);
    assert!(run(&mut warm) == fresh, "reused binning differs");
}
