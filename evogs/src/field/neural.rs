//! [`NeuralField`]: HexPlane features + the velocity MLP, batched over all Gaussians, with an
//! exact VJP, and its [`VectorField`] implementation for the Gaussian state.
//!
//! Per Gaussian the field maps a position `x` and a time `t` to
//! `[v (3), ω (3), ṡ (3)] = MLP(HexPlane(x, t))`: the velocity, the **world-frame** angular
//! velocity and the log-scale rate. As a vector field on the state layout
//! `[Euclidean(3) position, So3 rotation, Euclidean(3) log-scale]` it depends on the position
//! only, so its VJP has zero rotation and log-scale components.
//!
//! Work is split into fixed chunks of [`CHUNK`] Gaussians (rayon over chunks when the
//! parallelism value asks for it). MLP weight gradients are accumulated per chunk and reduced
//! in chunk order; plane gradients are scattered plane by plane (planes are disjoint parameter
//! ranges) in Gaussian order. Results are therefore bitwise identical for any thread count.
//! Buffers are kept between calls and only grow.
//!
//! **What the VJP reads from the forward pass.** The VJP needs the features and MLP
//! activations of the evaluation it differentiates. An evaluation writes them into a
//! [`FieldRecord`]; with a record the caller owns ([`Batch`] evaluated with
//! `Some(record)`, the [`VectorField::eval_recorded`] of the ODE stages) the caller hands
//! the same record back to the VJP ([`BatchVjp::record`], [`VectorField::vjp_recorded`]),
//! which then runs only the backward pass; without one the VJP runs the forward pass again
//! into the field's scratch. The field never stores evaluations for later or looks them up:
//! whoever made the evaluation knows which VJP belongs to it (the displacement of a frame,
//! the coherence samples, or the stage of an ODE step, where
//! [`evogs_ode::StageTape`] keeps the records of the last steps within the budget of
//! [`set_eval_budget`](NeuralField::set_eval_budget) and hands them back in reverse). A
//! record remembers the time, batch size and parameter generation it was written at, and
//! the VJP checks them, so a record handed back to the wrong evaluation or after a
//! parameter change is an error, never a silent wrong gradient. Both ways give bitwise the
//! same results.

use super::chunk::{
    CHUNK, ChunkRecord, ChunkWork, DecodeChunk, decode_chunk_vjp, forward_chunk, scatter_plane,
};
use super::gemm::Gemm;
use super::hexplane::{CellRecord, HexPlane, HexPlaneConfig, TimeMapping};
use super::mlp::{Mlp, N_OUT};
use super::profile::FieldProfile;
use crate::aligned::CacheAligned;
use evogs_math::Par;
use evogs_math::rng::SplitMix64;
use evogs_ode::{Block, StateLayout, VectorField};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

mod record;

pub use record::{EVAL_BUDGET_BYTES, FieldRecord};

/// State entries per Gaussian: position (3), quaternion (4), log-scale (3).
pub const STATE_STRIDE: usize = 10;

/// The per-Gaussian state layout of the dynamics: position, rotation, log-scale.
#[must_use]
pub fn gaussian_layout(count: usize) -> StateLayout {
    StateLayout::particles(
        &[Block::Euclidean(3), Block::So3, Block::Euclidean(3)],
        count,
    )
}

/// The configuration of the neural field.
///
/// A stored configuration may still name the removed `twist` key (the twist velocity
/// `v = a + ω × (x − c)`, measured worse: `docs/results.md`); `crate::config` reads it as
/// it reads every removed key.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NeuralFieldConfig {
    /// The HexPlane shape.
    pub hexplane: HexPlaneConfig,
    /// MLP hidden width W.
    pub width: usize,
    /// Initial output scales (velocity, angular velocity, log-scale rate).
    pub output_scales: [f64; 3],
    /// Start the last layer of every head at zero (the initial field is exactly zero, so
    /// switching the dynamics on does not disturb the static fit); the released code uses
    /// Xavier there too (`false`; the default when a file leaves it out).
    pub zero_init_output: bool,
}

/// `n` positions at one time: position `i` at `positions[i·stride..i·stride + 3]`.
#[derive(Clone, Copy, Debug)]
pub struct Batch<'a, T> {
    /// The time.
    pub t: T,
    /// The positions (at least `(n − 1)·stride + 3` entries).
    pub positions: &'a [T],
    /// Entries from one position to the next.
    pub stride: usize,
    /// Number of positions.
    pub n: usize,
}

/// The arguments of [`NeuralField::vjp_batch`].
#[derive(Debug)]
pub struct BatchVjp<'a, T> {
    /// Where the field was evaluated.
    pub at: Batch<'a, T>,
    /// The record the evaluation at `at` wrote (with the current parameters), or `None` to
    /// run the forward pass again.
    pub record: Option<&'a FieldRecord<T>>,
    /// The cotangent of the outputs, `n × 9`.
    pub d_out: &'a [T],
    /// `∂/∂position` of position `i` is **added** into
    /// `d_positions[i·d_stride..i·d_stride + 3]`.
    pub d_positions: &'a mut [T],
    /// Entries from one position's gradient to the next.
    pub d_stride: usize,
    /// `∂/∂θ` is **added** here (`n_params()` entries).
    pub d_params: &'a mut [T],
}

/// One chunk's share of a batched VJP: its MLP gradient partial, its lookup records,
/// sample gradients and position gradients (outputs), and the chunk of the forward record.
struct ChunkVjp<'a, T> {
    /// Chunk index.
    index: usize,
    /// This chunk's MLP parameter gradient.
    partial: &'a mut [T],
    /// The scatter records of the chunk's plane lookups.
    cells: &'a mut [CellRecord<T>],
    /// The gradient of each looked-up sample.
    d_samples: &'a mut [T],
    /// The position gradients of the chunk's rows (3 each).
    d_pos: &'a mut [T],
    /// The chunk's features and activations from the forward pass.
    record: &'a ChunkRecord<T>,
}

/// HexPlane + MLP with all parameters in one flat vector `[planes…, MLP…, output scales]`.
#[derive(Debug)]
pub struct NeuralField<T> {
    hex: HexPlane,
    mlp: Mlp,
    /// On a cache-line boundary, so that every texel is whole cache lines (`crate::aligned`).
    params: CacheAligned<T>,
    count: usize,
    par: Par,
    partials: Vec<T>,
    cells: Vec<CellRecord<T>>,
    /// On a cache-line boundary like the parameters: it holds one C-vector per lookup.
    d_samples: CacheAligned<T>,
    d_pos: Vec<T>,
    /// The record of evaluations made without one of the caller's, and of the forward pass
    /// a VJP without a record runs again.
    scratch: FieldRecord<T>,
    /// Bytes the records a [`StageTape`](evogs_ode::StageTape) keeps may take together
    /// ([`EVAL_BUDGET_BYTES`] by default).
    eval_budget: usize,
    /// The VJP's scratch, one per thread: a chunk takes the scratch of the thread that runs
    /// it, so the scratch stays in that core's caches from one chunk to the next (one per
    /// chunk left every chunk's scratch cold: the products that write it ran 1.15–2× slower,
    /// `docs/performance.md`). The lock is never contended (one thread, one slot); it is what
    /// lets a chunk reach its thread's slot without `unsafe`.
    work: Vec<Mutex<ChunkWork<T>>>,
    /// Incremented on every parameter change: a record written before is refused.
    generation: u64,
    /// Opt-in timing ([`set_profile`](Self::set_profile)).
    profile: Option<Arc<FieldProfile>>,
}

impl<T: Gemm> NeuralField<T> {
    /// A freshly initialised field over the box `[aabb_min, aabb_max]`.
    #[must_use]
    pub fn new(
        cfg: &NeuralFieldConfig,
        aabb_min: [f64; 3],
        aabb_max: [f64; 3],
        time: TimeMapping,
        seed: u64,
    ) -> Self {
        let hex = HexPlane::new(&cfg.hexplane, aabb_min, aabb_max, time);
        let mlp = Mlp {
            input: hex.feature_dim(),
            width: cfg.width,
        };
        let mut params = CacheAligned::new(hex.n_params() + mlp.n_params(), T::ZERO);
        let mut rng = SplitMix64::new(seed);
        hex.init_params(&mut rng, &mut params[..hex.n_params()]);
        mlp.init_params(
            &mut rng,
            cfg.output_scales,
            cfg.zero_init_output,
            &mut params[hex.n_params()..],
        );
        Self {
            hex,
            mlp,
            params,
            count: 0,
            par: Par::Seq,
            partials: Vec::new(),
            cells: Vec::new(),
            d_samples: CacheAligned::default(),
            d_pos: Vec::new(),
            scratch: FieldRecord::default(),
            eval_budget: EVAL_BUDGET_BYTES,
            work: Vec::new(),
            generation: 0,
            profile: None,
        }
    }

    /// The HexPlane layout.
    #[must_use]
    pub const fn hexplane(&self) -> &HexPlane {
        &self.hex
    }
    /// The MLP shape.
    #[must_use]
    pub const fn mlp(&self) -> &Mlp {
        &self.mlp
    }
    /// All parameters.
    #[must_use]
    pub fn params(&self) -> &[T] {
        &self.params
    }
    /// All parameters, mutable (for the optimiser and the gradient checks). Records written
    /// before are refused by the VJP from now on.
    pub fn params_mut(&mut self) -> &mut [T] {
        self.generation += 1;
        &mut self.params
    }

    /// The range of the plane parameters (optimiser group "grid").
    #[must_use]
    pub fn grid_range(&self) -> core::ops::Range<usize> {
        0..self.hex.n_params()
    }
    /// The range of the MLP parameters and output scales (optimiser group "deformation").
    #[must_use]
    pub fn mlp_range(&self) -> core::ops::Range<usize> {
        self.hex.n_params()..self.params.len()
    }
    /// Sets the number of Gaussians the [`VectorField`] implementation integrates.
    pub fn set_count(&mut self, n: usize) {
        self.count = n;
    }
    /// Sets the parallelism.
    pub fn set_par(&mut self, par: Par) {
        self.par = par;
    }
    /// The parallelism its batched evaluations and VJPs use.
    #[must_use]
    pub const fn par(&self) -> Par {
        self.par
    }
    /// Attaches a [`FieldProfile`] that accumulates the time of every batched evaluation,
    /// VJP and matrix product from now on (`None` detaches it; results never depend on it).
    pub fn set_profile(&mut self, profile: Option<Arc<FieldProfile>>) {
        self.profile = profile;
    }

    /// Evaluates the field at the positions of `at`; writes `[v, ω, ṡ]` of position `i` into
    /// `out[i·9..i·9+9]`. With `Some(record)` the record is overwritten with what the VJP at
    /// `at` needs (hand it back in [`BatchVjp::record`]); with `None` the field's scratch
    /// holds it until the next call.
    ///
    /// # Panics
    /// If the buffers are too short for `n`.
    pub fn eval_batch(
        &mut self,
        at: &Batch<'_, T>,
        out: &mut [T],
        record: Option<&mut FieldRecord<T>>,
    ) {
        let n = at.n;
        assert!(
            n == 0 || (at.positions.len() > (n - 1) * at.stride + 2 && out.len() >= n * N_OUT),
            "batch buffers too short"
        );
        let start = self.profile.as_ref().map(|_| Instant::now());
        match record {
            Some(rec) => self.forward(at, rec, Some(out)),
            None => {
                let mut scratch = std::mem::take(&mut self.scratch);
                self.forward(at, &mut scratch, Some(out));
                self.scratch = scratch;
            }
        }
        if let (Some(p), Some(start)) = (&self.profile, start) {
            p.add_evaluation(start, n);
        }
    }

    /// The forward pass of every chunk of `at` into `rec` (and the outputs into `out` when
    /// given).
    fn forward(&mut self, at: &Batch<'_, T>, rec: &mut FieldRecord<T>, out: Option<&mut [T]>) {
        let n = at.n;
        let n_chunks = n.div_ceil(CHUNK);
        rec.prepare(&self.hex, &self.mlp, at.t, n, self.generation);
        let (hex, mlp, params) = (&self.hex, &self.mlp, &self.params);
        let profile = self.profile.as_deref();
        let (t, positions, stride) = (at.t, at.positions, at.stride);
        let run = |(ci, rec): (usize, &mut ChunkRecord<T>), out_c: &mut [T]| {
            let rows = CHUNK.min(n - ci * CHUNK);
            let pos = &positions[ci * CHUNK * stride..];
            forward_chunk(
                hex,
                mlp,
                params,
                t,
                pos,
                stride,
                rows,
                rec,
                &mut out_c[..rows * N_OUT],
                profile,
            );
        };
        let chunks = rec.chunks_mut(n_chunks);
        match (self.par, out) {
            (Par::Seq, Some(out)) => chunks
                .iter_mut()
                .enumerate()
                .zip(out[..n * N_OUT].chunks_mut(CHUNK * N_OUT))
                .for_each(|(item, out_c)| run(item, out_c)),
            (Par::Seq, None) => chunks.iter_mut().enumerate().for_each(|item| {
                let mut out_c = [T::ZERO; CHUNK * N_OUT];
                run(item, &mut out_c);
            }),
            #[cfg(feature = "rayon")]
            (Par::Rayon, out) => {
                use rayon::prelude::*;
                let chunks = chunks.par_iter_mut().enumerate();
                match out {
                    Some(out) => chunks
                        .zip(out[..n * N_OUT].par_chunks_mut(CHUNK * N_OUT))
                        .for_each(|(item, out_c)| run(item, out_c)),
                    None => chunks.for_each(|item| {
                        let mut out_c = [T::ZERO; CHUNK * N_OUT];
                        run(item, &mut out_c);
                    }),
                }
            }
        }
    }

    /// VJP of [`eval_batch`](Self::eval_batch): given `d_out` (n × 9), **adds**
    /// `∂/∂position` into `d_positions` and `∂/∂θ` into `d_params` (see [`BatchVjp`]).
    ///
    /// # Panics
    /// If the buffers are too short, or if `record` was not written by an evaluation at
    /// this time and batch size with the current parameters.
    pub fn vjp_batch(&mut self, args: BatchVjp<'_, T>) {
        let start = self.profile.as_ref().map(|_| Instant::now());
        let n = args.at.n;
        let recomputed = args.record.is_none();
        match args.record {
            Some(rec) => self.backward(args, rec),
            None => {
                let mut scratch = std::mem::take(&mut self.scratch);
                self.forward(&args.at, &mut scratch, None);
                self.backward(args, &scratch);
                self.scratch = scratch;
            }
        }
        if let (Some(p), Some(start)) = (&self.profile, start) {
            p.add_vjp(start, n, recomputed);
        }
    }

    /// The backward pass of [`vjp_batch`](Self::vjp_batch) from the forward record `rec`.
    fn backward(&mut self, args: BatchVjp<'_, T>, rec: &FieldRecord<T>) {
        let BatchVjp {
            at,
            d_out,
            d_positions,
            d_stride,
            d_params,
            ..
        } = args;
        let (t, positions, stride, n) = (at.t, at.positions, at.stride, at.n);
        assert!(
            d_out.len() >= n * N_OUT && d_params.len() == self.params.len(),
            "vjp buffers have the wrong size"
        );
        rec.check(t, n, self.generation);
        let n_chunks = n.div_ceil(CHUNK);
        let n_lk = self.hex.n_lookups();
        let ch = self.hex.channels();
        let n_mlp = self.mlp.n_params();
        // Sized only: each chunk zeroes its own MLP partial and writes every entry of its
        // records, sample gradients and position gradients.
        self.partials.resize(n_chunks * n_mlp, T::ZERO);
        self.cells.resize(n * n_lk, CellRecord::default());
        self.d_samples.resize(n * n_lk * ch, T::ZERO);
        self.d_pos.resize(n * 3, T::ZERO);
        self.ensure_work(threads(self.par));
        let (hex, mlp, params) = (&self.hex, &self.mlp, &self.params);
        let profile = self.profile.as_deref();
        let works = &self.work;
        let run = |c: ChunkVjp<'_, T>| {
            // Scratch only: whatever a panicking chunk left in it is overwritten.
            let mut work = works[thread_index(self.par) % works.len()]
                .lock()
                .unwrap_or_else(PoisonError::into_inner);
            let work = &mut *work;
            let rows = c.cells.len() / n_lk;
            let pos = &positions[c.index * CHUNK * stride..];
            let d_o = &d_out[c.index * CHUNK * N_OUT..c.index * CHUNK * N_OUT + rows * N_OUT];
            c.partial.fill(T::ZERO);
            mlp.backward(
                &params[hex.n_params()..],
                &c.record.features,
                rows,
                &c.record.act,
                &mut work.mlp,
                d_o,
                &mut work.d_features,
                c.partial,
                profile,
            );
            decode_chunk_vjp(DecodeChunk {
                hex,
                params,
                t,
                pos,
                stride,
                rows,
                d_features: &work.d_features,
                samples: &mut work.samples,
                cells: c.cells,
                dss: c.d_samples,
                d_pos: c.d_pos,
            });
        };
        let records = rec.chunks(n_chunks);
        match self.par {
            Par::Seq => self
                .partials
                .chunks_mut(n_mlp)
                .zip(self.cells.chunks_mut(CHUNK * n_lk))
                .zip(self.d_samples.chunks_mut(CHUNK * n_lk * ch))
                .zip(self.d_pos.chunks_mut(CHUNK * 3))
                .zip(records)
                .enumerate()
                .map(ChunkVjp::from_zip)
                .for_each(run),
            #[cfg(feature = "rayon")]
            Par::Rayon => {
                use rayon::prelude::*;
                self.partials
                    .par_chunks_mut(n_mlp)
                    .zip(self.cells.par_chunks_mut(CHUNK * n_lk))
                    .zip(self.d_samples.par_chunks_mut(CHUNK * n_lk * ch))
                    .zip(self.d_pos.par_chunks_mut(CHUNK * 3))
                    .zip(records.par_iter())
                    .enumerate()
                    .map(ChunkVjp::from_zip)
                    .for_each(run);
            }
        }
        self.gather(n, d_params, d_positions, d_stride);
    }

    /// Adds what the chunks left into the caller's gradients, as independent tasks of one
    /// parallel pass: each plane's stored per-lookup sample gradients into the plane (in
    /// Gaussian order; a plane's records are read as one contiguous run per chunk), the
    /// chunks' MLP partials into the MLP gradient (in chunk order), and the position
    /// gradients. Every entry receives the same terms in the same order on any thread count.
    fn gather(&self, n: usize, d_params: &mut [T], d_positions: &mut [T], d_stride: usize) {
        let hex = &self.hex;
        let n_lk = hex.n_lookups();
        let ch = hex.channels();
        let n_mlp = self.mlp.n_params();
        let (d_grid, d_mlp) = d_params.split_at_mut(hex.n_params());
        let mut tasks: Vec<Gather<'_, T>> = Vec::with_capacity(n_lk + 2);
        tasks.push(Gather::Mlp(d_mlp));
        tasks.push(Gather::Positions(d_positions));
        let mut rest = d_grid;
        let mut consumed = 0;
        for l in 0..hex.levels() {
            for p in 0..6 {
                let r = hex.plane_range(l, p);
                debug_assert_eq!(r.start, consumed, "planes are contiguous");
                let (head, tail) = rest.split_at_mut(r.len());
                tasks.push(Gather::Plane(l, p, head));
                rest = tail;
                consumed = r.end;
            }
        }
        let (cells, d_samples) = (&self.cells, &self.d_samples);
        let (partials, d_pos) = (&self.partials, &self.d_pos);
        let work = |task: Gather<'_, T>| match task {
            Gather::Plane(l, p, plane) => {
                let k = l * 6 + p;
                for c0 in (0..n).step_by(CHUNK) {
                    // The chunk's records of plane k are contiguous (see decode_chunk_vjp).
                    let rows = CHUNK.min(n - c0);
                    let first = c0 * n_lk + k * rows;
                    scatter_plane(
                        hex,
                        l,
                        p,
                        &cells[first..first + rows],
                        &d_samples[first * ch..(first + rows) * ch],
                        plane,
                    );
                }
            }
            Gather::Mlp(d_mlp) => {
                for partial in partials.chunks(n_mlp) {
                    for (d, &p) in d_mlp.iter_mut().zip(partial) {
                        *d += p;
                    }
                }
            }
            Gather::Positions(d_positions) => {
                for i in 0..n {
                    for a in 0..3 {
                        d_positions[i * d_stride + a] += d_pos[i * 3 + a];
                    }
                }
            }
        };
        match self.par {
            Par::Seq => tasks.into_iter().for_each(work),
            #[cfg(feature = "rayon")]
            Par::Rayon => {
                use rayon::prelude::*;
                tasks.into_par_iter().for_each(work);
            }
        }
    }
}

/// The threads a pass with `par` runs on: the current pool's under rayon, else one.
fn threads(par: Par) -> usize {
    match par {
        Par::Seq => 1,
        #[cfg(feature = "rayon")]
        Par::Rayon => rayon::current_num_threads(),
    }
}

/// The index of the calling thread among [`threads`]`(par)` (0 outside the pool).
fn thread_index(par: Par) -> usize {
    match par {
        Par::Seq => 0,
        #[cfg(feature = "rayon")]
        Par::Rayon => rayon::current_thread_index().unwrap_or(0),
    }
}

/// One task of [`NeuralField::gather`]: a plane of the gradient (level, plane), the MLP's
/// part of the gradient, or the position gradients.
enum Gather<'a, T> {
    Plane(usize, usize, &'a mut [T]),
    Mlp(&'a mut [T]),
    Positions(&'a mut [T]),
}

/// The zipped per-chunk slices of [`NeuralField::vjp_batch`], in the order they are zipped.
type ChunkZip<'a, T> = (
    usize,
    (
        (
            ((&'a mut [T], &'a mut [CellRecord<T>]), &'a mut [T]),
            &'a mut [T],
        ),
        &'a ChunkRecord<T>,
    ),
);

impl<'a, T> ChunkVjp<'a, T> {
    /// Names the zipped slices of chunk `index`.
    fn from_zip(
        (index, ((((partial, cells), d_samples), d_pos), record)): ChunkZip<'a, T>,
    ) -> Self {
        Self {
            index,
            partial,
            cells,
            d_samples,
            d_pos,
            record,
        }
    }
}

impl<T: Gemm> VectorField<T> for NeuralField<T> {
    type Record = FieldRecord<T>;
    fn dim(&self) -> usize {
        self.count * N_OUT
    }
    fn layout(&self) -> StateLayout {
        gaussian_layout(self.count)
    }
    fn n_params(&self) -> usize {
        self.params.len()
    }
    fn eval(&mut self, t: T, y: &[T], dydt: &mut [T]) {
        let at = self.state_batch(t, y);
        self.eval_batch(&at, dydt, None);
    }
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        self.vjp_recorded_or_not(t, y, None, w, d_y, d_params);
    }
    fn eval_recorded(&mut self, t: T, y: &[T], dydt: &mut [T], record: &mut FieldRecord<T>) {
        let at = self.state_batch(t, y);
        self.eval_batch(&at, dydt, Some(record));
    }
    fn vjp_recorded(
        &mut self,
        t: T,
        y: &[T],
        record: &FieldRecord<T>,
        w: &[T],
        d_y: &mut [T],
        d_params: &mut [T],
    ) {
        self.vjp_recorded_or_not(t, y, Some(record), w, d_y, d_params);
    }
}

impl<T: Gemm> NeuralField<T> {
    /// The positions of the ODE state `y` (every Gaussian) at `t`.
    const fn state_batch<'a>(&self, t: T, y: &'a [T]) -> Batch<'a, T> {
        Batch {
            t,
            positions: y,
            stride: STATE_STRIDE,
            n: self.count,
        }
    }

    /// The [`VectorField`] VJP on the state, with or without a record.
    fn vjp_recorded_or_not(
        &mut self,
        t: T,
        y: &[T],
        record: Option<&FieldRecord<T>>,
        w: &[T],
        d_y: &mut [T],
        d_params: &mut [T],
    ) {
        let at = self.state_batch(t, y);
        self.vjp_batch(BatchVjp {
            at,
            record,
            d_out: w,
            d_positions: d_y,
            d_stride: N_OUT,
            d_params,
        });
    }
}
