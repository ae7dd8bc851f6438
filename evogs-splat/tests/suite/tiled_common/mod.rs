//! Shared helpers of the tiled-rasterizer tests: random scenes aimed at the tiling edge
//! cases, random pixel cotangents and error measures.
#![allow(dead_code, reason = "each test binary uses a subset of the helpers")]

use evogs_math::activation::logit;
use evogs_math::rng::SplitMix64;
use evogs_math::sh::SH_C0;
use evogs_math::{Quat, Real, Vec3};
use evogs_splat::{PinholeCamera, Splats, TILE_SIZE};

/// What a random Gaussian of a test scene looks like.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kind {
    /// Anywhere on (or a little off) the image, small to medium, semi-transparent.
    Regular,
    /// Centred within a pixel of a tile corner or edge (straddles tiles).
    TileBorder,
    /// Centred near an image border (partly outside the image).
    ImageBorder,
    /// Large and nearly opaque: heavy overlap, early termination.
    Opaque,
    /// Opacity within 1e-3 of 1 on a small footprint: alpha clamped at 0.999.
    Clamped,
}

const KINDS: [Kind; 5] = [
    Kind::Regular,
    Kind::TileBorder,
    Kind::ImageBorder,
    Kind::Opaque,
    Kind::Clamped,
];

/// A test camera for a `w × h` image (off-centre principal point, 0.8 rad field of view).
pub(crate) fn camera(w: usize, h: usize) -> PinholeCamera<f64> {
    let mut cam = PinholeCamera::look_at(
        Vec3::new(0.3, -0.2, 4.0),
        Vec3::new(0.05, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        0.8,
        w,
        h,
    )
    .expect("camera");
    cam.cx += 0.37;
    cam.cy -= 0.21;
    cam
}

/// The world point seen at pixel coordinates `(u, v)` at depth `z`.
fn unproject(cam: &PinholeCamera<f64>, u: f64, v: f64, z: f64) -> Vec3<f64> {
    let p = Vec3::new((u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z);
    cam.rotation.tr_mul_vec(p - cam.translation)
}

/// `n` random Gaussians (SH degree 1) for a `w × h` image; `mix` selects which kinds occur
/// (bit `i` for `KINDS[i]`, all if 0).
pub(crate) fn scene(
    w: usize,
    h: usize,
    n: usize,
    mix: u32,
    seed: u64,
) -> (Splats<f64>, PinholeCamera<f64>) {
    let cam = camera(w, h);
    let mut rng = SplitMix64::new(seed);
    let kinds: Vec<Kind> = KINDS
        .iter()
        .enumerate()
        .filter(|(i, _)| mix == 0 || mix & (1 << i) != 0)
        .map(|(_, k)| *k)
        .collect();
    let (wf, hf) = (w as f64, h as f64);
    let tile = TILE_SIZE as f64;
    let mut s = Splats::new(1);
    for _ in 0..n {
        let kind = kinds[rng.below(kinds.len())];
        let z = rng.uniform(3.0, 6.0);
        let (u, v, ls, o) = match kind {
            Kind::Regular => (
                rng.uniform(-4.0, wf + 4.0),
                rng.uniform(-4.0, hf + 4.0),
                rng.uniform(-3.8, -1.2),
                rng.uniform(0.05, 0.95),
            ),
            Kind::TileBorder => {
                let tu = (rng.below(w.div_ceil(TILE_SIZE) + 1) as f64) * tile;
                let tv = (rng.below(h.div_ceil(TILE_SIZE) + 1) as f64) * tile;
                (
                    tu + rng.uniform(-0.7, 0.7),
                    tv + rng.uniform(-0.7, 0.7),
                    rng.uniform(-3.5, -1.5),
                    rng.uniform(0.2, 0.95),
                )
            }
            Kind::ImageBorder => {
                let (bu, bv) = if rng.next_f64() < 0.5 {
                    (
                        if rng.next_f64() < 0.5 { 0.0 } else { wf },
                        rng.uniform(0.0, hf),
                    )
                } else {
                    (
                        rng.uniform(0.0, wf),
                        if rng.next_f64() < 0.5 { 0.0 } else { hf },
                    )
                };
                (
                    bu + rng.uniform(-3.0, 3.0),
                    bv + rng.uniform(-3.0, 3.0),
                    rng.uniform(-3.0, -1.5),
                    rng.uniform(0.3, 0.95),
                )
            }
            Kind::Opaque => (
                rng.uniform(0.0, wf),
                rng.uniform(0.0, hf),
                rng.uniform(-1.6, -0.6),
                rng.uniform(0.95, 0.999),
            ),
            Kind::Clamped => (
                rng.uniform(0.0, wf),
                rng.uniform(0.0, hf),
                rng.uniform(-2.6, -1.8),
                1.0 - 10.0_f64.powf(rng.uniform(-5.0, -3.3)),
            ),
        };
        let mean = unproject(&cam, u, v, z);
        let log_scale = Vec3::new(
            ls + rng.uniform(-0.4, 0.4),
            ls + rng.uniform(-0.4, 0.4),
            ls + rng.uniform(-0.4, 0.4),
        );
        let q = Quat::new(rng.normal(), rng.normal(), rng.normal(), rng.normal());
        let sh: Vec<[f64; 3]> = (0..4)
            .map(|k| {
                std::array::from_fn(|_| {
                    if k == 0 {
                        (rng.uniform(0.0, 1.0) - 0.5) / SH_C0
                    } else {
                        0.1 * rng.normal()
                    }
                })
            })
            .collect();
        s.push(mean, log_scale, q, logit(o), &sh);
    }
    (s, cam)
}

/// Random pixel cotangents: rgb (3 per pixel), alpha and depth (one per pixel).
pub(crate) fn cotangents(np: usize, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut rng = SplitMix64::new(seed ^ 0x9e37_79b9_7f4a_7c15);
    let rgb = (0..3 * np).map(|_| rng.normal()).collect();
    let alpha = (0..np).map(|_| rng.normal()).collect();
    let depth = (0..np).map(|_| 0.1 * rng.normal()).collect();
    (rgb, alpha, depth)
}

/// Converts a slice of scalars to `f64`.
pub(crate) fn to_f64<T: Real>(v: &[T]) -> Vec<f64> {
    v.iter().map(|x| x.to_f64()).collect()
}

/// `max_i |a_i − b_i| / max(1, |b_i|)`: the elementwise error measure of these tests.
pub(crate) fn rel_err(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "lengths");
    a.iter()
        .zip(b)
        .map(|(x, y)| {
            let e = (x - y).abs() / y.abs().max(1.0);
            if e.is_nan() { f64::INFINITY } else { e }
        })
        .fold(0.0, f64::max)
}
