//! The figures of `evogs bench` ([`BenchReport`], written as JSON) and their text tables.

use evogs::model::Motion;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

/// Seconds per iteration spent in each phase of a training iteration. The named phases are
/// disjoint stretches of the iteration on its calling thread; `other` is the rest of the
/// iteration (ODE stepping and state packing, the adjoint's glue, gradient zeroing and
/// finiteness checks, the densification statistics).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Phases {
    /// Field evaluations (HexPlane + MLP forward), including those the adjoint recomputes.
    pub field_forward: f64,
    /// Field VJPs (MLP backward, HexPlane backward and plane scatter).
    pub field_vjp: f64,
    /// Projection and SH colours, forward and VJP.
    pub projection: f64,
    /// Rasterization: binning, sorting, compositing.
    pub raster_forward: f64,
    /// Rasterization VJP.
    pub raster_backward: f64,
    /// Photometric loss (L1 and SSIM) and its image gradient.
    pub loss: f64,
    /// The step's regularisers (zero weights here, so the step skips them).
    pub regularizers: f64,
    /// The Adam step of every parameter group.
    pub optimizer: f64,
    /// Everything else.
    pub other: f64,
}

impl Phases {
    /// The sum of the named phases (all but `other`).
    #[must_use]
    pub fn named_sum(&self) -> f64 {
        self.field_forward
            + self.field_vjp
            + self.projection
            + self.raster_forward
            + self.raster_backward
            + self.loss
            + self.regularizers
            + self.optimizer
    }

    /// The sum of all phases (the iteration time).
    #[must_use]
    pub fn total(&self) -> f64 {
        self.named_sum() + self.other
    }

    /// The phases with their column names, in table order.
    #[must_use]
    pub fn entries(&self) -> [(&'static str, f64); 9] {
        [
            ("field fwd", self.field_forward),
            ("field VJP", self.field_vjp),
            ("project", self.projection),
            ("rast fwd", self.raster_forward),
            ("rast bwd", self.raster_backward),
            ("loss", self.loss),
            ("reg", self.regularizers),
            ("optim", self.optimizer),
            ("other", self.other),
        ]
    }

    /// The mean of `samples` (zero for none).
    #[must_use]
    pub fn mean<'a>(samples: impl IntoIterator<Item = &'a Self>) -> Self {
        let mut m = Self::default();
        let mut k = 0_u32;
        for s in samples {
            k += 1;
            m.field_forward += s.field_forward;
            m.field_vjp += s.field_vjp;
            m.projection += s.projection;
            m.raster_forward += s.raster_forward;
            m.raster_backward += s.raster_backward;
            m.loss += s.loss;
            m.regularizers += s.regularizers;
            m.optimizer += s.optimizer;
            m.other += s.other;
        }
        if k > 0 {
            let w = 1.0 / f64::from(k);
            for v in [
                &mut m.field_forward,
                &mut m.field_vjp,
                &mut m.projection,
                &mut m.raster_forward,
                &mut m.raster_backward,
                &mut m.loss,
                &mut m.regularizers,
                &mut m.optimizer,
                &mut m.other,
            ] {
                *v *= w;
            }
        }
        m
    }
}

/// Median, minimum, maximum and mean of a set of timings (seconds).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Median (the mean of the middle two for an even count).
    pub median: f64,
    /// Minimum.
    pub min: f64,
    /// Maximum.
    pub max: f64,
    /// Mean.
    pub mean: f64,
}

impl Summary {
    /// The summary of `values` (all zero for none).
    #[must_use]
    pub fn of(values: &[f64]) -> Self {
        if values.is_empty() {
            return Self::default();
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let k = v.len();
        let median = if k % 2 == 1 {
            v[k / 2]
        } else {
            0.5 * (v[k / 2 - 1] + v[k / 2])
        };
        let mean = v.iter().sum::<f64>() / k as f64;
        Self {
            median,
            min: v[0],
            max: v[k - 1],
            mean,
        }
    }
}

/// One timed iteration.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Sample {
    /// Seconds of the whole iteration.
    pub seconds: f64,
    /// Its phases (they sum to `seconds`).
    pub phases: Phases,
}

/// The field's work in one iteration.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct FieldWork {
    /// Batched evaluations (ODE stages, the adjoint's evaluations of stages whose records
    /// were not kept, displacement).
    pub evaluations: u64,
    /// Batched VJPs.
    pub vjps: u64,
    /// Rows (Gaussians) the MLP ran forward.
    pub forward_rows: u64,
    /// Rows the MLP ran backward.
    pub backward_rows: u64,
}

/// The MLP's matrix products in one iteration.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GemmFigures {
    /// Floating-point operations (counted from the layer sizes and the rows).
    pub flops: u64,
    /// Seconds inside the products, summed over threads (mean per iteration).
    pub thread_seconds: f64,
    /// `flops / thread_seconds / 1e9`: GFLOP/s of a thread while it is in a product (with
    /// one thread, the achieved rate of the products).
    pub gflops: f64,
}

/// The same configuration run on a one-thread pool.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SingleThread {
    /// Seconds per iteration.
    pub seconds: Summary,
    /// Mean phases per iteration.
    pub phases: Phases,
    /// Matrix products on one thread.
    pub gemm: GemmFigures,
    /// Median one-thread time over median multi-thread time.
    pub speedup: f64,
    /// Whether every iteration's loss equals the multi-thread run's bit for bit.
    pub same_losses: bool,
}

/// One configuration: a field size and a motion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BenchRow {
    /// Field size (`paper` or `fast`).
    pub size: String,
    /// Motion.
    pub motion: Motion,
    /// Number of field parameters.
    pub field_params: usize,
    /// Threads of the pool.
    pub threads: usize,
    /// Seconds per iteration over the timed iterations.
    pub seconds: Summary,
    /// Mean phases per iteration.
    pub phases: Phases,
    /// Every timed iteration.
    pub samples: Vec<Sample>,
    /// The loss of every timed iteration.
    pub losses: Vec<f64>,
    /// The field's work in the last iteration (the same in every one).
    pub field: FieldWork,
    /// The MLP's matrix products.
    pub gemm: GemmFigures,
    /// Peak resident set size during this configuration's warm-up and timed iterations
    /// (bytes; since the start of the process where the peak cannot be reset), if known.
    pub peak_rss_bytes: Option<u64>,
    /// Resident set size when this configuration started (bytes, if known): the scene and
    /// memory earlier configurations freed but the allocator kept, which the peak includes.
    pub rss_at_start_bytes: Option<u64>,
    /// The one-thread run (absent when the pool has one thread).
    pub single_thread: Option<SingleThread>,
}

/// Everything `evogs bench` measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BenchReport {
    /// The evogs version.
    pub version: String,
    /// The CPU model, if known.
    pub cpu: Option<String>,
    /// Logical CPUs available to the process.
    pub logical_cpus: usize,
    /// Threads of the multi-thread pool.
    pub threads: usize,
    /// Gaussians in the scene.
    pub gaussians: usize,
    /// Image width and height.
    pub image: [usize; 2],
    /// Untimed iterations before the timed ones (per configuration and pool).
    pub warmup: u64,
    /// Timed iterations (per round).
    pub iters: u64,
    /// Rounds per configuration (pool, then one thread, each round; 1 in reports written
    /// before the flag existed).
    #[serde(default = "one_round")]
    pub rounds: u64,
    /// Scene seed.
    pub seed: u64,
    /// Whether the peak RSS was reset before each configuration.
    pub peak_rss_reset: bool,
    /// One row per (size, motion).
    pub rows: Vec<BenchRow>,
}

/// The rounds of a report that does not name them.
const fn one_round() -> u64 {
    1
}

/// `bytes` in MiB, or `n/a`.
fn mib(bytes: Option<u64>) -> String {
    bytes.map_or_else(|| "n/a".into(), |b| format!("{:.0}", b as f64 / 1048576.0))
}

/// `flops` in GFLOP.
fn gflop(flops: u64) -> f64 {
    flops as f64 * 1e-9
}

impl BenchReport {
    /// The text tables: per configuration the iteration time, peak memory, GEMM rate and
    /// one-thread comparison; then the phases in seconds and in percent of the iteration.
    #[must_use]
    pub fn table(&self) -> String {
        let mut s = String::new();
        let cpu = self.cpu.as_deref().unwrap_or("unknown CPU");
        let _ = writeln!(
            s,
            "evogs {} bench: {} Gaussians, {}x{} image, {} warm-up + {} timed iterations{}, {} threads ({} logical CPUs, {cpu})",
            self.version,
            self.gaussians,
            self.image[0],
            self.image[1],
            self.warmup,
            self.iters,
            if self.rounds > 1 {
                format!(" x {} rounds", self.rounds)
            } else {
                String::new()
            },
            self.threads,
            self.logical_cpus
        );
        let _ = writeln!(
            s,
            "\n{:<6} {:<11} {:>8} {:>8} {:>8} {:>9} {:>9} {:>9} {:>9} {:>9} {:>8}",
            "size",
            "motion",
            "s/it",
            "min",
            "max",
            "peak MiB",
            "start MiB",
            "GEMM GF/s",
            "1-th s/it",
            "1-th GF/s",
            "speed-up"
        );
        for r in &self.rows {
            let (one, one_gf, speedup) = r.single_thread.as_ref().map_or_else(
                || ("-".into(), "-".into(), "-".into()),
                |o| {
                    (
                        format!("{:.3}", o.seconds.median),
                        format!("{:.1}", o.gemm.gflops),
                        format!("{:.2}x", o.speedup),
                    )
                },
            );
            let _ = writeln!(
                s,
                "{:<6} {:<11} {:>8.3} {:>8.3} {:>8.3} {:>9} {:>9} {:>9.1} {one:>9} {one_gf:>9} {speedup:>8}",
                r.size,
                r.motion.as_str(),
                r.seconds.median,
                r.seconds.min,
                r.seconds.max,
                mib(r.peak_rss_bytes),
                mib(r.rss_at_start_bytes),
                r.gemm.gflops,
            );
        }
        let names = Phases::default().entries().map(|(n, _)| n);
        let _ = write!(s, "\nphases, s/it (mean)\n{:<6} {:<11}", "size", "motion");
        for n in names {
            let _ = write!(s, " {n:>9}");
        }
        let _ = writeln!(s, " {:>9}", "sum");
        for r in &self.rows {
            let _ = write!(s, "{:<6} {:<11}", r.size, r.motion.as_str());
            for (_, v) in r.phases.entries() {
                let _ = write!(s, " {v:>9.4}");
            }
            let _ = writeln!(s, " {:>9.4}", r.phases.total());
        }
        let _ = write!(
            s,
            "\nphases, % of the iteration\n{:<6} {:<11}",
            "size", "motion"
        );
        for n in names {
            let _ = write!(s, " {n:>9}");
        }
        let _ = writeln!(s);
        for r in &self.rows {
            let _ = write!(s, "{:<6} {:<11}", r.size, r.motion.as_str());
            let total = r.phases.total();
            for (_, v) in r.phases.entries() {
                let pct = if total > 0.0 { 100.0 * v / total } else { 0.0 };
                let _ = write!(s, " {pct:>9.1}");
            }
            let _ = writeln!(s);
        }
        let _ = writeln!(s, "\nfield work per iteration");
        for r in &self.rows {
            let f = &r.field;
            let _ = writeln!(
                s,
                "{:<6} {:<11} {} evaluations, {} VJPs, MLP rows {} forward / {} backward, {:.2} GFLOP in GEMMs, {} field parameters",
                r.size,
                r.motion.as_str(),
                f.evaluations,
                f.vjps,
                f.forward_rows,
                f.backward_rows,
                gflop(r.gemm.flops),
                r.field_params
            );
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summaries_and_means() {
        let s = Summary::of(&[3.0, 1.0, 2.0, 10.0]);
        assert_eq!(
            (s.median, s.min, s.max, s.mean),
            (2.5, 1.0, 10.0, 4.0),
            "even count"
        );
        assert!(
            (Summary::of(&[2.0, 9.0, 1.0]).median - 2.0).abs() < 1e-15,
            "odd"
        );
        let a = Phases {
            loss: 1.0,
            other: 2.0,
            ..Phases::default()
        };
        let b = Phases {
            loss: 3.0,
            ..Phases::default()
        };
        let m = Phases::mean([&a, &b]);
        assert!(
            (m.loss - 2.0).abs() < 1e-15 && (m.other - 1.0).abs() < 1e-15,
            "{m:?}"
        );
        assert!((m.total() - 3.0).abs() < 1e-15, "total");
    }
}
