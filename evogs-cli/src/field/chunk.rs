//! The per-chunk kernels of [`NeuralField`](super::NeuralField): a chunk's scratch, the
//! HexPlane encoding of its positions, and the HexPlane part of its VJP (the Hadamard
//! leave-one-out products, the coordinate gradients and the per-lookup records the plane
//! scatter reads).

use super::gemm::Gemm;
use super::hexplane::{HexPlane, Lookup};
use super::mlp::{Mlp, MlpActivations};
use evogs_math::Real;

/// Gaussians per work chunk.
pub const CHUNK: usize = 256;

/// Channels per block of the leave-one-out products (one AVX2 register of f32).
const LANES: usize = 8;

/// The activations and scratch of one chunk.
#[derive(Debug)]
pub(super) struct ChunkScratch<T> {
    /// The sampled C-vector of every lookup, row-major `[row][lookup][channel]`.
    pub(super) samples: Vec<T>,
    /// The features (MLP input), `[row][feature]`.
    pub(super) features: Vec<T>,
    /// Their gradient.
    pub(super) d_features: Vec<T>,
    /// The MLP activations.
    pub(super) act: MlpActivations<T>,
}

impl<T: Gemm> ChunkScratch<T> {
    /// Scratch sized for [`CHUNK`] rows.
    pub(super) fn new(hex: &HexPlane, mlp: &Mlp) -> Self {
        Self {
            samples: vec![T::ZERO; CHUNK * hex.n_lookups() * hex.channels()],
            features: vec![T::ZERO; CHUNK * hex.feature_dim()],
            d_features: vec![T::ZERO; CHUNK * hex.feature_dim()],
            act: MlpActivations::new(mlp, CHUNK),
        }
    }
}

/// Samples every plane for `rows` positions and forms the features (Hadamard per level).
pub(super) fn encode_chunk<T: Gemm>(
    hex: &HexPlane,
    params: &[T],
    t: T,
    pos: &[T],
    stride: usize,
    rows: usize,
    s: &mut ChunkScratch<T>,
) {
    let ch = hex.channels();
    let n_lk = hex.n_lookups();
    let fd = hex.feature_dim();
    for r in 0..rows {
        let p = [pos[r * stride], pos[r * stride + 1], pos[r * stride + 2]];
        let (c, _) = hex.coords(p, t);
        for l in 0..hex.levels() {
            let feat = &mut s.features[r * fd + l * ch..r * fd + (l + 1) * ch];
            feat.fill(T::ONE);
            for q in 0..6 {
                let lk = hex.lookup(l, q, &c);
                let k = r * n_lk + l * 6 + q;
                let smp = &mut s.samples[k * ch..(k + 1) * ch];
                HexPlane::sample(params, &lk, smp);
                for (f, &v) in feat.iter_mut().zip(smp.iter()) {
                    *f *= v;
                }
            }
        }
    }
}

/// `ds_q = d_f ⊙ Π_{q' ≠ q} s_q` for the six planes of one level (`s_q` =
/// `smp[q·C..(q+1)·C]`), written to `out[at[q]..at[q] + C]`: prefix and suffix products, no
/// division. [`LANES`] channels at a time, so the running products stay in registers (and any
/// channel count works).
fn leave_one_out<T: Real>(d_f: &[T], smp: &[T], at: [usize; 6], out: &mut [T]) {
    let ch = d_f.len();
    let mut c0 = 0;
    while c0 < ch {
        let w = LANES.min(ch - c0);
        let mut pre = [T::ONE; LANES];
        for (q, &a) in at.iter().enumerate() {
            let (d, s) = (
                &mut out[a + c0..a + c0 + w],
                &smp[q * ch + c0..q * ch + c0 + w],
            );
            for k in 0..w {
                d[k] = d_f[c0 + k] * pre[k];
                pre[k] *= s[k];
            }
        }
        let mut suf = [T::ONE; LANES];
        for (q, &a) in at.iter().enumerate().rev() {
            let (d, s) = (
                &mut out[a + c0..a + c0 + w],
                &smp[q * ch + c0..q * ch + c0 + w],
            );
            for k in 0..w {
                d[k] *= suf[k];
                suf[k] *= s[k];
            }
        }
        c0 += w;
    }
}

/// From `d_features`, the per-lookup sample gradients and lookups (stored for the plane
/// scatter, plane-major within the chunk: record `(l·6 + q)·rows + r`) and the position
/// gradients (written into `d_pos`, 3 per row).
pub(super) fn decode_chunk_vjp<T: Gemm>(
    hex: &HexPlane,
    params: &[T],
    t: T,
    pos: &[T],
    stride: usize,
    rows: usize,
    s: &ChunkScratch<T>,
    lks: &mut [Lookup<T>],
    dss: &mut [T],
    d_pos: &mut [T],
) {
    let ch = hex.channels();
    let n_lk = hex.n_lookups();
    let fd = hex.feature_dim();
    for r in 0..rows {
        let p = [pos[r * stride], pos[r * stride + 1], pos[r * stride + 2]];
        let (c, dcdp) = hex.coords(p, t);
        let mut d_c = [T::ZERO; 4];
        for l in 0..hex.levels() {
            let d_f = &s.d_features[r * fd + l * ch..r * fd + (l + 1) * ch];
            let base = (r * n_lk + l * 6) * ch;
            let smp = &s.samples[base..base + 6 * ch];
            // Records are plane-major within the chunk, so the scatter streams each plane's
            // records: lookup q of this level and row is record (l·6 + q)·rows + r.
            let record = |q: usize| (l * 6 + q) * rows + r;
            leave_one_out(d_f, smp, core::array::from_fn(|q| record(q) * ch), dss);
            // Last plane first: the position gradient sums in the order it always has.
            for q in (0..6).rev() {
                let ds = &dss[record(q) * ch..(record(q) + 1) * ch];
                let lk = hex.lookup(l, q, &c);
                let (gu, gv) = HexPlane::sample_coord_grad(params, &lk, ds);
                let (i, j) = super::hexplane::PLANE_AXES[q];
                d_c[i] += gu;
                d_c[j] += gv;
                lks[record(q)] = lk;
            }
        }
        for a in 0..3 {
            d_pos[r * 3 + a] = d_c[a] * dcdp[a];
        }
    }
}
