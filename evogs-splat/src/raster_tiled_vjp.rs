//! The backward pass of the tiled rasterizer, [`TiledRasterizer::backward`], and the
//! per-view densification statistics [`DensifyStats`].
//!
//! The formulas are those of [`raster_ref_vjp`](crate::raster_ref_vjp) (`docs/splatting.md` §12);
//! the per-pixel terms are summed in another order (per group and lane, then per tile
//! entry, then per Gaussian).
//!
//! # Reverse traversal per tile
//!
//! ```text
//! per pixel (lane): T = T_final, S = 0, S_z = 0, and the pixel cotangents dC, dD, g_T
//!   (as the reference); last = the number of entries of the tile's list up to the last
//!   contributor (binary search of the forward's order position in the sorted list)
//! for the tile's entries j = max(last) − 1 … 0, back to front:
//!   for the 4×4 groups inside the Gaussian's pixel box that have a pixel with last > j:
//!     σ at the 16 pixels; if none has 0 ≤ σ ≤ cutoff, next group
//!     the same exp, α and skip rules as the forward (the same floats), and j < last:
//!       T ← T/(1 − α) (the reference's division); dα, the colour/depth terms and, unless
//!       α was clamped, the opacity, conic and 2D-mean terms, added into per-lane sums
//!   the lane sums (fixed tree order) are entry j's partial gradient
//! ```
//!
//! Per pixel these are the reference's expressions, except that `S/(1 − α)` and
//! `g_T·T_f/(1 − α)` are computed as products with `1/(1 − α)` (one division per lane
//! instead of five; ~1 ulp per term).
//!
//! # Deterministic reduction
//!
//! Every tile writes only its own slice of the per-entry buffer (entries are grouped by
//! tile), so tiles run in parallel without atomics. Then every Gaussian sums its entries in
//! tile order (the CSR index recorded by the binning) and **adds** the total into the
//! [`RasterInputGrad`]. The background gradient `Σ T_final dC` is summed per tile (its
//! pixels in order) and then over the tiles in tile order (the reference sums over all
//! pixels in order: the same terms, ~1 ulp apart). The result does not depend on the
//! schedule: [`Par::Rayon`] and [`Par::Seq`] give bitwise identical gradients.
//!
//! # Densification statistics
//!
//! Per Gaussian: the norm of its 2D-mean gradient for this view, `‖Σ_pixels ∂L/∂means2d‖`
//! in **pixel units**, and its screen radius `max(r_x, r_y)` in pixels (0 if culled).
//! 3DGS thresholds the gradient with respect to NDC coordinates `x_ndc = 2u/W − 1`, i.e. the
//! pixel gradient times `(W/2, H/2)`: `‖(g_x·W/2, g_y·H/2)‖` from the components in
//! `RasterInputGrad::means2d` (for a square image, the pixel norm times `W/2`).

use crate::binning::TileGrid;
use crate::fast_exp::ExpMode;
use crate::pool::for_each_item;
use crate::preprocess::{Preprocessed, RasterInputGrad};
use crate::raster_ref::{DEPTH_DENOM_MIN, RasterOutput};
use crate::raster_ref_vjp::PixelGrad;
use crate::raster_tiled::{ENTRY_GRAD_LEN, TiledRasterizer};
use crate::tile_lanes::{
    GROUPS, GROUPS_X, LANES, TileLanes, TileSplat, eval_lane, group_lane, group_sigma,
    lane_centres, lane_sum, select,
};
use alloc::vec::Vec;
use evogs_math::{Par, Real, Vec2};

/// Per-view densification statistics (see the module docs), indexed by Gaussian.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DensifyStats<T> {
    /// `‖∂L/∂means2d‖` of this view, pixel units (0 if culled or not hit).
    pub mean2d_grad_norm: Vec<T>,
    /// `max(r_x, r_y)` in pixels (0 if culled).
    pub radius: Vec<u32>,
}

impl<T: Real> DensifyStats<T> {
    /// Statistics from a view's 2D-mean gradients (`grad` holding this view only) and radii.
    ///
    /// # Panics
    /// If the lengths differ.
    #[must_use]
    pub fn from_grad(pre: &Preprocessed<T>, grad: &RasterInputGrad<T>) -> Self {
        assert_eq!(pre.radii.len(), grad.len(), "gradient length");
        Self {
            mean2d_grad_norm: grad.means2d.iter().map(|m| m.norm()).collect(),
            radius: pre.radii.iter().map(|r| r[0].max(r[1])).collect(),
        }
    }

    /// Resizes to `n` Gaussians and zeroes every entry.
    pub fn reset(&mut self, n: usize) {
        self.mean2d_grad_norm.clear();
        self.mean2d_grad_norm.resize(n, T::ZERO);
        self.radius.clear();
        self.radius.resize(n, 0);
    }
}

impl<T: Real> TiledRasterizer<T> {
    /// VJP of [`forward`](Self::forward): **adds** the gradients with respect to every
    /// Gaussian's 2D mean, conic, colour, effective opacity and depth into `grad` (like
    /// [`rasterize_ref_vjp`](crate::rasterize_ref_vjp)), writes the view's densification
    /// statistics into `stats` (resized), and returns the gradient with respect to the
    /// background.
    ///
    /// `out` must be the forward output for the same `pre`, `background` and exponential
    /// mode. The call depends on nothing but its arguments: the binning of the last forward
    /// is reused only if `pre` packs to exactly the same Gaussians (checked), else it is
    /// recomputed.
    ///
    /// # Panics
    /// If the cotangent or gradient lengths do not match the image and `pre`.
    ///
    /// ```
    /// use evogs_splat::{benchmark_scene, preprocess, DensifyStats, PixelGrad, RasterInputGrad, RenderOptions, TiledRasterizer};
    /// use evogs_math::Par;
    /// let (splats, cam) = benchmark_scene::<f64>(50, 16, 4);
    /// let opts = RenderOptions::default();
    /// let pre = preprocess(&splats, &cam, &opts);
    /// let mut rast = TiledRasterizer::new();
    /// let out = rast.forward(&pre, opts.background, Par::Seq);
    /// let d_rgb = vec![1.0; 16 * 16 * 3];
    /// let d = PixelGrad { rgb: &d_rgb, alpha: None, depth: None };
    /// let mut grad = RasterInputGrad::zeros(50);
    /// let mut stats = DensifyStats::default();
    /// let d_bg = rast.backward(&pre, opts.background, &out, &d, Par::Seq, &mut grad, &mut stats);
    /// assert!((d_bg[0] - out.final_t.iter().sum::<f64>()).abs() < 1e-12);
    /// assert!((stats.mean2d_grad_norm[0] - grad.means2d[0].norm()).abs() < 1e-15);
    /// ```
    pub fn backward(
        &mut self,
        pre: &Preprocessed<T>,
        background: [T; 3],
        out: &RasterOutput<T>,
        d: &PixelGrad<'_, T>,
        par: Par,
        grad: &mut RasterInputGrad<T>,
        stats: &mut DensifyStats<T>,
    ) -> [T; 3] {
        let (w, h) = (pre.width, pre.height);
        let np = w * h;
        d.assert_pixels(np);
        assert!(
            out.final_t.len() == np && out.last.len() == np,
            "forward output size"
        );
        assert_eq!(grad.len(), pre.means2d.len(), "gradient length");

        self.prepare_cached(pre, par);
        let grid = self.bins.grid();
        let n_entries = self.bins.n_entries();
        // Every tile writes all of its entries (no zeroing here).
        self.entry_grads
            .resize(n_entries, [T::ZERO; ENTRY_GRAD_LEN]);

        // One work item per tile: its slice of the per-entry buffer, and its part of the
        // background gradient.
        let mut items: Vec<TileItem<'_, T>> = Vec::with_capacity(grid.n_tiles());
        let mut rest = &mut self.entry_grads[..];
        let offsets = self.bins.tile_offsets();
        for t in 0..grid.n_tiles() {
            let len = (offsets[t + 1] - offsets[t]) as usize;
            let (mine, tail) = rest.split_at_mut(len);
            items.push(TileItem {
                grads: mine,
                d_bg: [T::ZERO; 3],
            });
            rest = tail;
        }
        let (bins, splats, exp) = (&self.bins, &self.splats[..], self.exp);
        for_each_item(par, &mut items, |tile, item| {
            let ctx = TileCtx {
                grid: &grid,
                tile,
                list: bins.tile_entries(tile),
                splats,
                out,
                d,
                background,
            };
            item.d_bg = match exp {
                ExpMode::Fast => backward_tile::<T, true>(&ctx, item.grads),
                ExpMode::Exact => backward_tile::<T, false>(&ctx, item.grads),
            };
        });
        // d bg = Σ T_final dC: per tile in pixel order, then over the tiles in tile order.
        let mut d_bg = [T::ZERO; 3];
        for item in &items {
            for ch in 0..3 {
                d_bg[ch] += item.d_bg[ch];
            }
        }
        drop(items);

        // Per-Gaussian reduction in tile order, in runs of Gaussians on the pool (each
        // Gaussian's sum is its own: the same bits on any thread count).
        stats.reset(pre.means2d.len());
        let mut runs: Vec<ReduceRun<'_, T>> = grad
            .means2d
            .chunks_mut(REDUCE_RUN)
            .zip(grad.conics.chunks_mut(REDUCE_RUN))
            .zip(grad.colors.chunks_mut(REDUCE_RUN))
            .zip(grad.opacities.chunks_mut(REDUCE_RUN))
            .zip(grad.depths.chunks_mut(REDUCE_RUN))
            .zip(stats.mean2d_grad_norm.chunks_mut(REDUCE_RUN))
            .zip(stats.radius.chunks_mut(REDUCE_RUN))
            .map(
                |((((((means2d, conics), colors), opacities), depths), norms), radius)| ReduceRun {
                    means2d,
                    conics,
                    colors,
                    opacities,
                    depths,
                    norms,
                    radius,
                },
            )
            .collect();
        let (rank, bins, entry_grads) = (&self.rank, &self.bins, &self.entry_grads);
        for_each_item(par, &mut runs, |r, run| {
            let first = r * REDUCE_RUN;
            for (j, &k) in rank[first..first + run.means2d.len()].iter().enumerate() {
                if k == u32::MAX {
                    continue;
                }
                let mut acc = [T::ZERO; ENTRY_GRAD_LEN];
                for &e in bins.splat_entries(k as usize) {
                    for (a, v) in acc.iter_mut().zip(&entry_grads[e as usize]) {
                        *a += *v;
                    }
                }
                let dm = Vec2::new(acc[0], acc[1]);
                run.means2d[j] += dm;
                for q in 0..3 {
                    run.conics[j][q] += acc[2 + q];
                    run.colors[j][q] += acc[5 + q];
                }
                run.opacities[j] += acc[8];
                run.depths[j] += acc[9];
                run.norms[j] = dm.norm();
                let radii = pre.radii[first + j];
                run.radius[j] = radii[0].max(radii[1]);
            }
        });
        drop(runs);
        d_bg
    }
}

/// One tile of the reverse traversal: its entries' partial gradients (written) and its part
/// of the background gradient.
struct TileItem<'a, T> {
    grads: &'a mut [[T; ENTRY_GRAD_LEN]],
    d_bg: [T; 3],
}

/// Gaussians per work item of the per-Gaussian reduction of the entry gradients.
const REDUCE_RUN: usize = 1024;

/// One run of Gaussians of the per-Gaussian reduction: its slices of the raster-input
/// gradient and of the densification statistics.
struct ReduceRun<'a, T> {
    means2d: &'a mut [Vec2<T>],
    conics: &'a mut [[T; 3]],
    colors: &'a mut [[T; 3]],
    opacities: &'a mut [T],
    depths: &'a mut [T],
    norms: &'a mut [T],
    radius: &'a mut [u32],
}

/// Everything a tile's backward reads.
struct TileCtx<'a, T> {
    grid: &'a TileGrid,
    tile: usize,
    list: &'a [u32],
    splats: &'a [TileSplat<T>],
    out: &'a RasterOutput<T>,
    d: &'a PixelGrad<'a, T>,
    background: [T; 3],
}

/// Per-pixel inputs and state of the reverse traversal of one tile, group-major (see
/// [`group_lane`](crate::tile_lanes::group_lane)).
struct TileBack<T> {
    /// Transmittance, recovered back to front.
    t: TileLanes<T>,
    /// Colour and depth accumulated behind the current Gaussian.
    s: [TileLanes<T>; 3],
    sz: TileLanes<T>,
    /// `g_T·T_final` (the reference's product).
    gtf: TileLanes<T>,
    dc: [TileLanes<T>; 3],
    dd: TileLanes<T>,
    /// Entries of the tile's list up to and including the last contributor.
    last: [[u32; LANES]; GROUPS],
    /// Pixel-centre coordinates of every lane.
    xs: TileLanes<T>,
    ys: TileLanes<T>,
}

/// Loads the pixel cotangents and traversal starts of a tile (the reference's expressions);
/// lanes outside the image get `last = 0` (never active) and zero cotangents. Returns the
/// tile's part of the background gradient, `Σ T_final dC` over its pixels in pixel order.
fn load_tile<T: Real>(c: &TileCtx<'_, T>, l: &mut TileBack<T>) -> [T; 3] {
    let px = c.grid.tile_pixels(c.tile);
    let mut d_bg = [T::ZERO; 3];
    lane_centres(px, &mut l.xs, &mut l.ys);
    let floor = T::from_f64(DEPTH_DENOM_MIN);
    let bg = c.background;
    for y in px.y0 as usize..px.y1 as usize {
        for x in px.x0 as usize..px.x1 as usize {
            let (g, i) = group_lane(x - px.x0 as usize, y - px.y0 as usize);
            let p = y * c.grid.width + x;
            let tf = c.out.final_t[p];
            let dc = [c.d.rgb[3 * p], c.d.rgb[3 * p + 1], c.d.rgb[3 * p + 2]];
            for ch in 0..3 {
                d_bg[ch] += tf * dc[ch];
            }
            let da = c.d.alpha.map_or(T::ZERO, |a| a[p]);
            let de = c.d.depth.map_or(T::ZERO, |a| a[p]);
            let one_minus_tf = T::ONE - tf;
            let denom = one_minus_tf.max(floor);
            let mut g_t = dc[0] * bg[0] + dc[1] * bg[1] + dc[2] * bg[2] - da;
            if one_minus_tf > floor {
                let depth_sum = c.out.depth[p] * denom;
                g_t += de * depth_sum / (denom * denom);
            }
            l.t[g][i] = tf;
            l.gtf[g][i] = g_t * tf;
            for ch in 0..3 {
                l.dc[ch][g][i] = dc[ch];
            }
            l.dd[g][i] = de / denom;
            let last = c.out.last[p];
            let local = c.list.partition_point(|&k| k < last);
            l.last[g][i] = u32::try_from(local).unwrap_or(u32::MAX);
        }
    }
    d_bg
}

/// The reverse traversal of one tile (see the module docs); writes every entry's partial
/// gradient into `grads` (the tile's slice of the per-entry buffer; entries behind every
/// pixel's last contributor, and entries that touch no pixel, get zero) and returns the tile's
/// part of the background gradient.
fn backward_tile<T: Real, const FAST: bool>(
    c: &TileCtx<'_, T>,
    grads: &mut [[T; ENTRY_GRAD_LEN]],
) -> [T; 3] {
    let px = c.grid.tile_pixels(c.tile);
    let zero = [[T::ZERO; LANES]; GROUPS];
    let mut l = TileBack {
        t: [[T::ONE; LANES]; GROUPS],
        s: [zero; 3],
        sz: zero,
        gtf: zero,
        dc: [zero; 3],
        dd: zero,
        last: [[0; LANES]; GROUPS],
        xs: zero,
        ys: zero,
    };
    let d_bg = load_tile(c, &mut l);
    let group_last: [u32; GROUPS] =
        core::array::from_fn(|g| l.last[g].iter().copied().max().unwrap_or(0));
    let j_end = group_last.iter().copied().max().unwrap_or(0);
    grads[j_end as usize..].fill([T::ZERO; ENTRY_GRAD_LEN]);
    for j in (0..j_end).rev() {
        let s = &c.splats[c.list[j as usize] as usize];
        let groups = s.groups_in(px);
        let mut acc: Option<[[T; LANES]; ENTRY_GRAD_LEN]> = None;
        for gy in groups.y0 as usize..groups.y1 as usize {
            for gx in groups.x0 as usize..groups.x1 as usize {
                let g = gy * GROUPS_X + gx;
                if group_last[g] > j {
                    let sums = acc.get_or_insert([[T::ZERO; LANES]; ENTRY_GRAD_LEN]);
                    backward_group::<T, FAST>(s, g, j, &mut l, sums);
                }
            }
        }
        grads[j as usize] = match acc {
            Some(acc) => core::array::from_fn(|q| lane_sum(&acc[q])),
            None => [T::ZERO; ENTRY_GRAD_LEN],
        };
    }
    d_bg
}

/// The reverse-traversal step of the Gaussian `s` at index `j` of the tile's list on the
/// 16 pixels of group `g`: adds the per-lane gradient terms into `acc`. Two vectorised lane
/// loops with exact 0/1 masks (see [`tile_lanes`](crate::tile_lanes)): an inactive lane
/// keeps its state and adds `0·x`.
#[inline(never)]
fn backward_group<T: Real, const FAST: bool>(
    s: &TileSplat<T>,
    g: usize,
    j: u32,
    l: &mut TileBack<T>,
    acc: &mut [[T; LANES]; ENTRY_GRAD_LEN],
) {
    let Some(gs) = group_sigma(s, &l.xs[g], &l.ys[g]) else {
        return;
    };
    let (zero, one) = (T::ZERO, T::ONE);
    let [a, b, cc] = s.conic;
    let z = s.depth;
    let [s0, s1, s2] = &mut l.s;
    let s_acc = [&mut s0[g], &mut s1[g], &mut s2[g]];
    let dc = [&l.dc[0][g], &l.dc[1][g], &l.dc[2][g]];
    let (t, sz, last) = (&mut l.t[g], &mut l.sz[g], &l.last[g]);
    let (gtf, dd) = (&l.gtf[g], &l.dd[g]);
    for i in 0..LANES {
        let (dx, dy) = (gs.dx[i], gs.dy[i]);
        let h = eval_lane::<T, FAST>(s, gs.sigma[i]);
        let act = select(j < last[i], h.visible, zero);
        let alpha = h.alpha;
        let om = one - alpha;
        // T_i = T_{i+1}/(1 − α_i), the reference's division; the other quotients use 1/(1 − α).
        let t_old = t[i];
        let ti = t_old / om;
        let r = one / om;
        let wgt = alpha * ti;
        let wa = wgt * act;
        let mut d_alpha = dd[i] * (z * ti - sz[i] * r) - gtf[i] * r;
        for ch in 0..3 {
            let s_old = s_acc[ch][i];
            d_alpha += dc[ch][i] * (s.color[ch] * ti - s_old * r);
            s_acc[ch][i] = s_old + s.color[ch] * wa;
            acc[5 + ch][i] += wa * dc[ch][i];
        }
        acc[9][i] += wa * dd[i];
        sz[i] += z * wa;
        // act = 1: T_i; act = 0: T (both products exact).
        t[i] = ti * act + t_old * (one - act);

        let geo = act * h.unclamped;
        let ds = -alpha * d_alpha * geo;
        acc[8][i] += h.g * d_alpha * geo;
        acc[2][i] += T::HALF * dx * dx * ds;
        acc[3][i] += dx * dy * ds;
        acc[4][i] += T::HALF * dy * dy * ds;
        acc[0][i] += ds * (a * dx + b * dy);
        acc[1][i] += ds * (b * dx + cc * dy);
    }
}

/// [`TiledRasterizer::backward`] with a temporary rasterizer (allocates its work memory).
///
/// # Panics
/// As [`TiledRasterizer::backward`].
pub fn rasterize_tiled_vjp<T: Real>(
    pre: &Preprocessed<T>,
    background: [T; 3],
    out: &RasterOutput<T>,
    d: &PixelGrad<'_, T>,
    par: Par,
    grad: &mut RasterInputGrad<T>,
    stats: &mut DensifyStats<T>,
) -> [T; 3] {
    TiledRasterizer::new().backward(pre, background, out, d, par, grad, stats)
}
