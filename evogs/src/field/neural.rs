//! [`NeuralField`]: HexPlane features + the velocity MLP, batched over all Gaussians, with an
//! exact VJP, and its [`VectorField`] implementation for the Gaussian state.
//!
//! Per Gaussian the field maps a position `x` and a time `t` to
//! `[v (3), ω (3), ṡ (3)] = MLP(HexPlane(x, t))`: the velocity, the **world-frame** angular
//! velocity and the log-scale rate (with [`NeuralFieldConfig::twist`] the velocity is
//! `a + ω × (x − c)`, `a` the velocity head). As a vector field on the state layout
//! `[Euclidean(3) position, So3 rotation, Euclidean(3) log-scale]` it depends on the position
//! only, so its VJP has zero rotation and log-scale components.
//!
//! Work is split into fixed chunks of [`CHUNK`] Gaussians (rayon over chunks when the
//! parallelism value asks for it). MLP weight gradients are accumulated per chunk and reduced
//! in chunk order; plane gradients are scattered plane by plane (planes are disjoint parameter
//! ranges) in Gaussian order. Results are therefore bitwise identical for any thread count.
//! Buffers are kept between calls and only grow.

use super::chunk::{CHUNK, ChunkRecord, ChunkWork, decode_chunk_vjp, forward_chunk};
use super::gemm::Gemm;
use super::hexplane::{HexPlane, HexPlaneConfig, Lookup, TimeMapping};
use super::mlp::{Mlp, N_OUT};
use super::profile::FieldProfile;
use eval_cache::Evaluation;
use evogs_math::rng::SplitMix64;
use evogs_math::{Par, Vec3};
use evogs_ode::{Block, StateLayout, VectorField};
use std::sync::Arc;
use std::time::Instant;

mod eval_cache;

pub use eval_cache::EVAL_BUDGET_BYTES;

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
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct NeuralFieldConfig {
    /// The HexPlane shape.
    pub hexplane: HexPlaneConfig,
    /// MLP hidden width W.
    pub width: usize,
    /// Initial output scales (velocity, angular velocity, log-scale rate).
    pub output_scales: [f64; 3],
    /// Start the last layer of every head at zero (the initial field is exactly zero, so
    /// switching the dynamics on does not disturb the static fit); the released code uses
    /// Xavier there too (`false`).
    #[serde(default)]
    pub zero_init_output: bool,
    /// Read the velocity head as the translational part `a` of a local twist (an SE(3)
    /// velocity field): `v(x, t) = a(x, t) + ω(x, t) × (x − c)`, with `ω` the angular-velocity
    /// head and `c` the centre of the field's box. A rigid motion then has a spatially
    /// constant `(a, ω)` over the body, and the `ω` that turns the Gaussians is the one that
    /// moves their centres; the velocity coherence then compares the twists `(a, ω)` of
    /// neighbours, so it costs nothing for any rigid motion. `false` (the released code):
    /// `v = a`.
    #[serde(default)]
    pub twist: bool,
}

/// One work item of the batched VJP: chunk index, MLP gradient partial, lookups, sample
/// gradients, position gradients and the activations of the chunk.
type VjpItem<'a, T> = (
    usize,
    (
        (
            &'a mut [T],
            (&'a mut [Lookup<T>], (&'a mut [T], &'a mut [T])),
        ),
        (&'a mut ChunkRecord<T>, &'a mut ChunkWork<T>),
    ),
);

/// HexPlane + MLP with all parameters in one flat vector `[planes…, MLP…, output scales]`.
#[derive(Debug)]
pub struct NeuralField<T> {
    hex: HexPlane,
    mlp: Mlp,
    params: Vec<T>,
    count: usize,
    par: Par,
    partials: Vec<T>,
    lookups: Vec<Lookup<T>>,
    d_samples: Vec<T>,
    d_pos: Vec<T>,
    /// Stored evaluations (activations chunk by chunk), most recent reused first.
    evals: Vec<Evaluation<T>>,
    /// How many evaluations are kept (at least 1), within `eval_budget`.
    capacity: usize,
    /// Bytes the stored evaluations may take together ([`EVAL_BUDGET_BYTES`] by default).
    eval_budget: usize,
    /// Scratch per chunk, shared by every evaluation and VJP.
    work: Vec<ChunkWork<T>>,
    /// Incremented on every parameter change: stored evaluations of older parameters are
    /// never reused.
    generation: u64,
    /// The velocity is a twist about the box centre ([`NeuralFieldConfig::twist`]).
    twist: bool,
    /// Use counter for the least-recently-used replacement.
    clock: u64,
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
        let mut params = vec![T::ZERO; hex.n_params() + mlp.n_params()];
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
            lookups: Vec::new(),
            d_samples: Vec::new(),
            d_pos: Vec::new(),
            evals: Vec::new(),
            capacity: 1,
            eval_budget: EVAL_BUDGET_BYTES,
            work: Vec::new(),
            generation: 0,
            twist: cfg.twist,
            clock: 0,
            profile: None,
        }
    }

    /// The twist reference point `c` (the box centre) when the velocity is a twist
    /// `v = a + ω × (x − c)`, else `None`.
    #[must_use]
    pub fn twist_centre(&self) -> Option<Vec3<T>> {
        let (lo, hi) = self.hex.aabb();
        self.twist
            .then(|| Vec3::from_array(core::array::from_fn(|a| T::from_f64(0.5 * (lo[a] + hi[a])))))
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
    /// All parameters, mutable (for the optimiser and the gradient checks). Invalidates the
    /// stored evaluations.
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
    /// Attaches a [`FieldProfile`] that accumulates the time of every batched evaluation,
    /// VJP and matrix product from now on (`None` detaches it; results never depend on it).
    pub fn set_profile(&mut self, profile: Option<Arc<FieldProfile>>) {
        self.profile = profile;
    }

    /// Evaluates the field at `n` positions (position `i` at `positions[i·stride..i·stride+3]`)
    /// and time `t`; writes `[v, ω, ṡ]` into `out[i·9..i·9+9]`.
    ///
    /// # Panics
    /// If the buffers are too short for `n`.
    pub fn eval_batch(&mut self, t: T, positions: &[T], stride: usize, n: usize, out: &mut [T]) {
        self.eval_heads(t, positions, stride, n, out);
        if let Some(c) = self.twist_centre() {
            for (i, o) in out[..n * N_OUT].chunks_exact_mut(N_OUT).enumerate() {
                let r = Vec3::from_slice(&positions[i * stride..]) - c;
                Vec3::from_slice(&o[3..]).cross(r).add_to(o);
            }
        }
    }

    /// The head outputs `[a, ω, ṡ]` (scaled) at `n` positions: [`eval_batch`](Self::eval_batch)
    /// without the twist's `ω × (x − c)` (the same as `eval_batch` without the twist).
    ///
    /// # Panics
    /// If the buffers are too short for `n`.
    pub fn eval_heads(&mut self, t: T, positions: &[T], stride: usize, n: usize, out: &mut [T]) {
        let start = self.profile.as_ref().map(|_| Instant::now());
        let fresh = self.eval_heads_untimed(t, positions, stride, n, out);
        if let (Some(p), Some(start)) = (&self.profile, start) {
            p.add_evaluation(start, if fresh { n } else { 0 });
        }
    }

    /// [`eval_heads`](Self::eval_heads) without the profile; `false` when a stored
    /// evaluation answered.
    fn eval_heads_untimed(
        &mut self,
        t: T,
        positions: &[T],
        stride: usize,
        n: usize,
        out: &mut [T],
    ) -> bool {
        assert!(
            n == 0 || (positions.len() >= (n - 1) * stride + 3 && out.len() >= n * N_OUT),
            "batch buffers too short"
        );
        let n_chunks = n.div_ceil(CHUNK);
        if let Some(slot) = self.find_eval(t, positions, stride, n) {
            // Evaluated before at exactly this input: the outputs are the stored unscaled
            // outputs times the output scales.
            self.touch(slot);
            let scales = &self.params[self.hex.n_params() + self.mlp.scales_offset()..];
            for (out_c, rec) in out[..n * N_OUT]
                .chunks_mut(CHUNK * N_OUT)
                .zip(&self.evals[slot].chunks)
            {
                for (o, r) in out_c
                    .chunks_exact_mut(N_OUT)
                    .zip(rec.act.raw.chunks_exact(N_OUT))
                {
                    for k in 0..N_OUT {
                        o[k] = r[k] * scales[k / 3];
                    }
                }
            }
            return false;
        }
        let slot = self.claim_eval(t, positions, stride, n);
        self.touch(slot);
        self.ensure_work(n_chunks);
        let (hex, mlp, params) = (&self.hex, &self.mlp, &self.params);
        let profile = self.profile.as_deref();
        let records = &mut self.evals[slot].chunks[..n_chunks];
        let works = &mut self.work[..n_chunks];
        type Item<'a, T> = (
            usize,
            (&'a mut [T], (&'a mut ChunkRecord<T>, &'a mut ChunkWork<T>)),
        );
        let run = |(ci, (out_c, (rec, work))): Item<'_, T>| {
            let rows = out_c.len() / N_OUT;
            let pos = &positions[ci * CHUNK * stride..];
            forward_chunk(
                hex, mlp, params, t, pos, stride, rows, rec, work, out_c, profile,
            );
        };
        match self.par {
            Par::Seq => out[..n * N_OUT]
                .chunks_mut(CHUNK * N_OUT)
                .zip(records.iter_mut().zip(works.iter_mut()))
                .enumerate()
                .for_each(run),
            #[cfg(feature = "rayon")]
            Par::Rayon => {
                use rayon::prelude::*;
                out[..n * N_OUT]
                    .par_chunks_mut(CHUNK * N_OUT)
                    .zip(records.par_iter_mut().zip(works.par_iter_mut()))
                    .enumerate()
                    .for_each(run);
            }
        }
        true
    }

    /// VJP of [`eval_batch`](Self::eval_batch): given `d_out` (n × 9), **adds**
    /// `∂/∂position` into `d_positions[i·d_stride..+3]` and `∂/∂θ` into `d_params`.
    ///
    /// # Panics
    /// If the buffers are too short.
    pub fn vjp_batch(
        &mut self,
        t: T,
        positions: &[T],
        stride: usize,
        n: usize,
        d_out: &[T],
        d_positions: &mut [T],
        d_stride: usize,
        d_params: &mut [T],
    ) {
        let twist = self.twist;
        self.vjp(
            t,
            positions,
            stride,
            n,
            d_out,
            d_positions,
            d_stride,
            d_params,
            twist,
        );
    }

    /// VJP of [`eval_heads`](Self::eval_heads): [`vjp_batch`](Self::vjp_batch) with `d_out`
    /// the cotangent of the heads `[a, ω, ṡ]` (the same as `vjp_batch` without the twist).
    ///
    /// # Panics
    /// If the buffers are too short.
    pub fn vjp_heads(
        &mut self,
        t: T,
        positions: &[T],
        stride: usize,
        n: usize,
        d_out: &[T],
        d_positions: &mut [T],
        d_stride: usize,
        d_params: &mut [T],
    ) {
        self.vjp(
            t,
            positions,
            stride,
            n,
            d_out,
            d_positions,
            d_stride,
            d_params,
            false,
        );
    }

    /// The VJP of the heads, plus the twist's `ω × (x − c)` term when `twist` (timed when a
    /// profile is attached).
    fn vjp(
        &mut self,
        t: T,
        positions: &[T],
        stride: usize,
        n: usize,
        d_out: &[T],
        d_positions: &mut [T],
        d_stride: usize,
        d_params: &mut [T],
        twist: bool,
    ) {
        let start = self.profile.as_ref().map(|_| Instant::now());
        let recomputed = self.vjp_untimed(
            t,
            positions,
            stride,
            n,
            d_out,
            d_positions,
            d_stride,
            d_params,
            twist,
        );
        if let (Some(p), Some(start)) = (&self.profile, start) {
            p.add_vjp(start, n, recomputed);
        }
    }

    /// [`vjp`](Self::vjp) without the profile; `true` when the forward pass was recomputed
    /// (no stored evaluation of this input).
    fn vjp_untimed(
        &mut self,
        t: T,
        positions: &[T],
        stride: usize,
        n: usize,
        d_out: &[T],
        d_positions: &mut [T],
        d_stride: usize,
        d_params: &mut [T],
        twist: bool,
    ) -> bool {
        assert!(
            d_out.len() >= n * N_OUT && d_params.len() == self.params.len(),
            "vjp buffers have the wrong size"
        );
        let n_chunks = n.div_ceil(CHUNK);
        let n_lk = self.hex.n_lookups();
        let ch = self.hex.channels();
        let n_mlp = self.mlp.n_params();
        self.partials.clear();
        self.partials.resize(n_chunks * n_mlp, T::ZERO);
        self.lookups.resize(n * n_lk, Lookup::default());
        self.d_samples.resize(n * n_lk * ch, T::ZERO);
        self.d_pos.clear();
        self.d_pos.resize(n * 3, T::ZERO);
        let (slot, stored) = match self.find_eval(t, positions, stride, n) {
            Some(i) => (i, true),
            None => (self.claim_eval(t, positions, stride, n), false),
        };
        self.touch(slot);
        self.ensure_work(n_chunks);
        let (hex, mlp, params) = (&self.hex, &self.mlp, &self.params);
        let profile = self.profile.as_deref();
        let twist = self
            .twist_centre()
            .filter(|_| twist)
            .map(|c| (c, params[hex.n_params() + mlp.scales_offset() + 1]));
        let records = &mut self.evals[slot].chunks[..n_chunks];
        let works = &mut self.work[..n_chunks];
        let run = |(ci, ((partial, (lks, (dss, dp))), (rec, work))): VjpItem<'_, T>| {
            let rows = lks.len() / n_lk;
            let pos = &positions[ci * CHUNK * stride..];
            if !stored {
                let mut out = [T::ZERO; CHUNK * N_OUT];
                let out = &mut out[..rows * N_OUT];
                forward_chunk(
                    hex, mlp, params, t, pos, stride, rows, rec, work, out, profile,
                );
            }
            let mut d_o = &d_out[ci * CHUNK * N_OUT..ci * CHUNK * N_OUT + rows * N_OUT];
            // Twist: v = a + ω × r with r = x − c, so for a cotangent w of v,
            // ∂/∂ω += r × w and ∂/∂x += w × ω (the head VJP below sees the first).
            let mut d_heads;
            if let Some((c, _)) = twist {
                d_heads = [T::ZERO; CHUNK * N_OUT];
                d_heads[..rows * N_OUT].copy_from_slice(d_o);
                for (r, dh) in d_heads[..rows * N_OUT].chunks_exact_mut(N_OUT).enumerate() {
                    let arm = Vec3::from_slice(&pos[r * stride..]) - c;
                    arm.cross(Vec3::from_slice(dh)).add_to(&mut dh[3..]);
                }
                d_o = &d_heads[..rows * N_OUT];
            }
            mlp.backward(
                &params[hex.n_params()..],
                &rec.features,
                rows,
                &rec.act,
                &mut work.mlp,
                d_o,
                &mut work.d_features,
                partial,
                profile,
            );
            decode_chunk_vjp(
                hex,
                params,
                t,
                pos,
                stride,
                rows,
                &work.d_features,
                &mut work.samples,
                lks,
                dss,
                dp,
            );
            if let Some((_, omega_scale)) = twist {
                let w_v = &d_out[ci * CHUNK * N_OUT..];
                for (r, d) in dp.chunks_exact_mut(3).take(rows).enumerate() {
                    let omega = Vec3::from_slice(&rec.act.raw[r * N_OUT + 3..]) * omega_scale;
                    Vec3::from_slice(&w_v[r * N_OUT..]).cross(omega).add_to(d);
                }
            }
        };
        match self.par {
            Par::Seq => self
                .partials
                .chunks_mut(n_mlp)
                .zip(
                    self.lookups.chunks_mut(CHUNK * n_lk).zip(
                        self.d_samples
                            .chunks_mut(CHUNK * n_lk * ch)
                            .zip(self.d_pos.chunks_mut(CHUNK * 3)),
                    ),
                )
                .zip(records.iter_mut().zip(works.iter_mut()))
                .enumerate()
                .for_each(run),
            #[cfg(feature = "rayon")]
            Par::Rayon => {
                use rayon::prelude::*;
                self.partials
                    .par_chunks_mut(n_mlp)
                    .zip(
                        self.lookups.par_chunks_mut(CHUNK * n_lk).zip(
                            self.d_samples
                                .par_chunks_mut(CHUNK * n_lk * ch)
                                .zip(self.d_pos.par_chunks_mut(CHUNK * 3)),
                        ),
                    )
                    .zip(records.par_iter_mut().zip(works.par_iter_mut()))
                    .enumerate()
                    .for_each(run);
            }
        }
        for i in 0..n {
            for a in 0..3 {
                d_positions[i * d_stride + a] += self.d_pos[i * 3 + a];
            }
        }
        let off = self.hex.n_params();
        for partial in self.partials.chunks(n_mlp) {
            for (d, &p) in d_params[off..].iter_mut().zip(partial) {
                *d += p;
            }
        }
        self.scatter_planes(n, &mut d_params[..off]);
        !stored
    }

    /// Adds the stored per-lookup sample gradients into the plane gradients, plane by plane
    /// (in parallel over planes), each in Gaussian order; a plane's records are read as one
    /// contiguous run per chunk.
    fn scatter_planes(&self, n: usize, d_grid: &mut [T]) {
        let hex = &self.hex;
        let n_lk = hex.n_lookups();
        let ch = hex.channels();
        let mut slices: Vec<(usize, usize, &mut [T])> = Vec::with_capacity(n_lk);
        let mut rest = d_grid;
        let mut consumed = 0;
        for l in 0..hex.levels() {
            for p in 0..6 {
                let r = hex.plane_range(l, p);
                debug_assert_eq!(r.start, consumed, "planes are contiguous");
                let (head, tail) = rest.split_at_mut(r.len());
                slices.push((l * 6 + p, r.start, head));
                rest = tail;
                consumed = r.end;
            }
        }
        let (lookups, d_samples) = (&self.lookups, &self.d_samples);
        let work = |(k, start, plane): (usize, usize, &mut [T])| {
            for c0 in (0..n).step_by(CHUNK) {
                // The chunk's records of plane k are contiguous (see decode_chunk_vjp).
                let rows = CHUNK.min(n - c0);
                let first = c0 * n_lk + k * rows;
                let lks = &lookups[first..first + rows];
                let gs = &d_samples[first * ch..(first + rows) * ch];
                for (lk, g) in lks.iter().zip(gs.chunks_exact(ch)) {
                    let mut lk = *lk;
                    lk.base -= start;
                    HexPlane::scatter(plane, &lk, g);
                }
            }
        };
        match self.par {
            Par::Seq => slices.into_iter().for_each(work),
            #[cfg(feature = "rayon")]
            Par::Rayon => {
                use rayon::prelude::*;
                slices.into_par_iter().for_each(work);
            }
        }
    }
}

impl<T: Gemm> VectorField<T> for NeuralField<T> {
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
        let n = self.count;
        self.eval_batch(t, y, STATE_STRIDE, n, dydt);
    }
    fn vjp(&mut self, t: T, y: &[T], w: &[T], d_y: &mut [T], d_params: &mut [T]) {
        let n = self.count;
        self.vjp_batch(t, y, STATE_STRIDE, n, w, d_y, N_OUT, d_params);
    }
}
