//! Covariance from log-scale and raw quaternion, and its VJP, in f32 and f64.

use criterion::{Criterion, criterion_group, criterion_main};
use evogs_math::covariance::{covariance, covariance_vjp};
use evogs_math::{Quat, Real, Sym3, Vec3};
use std::hint::black_box;

fn bench_precision<T: Real>(c: &mut Criterion, name: &str) {
    let mut r = evogs_math::rng::SplitMix64::new(5);
    let data: Vec<(Vec3<T>, Quat<T>)> = (0..256)
        .map(|_| {
            let s = Vec3::new(
                r.uniform(-5.0, -2.0),
                r.uniform(-5.0, -2.0),
                r.uniform(-5.0, -2.0),
            )
            .cast();
            let q = Quat::new(r.normal(), r.normal(), r.normal(), r.normal()).cast();
            (s, q)
        })
        .collect();
    let g = Sym3::new(T::ONE, T::HALF, T::ZERO, T::ONE, -T::HALF, T::TWO);
    let n = data.len();
    let mut i = 0;
    c.bench_function(&format!("covariance/forward/{name}"), |b| {
        b.iter(|| {
            i = (i + 1) % n;
            let (s, q) = data[i];
            covariance(black_box(s), black_box(q))
        });
    });
    c.bench_function(&format!("covariance/forward+vjp/{name}"), |b| {
        b.iter(|| {
            i = (i + 1) % n;
            let (s, q) = data[i];
            (
                covariance(black_box(s), black_box(q)),
                covariance_vjp(black_box(s), black_box(q), g),
            )
        });
    });
}

fn benches(c: &mut Criterion) {
    bench_precision::<f32>(c, "f32");
    bench_precision::<f64>(c, "f64");
}

criterion_group!(cov, benches);
criterion_main!(cov);
