//! The per-chunk kernels of [`NeuralField`](super::NeuralField): a chunk's scratch, the
//! HexPlane encoding of its positions, and the HexPlane part of its VJP (the Hadamard
//! leave-one-out products, the coordinate gradients and the per-lookup records the plane
//! scatter reads).

use super::gemm::Gemm;
use super::hexplane::{CellRecord, HexPlane};
use super::lanes::LANES;
use super::mlp::{Mlp, MlpActivations, MlpWork, N_OUT};
use super::profile::FieldProfile;
use crate::aligned::CacheAligned;
use evogs_math::Real;

/// Gaussians per work chunk. 512 against 256 took 6 % off the bench's iteration at both
/// N = 20 000 and 5 000 (larger matrix products); 1024 leaves too few chunks at N = 5 000
/// to share between two threads (`docs/performance.md`).
pub const CHUNK: usize = 512;

/// What a [`FieldRecord`](super::neural::FieldRecord) keeps of one chunk for the VJP: the
/// features and the MLP's activations (the plane samples are not kept: the VJP reads the same
/// texels again for the coordinate gradients, so it recomputes them there at little cost).
#[derive(Debug)]
pub(super) struct ChunkRecord<T> {
    /// The features (MLP input), `[row][feature]`.
    pub(super) features: CacheAligned<T>,
    /// The MLP activations.
    pub(super) act: MlpActivations<T>,
}

impl<T: Gemm> ChunkRecord<T> {
    /// A record sized for [`CHUNK`] rows.
    pub(super) fn new(hex: &HexPlane, mlp: &Mlp) -> Self {
        Self {
            features: CacheAligned::new(CHUNK * hex.feature_dim(), T::ZERO),
            act: MlpActivations::new(mlp, CHUNK),
        }
    }

    /// Scalars held per row.
    pub(super) fn scalars_per_row(hex: &HexPlane, mlp: &Mlp) -> usize {
        hex.feature_dim() + 4 * mlp.width + N_OUT
    }
}

/// The scratch of one chunk's VJP (one per chunk, shared by every stored evaluation).
#[derive(Debug)]
pub(super) struct ChunkWork<T> {
    /// The six sampled C-vectors of one level of one row.
    pub(super) samples: Vec<T>,
    /// The gradient of the features.
    pub(super) d_features: CacheAligned<T>,
    /// The MLP's backward scratch.
    pub(super) mlp: MlpWork<T>,
}

impl<T: Gemm> ChunkWork<T> {
    /// Scratch sized for [`CHUNK`] rows.
    pub(super) fn new(hex: &HexPlane, mlp: &Mlp) -> Self {
        Self {
            samples: vec![T::ZERO; 6 * hex.channels()],
            d_features: CacheAligned::new(CHUNK * hex.feature_dim(), T::ZERO),
            mlp: MlpWork::new(mlp, CHUNK),
        }
    }
}

/// Runs `$body` with `$ch` bound to the channel count `$n`: as a constant where `$n` is one
/// of the presets' counts (32, 16), so that the channel loops in `$body` are compiled for it
/// (no tails, no per-loop bounds), and as a run-time value otherwise. The same operations
/// either way, so the same bits. The kernels `$body` calls on the channels are
/// `#[inline(always)]`: three copies of the body would otherwise exceed the inliner's budget
/// and leave them as calls with run-time lengths.
macro_rules! with_channels {
    ($n:expr, |$ch:ident| $body:block) => {
        match $n {
            32 => {
                let $ch: usize = 32;
                $body
            }
            16 => {
                let $ch: usize = 16;
                $body
            }
            $ch => $body,
        }
    };
}

/// Samples every plane for `rows` positions and forms the features (the Hadamard product of
/// a level's six samples, each sample multiplied straight into the features). (Compiled for
/// the build's vector width: the widest, as [`decode_chunk_vjp`] is, made the forward 3–6 %
/// slower on the AVX-512 machine of `docs/performance.md`.)
fn encode_chunk<T: Gemm>(
    hex: &HexPlane,
    params: &[T],
    t: T,
    pos: &[T],
    stride: usize,
    rows: usize,
    features: &mut [T],
) {
    let fd = hex.feature_dim();
    with_channels!(hex.channels(), |ch| {
        for r in 0..rows {
            let p = [pos[r * stride], pos[r * stride + 1], pos[r * stride + 2]];
            let (c, _) = hex.coords(p, t);
            for l in 0..hex.levels() {
                let feat = &mut features[r * fd + l * ch..r * fd + (l + 1) * ch];
                let lks = hex.level_lookups(l, &c);
                // 1·s₀ is s₀ exactly, so the first plane is written, not multiplied in.
                HexPlane::sample(params, &lks[0], feat);
                for lk in &lks[1..] {
                    HexPlane::sample_mul(params, lk, feat);
                }
            }
        }
    });
}

/// The forward pass of one chunk: the HexPlane features of `rows` positions, then the MLP
/// (scaled outputs into `out`), keeping what the VJP needs in `rec`.
pub(super) fn forward_chunk<T: Gemm>(
    hex: &HexPlane,
    mlp: &Mlp,
    params: &[T],
    t: T,
    pos: &[T],
    stride: usize,
    rows: usize,
    rec: &mut ChunkRecord<T>,
    out: &mut [T],
    profile: Option<&FieldProfile>,
) {
    encode_chunk(hex, params, t, pos, stride, rows, &mut rec.features);
    mlp.forward(
        &params[hex.n_params()..],
        &rec.features,
        rows,
        &mut rec.act,
        out,
        profile,
    );
}

/// `ds_q = d_f ⊙ Π_{q' ≠ q} s_q` for the six planes of one level (`s_q` =
/// `smp[q·C..(q+1)·C]`), written to `out[at[q]..at[q] + C]`: prefix and suffix products, no
/// division. [`LANES`] channels at a time (then one at a time for the rest), so the running
/// products stay in registers and each output is written once, unmasked.
#[inline(always)]
fn leave_one_out<T: Real>(d_f: &[T], smp: &[T], at: [usize; 6], out: &mut [T]) {
    let ch = d_f.len();
    let mut c0 = 0;
    while c0 + LANES <= ch {
        leave_one_out_block::<T, LANES>(d_f, smp, c0, at, out);
        c0 += LANES;
    }
    for c in c0..ch {
        leave_one_out_block::<T, 1>(d_f, smp, c, at, out);
    }
}

/// [`leave_one_out`] for channels `c0..c0 + W`.
#[inline(always)]
fn leave_one_out_block<T: Real, const W: usize>(
    d_f: &[T],
    smp: &[T],
    c0: usize,
    at: [usize; 6],
    out: &mut [T],
) {
    let ch = d_f.len();
    let d_f = &d_f[c0..c0 + W];
    let mut pre = [[T::ONE; W]; 6];
    let mut run = [T::ONE; W];
    for (q, p) in pre.iter_mut().enumerate() {
        *p = run;
        let s = &smp[q * ch + c0..q * ch + c0 + W];
        for k in 0..W {
            run[k] *= s[k];
        }
    }
    let mut suf = [T::ONE; W];
    for q in (0..6).rev() {
        let d = &mut out[at[q] + c0..at[q] + c0 + W];
        let s = &smp[q * ch + c0..q * ch + c0 + W];
        for k in 0..W {
            d[k] = d_f[k] * pre[q][k] * suf[k];
            suf[k] *= s[k];
        }
    }
}

/// The operands of [`decode_chunk_vjp`]: where the chunk's rows are (`rows` positions of
/// `pos`, `stride` apart, at time `t`), the gradient of their features, the scratch of a
/// level's six samples (at least `6·C`), and the outputs.
pub(super) struct DecodeChunk<'a, T> {
    pub(super) hex: &'a HexPlane,
    pub(super) params: &'a [T],
    pub(super) t: T,
    pub(super) pos: &'a [T],
    pub(super) stride: usize,
    pub(super) rows: usize,
    pub(super) d_features: &'a [T],
    pub(super) samples: &'a mut [T],
    /// The scatter records (plane-major within the chunk: record `(l·6 + q)·rows + r`).
    pub(super) cells: &'a mut [CellRecord<T>],
    /// The per-lookup sample gradients, C per record.
    pub(super) dss: &'a mut [T],
    /// The position gradients, 3 per row (written).
    pub(super) d_pos: &'a mut [T],
}

/// From `d_features`, the per-lookup sample gradients and lookups (stored for the plane
/// scatter) and the position gradients. The six samples of a level are recomputed from the
/// texels the coordinate gradients read.
///
/// Compiled for the widest vector instructions the CPU has: [`pulp::Arch`] picks them at
/// run time (AVX-512, AVX2, NEON or scalar; the unsafe part lives in pulp) and runs the
/// body compiled with them. Its channel loops are plain loops and its lane sums fixed
/// arrays, so every width computes the same bits. On the AVX-512 machine of
/// `docs/performance.md` the field VJP took 3–5 % less than with the build's AVX2.
pub(super) fn decode_chunk_vjp<T: Gemm>(d: DecodeChunk<'_, T>) {
    pulp::Arch::new().dispatch(d);
}

/// The body runs inside pulp's function for the chosen instructions, so it must be inlined
/// there (a closure's body is not, and would keep the build's width).
impl<T: Gemm> pulp::WithSimd for DecodeChunk<'_, T> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        decode_rows(self);
    }
}

/// The body of [`decode_chunk_vjp`].
#[inline(always)]
fn decode_rows<T: Gemm>(d: DecodeChunk<'_, T>) {
    let DecodeChunk {
        hex,
        params,
        t,
        pos,
        stride,
        rows,
        d_features,
        samples,
        cells,
        dss,
        d_pos,
    } = d;
    let fd = hex.feature_dim();
    with_channels!(hex.channels(), |ch| {
        let smp = &mut samples[..6 * ch];
        for r in 0..rows {
            let p = [pos[r * stride], pos[r * stride + 1], pos[r * stride + 2]];
            let (c, dcdp) = hex.coords(p, t);
            let mut d_c = [T::ZERO; 4];
            for l in 0..hex.levels() {
                let d_f = &d_features[r * fd + l * ch..r * fd + (l + 1) * ch];
                // Records are plane-major within the chunk, so the scatter streams each
                // plane's records: lookup q of this level and row is record (l·6 + q)·rows + r.
                let record = |q: usize| (l * 6 + q) * rows + r;
                let lks = hex.level_lookups(l, &c);
                for (q, s_q) in smp.chunks_exact_mut(ch).enumerate() {
                    HexPlane::sample(params, &lks[q], s_q);
                    cells[record(q)] = hex.cell_record(l, q, &lks[q]);
                }
                leave_one_out(d_f, smp, core::array::from_fn(|q| record(q) * ch), dss);
                // Last plane first: the position gradient sums in the order it always has.
                for q in (0..6).rev() {
                    let ds = &dss[record(q) * ch..(record(q) + 1) * ch];
                    let (gu, gv) = HexPlane::sample_coord_grad(params, &lks[q], ds);
                    let (i, j) = super::hexplane::PLANE_AXES[q];
                    d_c[i] += gu;
                    d_c[j] += gv;
                }
            }
            for a in 0..3 {
                d_pos[r * 3 + a] = d_c[a] * dcdp[a];
            }
        }
    });
}

/// Adds the sample gradients `gs` (C per record) of the scatter records `cells` of plane `p`
/// of level `l` into `plane` (that plane's part of the gradient), record by record in
/// order, with the presets' channel counts as constants (the same operations: the same
/// bits). Specialised and inlined, on the cache-aligned buffers, it took the field VJP
/// from 56.9 to 50.2 ms at N = 5 000 (`docs/performance.md`); compiled for AVX-512 as well
/// it was no faster.
pub(super) fn scatter_plane<T: Gemm>(
    hex: &HexPlane,
    l: usize,
    p: usize,
    cells: &[CellRecord<T>],
    gs: &[T],
    plane: &mut [T],
) {
    with_channels!(hex.channels(), |ch| {
        for (cell, g) in cells.iter().zip(gs.chunks_exact(ch)) {
            HexPlane::scatter(plane, &hex.plane_lookup(l, p, cell), &g[..ch]);
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::hexplane::{HexPlaneConfig, TimeMapping};
    use evogs_math::rng::SplitMix64;

    /// The decode run at the widest width the CPU has (through pulp) gives the bits of the
    /// body compiled for the build's width, for both specialised channel counts and a
    /// run-time one (on a CPU without wider instructions both are the same code).
    #[test]
    fn the_dispatched_decode_is_bitwise_the_builds() {
        for channels in [32, 16, 12] {
            let cfg = HexPlaneConfig {
                channels,
                resolution: [9, 7, 8, 5],
                multires: vec![1, 2],
            };
            let time = TimeMapping::Normalized {
                t_min: 0.0,
                t_max: 1.0,
            };
            let hex = HexPlane::new(&cfg, [-1.0; 3], [1.0; 3], time);
            let mut rng = SplitMix64::new(11);
            let mut draw = |n: usize, lo: f64, hi: f64| -> Vec<f32> {
                #[allow(clippy::cast_possible_truncation, reason = "test data")]
                (0..n).map(|_| rng.uniform(lo, hi) as f32).collect()
            };
            let params = draw(hex.n_params(), 0.1, 1.0);
            let rows = 37;
            let pos = draw(rows * 3, -1.2, 1.2);
            let d_features = draw(rows * hex.feature_dim(), -1.0, 1.0);
            let n_lk = hex.n_lookups();
            let run = |dispatch: bool| {
                let mut samples = vec![0.0; 6 * channels];
                let mut cells = vec![CellRecord::default(); rows * n_lk];
                let mut dss = vec![0.0; rows * n_lk * channels];
                let mut d_pos = vec![0.0; rows * 3];
                let d = DecodeChunk {
                    hex: &hex,
                    params: &params,
                    t: 0.3,
                    pos: &pos,
                    stride: 3,
                    rows,
                    d_features: &d_features,
                    samples: &mut samples,
                    cells: &mut cells,
                    dss: &mut dss,
                    d_pos: &mut d_pos,
                };
                if dispatch {
                    decode_chunk_vjp(d);
                } else {
                    decode_rows(d);
                }
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                (cells, bits(&dss), bits(&d_pos))
            };
            let (widest, build) = (run(true), run(false));
            assert_eq!(widest.0, build.0, "{channels} channels: records");
            assert_eq!(widest.1, build.1, "{channels} channels: sample gradients");
            assert_eq!(widest.2, build.2, "{channels} channels: position gradients");
            assert!(
                widest.2.iter().any(|&b| b != 0),
                "the positions have a gradient"
            );
        }
    }
}
