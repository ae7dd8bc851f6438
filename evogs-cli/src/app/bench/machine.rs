//! The limits of this machine, measured rather than assumed (`evogs bench --machine`): the
//! peak rate of f32 fused multiply-adds with the instruction set the build uses, and the
//! rate at which one thread and every thread read f32 data that lives in the L1, L2 and L3
//! caches and in memory. `docs/performance.md` compares the field's GEMMs and its HexPlane
//! gather and scatter with these figures.
//!
//! The kernels are plain Rust that the compiler vectorises for the build's target (8-wide
//! with `target-cpu=x86-64-v3`): the figures are what this build can reach, not the
//! datasheet's. Each measurement is the best of several repetitions, as a limit is. The
//! threads are plain scoped threads (one per measured thread), so the figures do not
//! depend on the `rayon` feature.

use std::hint::black_box;
use std::time::Instant;

/// Independent accumulators of the FMA kernel: enough chains of 8 lanes to cover the
/// latency of two FMA ports (4 cycles × 2 ports × a margin).
const CHAINS: usize = 12;
/// Lanes per chain (one 256-bit register of f32).
const LANES: usize = 8;

/// One read-bandwidth measurement.
#[derive(Clone, Debug, PartialEq)]
pub struct Bandwidth {
    /// Where the data lives (`L1`, `L2`, `L3`, `memory`).
    pub level: String,
    /// Bytes each thread reads over and over.
    pub bytes_per_thread: usize,
    /// GB/s of one thread.
    pub one_thread: f64,
    /// GB/s of every thread together (each with its own buffer).
    pub all_threads: f64,
}

/// The measured limits.
#[derive(Clone, Debug, PartialEq)]
pub struct MachineLimits {
    /// Threads of the pool.
    pub threads: usize,
    /// The vector instruction sets the build was compiled for (`avx2+fma`, ...).
    pub isa: String,
    /// f32 FMA GFLOP/s (2 flops per FMA) of one thread.
    pub fma_one_thread: f64,
    /// f32 FMA GFLOP/s of every thread together.
    pub fma_all_threads: f64,
    /// Read bandwidth per level.
    pub bandwidth: Vec<Bandwidth>,
}

/// The instruction sets this build targets, as far as they matter for f32 arithmetic.
#[must_use]
pub fn build_isa() -> String {
    let mut out = Vec::new();
    if cfg!(target_feature = "avx512f") {
        out.push("avx512f");
    }
    if cfg!(target_feature = "avx2") {
        out.push("avx2");
    }
    if cfg!(target_feature = "fma") {
        out.push("fma");
    }
    if cfg!(target_feature = "neon") {
        out.push("neon");
    }
    if out.is_empty() {
        out.push(if cfg!(target_arch = "x86_64") {
            "sse2"
        } else {
            "scalar"
        });
    }
    out.join("+")
}

/// `rounds` rounds of `CHAINS × LANES` independent FMAs; returns a value that depends on
/// all of them (so that none is optimised away).
fn fma_kernel(rounds: u64, seed: f32) -> f32 {
    let a = black_box(0.999_999_9_f32);
    let b = black_box(1.0e-7_f32);
    let mut acc = [[seed; LANES]; CHAINS];
    for _ in 0..rounds {
        for chain in &mut acc {
            for x in chain.iter_mut() {
                *x = x.mul_add(a, b);
            }
        }
    }
    acc.iter().flatten().sum()
}

/// GFLOP/s of the FMA kernel over `threads` threads (the best of `reps`).
fn fma_rate(threads: usize, rounds: u64, reps: usize) -> f64 {
    let flops = 2.0 * (CHAINS * LANES) as f64 * rounds as f64 * threads as f64;
    (0..reps)
        .map(|_| {
            let t0 = Instant::now();
            let s: f32 = on_threads(threads, |k| fma_kernel(rounds, 1.0 + k as f32));
            black_box(s);
            flops / t0.elapsed().as_secs_f64() / 1e9
        })
        .fold(0.0, f64::max)
}

/// Runs `work(k)` on `threads` threads at once (`k` = 0..threads) and sums the results.
fn on_threads(threads: usize, work: impl Fn(usize) -> f32 + Sync) -> f32 {
    if threads == 1 {
        return work(0);
    }
    let work = &work;
    std::thread::scope(|s| {
        let handles: Vec<_> = (0..threads).map(|k| s.spawn(move || work(k))).collect();
        handles.into_iter().map(|h| h.join().unwrap_or(0.0)).sum()
    })
}

/// Sums `data` with 16 accumulators of 8 lanes: independent vector adds (no dependency
/// stall), the loads at fixed offsets of a 128-float block (no bounds check in the loop).
fn read_kernel(data: &[f32]) -> f32 {
    const BLOCK: usize = 16 * LANES;
    let mut acc = [[0.0_f32; LANES]; 16];
    let chunks = data.chunks_exact(BLOCK);
    let rest: f32 = chunks.remainder().iter().sum();
    for c in chunks {
        let Ok(c) = <&[f32; BLOCK]>::try_from(c) else {
            continue;
        };
        for (j, a) in acc.iter_mut().enumerate() {
            for (l, x) in a.iter_mut().enumerate() {
                *x += c[j * LANES + l];
            }
        }
    }
    acc.iter().flatten().sum::<f32>() + rest
}

/// GB/s of reading a buffer of `bytes` per thread `passes` times (the best of `reps`).
fn read_rate(threads: usize, bytes: usize, passes: usize, reps: usize) -> f64 {
    let n = (bytes / 4).max(16 * LANES);
    let buffers: Vec<Vec<f32>> = (0..threads)
        .map(|k| (0..n).map(|i| ((i + k) % 7) as f32).collect())
        .collect();
    let total = (n * 4 * passes * threads) as f64;
    (0..reps)
        .map(|_| {
            let t0 = Instant::now();
            let s: f32 = on_threads(threads, |k| {
                (0..passes)
                    .map(|_| read_kernel(black_box(&buffers[k])))
                    .sum::<f32>()
            });
            black_box(s);
            total / t0.elapsed().as_secs_f64() / 1e9
        })
        .fold(0.0, f64::max)
}

/// The data-cache sizes of CPU 0 (L1d, L2, L3) in bytes, from Linux's sysfs; `None` where
/// the system does not say.
#[must_use]
pub fn cache_sizes() -> [Option<usize>; 3] {
    let mut out = [None; 3];
    for index in 0..8 {
        let dir = format!("/sys/devices/system/cpu/cpu0/cache/index{index}");
        let read = |f: &str| std::fs::read_to_string(format!("{dir}/{f}")).ok();
        let (Some(level), Some(kind), Some(size)) = (read("level"), read("type"), read("size"))
        else {
            continue;
        };
        if kind.trim() == "Instruction" {
            continue;
        }
        let size = size.trim();
        let bytes = size
            .strip_suffix('K')
            .and_then(|k| k.parse::<usize>().ok().map(|k| k << 10))
            .or_else(|| {
                size.strip_suffix('M')
                    .and_then(|m| m.parse::<usize>().ok().map(|m| m << 20))
            });
        if let (Ok(l), Some(b)) = (level.trim().parse::<usize>(), bytes)
            && (1..=3).contains(&l)
        {
            out[l - 1] = Some(b);
        }
    }
    out
}

/// Measures the limits with one thread and with `threads` threads at once. `quick` shortens every
/// measurement (tests).
#[must_use]
pub fn measure(threads: usize, quick: bool) -> MachineLimits {
    let (rounds, reps) = if quick { (20_000, 2) } else { (20_000_000, 5) };
    let fma_one_thread = fma_rate(1, rounds, reps);
    let fma_all_threads = fma_rate(threads, rounds, reps);
    let [l1, l2, l3] = cache_sizes();
    // Half of a level per thread lives in it (L3 is shared: half of it over the threads);
    // memory: 256 MiB per thread, far beyond any cache.
    let mut levels = Vec::new();
    for (name, size, shared) in [("L1", l1, false), ("L2", l2, false), ("L3", l3, true)] {
        if let Some(s) = size {
            levels.push((name, s / 2, if shared { s / 2 / threads } else { s / 2 }));
        }
    }
    let memory = if quick { 4 << 20 } else { 256 << 20 };
    levels.push(("memory", memory, memory));
    let bandwidth = levels
        .into_iter()
        .map(|(name, one, per_thread)| {
            // About 2 GB read per measurement (a tenth when quick).
            let budget = if quick { 8 << 20 } else { 2 << 30 };
            let passes = |b: usize| (budget / b.max(1)).clamp(1, 1_000_000);
            Bandwidth {
                level: name.to_string(),
                bytes_per_thread: per_thread,
                one_thread: read_rate(1, one, passes(one), reps),
                all_threads: read_rate(threads, per_thread, passes(per_thread * threads), reps),
            }
        })
        .collect();
    MachineLimits {
        threads,
        isa: build_isa(),
        fma_one_thread,
        fma_all_threads,
        bandwidth,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_kernels_compute_what_they_claim() {
        // One round of FMAs from 1: 1·a + b.
        let a = 0.999_999_9_f32;
        let one = 1.0_f32.mul_add(a, 1.0e-7);
        let got = fma_kernel(1, 1.0);
        assert!((got - one * (CHAINS * LANES) as f32).abs() < 1e-4, "{got}");
        let data: Vec<f32> = (0..1000).map(|i| (i % 7) as f32).collect();
        let want: f32 = data.iter().sum();
        assert!(
            (read_kernel(&data) - want).abs() < 1e-3,
            "{}",
            read_kernel(&data)
        );
    }

    #[test]
    fn a_quick_measurement_gives_positive_figures_for_every_level() {
        let m = measure(1, true);
        assert!(m.fma_one_thread > 0.0 && m.fma_all_threads > 0.0);
        assert!(m.bandwidth.iter().any(|b| b.level == "memory"));
        assert!(
            m.bandwidth
                .iter()
                .all(|b| b.one_thread > 0.0 && b.all_threads > 0.0)
        );
        assert!(!m.isa.is_empty());
    }
}
