//! The tiled rasterizer as a whole: `Par::Rayon` equals `Par::Seq` bitwise, an empty scene
//! renders the background, the radius rule does not change the image, the densification
//! statistics are the norms of the reference 2D-mean gradients, the backward is the adjoint
//! of a dual-number forward, `render_tiled_vjp` matches `render_vjp` on the parameters, the
//! backward reuses the forward's binning only when it would bin the same, a reused output
//! follows the image size (empty ones included), and every pixel of a partial edge tile can
//! stop.

use crate::tiled_common;

use evogs_math::diff::vjp_dot_test;
use evogs_math::{Dual, Par, Real, Vec2, Vec3};
use evogs_splat::{
    Binning, DensifyStats, ExpMode, PixelGrad, Preprocessed, RadiusMode, RasterInputGrad,
    RenderOptions, Splats, TileGrid, TiledRasterizer, benchmark_scene, preprocess, rasterize_ref,
    rasterize_tiled_vjp, render, render_tiled, render_tiled_vjp, render_vjp,
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

/// `pre` with only the Gaussians `keep` valid, composited in that order.
fn restrict<T: Real>(pre: &Preprocessed<T>, keep: &[u32]) -> Preprocessed<T> {
    let mut p = pre.clone();
    p.valid.iter_mut().for_each(|v| *v = false);
    for &g in keep {
        p.valid[g as usize] = true;
    }
    p.order = keep.to_vec();
    p
}

#[test]
fn backward_rebins_when_the_inputs_change() {
    // The backward reuses the forward's binning only when it would bin the same: after a
    // forward of `a`, a backward of `b` must equal a fresh rasterizer's for every kind of
    // change (each one that a wrong cache test would let through).
    let (w, h, n) = (50, 40, 60);
    let (splats, cam) = scene(w, h, n, 0, 21);
    let opts = RenderOptions::<f64>::default();
    let pre = preprocess(&splats, &cam, &opts);
    let mut variants: Vec<(&str, Preprocessed<f64>, Preprocessed<f64>)> = Vec::new();

    // One Gaussian moved along the camera's x axis (so that no depth changes) by a fraction
    // of a pixel (its tiles may stay the same) and by more than a tile (they change).
    let g = pre
        .order
        .iter()
        .map(|&g| g as usize)
        .find(|&g| pre.means2d[g].x < (w - 25) as f64 && pre.radii[g][0] < 8)
        .expect("a Gaussian left of the middle");
    for (name, dx) in [("moved a little", 0.05), ("moved a tile", 17.0)] {
        let mut moved = splats.clone();
        let z = pre.depths[g];
        moved.means[g] += cam
            .rotation
            .tr_mul_vec(Vec3::new(dx * z / cam.fx, 0.0, 0.0));
        let b = preprocess(&moved, &cam, &opts);
        assert!(b.order == pre.order, "{name}: same compositing order");
        assert!(
            (b.means2d[g].x - pre.means2d[g].x - dx).abs() < 1e-6,
            "{name}: moved by dx"
        );
        variants.push((name, pre.clone(), b));
    }

    // The same Gaussians in a larger image: the packing is the same when no pixel box
    // reaches the right or bottom edge, the tile grid is not.
    let inside: Vec<u32> = pre
        .order
        .iter()
        .copied()
        .filter(|&g| {
            let (m, r) = (pre.means2d[g as usize], pre.radii[g as usize]);
            m.x + f64::from(r[0]) < (w - 2) as f64 && m.y + f64::from(r[1]) < (h - 2) as f64
        })
        .collect();
    assert!(inside.len() > 5, "{} Gaussians inside", inside.len());
    let small = restrict(&pre, &inside);
    let mut large = small.clone();
    (large.width, large.height) = (w + 16, h + 16);
    variants.push(("larger image", small, large));

    // Two Gaussians with the same packed fields, composited in the other order: the packing
    // is the same, the Gaussian at each position is not.
    let (k0, k1) = (pre.order[0], pre.order[1]);
    let (g0, g1) = (k0 as usize, k1 as usize);
    let mut twins = pre.clone();
    twins.means2d[g1] = twins.means2d[g0];
    twins.conics[g1] = twins.conics[g0];
    twins.colors[g1] = twins.colors[g0];
    twins.opacities[g1] = twins.opacities[g0];
    twins.depths[g1] = twins.depths[g0];
    twins.radii[g1] = twins.radii[g0];
    variants.push((
        "twins swapped",
        restrict(&twins, &[k0, k1]),
        restrict(&twins, &[k1, k0]),
    ));

    // The same inputs twice reuse the binning with identical results.
    variants.push(("same inputs", pre.clone(), pre.clone()));

    for (name, a, b) in &variants {
        let np = b.width * b.height;
        let (rgb, alpha, depth) = cotangents(np, 21);
        let d = PixelGrad {
            rgb: &rgb,
            alpha: Some(&alpha),
            depth: Some(&depth),
        };
        let out_b = TiledRasterizer::new().forward(b, opts.background, Par::Seq);
        let run = |rast: &mut TiledRasterizer<f64>| {
            let mut g = RasterInputGrad::zeros(n);
            let mut s = DensifyStats::default();
            let bg = rast.backward(b, opts.background, &out_b, &d, Par::Seq, &mut g, &mut s);
            (g, s, bg)
        };
        let fresh = run(&mut TiledRasterizer::new());
        assert!(
            fresh.0.means2d.iter().any(|m| m.norm() > 0.0),
            "{name}: some gradient"
        );
        let mut warm = TiledRasterizer::new();
        let _ = warm.forward(a, opts.background, Par::Seq);
        assert!(
            run(&mut warm) == fresh,
            "{name}: differs from a fresh backward"
        );
    }
}

#[test]
fn forward_into_resizes_a_reused_output() {
    // One output reused across image sizes, including empty ones (a zero width with a
    // non-zero height and the converse): each call equals a fresh `forward`.
    let mut rast = TiledRasterizer::<f64>::with_exp(ExpMode::Exact);
    assert!(
        rast.exp_mode() == ExpMode::Exact,
        "the exponential asked for"
    );
    assert!(
        TiledRasterizer::<f64>::new().exp_mode() == ExpMode::Fast,
        "the default exponential"
    );
    let bg = [0.1, 0.2, 0.3];
    let mut out = TiledRasterizer::new().forward(
        &preprocess(
            &scene(3, 2, 1, 0, 1).0,
            &camera(3, 2),
            &RenderOptions::default(),
        ),
        bg,
        Par::Seq,
    );
    for (w, h) in [(37, 21), (37, 5), (12, 5), (0, 7), (7, 0), (0, 0), (20, 33)] {
        // A camera has at least one pixel: an empty image is a preprocessed one cut down.
        let (splats, cam) = scene(w.max(1), h.max(1), 40, 0, 9);
        let mut pre = preprocess(&splats, &cam, &RenderOptions::default());
        (pre.width, pre.height) = (w, h);
        rast.forward_into(&pre, bg, Par::Seq, &mut out);
        let fresh = TiledRasterizer::with_exp(ExpMode::Exact).forward(&pre, bg, Par::Seq);
        assert!(out == fresh, "{w}×{h}: differs from a fresh forward");
        assert!(
            rast.binning().grid() == TileGrid::new(w, h),
            "{w}×{h}: the binning of the last call"
        );
        assert!(
            rast.binning().n_entries() == fresh_entries(&pre),
            "{w}×{h}: its entries"
        );
    }
}

/// The number of (tile, Gaussian) pairs of `pre`, binned afresh.
fn fresh_entries(pre: &Preprocessed<f64>) -> usize {
    let mut b = Binning::default();
    b.bin(pre, Par::Seq);
    b.n_entries()
}

#[test]
fn every_pixel_of_partial_edge_tiles_can_stop() {
    // Images whose edge tiles are partial, under so many opaque Gaussians that every pixel
    // stops: the tile counts down only its pixels inside the image, and the result is the
    // reference's.
    for (w, h, seed) in [(37, 21, 1), (20, 17, 2), (33, 40, 3)] {
        let (splats, cam) = scene(w, h, 1500, 0b11000, seed);
        let opts = RenderOptions::<f64>::default();
        let pre = preprocess(&splats, &cam, &opts);
        let out = TiledRasterizer::new().forward(&pre, opts.background, Par::Seq);
        assert!(
            out.terminated.iter().all(|&t| t),
            "{w}×{h}: every pixel stopped"
        );
        assert!(
            out == rasterize_ref(&pre, opts.background),
            "{w}×{h}: the reference's"
        );
    }
}

#[test]
fn the_one_call_vjp_is_the_rasterizers_backward() {
    let (splats, cam) = scene(30, 20, 40, 0, 4);
    let opts = RenderOptions::<f64>::default();
    let pre = preprocess(&splats, &cam, &opts);
    let mut rast = TiledRasterizer::new();
    let out = rast.forward(&pre, opts.background, Par::Seq);
    let (rgb, alpha, depth) = cotangents(30 * 20, 4);
    let d = PixelGrad {
        rgb: &rgb,
        alpha: Some(&alpha),
        depth: Some(&depth),
    };
    let (mut g1, mut s1) = (RasterInputGrad::zeros(40), DensifyStats::default());
    let bg1 = TiledRasterizer::new().backward(
        &pre,
        opts.background,
        &out,
        &d,
        Par::Seq,
        &mut g1,
        &mut s1,
    );
    let (mut g2, mut s2) = (RasterInputGrad::zeros(40), DensifyStats::default());
    let bg2 = rasterize_tiled_vjp(&pre, opts.background, &out, &d, Par::Seq, &mut g2, &mut s2);
    let (with_rast, one_call) = ((g1, s1, bg1), (g2, s2, bg2));
    assert!(
        with_rast.2.iter().all(|&b| b != 0.0),
        "a background gradient"
    );
    assert!(one_call == with_rast, "the same gradients");
}
