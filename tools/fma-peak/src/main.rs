//! Measures the f32 fused multiply-add peak of this machine for each vector width its CPU
//! supports (8 lanes with AVX2 + FMA, 16 with AVX-512F), on one thread and on every
//! logical CPU at once: twelve independent chains per thread, the best of five runs.
//!
//! ```sh
//! cargo run --release --manifest-path tools/fma-peak/Cargo.toml
//! ```

use std::time::Instant;

/// Independent accumulator chains: enough to cover the FMA latency of two ports.
const CHAINS: usize = 12;
/// FMAs per chain per thread.
const ROUNDS: usize = 40_000_000;

#[cfg(target_arch = "x86_64")]
mod kernels {
    use super::CHAINS;
    use std::arch::x86_64::*;

    /// `rounds` rounds of `CHAINS` independent 8-lane FMAs.
    ///
    /// # Safety
    /// The CPU must have AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    pub unsafe fn fma8(rounds: usize, seed: f32) -> f32 {
        let mut acc = [_mm256_set1_ps(seed); CHAINS];
        let a = _mm256_set1_ps(0.999_999_9);
        let b = _mm256_set1_ps(1.0e-7);
        for _ in 0..rounds {
            for x in &mut acc {
                *x = _mm256_fmadd_ps(*x, a, b);
            }
        }
        let mut out = [0.0_f32; 8];
        let mut s = _mm256_setzero_ps();
        for x in acc {
            s = _mm256_add_ps(s, x);
        }
        // SAFETY: `out` holds 8 f32, the width of the store.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), s) };
        out.iter().sum()
    }

    /// `rounds` rounds of `CHAINS` independent 16-lane FMAs.
    ///
    /// # Safety
    /// The CPU must have AVX-512F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn fma16(rounds: usize, seed: f32) -> f32 {
        let mut acc = [_mm512_set1_ps(seed); CHAINS];
        let a = _mm512_set1_ps(0.999_999_9);
        let b = _mm512_set1_ps(1.0e-7);
        for _ in 0..rounds {
            for x in &mut acc {
                *x = _mm512_fmadd_ps(*x, a, b);
            }
        }
        let mut s = _mm512_setzero_ps();
        for x in acc {
            s = _mm512_add_ps(s, x);
        }
        _mm512_reduce_add_ps(s)
    }
}

/// GFLOP/s of `kernel` on `threads` threads at once, the best of five runs.
fn rate(threads: usize, lanes: usize, kernel: fn(usize, f32) -> f32) -> f64 {
    let flops = (2 * CHAINS * lanes * ROUNDS * threads) as f64;
    (0..5)
        .map(|_| {
            let t0 = Instant::now();
            let s: f32 = std::thread::scope(|scope| {
                let handles: Vec<_> = (0..threads)
                    .map(|k| scope.spawn(move || kernel(ROUNDS, 1.0 + k as f32)))
                    .collect();
                handles.into_iter().map(|h| h.join().unwrap_or(0.0)).sum()
            });
            std::hint::black_box(s);
            flops / t0.elapsed().as_secs_f64() / 1e9
        })
        .fold(0.0, f64::max)
}

/// A measured kernel: its name, its lanes and the function that runs it.
type Kernel = (&'static str, usize, fn(usize, f32) -> f32);

fn main() {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!("f32 FMA peak, {CHAINS} chains per thread, best of 5, {threads} logical CPUs");
    println!("{:<22} {:>14} {:>14}", "kernel", "1 thread", "all threads");
    let mut kernels: Vec<Kernel> = Vec::new();
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            // SAFETY: AVX2 and FMA were detected just above.
            kernels.push(("avx2+fma (8 lanes)", 8, |r, s| unsafe {
                kernels::fma8(r, s)
            }));
        }
        if is_x86_feature_detected!("avx512f") {
            // SAFETY: AVX-512F was detected just above.
            kernels.push(("avx512f (16 lanes)", 16, |r, s| unsafe {
                kernels::fma16(r, s)
            }));
        }
    }
    if kernels.is_empty() {
        println!(
            "no x86-64 AVX2 or AVX-512 on this CPU: `evogs bench --machine` measures its width"
        );
        return;
    }
    for (name, lanes, kernel) in kernels {
        let one = rate(1, lanes, kernel);
        let all = rate(threads, lanes, kernel);
        println!("{name:<22} {one:>9.1} GF/s {all:>9.1} GF/s");
    }
}
