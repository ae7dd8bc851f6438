//! Per-Gaussian preprocessing shared by every rasterizer: projection, SH colour and
//! effective opacity for all Gaussians ([`preprocess`]), the compositing order, and the VJP
//! from the rasterizer's per-Gaussian input gradients back to the raw parameters and the
//! camera ([`preprocess_vjp`]).
//!
//! ```text
//! o  = sigmoid(ô)
//! o' = o              (RasterMode::Classic)
//! o' = o·ρ            (RasterMode::Antialiased; ρ the compensation)
//! colour = max(0, SH(d̂) + ½),  d̂ from the camera centre to the mean
//! order  = valid Gaussians sorted by (depth, index), front first
//! ```
//!
//! Backward per Gaussian: `do = ρ do'` (or `do'`), `dρ = o do'` (antialiased),
//! `dô = o(1 − o) do`; the colour VJP gives SH, mean and camera-centre gradients; the
//! projection VJP gives mean, log-scale, quaternion and view-matrix gradients.
//!
//! Culling: a Gaussian is valid if [`project`] keeps it and its colour and effective opacity
//! are finite.
//!
//! The 2D-mean gradient `RasterInputGrad::means2d` and the radii `Preprocessed::radii` are
//! what densification accumulates.
//!
//! Parallelism: with [`Par::Rayon`](evogs_math::Par) the Gaussians are split into fixed
//! chunks of [`CHUNK`] and the camera gradient is reduced in chunk order, so the results are
//! bitwise identical to [`Par::Seq`](evogs_math::Par).

use crate::camera::{CameraGrad, PinholeCamera};
use crate::color::{sh_color, sh_color_vjp};
use crate::gaussians::{Splats, SplatsGrad};
use crate::pool::run_items;
use crate::project::{ProjectOptions, RadiusMode, project};
use crate::project_vjp::{ProjectedGrad, project_vjp};
use alloc::vec;
use alloc::vec::Vec;
use core::cmp::Ordering;
use evogs_math::activation::sigmoid;
use evogs_math::sh::sh_coeff_count;
use evogs_math::{Par, Real, Vec2, Vec3};

/// Gaussians per parallel work item.
pub const CHUNK: usize = 256;

/// How effective opacities are formed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RasterMode {
    /// Classic 3DGS: `o' = o`.
    #[default]
    Classic,
    /// Mip-Splatting / gsplat "antialiased": `o' = o·ρ` with the compensation ρ.
    Antialiased,
}

/// Options of a render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions<T> {
    /// Low-pass dilation ε (0.3).
    pub eps2d: T,
    /// Radius rule (the reference rasterizer's image does not depend on it).
    pub radius: RadiusMode,
    /// Classic or antialiased opacities.
    pub mode: RasterMode,
    /// Active SH degree; the effective degree is `min(sh_degree, splats.sh_degree)`.
    pub sh_degree: usize,
    /// Background colour, added with the final transmittance.
    pub background: [T; 3],
    /// Sequential or rayon (deterministic either way).
    pub par: Par,
}

impl<T: Real> Default for RenderOptions<T> {
    fn default() -> Self {
        Self {
            eps2d: T::from_f64(crate::project::DEFAULT_EPS2D),
            radius: RadiusMode::default(),
            mode: RasterMode::default(),
            sh_degree: 3,
            background: [T::ZERO; 3],
            par: Par::Seq,
        }
    }
}

impl<T: Real> RenderOptions<T> {
    /// The projection options implied by these render options.
    #[must_use]
    pub fn project_options(&self) -> ProjectOptions<T> {
        ProjectOptions {
            eps2d: self.eps2d,
            radius: self.radius,
            antialiased: self.mode == RasterMode::Antialiased,
        }
    }
}

/// The rasterizer inputs for all Gaussians (struct of arrays, index = Gaussian index).
///
/// Culled Gaussians have `valid == false`, zero colour and opacity, and are absent from
/// `order`; their projected floats are kept as computed (see
/// [`Projected`](crate::Projected)).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Preprocessed<T> {
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// Pixel coordinates of the means.
    pub means2d: Vec<Vec2<T>>,
    /// Conics `[a, b, c]`: `σ = ½(a dx² + c dy²) + b dx dy`.
    pub conics: Vec<[T; 3]>,
    /// Colours after the +½ offset and the clamp at 0.
    pub colors: Vec<[T; 3]>,
    /// Effective opacities `o'`.
    pub opacities: Vec<T>,
    /// Depths (camera-space z).
    pub depths: Vec<T>,
    /// Per-axis screen radii in pixels (`[0, 0]` if culled).
    pub radii: Vec<[u32; 2]>,
    /// Not culled.
    pub valid: Vec<bool>,
    /// Compensations ρ (used in antialiased mode).
    pub compensations: Vec<T>,
    /// Valid Gaussians sorted by (depth, index): the compositing order, front first.
    pub order: Vec<u32>,
}

/// Gradients of a loss with respect to the rasterizer inputs of every Gaussian (zero for
/// culled ones): what a rasterizer backward returns.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RasterInputGrad<T> {
    /// `∂L/∂means2d` (also the densification statistic).
    pub means2d: Vec<Vec2<T>>,
    /// `∂L/∂[a, b, c]`.
    pub conics: Vec<[T; 3]>,
    /// `∂L/∂colour` (post-clamp colour).
    pub colors: Vec<[T; 3]>,
    /// `∂L/∂o'`.
    pub opacities: Vec<T>,
    /// `∂L/∂depth` (from the expected-depth output).
    pub depths: Vec<T>,
}

impl<T: Real> RasterInputGrad<T> {
    /// Zero gradients for `n` Gaussians.
    #[must_use]
    pub fn zeros(n: usize) -> Self {
        Self {
            means2d: vec![Vec2::zero(); n],
            conics: vec![[T::ZERO; 3]; n],
            colors: vec![[T::ZERO; 3]; n],
            opacities: vec![T::ZERO; n],
            depths: vec![T::ZERO; n],
        }
    }

    /// Resizes to `n` Gaussians and zeroes every entry.
    pub fn reset(&mut self, n: usize) {
        self.means2d.clear();
        self.means2d.resize(n, Vec2::zero());
        self.conics.clear();
        self.conics.resize(n, [T::ZERO; 3]);
        self.colors.clear();
        self.colors.resize(n, [T::ZERO; 3]);
        self.opacities.clear();
        self.opacities.resize(n, T::ZERO);
        self.depths.clear();
        self.depths.resize(n, T::ZERO);
    }

    /// Number of Gaussians.
    #[must_use]
    pub fn len(&self) -> usize {
        self.means2d.len()
    }

    /// `true` if empty.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.means2d.is_empty()
    }
}

/// One chunk of the preprocessing output.
struct PreChunk<'a, T> {
    start: usize,
    means2d: &'a mut [Vec2<T>],
    conics: &'a mut [[T; 3]],
    colors: &'a mut [[T; 3]],
    opacities: &'a mut [T],
    depths: &'a mut [T],
    radii: &'a mut [[u32; 2]],
    valid: &'a mut [bool],
    compensations: &'a mut [T],
}

/// Preprocesses every Gaussian for a camera (see the module docs).
///
/// # Panics
/// If `splats` is inconsistent ([`Splats::check`]) or holds more than `u32::MAX` Gaussians.
#[must_use]
pub fn preprocess<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
) -> Preprocessed<T> {
    let mut out = Preprocessed::default();
    preprocess_into(splats, camera, opts, &mut out);
    out
}

/// [`preprocess`] into caller-provided buffers (reused across calls).
///
/// # Panics
/// If `splats` is inconsistent ([`Splats::check`]) or holds more than `u32::MAX` Gaussians.
pub fn preprocess_into<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
    out: &mut Preprocessed<T>,
) {
    assert!(splats.check(), "inconsistent Splats arrays");
    let n = splats.len();
    assert!(u32::try_from(n).is_ok(), "too many Gaussians");
    out.width = camera.width;
    out.height = camera.height;
    out.means2d.resize(n, Vec2::zero());
    out.conics.resize(n, [T::ZERO; 3]);
    out.colors.resize(n, [T::ZERO; 3]);
    out.opacities.resize(n, T::ZERO);
    out.depths.resize(n, T::ZERO);
    out.radii.resize(n, [0; 2]);
    out.valid.resize(n, false);
    out.compensations.resize(n, T::ZERO);

    let popts = opts.project_options();
    let degree = opts.sh_degree.min(splats.sh_degree);
    let center = camera.center();
    let antialiased = opts.mode == RasterMode::Antialiased;
    let mut chunks: Vec<PreChunk<'_, T>> = out
        .means2d
        .chunks_mut(CHUNK)
        .zip(out.conics.chunks_mut(CHUNK))
        .zip(out.colors.chunks_mut(CHUNK))
        .zip(out.opacities.chunks_mut(CHUNK))
        .zip(out.depths.chunks_mut(CHUNK))
        .zip(out.radii.chunks_mut(CHUNK))
        .zip(out.valid.chunks_mut(CHUNK))
        .zip(out.compensations.chunks_mut(CHUNK))
        .enumerate()
        .map(
            |(k, (((((((means2d, conics), colors), opacities), depths), radii), valid), comps))| {
                PreChunk {
                    start: k * CHUNK,
                    means2d,
                    conics,
                    colors,
                    opacities,
                    depths,
                    radii,
                    valid,
                    compensations: comps,
                }
            },
        )
        .collect();
    run_items(opts.par, &mut chunks, |c| {
        for j in 0..c.means2d.len() {
            let i = c.start + j;
            let mean = splats.means[i];
            let o = sigmoid(splats.opacity_logits[i]);
            let p = project(
                mean,
                splats.log_scales[i],
                splats.quats[i],
                o,
                camera,
                &popts,
            );
            c.means2d[j] = p.means2d;
            c.conics[j] = p.conic;
            c.depths[j] = p.depth;
            c.compensations[j] = p.compensation;
            let (color, opacity) = if p.valid {
                let color = sh_color(degree, splats.sh_coeffs(i), mean, center);
                (color, if antialiased { o * p.compensation } else { o })
            } else {
                ([T::ZERO; 3], T::ZERO)
            };
            // A NaN/Inf colour or opacity (e.g. a diverged SH coefficient) culls the Gaussian
            // instead of poisoning the image.
            let finite = opacity.is_finite() && color.iter().all(|v| v.is_finite());
            let valid = p.valid && finite;
            c.valid[j] = valid;
            c.radii[j] = if valid { p.radii } else { [0; 2] };
            c.colors[j] = if valid { color } else { [T::ZERO; 3] };
            c.opacities[j] = if valid { opacity } else { T::ZERO };
        }
    });
    drop(chunks);

    out.order.clear();
    out.order.extend(
        (0..n)
            .filter(|&i| out.valid[i])
            .map(|i| u32::try_from(i).unwrap_or(u32::MAX)),
    );
    let depths = &out.depths;
    // A valid Gaussian's depth lies in (near, far), so it is finite and (depth, index) is a
    // strict total order: every correct sort, sequential or parallel, gives this one order.
    let by_depth = |a: &u32, b: &u32| {
        depths[*a as usize]
            .partial_cmp(&depths[*b as usize])
            .unwrap_or(Ordering::Equal)
            .then(a.cmp(b))
    };
    #[cfg(feature = "rayon")]
    if matches!(opts.par, Par::Rayon) {
        use rayon::slice::ParallelSliceMut;
        out.order.par_sort_unstable_by(by_depth);
        return;
    }
    out.order.sort_unstable_by(by_depth);
}

/// VJP of [`preprocess`]: from the per-Gaussian rasterizer-input gradients `d` to the raw
/// parameters (**added** into `grad`, which must be shaped like `splats`) and the camera
/// (returned).
///
/// `pre` must be the output of [`preprocess`] for the same arguments.
///
/// # Panics
/// If the shapes of `splats`, `pre`, `d` and `grad` disagree.
pub fn preprocess_vjp<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
    pre: &Preprocessed<T>,
    d: &RasterInputGrad<T>,
    grad: &mut SplatsGrad<T>,
) -> CameraGrad<T> {
    preprocess_vjp_with(splats, camera, opts, pre, d, grad, GradInit::Add)
}

/// What [`preprocess_vjp_with`] does with the gradient it is given.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum GradInit {
    /// Adds into it.
    Add,
    /// Overwrites it: each chunk of Gaussians is zeroed just before its terms are added (on
    /// the chunk's thread, while the lines are in its cache), culled Gaussians included.
    Overwrite,
}

/// [`preprocess_vjp`], adding into `grad` or overwriting it.
pub(crate) fn preprocess_vjp_with<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
    pre: &Preprocessed<T>,
    d: &RasterInputGrad<T>,
    grad: &mut SplatsGrad<T>,
    init: GradInit,
) -> CameraGrad<T> {
    let n = splats.len();
    assert!(
        pre.valid.len() == n && d.len() == n && grad.len() == n && grad.check(),
        "shape mismatch in preprocess_vjp"
    );
    assert_eq!(grad.sh_degree, splats.sh_degree, "gradient SH degree");
    let popts = opts.project_options();
    let degree = opts.sh_degree.min(splats.sh_degree);
    let center = camera.center();
    let antialiased = opts.mode == RasterMode::Antialiased;
    let k = sh_coeff_count(splats.sh_degree);
    let mut chunks = grad.runs_mut(CHUNK);
    let partial = run_items(opts.par, &mut chunks, |c| {
        if init == GradInit::Overwrite {
            c.fill_zero();
        }
        let mut cam = CameraGrad::zero();
        let mut d_center = Vec3::zero();
        for j in 0..c.means.len() {
            let i = c.first + j;
            if !pre.valid[i] {
                continue;
            }
            let mean = splats.means[i];
            let logit = splats.opacity_logits[i];
            let o = sigmoid(logit);
            let dop = d.opacities[i];
            let (d_o, d_comp) = if antialiased {
                (dop * pre.compensations[i], o * dop)
            } else {
                (dop, T::ZERO)
            };
            c.opacity_logits[j] += o * (T::ONE - o) * d_o;
            let d_sh = &mut c.sh[j * k..(j + 1) * k];
            let coeffs = splats.sh_coeffs(i);
            let (dm_color, dc_color) =
                sh_color_vjp(degree, coeffs, mean, center, d.colors[i], d_sh);
            d_center += dc_color;
            let dp = ProjectedGrad {
                means2d: d.means2d[i],
                depth: d.depths[i],
                conic: d.conics[i],
                compensation: d_comp,
            };
            let g = project_vjp(
                mean,
                splats.log_scales[i],
                splats.quats[i],
                o,
                camera,
                &popts,
                &dp,
            );
            c.means[j] += g.mean + dm_color;
            c.log_scales[j] += g.log_scale;
            c.quats[j] = c.quats[j] + g.quat;
            cam.add(&g.camera);
        }
        cam.add(&camera.center_vjp(d_center));
        cam
    });
    let mut cam = CameraGrad::zero();
    for p in &partial {
        cam.add(p);
    }
    cam
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gaussians::benchmark_scene;

    fn bits3(v: [f64; 3]) -> [u64; 3] {
        v.map(f64::to_bits)
    }

    /// Three whole chunks and a partial fourth, every fifth Gaussian far out of view.
    fn chunked_scene() -> (Splats<f64>, PinholeCamera<f64>) {
        let n = 3 * CHUNK + 17;
        let (mut s, cam) = benchmark_scene::<f64>(n, 64, 5);
        for i in (0..n).step_by(5) {
            s.means[i].x += 50.0;
        }
        (s, cam)
    }

    #[test]
    fn every_chunk_holds_its_own_gaussians() {
        // Sequential and parallel: each Gaussian's entries are those it gets when
        // preprocessed alone.
        let (s, cam) = chunked_scene();
        let n = s.len();
        for par in [Par::Seq, Par::best()] {
            let opts = RenderOptions {
                par,
                ..RenderOptions::default()
            };
            let all = preprocess(&s, &cam, &opts);
            for (k, chunk) in all.valid.chunks(CHUNK).enumerate() {
                assert!(
                    chunk.iter().any(|&v| v) && chunk.iter().any(|&v| !v),
                    "chunk {k} holds kept and culled Gaussians"
                );
            }
            for i in 0..n {
                let one = preprocess(&s.select([i]), &cam, &opts);
                assert_eq!(all.means2d[i], one.means2d[0], "mean of {i}");
                assert_eq!(bits3(all.conics[i]), bits3(one.conics[0]), "conic of {i}");
                assert_eq!(bits3(all.colors[i]), bits3(one.colors[0]), "colour of {i}");
                assert_eq!(
                    [all.opacities[i], all.depths[i], all.compensations[i]].map(f64::to_bits),
                    [one.opacities[0], one.depths[0], one.compensations[0]].map(f64::to_bits),
                    "opacity, depth and compensation of {i}"
                );
                assert_eq!(
                    (all.radii[i], all.valid[i]),
                    (one.radii[0], one.valid[0]),
                    "radii and validity of {i}"
                );
            }
        }
    }

    #[test]
    fn every_chunk_of_the_vjp_holds_its_own_gaussians() {
        // Each Gaussian's parameter gradient is the one it gets alone; the camera gradient
        // is the sum of theirs (up to the order of the additions).
        let (s, cam) = chunked_scene();
        let n = s.len();
        let mut rng = evogs_math::rng::SplitMix64::new(9);
        let mut d = RasterInputGrad::zeros(n);
        for i in 0..n {
            d.means2d[i] = Vec2::new(rng.normal(), rng.normal());
            d.conics[i] = [rng.normal(), rng.normal(), rng.normal()];
            d.colors[i] = [rng.normal(), rng.normal(), rng.normal()];
            d.opacities[i] = rng.normal();
            d.depths[i] = rng.normal();
        }
        for par in [Par::Seq, Par::best()] {
            let opts = RenderOptions {
                par,
                mode: RasterMode::Antialiased,
                ..RenderOptions::default()
            };
            let pre = preprocess(&s, &cam, &opts);
            let mut grad = s.zeros_like();
            let cam_grad = preprocess_vjp(&s, &cam, &opts, &pre, &d, &mut grad);
            let mut cam_sum = Vec3::zero();
            for i in 0..n {
                let one = s.select([i]);
                let pre1 = preprocess(&one, &cam, &opts);
                let mut d1 = RasterInputGrad::zeros(1);
                d1.means2d[0] = d.means2d[i];
                d1.conics[0] = d.conics[i];
                d1.colors[0] = d.colors[i];
                d1.opacities[0] = d.opacities[i];
                d1.depths[0] = d.depths[i];
                let mut g1 = one.zeros_like();
                cam_sum += preprocess_vjp(&one, &cam, &opts, &pre1, &d1, &mut g1).translation;
                assert_eq!(
                    (grad.means[i], grad.log_scales[i], grad.quats[i]),
                    (g1.means[0], g1.log_scales[0], g1.quats[0]),
                    "mean, scale and rotation gradients of {i}"
                );
                assert_eq!(
                    grad.opacity_logits[i].to_bits(),
                    g1.opacity_logits[0].to_bits(),
                    "opacity gradient of {i}"
                );
                assert!(
                    grad.sh_coeffs(i)
                        .iter()
                        .zip(g1.sh_coeffs(0))
                        .all(|(a, b)| bits3(*a) == bits3(*b)),
                    "SH gradient of {i}"
                );
            }
            let err = (cam_grad.translation - cam_sum).norm();
            assert!(
                err <= 1e-12 * cam_sum.norm() && cam_sum.norm() > 0.0,
                "camera gradient: {err}"
            );
        }
    }

    #[test]
    fn input_gradients_have_the_length_they_are_given_and_reset_to_zero() {
        let mut g = RasterInputGrad::<f64>::zeros(0);
        assert!(g.is_empty(), "no Gaussians");
        g.reset(3);
        assert!(!g.is_empty() && g.len() == 3, "three Gaussians");
        g.means2d[1] = Vec2::new(1.0, 2.0);
        g.opacities[2] = 4.0;
        g.reset(2);
        assert_eq!(g, RasterInputGrad::zeros(2), "two zero Gaussians");
    }
}
