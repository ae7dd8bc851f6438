//! The fast **tiled** rasterizer, forward pass: [`TiledRasterizer::forward`] (the backward is
//! in [`raster_tiled_vjp`](crate::raster_tiled_vjp)).
//!
//! It composites with exactly the rules of [`raster_ref`](crate::raster_ref) (the same
//! expressions, evaluated in the same order per pixel), so it returns the same
//! [`RasterOutput`]: bitwise in `f64`, and in `f32` with [`ExpMode::Exact`]; with the default
//! [`ExpMode::Fast`] the `f32` exponential is a vectorised one that rounds like `expf` in all
//! but ~10⁻⁴ of the cases, by one ulp (see [`fast_exp`](crate::fast_exp)).
//!
//! # Algorithm
//!
//! ```text
//! 1. pack    the valid Gaussians in compositing order (Preprocessed::order): mean, conic,
//!            opacity, σ cutoff, colour, depth and the pixel box of its radii (chunks of
//!            Gaussians on the pool)
//! 2. bin     counting sort of the (tile, Gaussian) pairs by tile, stable, so every tile's
//!            list is in depth order (crate::binning; chunks of Gaussians, then rows of
//!            tiles, on the pool)
//! 3. tiles   independently (rayon over tiles with Par::Rayon, work stealing):
//!            for each Gaussian of the tile's list, front to back
//!              for each 4×4 group of the tile inside the Gaussian's pixel box, not finished
//!                16 lanes (one per pixel), no branch:
//!                  σ; if no lane has 0 ≤ σ ≤ cutoff, next group
//!                  exp(−σ), α, the skip rules, the stop rule and a masked update of
//!                  T, colour, depth, count and last contributor; a lane that stops is done
//!            until every pixel of the tile is done
//! 4. write   the per-tile states into the row-major output images
//! ```
//!
//! (See [`tile_lanes`](crate::tile_lanes) for the groups and the lane loops.)
//!
//! Lanes of a partial edge tile that fall outside the image start out done. Restricting a
//! Gaussian to its pixel box (and its tiles) changes no decision: outside it `α < 1/255`
//! (see [`binning`](crate::binning)). The per-pixel state is the reference's: `T`, the
//! colour and depth sums, the count, whether the pixel stopped, and `last`, one past the
//! **order position** of the last contributor (as the reference stores it; the backward
//! maps it back into the tile's list by a binary search, the list being sorted).
//!
//! All work memory lives in the [`TiledRasterizer`] and only grows; nothing is allocated per
//! tile, per Gaussian or per pixel.

use crate::binning::{Binning, Rect, TILE_SIZE, TileGrid};
pub use crate::fast_exp::ExpMode;
use crate::image::Image;
use crate::pool::{for_each_item, run_items};
use crate::preprocess::Preprocessed;
use crate::raster_ref::{DEPTH_DENOM_MIN, RasterOutput, T_STOP, sigma_cutoff};
use crate::tile_lanes::{
    GROUPS, GROUPS_X, LANES, SEGMENT, TileLanes, TileSplat, eval_lane, group_lane, group_sigma,
    lane_centres, mask, select, to_index,
};
use alloc::vec::Vec;
use evogs_math::{Par, Real, Vec2};

/// Order positions per work item of the packing.
const PACK_CHUNK: usize = 2048;

/// Scalars of one entry's partial gradient: 2D mean (2), conic (3), colour (3), opacity,
/// depth.
pub(crate) const ENTRY_GRAD_LEN: usize = 10;

/// Per-pixel compositing state of one tile, group-major (see
/// [`group_lane`](crate::tile_lanes::group_lane)).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct TileState<T> {
    t: TileLanes<T>,
    color: [TileLanes<T>; 3],
    depth: TileLanes<T>,
    n: [[u32; LANES]; GROUPS],
    /// One past the order position of the last contributor (0 if none).
    last: [[u32; LANES]; GROUPS],
    /// Position (1-based) in the current list segment of the last contributor, 0 if none.
    seg_last: TileLanes<T>,
    /// 1 while the pixel composites, 0 once it stopped (or if it lies outside the image).
    live: TileLanes<T>,
    /// Pixel-centre coordinates of every lane.
    xs: TileLanes<T>,
    ys: TileLanes<T>,
}

impl<T: Real> TileState<T> {
    pub(crate) fn new() -> Self {
        let zero = [[T::ZERO; LANES]; GROUPS];
        Self {
            t: zero,
            color: [zero; 3],
            depth: zero,
            n: [[0; LANES]; GROUPS],
            last: [[0; LANES]; GROUPS],
            seg_last: zero,
            live: zero,
            xs: zero,
            ys: zero,
        }
    }
}

/// The tiled rasterizer and its work memory (binning, packed Gaussians, tile states,
/// per-entry gradients), reused across calls: create one per thread of training and call
/// [`forward`](Self::forward) / [`backward`](Self::backward) every iteration.
///
/// Conventions: those of [`RasterOutput`] and [`rasterize_ref`](crate::rasterize_ref);
/// images are row-major, row 0 at the top; 16×16 tiles.
///
/// ```
/// use evogs_splat::{benchmark_scene, preprocess, rasterize_ref, RenderOptions, TiledRasterizer};
/// use evogs_math::Par;
/// let (splats, cam) = benchmark_scene::<f64>(200, 40, 3);
/// let opts = RenderOptions::default();
/// let pre = preprocess(&splats, &cam, &opts);
/// let mut rast = TiledRasterizer::new();
/// let out = rast.forward(&pre, opts.background, Par::Seq);
/// assert!(out == rasterize_ref(&pre, opts.background)); // bitwise, in f64
/// ```
#[derive(Clone, Debug, Default)]
pub struct TiledRasterizer<T> {
    pub(crate) exp: ExpMode,
    pub(crate) bins: Binning,
    pub(crate) splats: Vec<TileSplat<T>>,
    /// Order position of every Gaussian index (`u32::MAX` if culled).
    pub(crate) rank: Vec<u32>,
    /// Packing scratch of [`prepare_cached`](Self::prepare_cached).
    scratch: Vec<TileSplat<T>>,
    tiles: Vec<TileState<T>>,
    /// Per-entry partial gradients (backward).
    pub(crate) entry_grads: Vec<[T; ENTRY_GRAD_LEN]>,
}

impl<T: Real> TiledRasterizer<T> {
    /// An empty rasterizer with the default [`ExpMode::Fast`].
    #[must_use]
    pub fn new() -> Self {
        Self::with_exp(ExpMode::default())
    }

    /// An empty rasterizer with the given exponential.
    #[must_use]
    pub fn with_exp(exp: ExpMode) -> Self {
        Self {
            exp,
            bins: Binning::default(),
            splats: Vec::new(),
            rank: Vec::new(),
            scratch: Vec::new(),
            tiles: Vec::new(),
            entry_grads: Vec::new(),
        }
    }

    /// The exponential used by the lane loops.
    #[must_use]
    pub fn exp_mode(&self) -> ExpMode {
        self.exp
    }

    /// The binning of the last call (tile lists in compositing order).
    #[must_use]
    pub fn binning(&self) -> &Binning {
        &self.bins
    }

    /// Packs the valid Gaussians of `pre` in compositing order into `out` (resized), in
    /// chunks of [`PACK_CHUNK`] on the pool with `par`, and returns whether
    /// `check(first, chunk)` holds for every packed chunk (`first`: its first order position).
    fn pack(
        pre: &Preprocessed<T>,
        out: &mut Vec<TileSplat<T>>,
        par: Par,
        check: impl Fn(usize, &[TileSplat<T>]) -> bool + Sync + Send,
    ) -> bool {
        let grid = TileGrid::new(pre.width, pre.height);
        let blank = TileSplat {
            mean: Vec2::zero(),
            conic: [T::ZERO; 3],
            opacity: T::ZERO,
            cut: T::ZERO,
            color: [T::ZERO; 3],
            depth: T::ZERO,
            pixels: Rect::default(),
            radii: [0; 2],
        };
        out.resize(pre.order.len(), blank);
        let mut chunks: Vec<(usize, &mut [TileSplat<T>])> = out
            .chunks_mut(PACK_CHUNK)
            .enumerate()
            .map(|(c, chunk)| (c * PACK_CHUNK, chunk))
            .collect();
        let checks = run_items(par, &mut chunks, |(first, chunk)| {
            for (s, &g) in chunk.iter_mut().zip(&pre.order[*first..]) {
                let g = g as usize;
                *s = TileSplat {
                    mean: pre.means2d[g],
                    conic: pre.conics[g],
                    opacity: pre.opacities[g],
                    cut: sigma_cutoff(pre.opacities[g]),
                    color: pre.colors[g],
                    depth: pre.depths[g],
                    pixels: grid.pixel_rect(pre.means2d[g], pre.radii[g]),
                    radii: pre.radii[g],
                };
            }
            check(*first, chunk)
        });
        checks.into_iter().all(|ok| ok)
    }

    /// Packs and bins the valid Gaussians of `pre`.
    pub(crate) fn prepare(&mut self, pre: &Preprocessed<T>, par: Par) {
        Self::pack(pre, &mut self.splats, par, |_, _| true);
        self.rank.clear();
        self.rank.resize(pre.means2d.len(), u32::MAX);
        for (k, &g) in (0_u32..).zip(&pre.order) {
            self.rank[g as usize] = k;
        }
        self.bins.bin(pre, par);
    }

    /// [`prepare`](Self::prepare), skipping the binning when `pre` packs to exactly what the
    /// last call binned (same image size, order, means, radii, …: then the binning would be
    /// the same). The backward uses it after the forward of the same `pre`.
    pub(crate) fn prepare_cached(&mut self, pre: &Preprocessed<T>, par: Par) {
        let mut packed = core::mem::take(&mut self.scratch);
        let (old, rank) = (&self.splats, &self.rank);
        let shape = self.bins.grid() == TileGrid::new(pre.width, pre.height)
            && rank.len() == pre.means2d.len()
            && old.len() == pre.order.len();
        // Chunk by chunk: the same packing, and the same order (the ranks of the last call).
        let same = Self::pack(pre, &mut packed, par, |first, chunk| {
            let range = first..first + chunk.len();
            shape
                && chunk == &old[range.clone()]
                && pre.order[range]
                    .iter()
                    .zip(u32::try_from(first).unwrap_or(u32::MAX)..)
                    .all(|(&g, k)| rank.get(g as usize) == Some(&k))
        });
        if same {
            // Use the new packing (equal up to the sign of zeros).
            core::mem::swap(&mut self.splats, &mut packed);
            self.scratch = packed;
        } else {
            self.scratch = packed;
            self.prepare(pre, par);
        }
    }

    /// Renders `pre` over `background` (see the module docs); the result equals
    /// [`rasterize_ref`](crate::rasterize_ref)'s (bitwise in `f64`).
    #[must_use]
    pub fn forward(
        &mut self,
        pre: &Preprocessed<T>,
        background: [T; 3],
        par: Par,
    ) -> RasterOutput<T> {
        let mut out = RasterOutput::new(pre.width, pre.height, background);
        self.forward_into(pre, background, par, &mut out);
        out
    }

    /// [`forward`](Self::forward) into an existing output (resized if needed).
    pub fn forward_into(
        &mut self,
        pre: &Preprocessed<T>,
        background: [T; 3],
        par: Par,
        out: &mut RasterOutput<T>,
    ) {
        let (w, h) = (pre.width, pre.height);
        resize_output(out, w, h);
        self.prepare(pre, par);
        if w == 0 || h == 0 {
            return;
        }
        let grid = self.bins.grid();
        let n_tiles = grid.n_tiles();
        if self.tiles.len() < n_tiles {
            self.tiles.resize(n_tiles, TileState::new());
        }
        let (bins, splats, exp) = (&self.bins, &self.splats[..], self.exp);
        let kernel = match exp {
            ExpMode::Fast => forward_tile::<T, true>,
            ExpMode::Exact => forward_tile::<T, false>,
        };
        for_each_item(par, &mut self.tiles[..n_tiles], |tile, st| {
            kernel(st, tile, &grid, bins.tile_entries(tile), splats, SEGMENT);
        });

        // Write the tile states into the row-major images, one band of tile rows per item.
        let band = TILE_SIZE * w;
        let mut bands: Vec<OutBand<'_, T>> = out
            .rgb
            .data_mut()
            .chunks_mut(3 * band)
            .zip(out.alpha.chunks_mut(band))
            .zip(out.depth.chunks_mut(band))
            .zip(out.n_contrib.chunks_mut(band))
            .zip(out.final_t.chunks_mut(band))
            .zip(out.terminated.chunks_mut(band))
            .zip(out.last.chunks_mut(band))
            .map(
                |((((((rgb, alpha), depth), n_contrib), final_t), terminated), last)| OutBand {
                    rgb,
                    alpha,
                    depth,
                    n_contrib,
                    final_t,
                    terminated,
                    last,
                },
            )
            .collect();
        let tiles = &self.tiles[..n_tiles];
        for_each_item(par, &mut bands, |ty, b| {
            write_band(
                b,
                &tiles[ty * grid.tiles_x..(ty + 1) * grid.tiles_x],
                w,
                background,
            );
        });
    }
}

/// The output rows of one band of tiles.
struct OutBand<'a, T> {
    rgb: &'a mut [T],
    alpha: &'a mut [T],
    depth: &'a mut [T],
    n_contrib: &'a mut [u32],
    final_t: &'a mut [T],
    terminated: &'a mut [bool],
    last: &'a mut [u32],
}

/// Writes the pixels of the tiles `tiles` (one band) into their output rows: the reference's
/// output expressions.
fn write_band<T: Real>(b: &mut OutBand<'_, T>, tiles: &[TileState<T>], w: usize, bg: [T; 3]) {
    let floor = T::from_f64(DEPTH_DENOM_MIN);
    for p in 0..b.alpha.len() {
        let (row, col) = (p / w, p % w);
        let (g, i) = group_lane(col % TILE_SIZE, row);
        let st = &tiles[col / TILE_SIZE];
        let t = st.t[g][i];
        for ch in 0..3 {
            b.rgb[3 * p + ch] = st.color[ch][g][i] + t * bg[ch];
        }
        b.alpha[p] = T::ONE - t;
        b.depth[p] = st.depth[g][i] / (T::ONE - t).max(floor);
        b.n_contrib[p] = st.n[g][i];
        b.final_t[p] = t;
        // In-image pixels only leave `live` by the stop rule.
        b.terminated[p] = st.live[g][i] <= T::ZERO;
        b.last[p] = st.last[g][i];
    }
}

/// Makes `out` a `w × h` output (contents are overwritten by the caller).
fn resize_output<T: Real>(out: &mut RasterOutput<T>, w: usize, h: usize) {
    let n = w * h;
    if out.rgb.width() != w || out.rgb.height() != h {
        out.rgb = Image::new(w, h);
    }
    out.alpha.resize(n, T::ZERO);
    out.depth.resize(n, T::ZERO);
    out.n_contrib.resize(n, 0);
    out.final_t.resize(n, T::ONE);
    out.terminated.resize(n, false);
    out.last.resize(n, 0);
}

/// Composites one tile (see the module docs); `FAST` selects [`ExpMode::Fast`]. The list
/// is walked in segments of `segment` entries ([`SEGMENT`]; the tests take shorter ones to
/// cover the passage from one segment to the next without millions of Gaussians).
fn forward_tile<T: Real, const FAST: bool>(
    st: &mut TileState<T>,
    tile: usize,
    grid: &TileGrid,
    list: &[u32],
    splats: &[TileSplat<T>],
    segment: usize,
) {
    let px = grid.tile_pixels(tile);
    let (w_in, h_in) = ((px.x1 - px.x0) as usize, (px.y1 - px.y0) as usize);
    let zero = [[T::ZERO; LANES]; GROUPS];
    st.t = [[T::ONE; LANES]; GROUPS];
    st.color = [zero; 3];
    st.depth = zero;
    st.n = [[0; LANES]; GROUPS];
    st.last = [[0; LANES]; GROUPS];
    st.seg_last = zero;
    let mut group_active = [0_u32; GROUPS];
    for ly in 0..TILE_SIZE {
        for lx in 0..TILE_SIZE {
            let (g, i) = group_lane(lx, ly);
            let inside = lx < w_in && ly < h_in;
            st.live[g][i] = mask(inside);
            group_active[g] += u32::from(inside);
        }
    }
    let mut remaining = w_in * h_in;
    lane_centres(px, &mut st.xs, &mut st.ys);

    for (seg_index, seg) in list.chunks(segment).enumerate() {
        let mut pos = T::ZERO;
        for &k in seg {
            pos += T::ONE;
            if remaining == 0 {
                break;
            }
            let s = &splats[k as usize];
            let groups = s.groups_in(px);
            for gy in groups.y0 as usize..groups.y1 as usize {
                for gx in groups.x0 as usize..groups.x1 as usize {
                    let g = gy * GROUPS_X + gx;
                    if group_active[g] > 0 {
                        let stops = forward_group::<T, FAST>(st, g, s, pos);
                        group_active[g] -= stops;
                        remaining -= stops as usize;
                    }
                }
            }
        }
        // Segment positions → order positions.
        for g in 0..GROUPS {
            for i in 0..LANES {
                if st.seg_last[g][i] > T::ZERO {
                    let j = seg_index * segment + to_index(st.seg_last[g][i]) - 1;
                    st.last[g][i] = list[j] + 1;
                    st.seg_last[g][i] = T::ZERO;
                }
            }
        }
        if remaining == 0 {
            break;
        }
    }
}

/// Composites one Gaussian (at 1-based position `pos` of the current list segment) on the
/// 16 pixels of group `g`; returns how many of them stopped. Two vectorised lane loops with
/// exact 0/1 masks (see [`tile_lanes`](crate::tile_lanes)).
#[inline(never)]
fn forward_group<T: Real, const FAST: bool>(
    st: &mut TileState<T>,
    g: usize,
    s: &TileSplat<T>,
    pos: T,
) -> u32 {
    let Some(gs) = group_sigma(s, &st.xs[g], &st.ys[g]) else {
        return 0;
    };
    let (zero, one) = (T::ZERO, T::ONE);
    let t_stop = T::from_f64(T_STOP);
    let [c0, c1, c2] = &mut st.color;
    let (c0, c1, c2) = (&mut c0[g], &mut c1[g], &mut c2[g]);
    let (t, depth, n) = (&mut st.t[g], &mut st.depth[g], &mut st.n[g]);
    let (seg_last, live) = (&mut st.seg_last[g], &mut st.live[g]);
    let mut stops = 0;
    for i in 0..LANES {
        let h = eval_lane::<T, FAST>(s, gs.sigma[i]);
        let visible = h.visible * live[i];
        let t_old = t[i];
        let next_t = t_old * (one - h.alpha);
        let stop = select(next_t <= t_stop, visible, zero);
        let add = visible - stop;
        // add = 1: C + c·(α·T), D + z·(α·T), T·(1 − α), the reference's floats;
        // add = 0: C + c·0 = C, T·(1 − 0) = T.
        let wgt = h.alpha * t_old * add;
        c0[i] += s.color[0] * wgt;
        c1[i] += s.color[1] * wgt;
        c2[i] += s.color[2] * wgt;
        depth[i] += s.depth * wgt;
        t[i] = t_old * (one - h.alpha * add);
        n[i] += u32::from(add > zero);
        seg_last[i] += (pos - seg_last[i]) * add;
        live[i] -= stop;
        stops += u32::from(stop > zero);
    }
    stops
}

/// [`TiledRasterizer::forward`] with a temporary rasterizer (allocates its work memory).
///
/// ```
/// use evogs_splat::{benchmark_scene, preprocess, rasterize_tiled, RenderOptions};
/// use evogs_math::Par;
/// let (splats, cam) = benchmark_scene::<f32>(100, 20, 1);
/// let opts = RenderOptions::default();
/// let out = rasterize_tiled(&preprocess(&splats, &cam, &opts), opts.background, Par::Seq);
/// assert_eq!(out.alpha.len(), 400);
/// ```
#[must_use]
pub fn rasterize_tiled<T: Real>(
    pre: &Preprocessed<T>,
    background: [T; 3],
    par: Par,
) -> RasterOutput<T> {
    TiledRasterizer::new().forward(pre, background, par)
}

/// The number of lanes of a tile that lie in the image, for the tests of edge tiles.
#[cfg(test)]
fn lanes_in_image(grid: &TileGrid, tile: usize) -> usize {
    grid.tile_pixels(tile).area()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edge_tiles_are_partial() {
        let grid = TileGrid::new(20, 17);
        assert_eq!(grid.n_tiles(), 4, "2×2 tiles");
        assert_eq!(lanes_in_image(&grid, 0), 256, "full tile");
        assert_eq!(lanes_in_image(&grid, 1), 4 * 16, "right edge");
        assert_eq!(lanes_in_image(&grid, 2), 16, "bottom edge");
        assert_eq!(lanes_in_image(&grid, 3), 4, "corner");
    }

    #[test]
    fn short_segments_composite_like_one() {
        // Each tile's state, walked in segments of 1 to 7 entries, is bitwise the state of
        // one segment: the passage between segments keeps T, the sums, the counts, the stops
        // and the last contributors. Scenes where most pixels stop and where few do.
        for (n, size, seed) in [(400, 40, 3), (150, 37, 8), (60, 21, 5)] {
            let (splats, cam) = crate::benchmark_scene::<f64>(n, size, seed);
            let pre = crate::preprocess(&splats, &cam, &crate::RenderOptions::default());
            let mut rast = TiledRasterizer::<f64>::new();
            rast.prepare(&pre, Par::Seq);
            let grid = rast.bins.grid();
            let mut longest = 0;
            for tile in 0..grid.n_tiles() {
                let list = rast.bins.tile_entries(tile);
                longest = longest.max(list.len());
                let run = |segment| {
                    let mut st = TileState::new();
                    forward_tile::<f64, true>(&mut st, tile, &grid, list, &rast.splats, segment);
                    st
                };
                let whole = run(SEGMENT);
                for segment in [1, 2, 3, 7] {
                    assert!(run(segment) == whole, "tile {tile}: segments of {segment}");
                }
            }
            assert!(longest > 20, "{longest} entries in the longest list");
        }
    }
}
