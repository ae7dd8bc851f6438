//! Tile binning for the tiled rasterizer: which Gaussians touch which 16×16 tile, in
//! compositing order ([`Binning`]).
//!
//! # Tile range (`docs/splatting.md` §9, gsplat `isect_tiles`)
//!
//! ```text
//! tiles_x = ceil(W/16),  tiles_y = ceil(H/16)
//! Gaussian with 2D mean (u, v) and per-axis radii (r_x, r_y):
//!   tile columns [floor((u − r_x)/16), ceil((u + r_x)/16))  clamped to [0, tiles_x]
//!   tile rows    [floor((v − r_y)/16), ceil((v + r_y)/16))  clamped to [0, tiles_y]
//! ```
//!
//! **Exactness.** The radii bound the screen box outside which `α < 1/255` (opacity-aware:
//! `r = ceil(e·sqrt(Σ'ₓₓ))` with `e = sqrt(2 ln(255 o'))` is the x-extent of the ellipse
//! `σ = ln(255 o')`, where `o'·exp(−σ) = 1/255`; plain: `e = 3.33 ≥ sqrt(2 ln 255)`), so a pixel
//! whose centre `c + ½` has `|u − (c + ½)| > r_x` is skipped by the reference rule anyway. Every
//! pixel centre with `u − r_x ≤ c + ½ ≤ u + r_x` lies in a binned tile, partial edge tiles
//! included: `c ≥ u − r_x − ½` and `(u − r_x, u − r_x + ½]` holds no integer, so
//! `floor(c/16) ≥ floor((u − r_x)/16)`; and `c < u + r_x` gives
//! `floor(c/16) < ceil((u + r_x)/16)`. The only slack is the floating-point rounding of the
//! radius itself (a pixel within a few ulps of the ellipse's tangent exactly at an integer
//! radius), which the plain 3.33σ radii do not have at all.
//!
//! # Sorting (counting sort, stable)
//!
//! The Gaussians are visited in `Preprocessed::order` (depth, ties by index) and every
//! (tile, Gaussian) pair is an **entry**: count the entries per tile, take the exclusive
//! prefix sum, scatter. The scatter visits the Gaussians front to back, so each tile's list
//! stays in depth order (a stable sort by tile then depth), in O(N + I) for I entries.
//! During the scatter each Gaussian also records the positions of its own entries, in tile
//! order (a CSR array), so the backward reduction per Gaussian needs no search.
//!
//! On the pool the sort runs in chunks of consecutive Gaussians: each chunk counts its
//! entries per tile and sorts them by tile on its own; a short serial pass over (tile,
//! chunk) gives every chunk its first slot in every tile's list; then each tile's list is
//! chunk 0's part, chunk 1's, … ([`Binning::bin`]). Within a tile that is the order of the
//! Gaussians again, so the lists are the ones of the plain sort, whatever the split.
//!
//! All buffers are reused between calls; they only grow.

use crate::pool::for_each_item;
use crate::preprocess::Preprocessed;
use alloc::vec::Vec;
use evogs_math::{Par, Real, Vec2};

/// Tile side in pixels.
pub const TILE_SIZE: usize = 16;
/// The tiles of a `width × height` image (the last column and row of tiles may be partial).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TileGrid {
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
    /// `ceil(width/16)`.
    pub tiles_x: usize,
    /// `ceil(height/16)`.
    pub tiles_y: usize,
}

/// A half-open rectangle `[x0, x1) × [y0, y1)` of tiles (or pixels).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Rect {
    /// First column.
    pub x0: u32,
    /// One past the last column.
    pub x1: u32,
    /// First row.
    pub y0: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Rect {
    /// Number of cells (0 if empty).
    #[must_use]
    pub fn area(&self) -> usize {
        (self.x1.saturating_sub(self.x0) as usize) * (self.y1.saturating_sub(self.y0) as usize)
    }

    /// `true` if `(x, y)` lies inside.
    #[must_use]
    pub fn contains(&self, x: usize, y: usize) -> bool {
        (self.x0 as usize..self.x1 as usize).contains(&x)
            && (self.y0 as usize..self.y1 as usize).contains(&y)
    }
}

/// `v` clamped to `[0, hi]` as an index (0 for NaN).
fn clamp_index(v: f64, hi: usize) -> u32 {
    let hi = u32::try_from(hi).unwrap_or(u32::MAX);
    if v >= f64::from(hi) {
        hi
    } else if v > 0.0 {
        #[allow(
            clippy::cast_possible_truncation,
            reason = "v is an integer-valued float in [0, hi)"
        )]
        let i = v as u32;
        i
    } else {
        0
    }
}

impl TileGrid {
    /// The grid of a `width × height` image.
    #[must_use]
    pub const fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            tiles_x: width.div_ceil(TILE_SIZE),
            tiles_y: height.div_ceil(TILE_SIZE),
        }
    }

    /// Number of tiles.
    #[must_use]
    pub const fn n_tiles(&self) -> usize {
        self.tiles_x * self.tiles_y
    }

    /// The tiles a Gaussian is binned into (see the module docs), clamped to the grid.
    #[must_use]
    pub fn tile_rect<T: Real>(&self, mean: Vec2<T>, radii: [u32; 2]) -> Rect {
        let (u, v) = (mean.x.to_f64(), mean.y.to_f64());
        let (rx, ry) = (f64::from(radii[0]), f64::from(radii[1]));
        let t = TILE_SIZE as f64;
        Rect {
            x0: clamp_index(Real::floor((u - rx) / t), self.tiles_x),
            x1: clamp_index(Real::ceil((u + rx) / t), self.tiles_x),
            y0: clamp_index(Real::floor((v - ry) / t), self.tiles_y),
            y1: clamp_index(Real::ceil((v + ry) / t), self.tiles_y),
        }
    }

    /// The pixels whose centres lie in the Gaussian's screen box
    /// `[u − r_x, u + r_x] × [v − r_y, v + r_y]`, clamped to the image.
    #[must_use]
    pub fn pixel_rect<T: Real>(&self, mean: Vec2<T>, radii: [u32; 2]) -> Rect {
        let (u, v) = (mean.x.to_f64(), mean.y.to_f64());
        let (rx, ry) = (f64::from(radii[0]), f64::from(radii[1]));
        // Centre c + ½ ≥ u − r ⇔ c ≥ ceil(u − r − ½); c + ½ ≤ u + r ⇔ c < floor(u + r − ½) + 1.
        Rect {
            x0: clamp_index(Real::ceil(u - rx - 0.5), self.width),
            x1: clamp_index(Real::floor(u + rx - 0.5) + 1.0, self.width),
            y0: clamp_index(Real::ceil(v - ry - 0.5), self.height),
            y1: clamp_index(Real::floor(v + ry - 0.5) + 1.0, self.height),
        }
    }

    /// The pixel rectangle of tile `tile` (row-major tile index), clipped to the image.
    #[must_use]
    pub fn tile_pixels(&self, tile: usize) -> Rect {
        let (tx, ty) = (tile % self.tiles_x.max(1), tile / self.tiles_x.max(1));
        let to = |v: usize| u32::try_from(v).unwrap_or(u32::MAX);
        Rect {
            x0: to(tx * TILE_SIZE),
            x1: to(((tx + 1) * TILE_SIZE).min(self.width)),
            y0: to(ty * TILE_SIZE),
            y1: to(((ty + 1) * TILE_SIZE).min(self.height)),
        }
    }
}

/// The (tile, Gaussian) entries of one view, sorted by tile then depth, with the per-Gaussian
/// index of its own entries (see the module docs).
///
/// Gaussians are identified by their **position** `k` in `Preprocessed::order` (the
/// Gaussian index is `order[k]`).
///
/// ```
/// use evogs_math::Par;
/// use evogs_splat::{benchmark_scene, preprocess, Binning, RenderOptions};
/// let (splats, cam) = benchmark_scene::<f32>(300, 40, 1);
/// let pre = preprocess(&splats, &cam, &RenderOptions::default());
/// let mut bins = Binning::default();
/// bins.bin(&pre, Par::best());
/// assert_eq!(bins.grid().n_tiles(), 9);
/// for t in 0..9 {
///     // Each tile's list is in compositing order.
///     assert!(bins.tile_entries(t).windows(2).all(|w| w[0] < w[1]));
/// }
/// ```
#[derive(Clone, Debug, Default)]
pub struct Binning {
    grid: TileGrid,
    /// Tile rectangle per order position.
    rects: Vec<Rect>,
    /// `tile_offsets[t]..tile_offsets[t + 1]`: the entries of tile `t`.
    tile_offsets: Vec<u32>,
    /// Order position of every entry.
    entries: Vec<u32>,
    /// `splat_offsets[k]..splat_offsets[k + 1]`: the entries of order position `k`.
    splat_offsets: Vec<u32>,
    /// Entry indices of every Gaussian, in tile order.
    splat_entries: Vec<u32>,
    /// Scratch of the parallel sort, per chunk of order positions and tile (`n_tiles`
    /// values per chunk): the chunk's entries in the tile ...
    counts: Vec<u32>,
    /// ... the cursor into the chunk's own tile-sorted list (`by_chunk`) ...
    local: Vec<u32>,
    /// ... and the cursor into the final list (`entries`).
    global: Vec<u32>,
    /// Each chunk's entries sorted by tile, chunk after chunk.
    by_chunk: Vec<u32>,
}

/// One chunk of consecutive order positions in the parallel binning: its slices of the
/// per-Gaussian arrays and of the per-(chunk, tile) scratch.
struct BinChunk<'a> {
    /// First order position.
    first: usize,
    /// First entry of the chunk's Gaussians (in `splat_entries` and `by_chunk`).
    base: usize,
    rects: &'a mut [Rect],
    /// `splat_offsets[first + 1..]` of the chunk: running entry totals.
    ends: &'a mut [u32],
    counts: &'a mut [u32],
    local: &'a mut [u32],
    global: &'a mut [u32],
    splat_entries: &'a mut [u32],
    by_chunk: &'a mut [u32],
}

/// Whether [`Binning::chunk_items`] hands each chunk its part of the entry arrays: not
/// before the chunks have counted their entries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Entries {
    NotYet,
    Counted,
}

impl Binning {
    /// Bins the valid Gaussians of `pre` (in `pre.order`) into the tiles of its image; with
    /// `par`, in chunks of Gaussians and bands of tiles on the pool. The result is the one
    /// stable counting sort, whatever the chunks and the threads:
    ///
    /// ```text
    /// per chunk of order positions (in parallel):   tile rectangles, entries per tile
    /// serial, per tile and chunk (n_tiles × chunks): tile offsets, each chunk's first slot
    ///                                                 in each tile's list
    /// per chunk (in parallel):  its entries sorted by tile (a local counting sort), and each
    ///                           Gaussian's entry indices in the final list
    /// per tile row (in parallel): each tile's list = its part of chunk 0, of chunk 1, …
    /// ```
    ///
    /// # Panics
    /// If there are `u32::MAX` entries or more.
    pub fn bin<T: Real>(&mut self, pre: &Preprocessed<T>, par: Par) {
        // The chunks only split the work: every split gives the same lists, so their number
        // follows the pool (one chunk, the plain counting sort, on one thread).
        let n = pre.order.len();
        let chunk = match threads(par) {
            1 => n.max(1),
            th => n.div_ceil(2 * th).max(MIN_CHUNK),
        };
        self.bin_in_chunks(pre, par, chunk);
    }

    /// [`bin`](Self::bin) in chunks of `chunk` order positions.
    fn bin_in_chunks<T: Real>(&mut self, pre: &Preprocessed<T>, par: Par, chunk: usize) {
        let grid = TileGrid::new(pre.width, pre.height);
        self.grid = grid;
        let n_tiles = grid.n_tiles();
        // Scratch values per chunk (one even without tiles, so that every chunk has a slice).
        let stride = n_tiles.max(1);
        let n = pre.order.len();
        let chunk = chunk.max(1);
        let n_chunks = n.div_ceil(chunk);
        self.rects.resize(n, Rect::default());
        self.splat_offsets.resize(n + 1, 0);
        self.splat_offsets[0] = 0;
        for v in [&mut self.counts, &mut self.local, &mut self.global] {
            v.clear();
            v.resize(n_chunks * stride, 0);
        }

        // 1. Rectangles, the chunk's entries per tile and its running totals.
        let mut chunks = self.chunk_items(chunk, stride, Entries::NotYet);
        for_each_item(par, &mut chunks, |_, c| {
            let order = &pre.order[c.first..c.first + c.rects.len()];
            let mut total = 0_usize;
            for ((r, end), &g) in c.rects.iter_mut().zip(c.ends.iter_mut()).zip(order) {
                let g = g as usize;
                *r = grid.tile_rect(pre.means2d[g], pre.radii[g]);
                for ty in r.y0..r.y1 {
                    for tx in r.x0..r.x1 {
                        c.counts[ty as usize * grid.tiles_x + tx as usize] += 1;
                    }
                }
                total += r.area();
                *end = u32::try_from(total).expect("too many tile entries");
            }
        });
        drop(chunks);

        // 2. Serial, over tiles and chunks: the tile offsets, and where each chunk's entries
        //    start in each tile's list (global) and in its own tile-sorted list (local).
        self.tile_offsets.clear();
        self.tile_offsets.resize(n_tiles + 1, 0);
        let mut total = 0_usize;
        for t in 0..n_tiles {
            let tile_start = total;
            for c in 0..n_chunks {
                let i = c * stride + t;
                self.global[i] = u32::try_from(total).expect("too many tile entries");
                total += self.counts[i] as usize;
            }
            self.tile_offsets[t] = u32::try_from(tile_start).expect("too many tile entries");
        }
        self.tile_offsets[n_tiles] = u32::try_from(total).expect("too many tile entries");
        for c in 0..n_chunks {
            let mut run = 0;
            for t in 0..n_tiles {
                let i = c * stride + t;
                self.local[i] = run;
                run += self.counts[i];
            }
        }
        self.entries.resize(total, 0);
        self.splat_entries.resize(total, 0);
        self.by_chunk.resize(total, 0);

        // 3. Per chunk: the entries sorted by tile, and every Gaussian's entry indices.
        let mut chunks = self.chunk_items(chunk, stride, Entries::Counted);
        for_each_item(par, &mut chunks, |_, c| {
            let base = u32::try_from(c.base).expect("too many tile entries");
            let mut e = 0;
            for (j, (r, end)) in c.rects.iter().zip(c.ends.iter_mut()).enumerate() {
                let k = u32::try_from(c.first + j).expect("too many Gaussians");
                for ty in r.y0..r.y1 {
                    for tx in r.x0..r.x1 {
                        let t = ty as usize * grid.tiles_x + tx as usize;
                        c.by_chunk[c.local[t] as usize] = k;
                        c.local[t] += 1;
                        c.splat_entries[e] = c.global[t];
                        c.global[t] += 1;
                        e += 1;
                    }
                }
                *end += base;
            }
        });
        drop(chunks);

        // 4. Per tile row: each tile's list, chunk by chunk (one chunk: already in place).
        if n_chunks <= 1 {
            core::mem::swap(&mut self.entries, &mut self.by_chunk);
            return;
        }
        let row = grid.tiles_x;
        let mut rows: Vec<&mut [u32]> = Vec::with_capacity(grid.tiles_y);
        let mut tail = &mut self.entries[..];
        for ty in 0..grid.tiles_y {
            let range =
                self.tile_offsets[ty * row] as usize..self.tile_offsets[(ty + 1) * row] as usize;
            let (mine, rest) = tail.split_at_mut(range.len());
            rows.push(mine);
            tail = rest;
        }
        let (counts, local, by_chunk) = (&self.counts, &self.local, &self.by_chunk);
        let chunk_base = |c: usize| self.splat_offsets[c * chunk] as usize;
        for_each_item(par, &mut rows, |ty, out| {
            let mut at = 0;
            for t in ty * row..(ty + 1) * row {
                for c in 0..n_chunks {
                    let i = c * stride + t;
                    let (count, end) = (counts[i] as usize, local[i] as usize);
                    let from = chunk_base(c) + end - count;
                    out[at..at + count].copy_from_slice(&by_chunk[from..from + count]);
                    at += count;
                }
            }
        });
    }

    /// The chunks of `chunk` order positions (the last one shorter) over the per-Gaussian
    /// arrays and the per-(chunk, tile) scratch (`stride` values per chunk); once the
    /// chunks' entries are counted, also their slices of `splat_entries` and `by_chunk`.
    fn chunk_items(&mut self, chunk: usize, stride: usize, entries: Entries) -> Vec<BinChunk<'_>> {
        let Self {
            rects,
            splat_offsets,
            counts,
            local,
            global,
            splat_entries,
            by_chunk,
            ..
        } = self;
        let mut items: Vec<BinChunk<'_>> = rects
            .chunks_mut(chunk)
            .zip(splat_offsets[1..].chunks_mut(chunk))
            .zip(counts.chunks_mut(stride))
            .zip(local.chunks_mut(stride))
            .zip(global.chunks_mut(stride))
            .enumerate()
            .map(|(c, ((((rects, ends), counts), local), global))| BinChunk {
                first: c * chunk,
                base: 0,
                rects,
                ends,
                counts,
                local,
                global,
                splat_entries: &mut [],
                by_chunk: &mut [],
            })
            .collect();
        if entries == Entries::Counted {
            // Each chunk's entries follow the previous chunk's, `ends` running totals of
            // its own.
            let (mut tail_entries, mut tail_by_chunk) = (&mut splat_entries[..], &mut by_chunk[..]);
            let mut base = 0;
            for c in &mut items {
                let len = c.ends.last().map_or(0, |&e| e as usize);
                let (mine, rest) = tail_entries.split_at_mut(len);
                (c.splat_entries, tail_entries) = (mine, rest);
                let (mine, rest) = tail_by_chunk.split_at_mut(len);
                (c.by_chunk, tail_by_chunk) = (mine, rest);
                c.base = base;
                base += len;
            }
        }
        items
    }

    /// The tile grid of the last binned image.
    #[must_use]
    pub fn grid(&self) -> TileGrid {
        self.grid
    }

    /// Total number of (tile, Gaussian) entries.
    #[must_use]
    pub fn n_entries(&self) -> usize {
        self.entries.len()
    }

    /// The entries (order positions, ascending) of tile `t`.
    #[must_use]
    pub fn tile_entries(&self, t: usize) -> &[u32] {
        &self.entries[self.tile_range(t)]
    }

    /// The index range of tile `t`'s entries.
    #[must_use]
    pub fn tile_range(&self, t: usize) -> core::ops::Range<usize> {
        self.tile_offsets[t] as usize..self.tile_offsets[t + 1] as usize
    }

    /// The entry indices of order position `k`, in tile order.
    #[must_use]
    pub fn splat_entries(&self, k: usize) -> &[u32] {
        &self.splat_entries[self.splat_offsets[k] as usize..self.splat_offsets[k + 1] as usize]
    }

    /// The tile rectangle of order position `k`.
    #[must_use]
    pub fn rect(&self, k: usize) -> Rect {
        self.rects[k]
    }

    /// The per-tile entry offsets (`n_tiles + 1` values).
    pub(crate) fn tile_offsets(&self) -> &[u32] {
        &self.tile_offsets
    }
}

/// Order positions per chunk of the parallel binning, at least.
const MIN_CHUNK: usize = 1024;

/// The threads that `par` runs on.
fn threads(par: Par) -> usize {
    #[cfg(feature = "rayon")]
    if matches!(par, Par::Rayon) {
        return rayon::current_num_threads();
    }
    let _ = par;
    1
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rect_contains_exactly_its_half_open_cells() {
        let r = Rect {
            x0: 2,
            x1: 4,
            y0: 5,
            y1: 6,
        };
        let inside: Vec<(usize, usize)> = (0..8)
            .flat_map(|y| (0..8).map(move |x| (x, y)))
            .filter(|&(x, y)| r.contains(x, y))
            .collect();
        assert_eq!(inside, [(2, 5), (3, 5)]);
        assert_eq!(inside.len(), r.area());
    }

    #[test]
    fn every_split_into_chunks_bins_like_one_chunk() {
        // The parallel counting sort (chunks of order positions, then tile rows) against the
        // plain one (one chunk, sequential): the same lists, offsets and entry indices, for
        // chunks of one Gaussian up to all of them, sequential and on the pool, on images
        // with partial edge tiles, one tile, and no pixels.
        let opts = crate::RenderOptions::default();
        for (n, size, seed) in [
            (3000, 70, 1),
            (500, 37, 2),
            (40, 16, 3),
            (300, 9, 4),
            (20, 0, 5),
        ] {
            let (splats, cam) = crate::benchmark_scene::<f32>(n, size.max(1), seed);
            let mut pre = crate::preprocess(&splats, &cam, &opts);
            if size == 0 {
                pre.width = 0;
            }
            let mut plain = Binning::default();
            plain.bin_in_chunks(&pre, Par::Seq, usize::MAX);
            let fields = |b: &Binning| {
                (
                    b.grid,
                    b.rects.clone(),
                    b.tile_offsets.clone(),
                    b.entries.clone(),
                    b.splat_offsets.clone(),
                    b.splat_entries.clone(),
                )
            };
            let want = fields(&plain);
            // Gaussians over several tiles where there are several.
            assert!(
                size <= 16 || plain.n_entries() > pre.order.len(),
                "{n}: few entries"
            );
            // One binning reused across the splits, as a rasterizer reuses its own.
            let mut bins = Binning::default();
            for chunk in [1, 7, 64, 999, n / 2 + 1, n] {
                for par in [Par::Seq, Par::best()] {
                    bins.bin_in_chunks(&pre, par, chunk);
                    assert!(
                        fields(&bins) == want,
                        "{n} Gaussians, chunks of {chunk}, {par:?}"
                    );
                }
            }
            bins.bin(&pre, Par::best());
            assert!(fields(&bins) == want, "{n} Gaussians, bin");
        }
    }

    #[test]
    fn every_pixel_centre_in_the_screen_box_lies_in_a_binned_tile() {
        // The exactness claim of the module docs, on both axes: for means on a quarter-pixel
        // grid around and across tile edges and integer radii, each pixel whose centre
        // c + 1/2 is within r of the mean is in one of the Gaussian's tiles.
        let grid = TileGrid::new(64, 48);
        for ui in -80..300 {
            let u = f64::from(ui) * 0.25;
            for r in [0_u32, 1, 2, 3, 7, 16, 17] {
                let rect = grid.tile_rect(Vec2::new(u, u * 0.75), [r, r]);
                let box_holds = |c: usize, centre: f64| {
                    let c = f64::from(u32::try_from(c).expect("pixel")) + 0.5;
                    (centre - f64::from(r)..=centre + f64::from(r)).contains(&c)
                };
                for c in (0..64).filter(|&c| box_holds(c, u)) {
                    assert!(
                        rect.x0 as usize <= c / TILE_SIZE && c / TILE_SIZE < rect.x1 as usize,
                        "column {c} of the box of u = {u}, r = {r}: {rect:?}"
                    );
                }
                for c in (0..48).filter(|&c| box_holds(c, u * 0.75)) {
                    assert!(
                        rect.y0 as usize <= c / TILE_SIZE && c / TILE_SIZE < rect.y1 as usize,
                        "row {c} of the box of v = {}, r = {r}: {rect:?}",
                        u * 0.75
                    );
                }
            }
        }
    }
}
