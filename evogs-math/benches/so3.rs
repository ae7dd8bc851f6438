//! SO(3) exp/log and the exp-map update, in f32 and f64.

use criterion::{Criterion, criterion_group, criterion_main};
use evogs_math::so3::{exp_matrix, exp_quat, log_matrix, log_quat};
use evogs_math::update::{exp_update_left, exp_update_left_vjp};
use evogs_math::{Quat, Real, Vec3};
use std::hint::black_box;

fn inputs<T: Real>() -> Vec<Vec3<T>> {
    let mut r = evogs_math::rng::SplitMix64::new(3);
    (0..256)
        .map(|_| {
            Vec3::new(
                r.uniform(-1.5, 1.5),
                r.uniform(-1.5, 1.5),
                r.uniform(-1.5, 1.5),
            )
            .cast()
        })
        .collect()
}

fn bench_precision<T: Real>(c: &mut Criterion, name: &str) {
    let phis = inputs::<T>();
    let quats: Vec<Quat<T>> = phis.iter().map(|&p| exp_quat(p)).collect();
    let mats: Vec<_> = phis.iter().map(|&p| exp_matrix(p)).collect();
    let n = phis.len();
    let mut i = 0;
    c.bench_function(&format!("so3/exp_quat/{name}"), |b| {
        b.iter(|| {
            i = (i + 1) % n;
            exp_quat(black_box(phis[i]))
        });
    });
    c.bench_function(&format!("so3/exp_matrix/{name}"), |b| {
        b.iter(|| {
            i = (i + 1) % n;
            exp_matrix(black_box(phis[i]))
        });
    });
    c.bench_function(&format!("so3/log_quat/{name}"), |b| {
        b.iter(|| {
            i = (i + 1) % n;
            log_quat(black_box(quats[i]))
        });
    });
    c.bench_function(&format!("so3/log_matrix/{name}"), |b| {
        b.iter(|| {
            i = (i + 1) % n;
            log_matrix(black_box(mats[i]))
        });
    });
    let dt = T::from_f64(0.01);
    c.bench_function(&format!("so3/exp_update_left/{name}"), |b| {
        b.iter(|| {
            i = (i + 1) % n;
            exp_update_left(black_box(quats[i]), black_box(phis[(i + 7) % n]), dt)
        });
    });
    let g = Quat::new(T::ONE, T::HALF, -T::HALF, T::from_f64(0.25));
    c.bench_function(&format!("so3/exp_update_left_vjp/{name}"), |b| {
        b.iter(|| {
            i = (i + 1) % n;
            exp_update_left_vjp(black_box(quats[i]), black_box(phis[(i + 7) % n]), dt, g)
        });
    });
}

fn benches(c: &mut Criterion) {
    bench_precision::<f32>(c, "f32");
    bench_precision::<f64>(c, "f64");
}

criterion_group!(so3, benches);
criterion_main!(so3);
