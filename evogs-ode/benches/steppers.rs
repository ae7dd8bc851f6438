//! Stepper throughput for 10⁴ particles under a rigid rotation field, and the cost of the
//! discrete adjoint relative to the forward pass.
//!
//! Run with `cargo bench -p evogs-ode --bench steppers` (add `--features rayon` for the
//! parallel block updates).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use evogs_math::rng::SplitMix64;
use evogs_math::so3::exp_quat;
use evogs_math::{Par, Vec3};
use evogs_ode::algebra::{ParticleFrame, RigidRotation};
use evogs_ode::{
    Checkpointing, Method, Stepper, TimeGrid, VectorField, discrete_adjoint, integrate_trajectory,
};
use std::hint::black_box;
use std::time::Duration;

const PARTICLES: usize = 10_000;

/// Seeded particles: positions in [−1, 1)³ and, for oriented frames, random rotations.
fn initial_state(frame: &ParticleFrame) -> Vec<f64> {
    let layout = frame.layout();
    let mut rng = SplitMix64::new(7);
    let mut y = vec![0.0; layout.ambient_len()];
    let pa = layout.particle_ambient_len();
    for p in 0..PARTICLES {
        for v in &mut y[p * pa..p * pa + 3] {
            *v = rng.uniform(-1.0, 1.0);
        }
        if pa == 7 {
            let phi = Vec3::new(
                rng.uniform(-2.0, 2.0),
                rng.uniform(-2.0, 2.0),
                rng.uniform(-2.0, 2.0),
            );
            exp_quat(phi).write_to(&mut y[p * pa + 3..]);
        }
    }
    y
}

fn field(frame: ParticleFrame) -> RigidRotation<f64> {
    RigidRotation::new(frame, Vec3::new(0.3, -0.7, 1.1), Vec3::new(0.1, 0.0, -0.2))
}

fn cases() -> Vec<(&'static str, ParticleFrame, Method)> {
    vec![
        ("points/rk4", ParticleFrame::points(PARTICLES), Method::Rk4),
        (
            "oriented/rkmk4",
            ParticleFrame::oriented_points(PARTICLES),
            Method::Rk4,
        ),
        (
            "oriented/lie-euler",
            ParticleFrame::oriented_points(PARTICLES),
            Method::Euler,
        ),
    ]
}

fn pars() -> Vec<(&'static str, Par)> {
    let mut v = vec![("seq", Par::Seq)];
    if !Par::best().is_seq() {
        v.push(("rayon", Par::best()));
    }
    v
}

/// Steps per second (throughput: one element = one step of all 10⁴ particles).
fn steps(c: &mut Criterion) {
    let mut g = c.benchmark_group("step_1e4_particles");
    g.sample_size(20)
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    g.throughput(Throughput::Elements(1));
    for (name, frame, method) in cases() {
        for (par_name, par) in pars() {
            let mut f = field(frame);
            let mut st = Stepper::new(method, frame.layout()).with_par(par);
            let mut y = initial_state(&frame);
            g.bench_function(format!("{name}/{par_name}"), |b| {
                b.iter(|| st.step(&mut f, black_box(0.0), black_box(1e-3), black_box(&mut y)));
            });
        }
    }
    g.finish();
}

/// Forward (16 steps, store-all trajectory) vs the discrete adjoint of the same run.
fn adjoint_vs_forward(c: &mut Criterion) {
    let mut g = c.benchmark_group("adjoint_vs_forward_16_steps");
    g.sample_size(10)
        .measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));
    let grid = TimeGrid::uniform(0.0, 0.5, 16);
    for (name, frame, method) in cases().into_iter().take(2) {
        let mut f = field(frame);
        let mut st = Stepper::new(method, frame.layout());
        let y0 = initial_state(&frame);
        g.bench_function(format!("{name}/forward"), |b| {
            b.iter(|| {
                integrate_trajectory(
                    &mut f,
                    &mut st,
                    &grid,
                    black_box(&y0),
                    Checkpointing::StoreAll,
                )
            });
        });
        let traj = integrate_trajectory(&mut f, &mut st, &grid, &y0, Checkpointing::StoreAll);
        let d_final = vec![1.0; frame.layout().tangent_len()];
        let mut d_y0 = vec![0.0; d_final.len()];
        let mut d_th = vec![0.0; f.n_params()];
        g.bench_function(format!("{name}/adjoint"), |b| {
            b.iter(|| {
                discrete_adjoint(
                    &mut f,
                    &mut st,
                    &traj,
                    black_box(&d_final),
                    &mut d_y0,
                    &mut d_th,
                );
            });
        });
        let sqrt_traj = integrate_trajectory(&mut f, &mut st, &grid, &y0, Checkpointing::sqrt(16));
        g.bench_function(format!("{name}/adjoint-sqrtN"), |b| {
            b.iter(|| {
                discrete_adjoint(
                    &mut f,
                    &mut st,
                    &sqrt_traj,
                    black_box(&d_final),
                    &mut d_y0,
                    &mut d_th,
                );
            });
        });
    }
    g.finish();
}

criterion_group!(benches, steps, adjoint_vs_forward);
criterion_main!(benches);
