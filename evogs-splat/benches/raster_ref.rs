//! The reference rasterizer on the benchmark scene of the performance notes (2·10⁴
//! Gaussians, 400×400, SH degree 3, f32): forward (preprocess + dense compositing) and
//! forward + backward. This is the O(pixels × Gaussians) correctness baseline the tiled
//! rasterizer is compared against, not a fast path. Also the per-Gaussian preprocessing
//! (projection + SH + opacity) and its VJP alone, sequential and (with `rayon`) parallel.

use criterion::{Criterion, criterion_group, criterion_main};
use evogs_math::{Par, Vec2};
use evogs_splat::{
    PixelGrad, RasterInputGrad, RenderOptions, benchmark_scene, preprocess, preprocess_vjp, render,
    render_vjp,
};
use std::hint::black_box;
use std::time::Duration;

const N: usize = 20_000;
const SIZE: usize = 400;

fn bench(c: &mut Criterion) {
    let (splats, cam) = benchmark_scene::<f32>(N, SIZE, 2024);
    let opts = RenderOptions::<f32>::default();
    let d_rgb: Vec<f32> = (0..SIZE * SIZE * 3)
        .map(|i| ((i % 11) as f32 - 5.0) * 0.01)
        .collect();
    let mut g = c.benchmark_group("raster_ref_20k_400x400");
    g.sample_size(10);
    g.warm_up_time(Duration::from_millis(1));
    g.measurement_time(Duration::from_secs(1));
    g.bench_function("forward", |b| {
        b.iter(|| black_box(render(black_box(&splats), &cam, &opts)));
    });
    g.bench_function("forward_backward", |b| {
        b.iter(|| {
            let fwd = render(black_box(&splats), &cam, &opts);
            let d = PixelGrad {
                rgb: &d_rgb,
                alpha: None,
                depth: None,
            };
            black_box(render_vjp(&splats, &cam, &opts, &fwd, &d))
        });
    });
    g.finish();

    let mut g = c.benchmark_group("preprocess_20k");
    let mut pars = vec![("seq", Par::Seq)];
    #[cfg(feature = "rayon")]
    pars.push(("rayon", Par::Rayon));
    for (name, par) in pars {
        let opts = RenderOptions::<f32> {
            par,
            ..RenderOptions::default()
        };
        g.bench_function(format!("forward_{name}"), |b| {
            b.iter(|| black_box(preprocess(black_box(&splats), &cam, &opts)));
        });
        let pre = preprocess(&splats, &cam, &opts);
        let mut d = RasterInputGrad::zeros(N);
        d.means2d.fill(Vec2::new(0.1, -0.2));
        d.conics.fill([0.3, -0.1, 0.2]);
        d.colors.fill([0.1, 0.2, -0.3]);
        d.opacities.fill(0.4);
        let mut grad = splats.zeros_like();
        g.bench_function(format!("vjp_{name}"), |b| {
            b.iter(|| {
                grad.fill_zero();
                black_box(preprocess_vjp(&splats, &cam, &opts, &pre, &d, &mut grad))
            });
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
