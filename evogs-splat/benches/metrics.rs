//! Training-loss costs at 400×400×3 in f32: SSIM value + gradient (fused), SSIM value
//! alone, L1 value + gradient, and the full 3DGS photometric loss; sequential and, with
//! the `rayon` feature, on rayon's pool.

use criterion::{Criterion, criterion_group, criterion_main};
use evogs_math::Par;
use evogs_math::rng::SplitMix64;
use evogs_splat::Image;
use evogs_splat::loss::{l1_and_grad, photometric_loss_and_grad};
use evogs_splat::ssim::SsimWorkspace;
use std::hint::black_box;

const W: usize = 400;
const H: usize = 400;

/// A seeded render/target pair: a smooth target and a noisy render of it.
fn images() -> (Image<f32>, Image<f32>) {
    let mut r = SplitMix64::new(9);
    let mut target = Image::<f64>::new(W, H);
    let mut render = Image::<f64>::new(W, H);
    for y in 0..H {
        for x in 0..W {
            let (u, v) = (x as f64 / W as f64, y as f64 / H as f64);
            let t = [
                0.5 + 0.4 * (6.0 * u).sin() * (4.0 * v).cos(),
                0.5 + 0.3 * (9.0 * (u + v)).sin(),
                u * v,
            ];
            target.set(x, y, t);
            render.set(x, y, t.map(|c| (c + 0.05 * r.normal()).clamp(0.0, 1.0)));
        }
    }
    (render.cast(), target.cast())
}

fn bench_par(c: &mut Criterion, par: Par, tag: &str) {
    let (a, b) = images();
    let mut ws = SsimWorkspace::with_size(W, H);
    let mut grad = Image::new(W, H);
    c.bench_function(&format!("metrics/ssim_and_grad/400x400/f32/{tag}"), |bch| {
        bch.iter(|| ws.ssim_and_grad(black_box(&a), black_box(&b), 1.0, &mut grad, par));
    });
    c.bench_function(&format!("metrics/ssim/400x400/f32/{tag}"), |bch| {
        bch.iter(|| ws.ssim(black_box(&a), black_box(&b), par));
    });
    c.bench_function(
        &format!("metrics/l1+ssim_photometric_and_grad/400x400/f32/{tag}"),
        |bch| {
            bch.iter(|| {
                grad.data_mut().fill(0.0);
                photometric_loss_and_grad(
                    &mut ws,
                    black_box(&a),
                    black_box(&b),
                    0.2,
                    1.0,
                    &mut grad,
                    par,
                )
            });
        },
    );
}

fn benches(c: &mut Criterion) {
    let (a, b) = images();
    let mut grad = Image::new(W, H);
    c.bench_function("metrics/l1_and_grad/400x400/f32", |bch| {
        bch.iter(|| l1_and_grad(black_box(&a), black_box(&b), 1.0, &mut grad));
    });
    bench_par(c, Par::Seq, "seq");
    #[cfg(feature = "rayon")]
    bench_par(c, Par::Rayon, "rayon");
}

criterion_group! {
    name = metrics;
    config = Criterion::default().sample_size(20);
    targets = benches
}
criterion_main!(metrics);
