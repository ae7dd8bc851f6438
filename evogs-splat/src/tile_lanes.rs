//! The lane machinery shared by the tiled forward and backward passes: the packed Gaussian
//! record, the 4×4 pixel groups of a tile, the per-pixel evaluation of the compositing rules
//! in lane form, and the tile-parallel driver.
//!
//! # Groups and lanes
//!
//! A 16×16 tile is cut into 16 **groups** of 4×4 pixels; the 16 pixels of a group are the
//! 16 lanes of the inner loops (`for i in 0..16`, two 8-wide AVX2 vectors in `f32`). A
//! Gaussian visits the groups that its pixel box covers, in two phases per group: first `σ`
//! at the 16 pixels (cheap); if no pixel has `0 ≤ σ ≤ cutoff` the group is skipped (the
//! reference skips every such pixel), else the exponential and the compositing follow. 4×4
//! groups follow the elliptic footprints more tightly than tile rows (about half the lane
//! evaluations of 16×1 rows on the benchmark scenes).
//!
//! # Lane loops
//!
//! The loops are written so that the compiler vectorises them, without branches and
//! without boolean lane state:
//!
//! - every decision is turned into a 0/1 number of type `T` right away (`mask`), and a
//!   masked update is exact arithmetic: `x + c·(w·m)` is `x + c·w` for `m = 1` and `x` for
//!   `m = 0`, `T·(1 − α·m)` is `T·(1 − α)` or `T` — the reference's floats where the lane is
//!   active, the old value where it is not (all lane values are finite, so `0·y = 0`);
//! - the updated state is always stored (a select of the old value would let the compiler
//!   turn the store into a slow masked store).
//!
//! Positions in a tile's list are carried as `T` in the lanes as well, which is exact below
//! 2²⁴ in `f32`; the loops work through a list in segments of 2²² entries.

use crate::binning::{Rect, TILE_SIZE};
use crate::fast_exp::exp_neg;
use crate::raster_ref::{ALPHA_MAX, ALPHA_MIN};
use evogs_math::{Real, Vec2};

/// Side of a lane group in pixels, as `u32` (pixel rectangles are `u32`).
const SIDE_U32: u32 = 4;
/// Side of a lane group in pixels.
pub(crate) const SIDE: usize = SIDE_U32 as usize;
/// Lanes (pixels) per group.
pub(crate) const LANES: usize = SIDE * SIDE;
/// Groups per tile side.
pub(crate) const GROUPS_X: usize = TILE_SIZE / SIDE;
/// Groups per tile.
pub(crate) const GROUPS: usize = GROUPS_X * GROUPS_X;

/// Per-lane values of a tile, group-major: `[group][lane]`.
pub(crate) type TileLanes<T> = [[T; LANES]; GROUPS];

/// Tile-list entries per segment (list positions carried as `T` stay exact).
pub(crate) const SEGMENT: usize = 1 << 22;

/// The group and lane of the pixel `(lx, ly)` of a tile (tile-local coordinates).
#[inline]
pub(crate) fn group_lane(lx: usize, ly: usize) -> (usize, usize) {
    (
        (ly / SIDE) * GROUPS_X + lx / SIDE,
        (ly % SIDE) * SIDE + lx % SIDE,
    )
}

/// The pixel-centre coordinates of every lane of the tile with pixel rectangle `px`
/// (`pixel_center`'s floats).
pub(crate) fn lane_centres<T: Real>(px: Rect, xs: &mut TileLanes<T>, ys: &mut TileLanes<T>) {
    for g in 0..GROUPS {
        for i in 0..LANES {
            let x = px.x0 as usize + (g % GROUPS_X) * SIDE + i % SIDE;
            let y = px.y0 as usize + (g / GROUPS_X) * SIDE + i / SIDE;
            xs[g][i] = T::from_usize(x) + T::HALF;
            ys[g][i] = T::from_usize(y) + T::HALF;
        }
    }
}

/// One valid Gaussian in compositing order, packed for the tile loops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct TileSplat<T> {
    pub(crate) mean: Vec2<T>,
    pub(crate) conic: [T; 3],
    pub(crate) opacity: T,
    /// [`sigma_cutoff`](crate::raster_ref::sigma_cutoff) of the opacity.
    pub(crate) cut: T,
    pub(crate) color: [T; 3],
    pub(crate) depth: T,
    /// Pixels whose centres lie in the radius box.
    pub(crate) pixels: Rect,
    /// The screen radii (with `mean`, what the binning depends on).
    pub(crate) radii: [u32; 2],
}

impl<T> TileSplat<T> {
    /// The groups `[gx0, gx1) × [gy0, gy1)` of tile `px` that the pixel box covers (an
    /// empty rectangle if none).
    #[inline]
    pub(crate) fn groups_in(&self, px: Rect) -> Rect {
        let (x0, x1) = (self.pixels.x0.max(px.x0), self.pixels.x1.min(px.x1));
        let (y0, y1) = (self.pixels.y0.max(px.y0), self.pixels.y1.min(px.y1));
        if x0 >= x1 || y0 >= y1 {
            return Rect::default();
        }
        let side = SIDE_U32;
        Rect {
            x0: (x0 - px.x0) / side,
            x1: (x1 - 1 - px.x0) / side + 1,
            y0: (y0 - px.y0) / side,
            y1: (y1 - 1 - px.y0) / side + 1,
        }
    }
}

/// `if c { a } else { b }` with both values already computed: a plain select.
#[inline(always)]
pub(crate) fn select<V>(c: bool, a: V, b: V) -> V {
    if c { a } else { b }
}

/// `c ? 1 : 0` in `T` (see the module docs).
#[inline(always)]
pub(crate) fn mask<T: Real>(c: bool) -> T {
    select(c, T::ONE, T::ZERO)
}

/// The first phase at a group: `dx`, `dy` and `σ = ½(a dx² + c dy²) + b dx dy` at its 16
/// pixel centres `(xs[i], ys[i])` (the reference's expression), or `None` if no pixel has
/// `0 ≤ σ ≤ cutoff` (the reference skips all of them).
#[derive(Clone, Copy, Debug)]
pub(crate) struct GroupSigma<T> {
    /// `mean.x − p.x`.
    pub(crate) dx: [T; LANES],
    /// `mean.y − p.y`.
    pub(crate) dy: [T; LANES],
    /// `σ`.
    pub(crate) sigma: [T; LANES],
}

/// Computes [`GroupSigma`] (see there).
#[inline(always)]
pub(crate) fn group_sigma<T: Real>(
    s: &TileSplat<T>,
    xs: &[T; LANES],
    ys: &[T; LANES],
) -> Option<GroupSigma<T>> {
    let [a, b, c] = s.conic;
    let mut dx = [T::ZERO; LANES];
    let mut dy = [T::ZERO; LANES];
    let mut sigma = [T::ZERO; LANES];
    let mut in_range = 0_u32;
    for i in 0..LANES {
        dx[i] = s.mean.x - xs[i];
        dy[i] = s.mean.y - ys[i];
        sigma[i] = T::HALF * (a * dx[i] * dx[i] + c * dy[i] * dy[i]) + b * dx[i] * dy[i];
        in_range += u32::from(sigma[i] >= T::ZERO) & u32::from(sigma[i] <= s.cut);
    }
    (in_range > 0).then_some(GroupSigma { dx, dy, sigma })
}

/// One Gaussian evaluated at one pixel: the lane form of
/// [`splat_alpha_cut`](crate::raster_ref::splat_alpha_cut), with the same floats.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneHit<T> {
    /// `min(0.999, o'·G)`.
    pub(crate) alpha: T,
    /// `G = exp(−σ)`.
    pub(crate) g: T,
    /// 1 where `o'·G ≤ 0.999` (alpha not clamped), else 0.
    pub(crate) unclamped: T,
    /// 1 where the skip rules pass (`0 ≤ σ ≤ cutoff`, `α ≥ 1/255`), else 0.
    pub(crate) visible: T,
}

/// The second phase at one lane: `G`, `α` and the skip rules from `σ`; `FAST` selects
/// [`ExpMode::Fast`](crate::ExpMode). Every field is finite in every lane (the exponential
/// of a skipped lane too).
#[inline(always)]
pub(crate) fn eval_lane<T: Real, const FAST: bool>(s: &TileSplat<T>, sigma: T) -> LaneHit<T> {
    let (zero, one) = (T::ZERO, T::ONE);
    // The reference skips `σ < 0 || σ > cut`; a NaN σ passes that test there but then fails
    // `α ≥ 1/255`: skipped either way.
    let keep = select(sigma < zero, zero, select(sigma > s.cut, zero, one));
    let g = exp_neg::<T, FAST>(sigma, keep > zero);
    let v = s.opacity * g;
    let amax = T::from_f64(ALPHA_MAX);
    let clamped = v > amax;
    // `α ≥ 1/255` is false for NaN.
    let alpha = select(clamped, amax, v);
    LaneHit {
        alpha,
        g,
        unclamped: select(clamped, zero, one),
        visible: select(alpha >= T::from_f64(ALPHA_MIN), keep, zero),
    }
}

/// `Σ v[i]` over the 16 lanes of a group, in a fixed tree order.
#[inline]
pub(crate) fn lane_sum<T: Real>(v: &[T; LANES]) -> T {
    let h: [T; 8] = core::array::from_fn(|i| v[i] + v[i + 8]);
    let q: [T; 4] = core::array::from_fn(|i| h[i] + h[i + 4]);
    (q[0] + q[2]) + (q[1] + q[3])
}

/// `v` (a non-negative integer-valued `T` below [`SEGMENT`]) as an index.
#[inline]
pub(crate) fn to_index<T: Real>(v: T) -> usize {
    #[allow(
        clippy::cast_possible_truncation,
        reason = "v is a small non-negative integer carried as T"
    )]
    let i = v.to_f64() as usize;
    i
}

#[cfg(test)]
mod tests {
    use super::*;

    fn splat<T: Real>(opacity: f64) -> TileSplat<T> {
        TileSplat {
            mean: Vec2::zero(),
            conic: [T::ONE, T::ZERO, T::ONE],
            opacity: T::from_f64(opacity),
            cut: crate::raster_ref::sigma_cutoff(T::from_f64(opacity)),
            color: [T::ZERO; 3],
            depth: T::ONE,
            pixels: Rect::default(),
            radii: [0; 2],
        }
    }

    #[test]
    fn the_pixel_at_the_mean_is_kept_like_the_reference_keeps_it() {
        // σ = 0 exactly (a mean on a pixel centre): not skipped, α = o', unclamped.
        let hit = eval_lane::<f64, false>(&splat(0.5), 0.0);
        assert_eq!(
            [hit.alpha, hit.g, hit.unclamped, hit.visible].map(f64::to_bits),
            [0.5, 1.0, 1.0, 1.0].map(f64::to_bits)
        );
        let r = crate::raster_ref::splat_alpha_cut::<f64>(
            Vec2::zero(),
            [1.0, 0.0, 1.0],
            0.5,
            crate::raster_ref::sigma_cutoff(0.5),
            0.0,
            0.0,
        )
        .expect("the reference keeps it");
        assert_eq!(r.alpha.to_bits(), hit.alpha.to_bits());
    }

    #[test]
    fn a_skipped_lane_has_finite_fields_however_negative_its_sigma() {
        // σ far below zero (an indefinite conic far from its mean): exp(−σ) would overflow,
        // and a skipped lane's zero weight times an infinite G is NaN in the backward pass.
        fn finite_and_skipped<T: Real>(h: LaneHit<T>) -> bool {
            [h.alpha, h.g, h.unclamped, h.visible]
                .iter()
                .all(|v| v.is_finite())
                && h.visible == T::ZERO
        }
        let h32 = eval_lane::<f32, false>(&splat(0.5), -200.0);
        let h64 = eval_lane::<f64, false>(&splat(0.5), -1000.0);
        assert!(finite_and_skipped(h32), "f32: {h32:?}");
        assert!(finite_and_skipped(h64), "f64: {h64:?}");
    }
}
