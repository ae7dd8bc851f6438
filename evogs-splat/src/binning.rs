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
//! All buffers are reused between calls; they only grow.

use crate::preprocess::Preprocessed;
use alloc::vec::Vec;
use evogs_math::{Real, Vec2};

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
/// use evogs_splat::{benchmark_scene, preprocess, Binning, RenderOptions};
/// let (splats, cam) = benchmark_scene::<f32>(300, 40, 1);
/// let pre = preprocess(&splats, &cam, &RenderOptions::default());
/// let mut bins = Binning::default();
/// bins.bin(&pre);
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
    /// Scatter cursors (scratch).
    cursor: Vec<u32>,
}

impl Binning {
    /// Bins the valid Gaussians of `pre` (in `pre.order`) into the tiles of its image.
    ///
    /// # Panics
    /// If there are `u32::MAX` entries or more.
    pub fn bin<T: Real>(&mut self, pre: &Preprocessed<T>) {
        let grid = TileGrid::new(pre.width, pre.height);
        self.grid = grid;
        let n_tiles = grid.n_tiles();
        self.rects.clear();
        self.rects.extend(
            pre.order
                .iter()
                .map(|&g| grid.tile_rect(pre.means2d[g as usize], pre.radii[g as usize])),
        );

        // Count per tile and per Gaussian.
        self.tile_offsets.clear();
        self.tile_offsets.resize(n_tiles + 1, 0);
        self.splat_offsets.clear();
        self.splat_offsets.reserve(self.rects.len() + 1);
        self.splat_offsets.push(0);
        let mut total = 0_usize;
        for r in &self.rects {
            for ty in r.y0..r.y1 {
                for tx in r.x0..r.x1 {
                    self.tile_offsets[ty as usize * grid.tiles_x + tx as usize + 1] += 1;
                }
            }
            total += r.area();
            assert!(u32::try_from(total).is_ok(), "too many tile entries");
            self.splat_offsets
                .push(u32::try_from(total).unwrap_or(u32::MAX));
        }
        // Exclusive prefix sum.
        for t in 0..n_tiles {
            self.tile_offsets[t + 1] += self.tile_offsets[t];
        }

        // Stable scatter, front to back.
        self.cursor.clear();
        self.cursor.extend_from_slice(&self.tile_offsets[..n_tiles]);
        self.entries.clear();
        self.entries.resize(total, 0);
        self.splat_entries.clear();
        self.splat_entries.resize(total, 0);
        let mut j = 0;
        for (k, r) in (0_u32..).zip(&self.rects) {
            for ty in r.y0..r.y1 {
                for tx in r.x0..r.x1 {
                    let c = &mut self.cursor[ty as usize * grid.tiles_x + tx as usize];
                    self.entries[*c as usize] = k;
                    self.splat_entries[j] = *c;
                    *c += 1;
                    j += 1;
                }
            }
        }
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
