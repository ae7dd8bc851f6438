//! The trainable Gaussian parameters [`Splats`] (struct of arrays) and their gradient
//! [`SplatsGrad`], with the benchmark scene of the performance notes
//! (`docs/architecture.md` §6).
//!
//! Parameters are the **raw** training parameters; the activations are applied when the
//! Gaussians are projected and shaded:
//!
//! ```text
//! mean μ (world)              used as is
//! log-scale ŝ                 s = exp(ŝ)              Σ = R(q/|q|) diag(s)² R(q/|q|)ᵀ
//! raw quaternion q (w,x,y,z)  normalised when used    (gradients are orthogonal to q)
//! opacity logit ô             o = sigmoid(ô)
//! SH coefficients k_j (RGB)   colour = max(0, Σ_j Y_j(d̂) k_j + ½),  j < (degree + 1)², DC first
//! ```

use crate::camera::PinholeCamera;
use crate::pool::for_each_item;
use alloc::vec;
use alloc::vec::Vec;
use evogs_math::activation::logit;
use evogs_math::rng::SplitMix64;
use evogs_math::sh::{MAX_SH_DEGREE, SH_C0, sh_coeff_count};
use evogs_math::{Par, Quat, Real, Vec3};

/// A set of Gaussians as struct of arrays, in their raw training parameterisation.
///
/// Gaussian `i` owns `means[i]`, `log_scales[i]`, `quats[i]`, `opacity_logits[i]` and the
/// `(sh_degree + 1)²` RGB coefficient triples `sh[i·K .. (i+1)·K]` (DC first, in the order
/// of the 3DGS `.ply` files and gsplat). All vectors must have consistent lengths
/// ([`Splats::check`]).
///
/// ```
/// use evogs_splat::Splats;
/// use evogs_math::{Quat, Vec3};
/// let mut s = Splats::<f64>::new(1);
/// s.push(Vec3::zero(), Vec3::splat(-3.0), Quat::identity(), 0.0, &[[0.1, 0.2, 0.3]; 4]);
/// assert_eq!(s.len(), 1);
/// assert_eq!(s.sh_coeffs(0).len(), 4);
/// ```
#[derive(Debug, Default, PartialEq)]
pub struct Splats<T> {
    /// Storage SH degree (0 to 3): `(sh_degree + 1)²` coefficients per Gaussian.
    pub sh_degree: usize,
    /// World-space means.
    pub means: Vec<Vec3<T>>,
    /// Log standard deviations along the local axes.
    pub log_scales: Vec<Vec3<T>>,
    /// Raw quaternions (w, x, y, z), not necessarily unit.
    pub quats: Vec<Quat<T>>,
    /// Opacity logits.
    pub opacity_logits: Vec<T>,
    /// SH coefficients, `(sh_degree + 1)²` RGB triples per Gaussian, DC first.
    pub sh: Vec<[T; 3]>,
}

/// `clone_from` copies into the buffers it has (the derived one would allocate new ones and
/// free the old: a render that starts from the canonical Gaussians every iteration paid page
/// faults for it).
impl<T: Clone> Clone for Splats<T> {
    fn clone(&self) -> Self {
        Self {
            sh_degree: self.sh_degree,
            means: self.means.clone(),
            log_scales: self.log_scales.clone(),
            quats: self.quats.clone(),
            opacity_logits: self.opacity_logits.clone(),
            sh: self.sh.clone(),
        }
    }

    fn clone_from(&mut self, source: &Self) {
        self.sh_degree = source.sh_degree;
        self.means.clone_from(&source.means);
        self.log_scales.clone_from(&source.log_scales);
        self.quats.clone_from(&source.quats);
        self.opacity_logits.clone_from(&source.opacity_logits);
        self.sh.clone_from(&source.sh);
    }
}

/// Gaussians per work item of [`Splats::fill_zero`] and [`Splats::copy_from`] on the pool: a
/// fixed number, so the work splits the same way on any thread count.
const RUN: usize = 2048;

/// One run of consecutive Gaussians: its first index and its slices of every field (the
/// work item of the passes over Gaussians and over their gradients).
pub(crate) struct RunMut<'a, T> {
    pub(crate) first: usize,
    pub(crate) means: &'a mut [Vec3<T>],
    pub(crate) log_scales: &'a mut [Vec3<T>],
    pub(crate) quats: &'a mut [Quat<T>],
    pub(crate) opacity_logits: &'a mut [T],
    pub(crate) sh: &'a mut [[T; 3]],
}

impl<T: Real> RunMut<'_, T> {
    /// Sets every entry of the run to zero.
    pub(crate) fn fill_zero(&mut self) {
        self.means.fill(Vec3::zero());
        self.log_scales.fill(Vec3::zero());
        self.quats.fill(Quat::zero());
        self.opacity_logits.fill(T::ZERO);
        self.sh.fill([T::ZERO; 3]);
    }
}

/// Gradient of a loss with respect to every field of [`Splats`] (same layout).
pub type SplatsGrad<T> = Splats<T>;

impl<T: Real> Splats<T> {
    /// An empty set with storage SH degree `sh_degree`.
    ///
    /// # Panics
    /// If `sh_degree > 3`.
    #[must_use]
    pub fn new(sh_degree: usize) -> Self {
        assert!(sh_degree <= MAX_SH_DEGREE, "SH degree {sh_degree} > 3");
        Self {
            sh_degree,
            ..Self::default()
        }
    }

    /// `n` Gaussians with every parameter zero (the layout of a gradient).
    ///
    /// # Panics
    /// If `sh_degree > 3`.
    #[must_use]
    pub fn zeros(n: usize, sh_degree: usize) -> Self {
        assert!(sh_degree <= MAX_SH_DEGREE, "SH degree {sh_degree} > 3");
        Self {
            sh_degree,
            means: vec![Vec3::zero(); n],
            log_scales: vec![Vec3::zero(); n],
            quats: vec![Quat::zero(); n],
            opacity_logits: vec![T::ZERO; n],
            sh: vec![[T::ZERO; 3]; n * sh_coeff_count(sh_degree)],
        }
    }

    /// A zero gradient shaped like `self`.
    #[must_use]
    pub fn zeros_like(&self) -> Self {
        Self::zeros(self.len(), self.sh_degree)
    }

    /// Sets every entry to zero, keeping the length; with `par`, in runs of Gaussians on the
    /// pool (a gradient of a scene is megabytes of zeros).
    pub fn fill_zero(&mut self, par: Par) {
        if !self.check() {
            // Fields of different lengths do not split into runs: each is zeroed whole.
            self.means.fill(Vec3::zero());
            self.log_scales.fill(Vec3::zero());
            self.quats.fill(Quat::zero());
            self.opacity_logits.fill(T::ZERO);
            self.sh.fill([T::ZERO; 3]);
            return;
        }
        for_each_item(par, &mut self.runs_mut(RUN), |_, r| r.fill_zero());
    }

    /// Makes `self` a copy of `source` in the buffers it has (like
    /// [`clone_from`](Clone::clone_from)), with `par` in runs of Gaussians on the pool.
    ///
    /// # Panics
    /// If `source` is inconsistent ([`check`](Self::check)).
    ///
    /// ```
    /// use evogs_math::Par;
    /// use evogs_splat::{benchmark_scene, Splats};
    /// let (source, _) = benchmark_scene::<f32>(5000, 8, 1);
    /// let mut copy = Splats::new(0);
    /// copy.copy_from(&source, Par::best());
    /// assert_eq!(copy, source);
    /// ```
    pub fn copy_from(&mut self, source: &Self, par: Par) {
        assert!(source.check(), "copy_from: inconsistent Gaussians");
        let n = source.len();
        self.sh_degree = source.sh_degree;
        self.means.resize(n, Vec3::zero());
        self.log_scales.resize(n, Vec3::zero());
        self.quats.resize(n, Quat::zero());
        self.opacity_logits.resize(n, T::ZERO);
        self.sh.resize(source.sh.len(), [T::ZERO; 3]);
        let k = source.coeffs_per_gaussian();
        for_each_item(par, &mut self.runs_mut(RUN), |_, r| {
            let range = r.first..r.first + r.means.len();
            r.means.copy_from_slice(&source.means[range.clone()]);
            r.log_scales
                .copy_from_slice(&source.log_scales[range.clone()]);
            r.quats.copy_from_slice(&source.quats[range.clone()]);
            r.opacity_logits
                .copy_from_slice(&source.opacity_logits[range.clone()]);
            r.sh.copy_from_slice(&source.sh[range.start * k..range.end * k]);
        });
    }

    /// The runs of `run` consecutive Gaussians (the last one shorter) of a consistent set.
    pub(crate) fn runs_mut(&mut self, run: usize) -> Vec<RunMut<'_, T>> {
        let k = self.coeffs_per_gaussian();
        self.means
            .chunks_mut(run)
            .zip(self.log_scales.chunks_mut(run))
            .zip(self.quats.chunks_mut(run))
            .zip(self.opacity_logits.chunks_mut(run))
            .zip(self.sh.chunks_mut(run * k))
            .enumerate()
            .map(
                |(r, ((((means, log_scales), quats), opacity_logits), sh))| RunMut {
                    first: r * run,
                    means,
                    log_scales,
                    quats,
                    opacity_logits,
                    sh,
                },
            )
            .collect()
    }

    /// Number of Gaussians.
    #[inline]
    #[must_use]
    pub fn len(&self) -> usize {
        self.means.len()
    }

    /// `true` if there are no Gaussians.
    #[inline]
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.means.is_empty()
    }

    /// SH coefficients per Gaussian, `(sh_degree + 1)²`.
    #[inline]
    #[must_use]
    pub const fn coeffs_per_gaussian(&self) -> usize {
        sh_coeff_count(self.sh_degree)
    }

    /// The SH coefficients of Gaussian `i`.
    #[inline]
    #[must_use]
    pub fn sh_coeffs(&self, i: usize) -> &[[T; 3]] {
        let k = self.coeffs_per_gaussian();
        &self.sh[i * k..(i + 1) * k]
    }

    /// The SH coefficients of Gaussian `i`, mutable.
    #[inline]
    pub fn sh_coeffs_mut(&mut self, i: usize) -> &mut [[T; 3]] {
        let k = self.coeffs_per_gaussian();
        &mut self.sh[i * k..(i + 1) * k]
    }

    /// Appends a Gaussian; `sh` must hold at least `(sh_degree + 1)²` triples (extra ones are
    /// ignored).
    ///
    /// # Panics
    /// If `sh` is too short.
    pub fn push(
        &mut self,
        mean: Vec3<T>,
        log_scale: Vec3<T>,
        quat: Quat<T>,
        opacity_logit: T,
        sh: &[[T; 3]],
    ) {
        let k = self.coeffs_per_gaussian();
        assert!(sh.len() >= k, "need {k} SH triples, got {}", sh.len());
        self.means.push(mean);
        self.log_scales.push(log_scale);
        self.quats.push(quat);
        self.opacity_logits.push(opacity_logit);
        self.sh.extend_from_slice(&sh[..k]);
    }

    /// The Gaussians at `indices`, in that order (a subset, a permutation, or repeats),
    /// at the same SH degree.
    ///
    /// ```
    /// use evogs_splat::Splats;
    /// use evogs_math::{Quat, Vec3};
    /// let mut s = Splats::<f64>::new(0);
    /// for k in 0..3 {
    ///     s.push(Vec3::splat(f64::from(k)), Vec3::zero(), Quat::identity(), 0.0, &[[0.5; 3]]);
    /// }
    /// let t = s.select([2, 0]);
    /// assert_eq!(t.means, [Vec3::splat(2.0), Vec3::zero()]);
    /// ```
    ///
    /// # Panics
    /// If an index is out of range.
    #[must_use]
    pub fn select(&self, indices: impl IntoIterator<Item = usize>) -> Self {
        let mut out = Self::new(self.sh_degree);
        for i in indices {
            out.push(
                self.means[i],
                self.log_scales[i],
                self.quats[i],
                self.opacity_logits[i],
                self.sh_coeffs(i),
            );
        }
        out
    }

    /// `true` if every vector has the length implied by [`len`](Self::len) and the degree is
    /// at most 3.
    #[must_use]
    pub fn check(&self) -> bool {
        let n = self.len();
        self.sh_degree <= MAX_SH_DEGREE
            && self.log_scales.len() == n
            && self.quats.len() == n
            && self.opacity_logits.len() == n
            && self.sh.len() == n * self.coeffs_per_gaussian()
    }

    /// Number of scalars in the flat layout of [`write_flat`](Self::write_flat).
    #[must_use]
    pub fn flat_len(&self) -> usize {
        self.len() * 11 + self.sh.len() * 3
    }

    /// Writes every parameter into one flat vector (cleared first), in blocks: means (3 per
    /// Gaussian), log-scales (3), quaternions (w, x, y, z), opacity logits (1), SH
    /// coefficients (3 per triple). A [`SplatsGrad`] uses the same layout, so analytic and
    /// numerical gradients compare entry by entry.
    pub fn write_flat(&self, out: &mut Vec<T>) {
        out.clear();
        out.reserve(self.flat_len());
        out.extend(self.means.iter().flat_map(|v| v.to_array()));
        out.extend(self.log_scales.iter().flat_map(|v| v.to_array()));
        out.extend(self.quats.iter().flat_map(|q| q.to_array()));
        out.extend_from_slice(&self.opacity_logits);
        out.extend(self.sh.iter().flatten());
    }

    /// Reads every parameter back from the layout of [`write_flat`](Self::write_flat).
    ///
    /// # Panics
    /// If `flat.len() != self.flat_len()`.
    pub fn read_flat(&mut self, flat: &[T]) {
        assert_eq!(flat.len(), self.flat_len(), "flat parameter length");
        let n = self.len();
        let (m, rest) = flat.split_at(3 * n);
        let (s, rest) = rest.split_at(3 * n);
        let (q, rest) = rest.split_at(4 * n);
        let (o, sh) = rest.split_at(n);
        for i in 0..n {
            self.means[i] = Vec3::from_slice(&m[3 * i..]);
            self.log_scales[i] = Vec3::from_slice(&s[3 * i..]);
            self.quats[i] = Quat::from_slice(&q[4 * i..]);
        }
        self.opacity_logits.copy_from_slice(o);
        for (d, c) in self.sh.iter_mut().zip(sh.chunks_exact(3)) {
            *d = [c[0], c[1], c[2]];
        }
    }

    /// Converts the scalar type (through `f64`).
    #[must_use]
    pub fn cast<U: Real>(&self) -> Splats<U> {
        let c = |v: T| U::from_f64(v.to_f64());
        Splats {
            sh_degree: self.sh_degree,
            means: self.means.iter().map(|v| v.cast()).collect(),
            log_scales: self.log_scales.iter().map(|v| v.cast()).collect(),
            quats: self.quats.iter().map(|q| q.cast()).collect(),
            opacity_logits: self.opacity_logits.iter().map(|&v| c(v)).collect(),
            sh: self.sh.iter().map(|t| t.map(c)).collect(),
        }
    }
}

/// The benchmark scene of the performance notes (`docs/architecture.md` §6): `n` Gaussians
/// uniform in the cube `[−0.5, 0.5]³`, log-uniform scales in `[0.01, 0.03]`, opacities
/// uniform in `[0.5, 0.9]`, random unit quaternions, SH degree 3 (random DC colour, higher
/// coefficients ~ N(0, 0.05²));
/// the camera at distance 4 on the +z axis looking at the origin, 40° horizontal field of
/// view, `size × size` pixels. Seeded and deterministic. ([`random_scene`] with those
/// ranges.)
///
/// # Panics
/// If `size` is zero.
#[must_use]
pub fn benchmark_scene<T: Real>(n: usize, size: usize, seed: u64) -> (Splats<T>, PinholeCamera<T>) {
    random_scene(n, size, seed, [0.01, 0.03], [0.5, 0.9])
}

/// A seeded random scene like [`benchmark_scene`], with the per-axis scale range (log-uniform)
/// and the opacity range (uniform; a degenerate range `[o, o]` gives every Gaussian opacity
/// `o` without drawing) chosen by the caller.
///
/// # Panics
/// If `size` is zero.
#[must_use]
pub fn random_scene<T: Real>(
    n: usize,
    size: usize,
    seed: u64,
    scale_range: [f64; 2],
    opacity_range: [f64; 2],
) -> (Splats<T>, PinholeCamera<T>) {
    let mut rng = SplitMix64::new(seed);
    let mut s = Splats::new(3);
    let (lo, hi) = (Real::ln(scale_range[0]), Real::ln(scale_range[1]));
    let mut sh = [[T::ZERO; 3]; 16];
    for _ in 0..n {
        let mean = Vec3::new(
            rng.uniform(-0.5, 0.5),
            rng.uniform(-0.5, 0.5),
            rng.uniform(-0.5, 0.5),
        );
        let ls = Vec3::new(
            rng.uniform(lo, hi),
            rng.uniform(lo, hi),
            rng.uniform(lo, hi),
        );
        let q = Quat::new(rng.normal(), rng.normal(), rng.normal(), rng.normal()).normalize();
        #[allow(clippy::float_cmp, reason = "a degenerate range is given exactly")]
        let opacity = if opacity_range[0] == opacity_range[1] {
            opacity_range[0]
        } else {
            rng.uniform(opacity_range[0], opacity_range[1])
        };
        for (k, c) in sh.iter_mut().enumerate() {
            for ch in c.iter_mut() {
                let v = if k == 0 {
                    (rng.uniform(0.0, 1.0) - 0.5) / SH_C0
                } else {
                    0.05 * rng.normal()
                };
                *ch = T::from_f64(v);
            }
        }
        s.push(
            mean.cast(),
            ls.cast(),
            q.cast(),
            T::from_f64(logit(opacity)),
            &sh,
        );
    }
    let cam = PinholeCamera::look_at(
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::zero(),
        Vec3::new(0.0, 1.0, 0.0),
        40.0_f64.to_radians(),
        size,
        size,
    )
    .expect("benchmark camera is valid for a non-empty image");
    (s, cam)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fill_zero_zeroes_every_entry_and_keeps_the_length() {
        for (n, par) in [(3, Par::Seq), (3, Par::best()), (2 * RUN + 5, Par::best())] {
            let (mut s, _) = benchmark_scene::<f64>(n, 8, 1);
            s.fill_zero(par);
            assert_eq!(s, Splats::zeros(n, 3), "{n} Gaussians, {par:?}");
        }
        // An inconsistent set (one SH triple short) is zeroed field by field.
        let (mut bad, _) = benchmark_scene::<f64>(4, 8, 1);
        bad.sh.pop();
        bad.fill_zero(Par::best());
        let mut want = Splats::zeros(4, 3);
        want.sh.pop();
        assert_eq!(bad, want, "an inconsistent set too");
    }

    #[test]
    fn copy_from_is_clone_from_on_any_thread_count() {
        // Sizes across runs, growing, shrinking, and another SH degree.
        let mut copy = Splats::<f64>::new(0);
        for (n, degree) in [(2 * RUN + 5, 3), (7, 3), (RUN, 1), (0, 2), (3 * RUN - 1, 3)] {
            let (s, _) = benchmark_scene::<f64>(n, 8, 1);
            let mut source = Splats::new(degree);
            for i in 0..n {
                let k = sh_coeff_count(degree);
                let sh = &s.sh_coeffs(i)[..k];
                source.push(
                    s.means[i],
                    s.log_scales[i],
                    s.quats[i],
                    s.opacity_logits[i],
                    sh,
                );
            }
            for par in [Par::Seq, Par::best()] {
                copy.copy_from(&source, par);
                assert_eq!(copy, source, "{n} Gaussians of degree {degree}, {par:?}");
            }
        }
    }

    #[test]
    fn clone_from_copies_into_the_buffers_it_has() {
        let (a, _) = benchmark_scene::<f64>(5, 8, 1);
        let (b, _) = benchmark_scene::<f64>(5, 8, 2);
        let mut c = a.clone();
        assert_eq!(c, a, "clone");
        let at = (c.means.as_ptr(), c.quats.as_ptr(), c.sh.as_ptr());
        c.clone_from(&b);
        assert_eq!(c, b, "clone_from");
        assert_eq!(
            at,
            (c.means.as_ptr(), c.quats.as_ptr(), c.sh.as_ptr()),
            "same buffers"
        );
        let small = Splats::<f64>::zeros(2, 1);
        c.clone_from(&small);
        assert_eq!(c, small, "into a different size and degree");
    }

    #[test]
    fn emptiness_follows_the_gaussians() {
        let mut s = Splats::<f64>::new(0);
        assert!(s.is_empty(), "new");
        s.push(
            Vec3::zero(),
            Vec3::zero(),
            Quat::identity(),
            0.0,
            &[[0.0; 3]],
        );
        assert!(!s.is_empty(), "after a push");
    }

    #[test]
    fn each_gaussian_writes_its_own_coefficients() {
        // Degree 1: 4 triples per Gaussian, Gaussian i at sh[4i..4i + 4].
        let mut s = Splats::<f64>::zeros(3, 1);
        for i in 0..3 {
            let c = s.sh_coeffs_mut(i);
            assert_eq!(c.len(), 4, "triples of {i}");
            for (j, t) in c.iter_mut().enumerate() {
                *t = [(10 * i + j) as f64, 0.5, -1.0];
            }
        }
        for (flat, t) in s.sh.iter().enumerate() {
            let (i, j) = (flat / 4, flat % 4);
            assert_eq!(
                t[0].to_bits(),
                ((10 * i + j) as f64).to_bits(),
                "triple {j} of {i}"
            );
        }
        assert_eq!(s.sh_coeffs(2)[3][0].to_bits(), 23.0_f64.to_bits());
    }

    #[test]
    fn check_refuses_each_inconsistency_alone() {
        let (s, _) = benchmark_scene::<f64>(2, 8, 1);
        assert!(s.check(), "consistent");
        type Break = fn(&mut Splats<f64>);
        let broken: [(&str, Break); 5] = [
            ("degree 4", |s| {
                s.sh_degree = 4;
                s.sh.resize(2 * 25, [0.0; 3]);
            }),
            ("a log-scale short", |s| {
                s.log_scales.pop();
            }),
            ("a quaternion short", |s| {
                s.quats.pop();
            }),
            ("an opacity short", |s| {
                s.opacity_logits.pop();
            }),
            ("a triple short", |s| {
                s.sh.pop();
            }),
        ];
        for (what, breaks) in broken {
            let mut b = s.clone();
            breaks(&mut b);
            assert!(!b.check(), "{what}");
        }
    }

    #[test]
    fn random_scenes_span_their_documented_ranges() {
        let n = 2000;
        let (s, _) = random_scene::<f64>(n, 8, 3, [0.01, 0.03], [0.5, 0.9]);
        // Means fill the cube [-0.5, 0.5]^3 in every component.
        for c in 0..3 {
            let v: Vec<f64> = s.means.iter().map(|m| m.to_array()[c]).collect();
            let (lo, hi) = v
                .iter()
                .fold((1.0_f64, -1.0_f64), |(a, b), &x| (a.min(x), b.max(x)));
            assert!(
                (-0.5..-0.45).contains(&lo) && hi > 0.45 && hi <= 0.5,
                "component {c}: {lo}..{hi}"
            );
        }
        // Opacities uniform in [0.5, 0.9].
        let o: Vec<f64> = s
            .opacity_logits
            .iter()
            .map(|&l| evogs_math::activation::sigmoid(l))
            .collect();
        assert!(
            o.iter().all(|&x| (0.5 - 1e-12..=0.9 + 1e-12).contains(&x)),
            "opacity range"
        );
        assert!(
            o.iter().any(|&x| x < 0.52) && o.iter().any(|&x| x > 0.88),
            "opacities spread"
        );
        // DC colours (colour = SH_C0 k0 + 1/2) uniform in [0, 1]; higher coefficients ~ N(0, 0.05²).
        let k = s.coeffs_per_gaussian();
        let dc: Vec<f64> = (0..n)
            .flat_map(|i| s.sh_coeffs(i)[0])
            .map(|v| SH_C0 * v + 0.5)
            .collect();
        assert!(
            dc.iter().all(|&x| (-1e-12..=1.0 + 1e-12).contains(&x)),
            "colour range"
        );
        assert!(
            dc.iter().any(|&x| x < 0.02) && dc.iter().any(|&x| x > 0.98),
            "colours spread"
        );
        let rest: Vec<f64> = (0..n)
            .flat_map(|i| {
                s.sh_coeffs(i)[1..k]
                    .iter()
                    .flatten()
                    .copied()
                    .collect::<Vec<_>>()
            })
            .collect();
        let rms = (rest.iter().map(|v| v * v).sum::<f64>()
            / f64::from(u32::try_from(rest.len()).expect("count")))
        .sqrt();
        assert!(
            (0.048..0.052).contains(&rms),
            "higher coefficients' spread {rms}"
        );
        // A degenerate opacity range gives that opacity exactly, without drawing.
        let (d, _) = random_scene::<f64>(5, 8, 3, [0.01, 0.03], [0.7, 0.7]);
        assert!(
            d.opacity_logits
                .iter()
                .all(|&l| (evogs_math::activation::sigmoid(l) - 0.7).abs() < 1e-12),
            "degenerate range"
        );
    }
}
