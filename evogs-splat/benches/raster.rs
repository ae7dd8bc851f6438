//! Rasterizer benches at 400×400 in f32 (issue item 8).
//!
//! Scene of the issue: `n` Gaussians uniform in the unit cube `[−0.5, 0.5]³`, 4 units in front
//! of a 40° (horizontal field of view) camera, scales around 0.01 (log-uniform in
//! `[0.008, 0.0125]` per axis), opacity 0.5, random unit quaternions, SH degree 3 (random DC
//! colour, higher coefficients ~ N(0, 0.05²)). Seeded. (`benchmark_scene` of the performance
//! notes uses scales 0.01–0.03 and opacities 0.5–0.9: a denser image, benched once for
//! comparison as `perfnotes_20k`.)
//!
//! For 2·10⁴ and 10⁵ Gaussians: forward (`render_tiled_into`: preprocessing +
//! rasterization) and forward + backward (`render_tiled_into` + `render_tiled_vjp_into`
//! down to the raw parameters and the camera; the training-loop form, buffers reused), for
//! the tiled rasterizer sequential and (feature `rayon`) on rayon's pool, and the
//! same for the reference rasterizer at 2·10⁴, sequential only: its compositing is
//! sequential code whatever `Par` says (`rayon` would only parallelise the preprocessing,
//! ~5 ms of its ~5 s per forward), and one sample costs seconds. The reference is
//! O(pixels × Gaussians) and is skipped at 10⁵. Notes are printed for both skips. Pixel
//! cotangents: a fixed pattern on rgb.

use criterion::{
    BenchmarkGroup, Criterion, criterion_group, criterion_main, measurement::WallTime,
};
use evogs_math::{Par, Vec2};
use evogs_splat::{
    PinholeCamera, PixelGrad, RasterInputGrad, RenderOptions, Splats, TiledRasterizer,
    benchmark_scene, preprocess, preprocess_vjp, random_scene, render, render_tiled,
    render_tiled_into, render_tiled_vjp, render_tiled_vjp_into, render_vjp,
};
use std::hint::black_box;
use std::time::Duration;

const SIZE: usize = 400;

/// The scene of the issue (see the module docs).
fn issue_scene(n: usize, seed: u64) -> (Splats<f32>, PinholeCamera<f32>) {
    random_scene(n, SIZE, seed, [0.008, 0.0125], [0.5, 0.5])
}

fn pars() -> Vec<(&'static str, Par)> {
    let mut p = vec![("seq", Par::Seq)];
    if !Par::best().is_seq() {
        p.push(("rayon", Par::best()));
    }
    p
}

fn group<'a>(c: &'a mut Criterion, name: &str) -> BenchmarkGroup<'a, WallTime> {
    let mut g = c.benchmark_group(name);
    g.sample_size(10);
    g.warm_up_time(Duration::from_millis(200));
    g.measurement_time(Duration::from_secs(2));
    g
}

fn bench_scene(
    c: &mut Criterion,
    name: &str,
    splats: &Splats<f32>,
    cam: &PinholeCamera<f32>,
    reference: bool,
) {
    let d_rgb: Vec<f32> = (0..SIZE * SIZE * 3)
        .map(|i| ((i % 11) as f32 - 5.0) * 0.01)
        .collect();
    let d = PixelGrad {
        rgb: &d_rgb,
        alpha: None,
        depth: None,
    };
    let mut g = group(c, name);
    for (pname, par) in pars() {
        let opts = RenderOptions::<f32> {
            par,
            ..RenderOptions::default()
        };
        // The training-loop form: every buffer is reused between iterations.
        let mut rast = TiledRasterizer::new();
        let mut fwd = render_tiled(splats, cam, &opts, &mut rast);
        let mut grad = render_tiled_vjp(splats, cam, &opts, &mut rast, &fwd, &d);
        g.bench_function(format!("tiled_{pname}/forward"), |b| {
            b.iter(|| render_tiled_into(black_box(splats), cam, &opts, &mut rast, &mut fwd));
        });
        g.bench_function(format!("tiled_{pname}/forward_backward"), |b| {
            b.iter(|| {
                render_tiled_into(black_box(splats), cam, &opts, &mut rast, &mut fwd);
                render_tiled_vjp_into(splats, cam, &opts, &mut rast, &fwd, &d, &mut grad);
                black_box(&grad);
            });
        });
        if !reference || !par.is_seq() {
            continue;
        }
        g.bench_function(format!("reference_{pname}/forward"), |b| {
            b.iter(|| black_box(render(black_box(splats), cam, &opts)));
        });
        g.bench_function(format!("reference_{pname}/forward_backward"), |b| {
            b.iter(|| {
                let fwd = render(black_box(splats), cam, &opts);
                black_box(render_vjp(splats, cam, &opts, &fwd, &d))
            });
        });
    }
    g.finish();
}

fn bench(c: &mut Criterion) {
    let (splats, cam) = issue_scene(20_000, 2024);
    if !Par::best().is_seq() {
        println!(
            "note: the reference rasterizer is benched sequentially only (its compositing \
             does not use rayon; ~5 s per forward)"
        );
    }
    bench_scene(c, "raster_20k_400x400", &splats, &cam, true);
    let (splats, cam) = issue_scene(100_000, 2024);
    println!(
        "note: the reference rasterizer is skipped at 1e5 Gaussians (O(pixels × Gaussians), \
         minutes per sample)"
    );
    bench_scene(c, "raster_100k_400x400", &splats, &cam, false);
    let (splats, cam) = benchmark_scene::<f32>(20_000, SIZE, 2024);
    bench_scene(c, "perfnotes_20k_400x400", &splats, &cam, false);

    // The per-Gaussian preprocessing and its VJP alone.
    let (splats, cam) = issue_scene(20_000, 2024);
    let mut g = group(c, "preprocess_20k");
    for (name, par) in pars() {
        let opts = RenderOptions::<f32> {
            par,
            ..RenderOptions::default()
        };
        g.bench_function(format!("forward_{name}"), |b| {
            b.iter(|| black_box(preprocess(black_box(&splats), &cam, &opts)));
        });
        let pre = preprocess(&splats, &cam, &opts);
        let mut d = RasterInputGrad::zeros(splats.len());
        d.means2d.fill(Vec2::new(0.1, -0.2));
        d.conics.fill([0.3, -0.1, 0.2]);
        d.colors.fill([0.1, 0.2, -0.3]);
        d.opacities.fill(0.4);
        let mut grad = splats.zeros_like();
        g.bench_function(format!("vjp_{name}"), |b| {
            b.iter(|| {
                grad.fill_zero(opts.par);
                black_box(preprocess_vjp(&splats, &cam, &opts, &pre, &d, &mut grad))
            });
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
