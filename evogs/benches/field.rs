//! The neural field at the reference step's configuration (`docs/architecture.md` §6):
//! HexPlane 2 levels × 32
//! channels at [64, 64, 64, 25], MLP 64 wide with three heads (`paper`), and at the `fast`
//! preset's (2 levels × 16 channels at [32, 32, 32, 16], MLP 32 wide); f32, for 5k and 20k
//! Gaussians: one fresh evaluation, and one VJP (which reuses the stored forward pass of the same input, as
//! in training).

use criterion::{Criterion, criterion_group, criterion_main};
use evogs::field::{HexPlaneConfig, NeuralField, NeuralFieldConfig, TimeMapping};
use evogs_math::Par;
use evogs_math::rng::SplitMix64;
use evogs_ode::VectorField;
use std::hint::black_box;

fn field(preset: &str) -> NeuralField<f32> {
    let (channels, resolution, width) = match preset {
        "paper" => (32, [64, 64, 64, 25], 64),
        _ => (16, [32, 32, 32, 16], 32),
    };
    let cfg = NeuralFieldConfig {
        hexplane: HexPlaneConfig {
            channels,
            resolution,
            multires: vec![1, 2],
        },
        width,
        output_scales: [10.0, 1.0, 1.0],
        zero_init_output: false,
    };
    NeuralField::new(
        &cfg,
        [-0.5; 3],
        [0.5; 3],
        TimeMapping::Normalized {
            t_min: 0.0,
            t_max: 1.0,
        },
        1,
    )
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("neural_field");
    g.sample_size(10);
    for n in [5_000usize, 20_000] {
        let mut rng = SplitMix64::new(2);
        let mut y = Vec::with_capacity(n * 10);
        for _ in 0..n {
            #[allow(clippy::cast_possible_truncation, reason = "bench inputs")]
            y.extend([
                rng.uniform(-0.5, 0.5) as f32,
                rng.uniform(-0.5, 0.5) as f32,
                rng.uniform(-0.5, 0.5) as f32,
            ]);
            y.extend([1.0, 0.0, 0.0, 0.0, -4.0, -4.0, -4.0]);
        }
        #[allow(clippy::cast_possible_truncation, reason = "bench inputs")]
        let w: Vec<f32> = (0..n * 9).map(|_| rng.uniform(-1.0, 1.0) as f32).collect();
        for (preset, name, par) in [
            ("paper", "seq", Par::Seq),
            ("paper", "rayon", Par::best()),
            ("fast", "seq", Par::Seq),
            ("fast", "rayon", Par::best()),
        ] {
            let name = format!("{preset}/{name}");
            let mut f = field(preset);
            f.set_count(n);
            f.set_par(par);
            let mut out = vec![0.0; n * 9];
            g.bench_function(format!("eval/{n}/{name}"), |b| {
                b.iter(|| {
                    // A parameter change, as after every optimiser step: the stored
                    // evaluation of the previous call must not be reused.
                    f.params_mut();
                    f.eval(black_box(0.3), &y, &mut out);
                });
            });
            let mut d_y = vec![0.0; n * 9];
            let mut d_p = vec![0.0; f.n_params()];
            g.bench_function(format!("vjp/{n}/{name}"), |b| {
                b.iter(|| f.vjp(black_box(0.3), &y, &w, &mut d_y, &mut d_p));
            });
        }
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
