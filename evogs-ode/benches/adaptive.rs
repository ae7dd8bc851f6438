//! Work–precision benchmark: the adaptive pairs against fixed-step methods **at equal
//! accuracy** on Kepler (e = 0.6, one period) and Van der Pol (μ = 1, t ∈ [0, 10]).
//!
//! For a target end-time error of 1e-8 (max norm), the study of
//! `benches/common/work_precision.rs` picks, per method, the cheapest setting that reaches
//! it (a tolerance 10⁻ᵏ for `dopri5`/`bs32`, a power-of-two step count for RK4 and for
//! Dormand–Prince's tableau with fixed steps); the benchmark then times one solve with that
//! setting. The chosen settings, their evaluations and errors are printed first. The full
//! error-vs-evaluations table: `cargo run --release -p evogs-ode --example work_precision`.
//!
//! `cargo bench -p evogs-ode --bench adaptive`

#[path = "common/work_precision.rs"]
mod work_precision;

use criterion::{Criterion, criterion_group, criterion_main};
use evogs_ode::adaptive::Pair;
use std::hint::black_box;
use std::time::Duration;
use work_precision::{Point, Problem, adaptive, fixed, fixed_methods, study};

const TARGET: f64 = 1e-8;

/// The cheapest point of each method whose error is at most `TARGET`.
fn choices(points: &[Point]) -> Vec<Point> {
    let mut out: Vec<Point> = Vec::new();
    for p in points.iter().filter(|p| p.error <= TARGET) {
        match out.iter_mut().find(|q| q.method == p.method) {
            Some(q) if q.nfev > p.nfev => *q = p.clone(),
            Some(_) => {}
            None => out.push(p.clone()),
        }
    }
    out
}

fn work_precision(c: &mut Criterion) {
    for problem in Problem::ALL {
        let reference = problem.reference();
        let picks = choices(&study(problem));
        println!(
            "\n{} — cheapest settings with end error ≤ {TARGET:e}:",
            problem.name()
        );
        for p in &picks {
            println!(
                "  {:<16} setting {:>10.3e}  nfev {:>7}  error {:.2e}",
                p.method, p.setting, p.nfev, p.error
            );
        }
        let mut g = c.benchmark_group(format!("work_precision/{}/err1e-8", problem.short()));
        g.sample_size(20)
            .measurement_time(Duration::from_secs(2))
            .warm_up_time(Duration::from_millis(500));
        for p in &picks {
            if let Some(pair) = Pair::ALL.into_iter().find(|q| q.name() == p.method) {
                let tol = p.setting;
                g.bench_function(p.method.as_str(), |b| {
                    b.iter(|| black_box(adaptive(problem, pair, black_box(tol), &reference)));
                });
            } else if let Some((name, t)) = fixed_methods()
                .into_iter()
                .find(|(n, _)| format!("{n} (fixed)") == p.method)
            {
                #[allow(
                    clippy::cast_possible_truncation,
                    reason = "step counts are small powers of two"
                )]
                let n = p.setting as usize;
                g.bench_function(format!("{name}_fixed"), |b| {
                    b.iter(|| black_box(fixed(problem, name, t, black_box(n), &reference)));
                });
            }
        }
        g.finish();
    }
}

criterion_group!(benches, work_precision);
criterion_main!(benches);
