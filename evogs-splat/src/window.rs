//! Rendering a window of an image: the tiles of a [`Window`] rendered exactly as they are in
//! the full image, at a compositing cost proportional to the window's pixels.
//!
//! A window is a tile-aligned rectangle of the full image's pixels. [`to_window`] turns the
//! full image's [`Preprocessed`] into the window's: the 2D means shift by the window's origin
//! and the size becomes the window's, while depths, conics, colours, opacities, radii,
//! validity and the depth order stay those of the full camera. So the FOV clamp and the
//! culling are the full image's (a smaller camera with a shifted principal point would clamp
//! differently). Because the origin is a multiple of [`TILE_SIZE`], each tile of the window is
//! a tile of the full image with the same Gaussians in the same order, and each pixel is the
//! full render's (equal in exact arithmetic; the shifted means round differently only when
//! the shift changes their binary exponent).
//!
//! ```text
//! full image  ┌──────────────────────────┐     window = tiles [tx0, tx1) × [ty0, ty1)
//!             │      ┌────────┐          │     u_window = u − 16·tx0,  v_window = v − 16·ty0
//!             │      │ window │          │     everything else per Gaussian unchanged
//!             │      └────────┘          │
//!             └──────────────────────────┘
//! ```
//!
//! The backward pass needs nothing new. The tiled rasterizer's VJP on the window's
//! `Preprocessed` gives the rasterizer-input gradients (which do not depend on the shift), and
//! [`preprocess_vjp`](crate::preprocess_vjp) with the full camera takes them to the Gaussians
//! (it reads the validity and the compensations, not the means). So a loss whose pixels
//! outside the window do not depend on some Gaussians gets those Gaussians' exact gradients
//! from the window alone: [`render_tiled_vjp_into`](crate::render_tiled_vjp_into) with the
//! window render and the window's pixel cotangents.
//!
//! ```
//! use evogs_splat::window::{Window, footprint, render_window_into};
//! use evogs_splat::{benchmark_scene, render_tiled, preprocess, Render, RenderOptions, TileGrid, TiledRasterizer};
//! let (splats, camera) = benchmark_scene::<f64>(300, 64, 1);
//! let opts = RenderOptions::default();
//! let mut rast = TiledRasterizer::new();
//! let full = render_tiled(&splats, &camera, &opts, &mut rast);
//! // The tiles Gaussians 0..10 touch, and one tile around them.
//! let grid = TileGrid::new(64, 64);
//! let tiles = footprint(&preprocess(&splats, &camera, &opts), 0..10).unwrap().dilated(1, &grid);
//! let w = Window::from_tiles(&grid, tiles);
//! let mut part = render_tiled(&splats, &camera, &opts, &mut rast); // any Render to reuse
//! render_window_into(&splats, &camera, &opts, &w, &mut rast, &mut part);
//! let (x, y) = (w.x0 + w.width / 2, w.y0 + w.height / 2);
//! let (a, b) = (part.raster.rgb.get(x - w.x0, y - w.y0), full.raster.rgb.get(x, y));
//! assert!((0..3).all(|c| (a[c] - b[c]).abs() < 1e-12));
//! ```

use crate::binning::{Rect, TILE_SIZE, TileGrid};
use crate::camera::PinholeCamera;
use crate::gaussians::Splats;
use crate::image::Image;
use crate::preprocess::{Preprocessed, RenderOptions, preprocess_into};
use crate::raster_tiled::TiledRasterizer;
use crate::render::Render;
use evogs_math::{Real, Vec2};

/// A tile-aligned pixel rectangle `[x0, x0 + width) × [y0, y0 + height)` of a full image.
/// `x0` and `y0` are multiples of [`TILE_SIZE`]; the width and height are too, except where
/// the window reaches the image's right or bottom edge.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Window {
    /// First pixel column.
    pub x0: usize,
    /// First pixel row.
    pub y0: usize,
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
}

impl Window {
    /// The whole `width × height` image.
    #[must_use]
    pub const fn full(width: usize, height: usize) -> Self {
        Self {
            x0: 0,
            y0: 0,
            width,
            height,
        }
    }

    /// The pixels of the tile rectangle `tiles` of `grid` (clipped to the image).
    #[must_use]
    pub fn from_tiles(grid: &TileGrid, tiles: Rect) -> Self {
        let x0 = (tiles.x0 as usize * TILE_SIZE).min(grid.width);
        let y0 = (tiles.y0 as usize * TILE_SIZE).min(grid.height);
        let x1 = (tiles.x1 as usize * TILE_SIZE).min(grid.width);
        let y1 = (tiles.y1 as usize * TILE_SIZE).min(grid.height);
        Self {
            x0,
            y0,
            width: x1.saturating_sub(x0),
            height: y1.saturating_sub(y0),
        }
    }

    /// Number of pixels.
    #[must_use]
    pub const fn pixels(&self) -> usize {
        self.width * self.height
    }

    /// `true` if the pixel `(x, y)` of the full image lies inside.
    #[must_use]
    pub const fn contains(&self, x: usize, y: usize) -> bool {
        x >= self.x0 && x < self.x0 + self.width && y >= self.y0 && y < self.y0 + self.height
    }

    /// Copies the window's pixels of `image` (the full image) into `out` (resized).
    ///
    /// # Panics
    /// If the window does not lie inside `image`.
    pub fn crop<T: Real>(&self, image: &Image<T>, out: &mut Image<T>) {
        assert!(
            self.x0 + self.width <= image.width() && self.y0 + self.height <= image.height(),
            "window outside the image"
        );
        if out.width() != self.width || out.height() != self.height {
            *out = Image::new(self.width, self.height);
        }
        let (src_row, dst_row) = (3 * image.width(), 3 * self.width);
        if dst_row == 0 {
            return;
        }
        for (y, dst) in out.data_mut().chunks_exact_mut(dst_row).enumerate() {
            let start = (self.y0 + y) * src_row + 3 * self.x0;
            dst.copy_from_slice(&image.data()[start..start + dst_row]);
        }
    }
}

impl Rect {
    /// The rectangle grown by `margin` cells on every side, clamped to `grid`'s tiles.
    #[must_use]
    pub fn dilated(&self, margin: u32, grid: &TileGrid) -> Self {
        let clamp = |v: u32, hi: usize| v.min(u32::try_from(hi).unwrap_or(u32::MAX));
        Self {
            x0: self.x0.saturating_sub(margin),
            x1: clamp(self.x1.saturating_add(margin), grid.tiles_x),
            y0: self.y0.saturating_sub(margin),
            y1: clamp(self.y1.saturating_add(margin), grid.tiles_y),
        }
    }
}

/// The union of the tiles of the full image that the Gaussians `ids` are binned into
/// (`pre` preprocessed for the full image), or `None` if none of them touches a tile. Outside
/// these tiles the Gaussians contribute to no pixel.
#[must_use]
pub fn footprint<T: Real>(
    pre: &Preprocessed<T>,
    ids: impl IntoIterator<Item = usize>,
) -> Option<Rect> {
    let grid = TileGrid::new(pre.width, pre.height);
    let mut out: Option<Rect> = None;
    for i in ids {
        if !pre.valid[i] {
            continue;
        }
        let r = grid.tile_rect(pre.means2d[i], pre.radii[i]);
        if r.area() == 0 {
            continue;
        }
        out = Some(match out {
            None => r,
            Some(o) => Rect {
                x0: o.x0.min(r.x0),
                x1: o.x1.max(r.x1),
                y0: o.y0.min(r.y0),
                y1: o.y1.max(r.y1),
            },
        });
    }
    out
}

/// Turns `pre`, preprocessed for the full image, into the window's (see the module docs).
///
/// # Panics
/// If `window` is not tile-aligned or does not lie inside `pre`'s image.
pub fn to_window<T: Real>(pre: &mut Preprocessed<T>, window: &Window) {
    assert!(
        window.x0.is_multiple_of(TILE_SIZE) && window.y0.is_multiple_of(TILE_SIZE),
        "window origin ({}, {}) is not tile-aligned",
        window.x0,
        window.y0
    );
    assert!(
        window.x0 + window.width <= pre.width && window.y0 + window.height <= pre.height,
        "window outside the image"
    );
    #[allow(clippy::cast_precision_loss, reason = "pixel offsets are small")]
    let shift = Vec2::new(T::from_f64(window.x0 as f64), T::from_f64(window.y0 as f64));
    for m in &mut pre.means2d {
        *m -= shift;
    }
    pre.width = window.width;
    pre.height = window.height;
}

/// Renders the window `window` of the image `camera` sees into `out`: [`preprocess_into`]
/// for the full image, [`to_window`], then the tiled rasterizer. `out.raster` holds the
/// window's pixels; `out.pre` is the window's, ready for
/// [`render_tiled_vjp_into`](crate::render_tiled_vjp_into) with the full camera.
///
/// # Panics
/// If `splats` is inconsistent or the window is not tile-aligned inside the image.
pub fn render_window_into<T: Real>(
    splats: &Splats<T>,
    camera: &PinholeCamera<T>,
    opts: &RenderOptions<T>,
    window: &Window,
    rast: &mut TiledRasterizer<T>,
    out: &mut Render<T>,
) {
    preprocess_into(splats, camera, opts, &mut out.pre);
    to_window(&mut out.pre, window);
    rast.forward_into(&out.pre, opts.background, opts.par, &mut out.raster);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster_ref_vjp::PixelGrad;
    use crate::render::{RenderGrad, render_tiled, render_tiled_vjp, render_tiled_vjp_into};
    use crate::{preprocess, random_scene};
    use alloc::vec;
    use alloc::vec::Vec;

    /// A random scene seen at 72 × 72: the Gaussians, the camera, the render options, a
    /// rasterizer and the full render.
    type Rendered = (
        Splats<f64>,
        PinholeCamera<f64>,
        RenderOptions<f64>,
        TiledRasterizer<f64>,
        Render<f64>,
    );

    fn rendered_scene() -> Rendered {
        let (splats, camera) = random_scene::<f64>(400, 72, 5, [0.01, 0.08], [0.3, 0.95]);
        let opts = RenderOptions::default();
        let mut rast = TiledRasterizer::new();
        let full = render_tiled(&splats, &camera, &opts, &mut rast);
        (splats, camera, opts, rast, full)
    }

    #[test]
    fn window_pixels_are_the_full_render_s() {
        let (splats, camera, opts, mut rast, full) = rendered_scene();
        let grid = TileGrid::new(72, 72);
        // Interior, touching the right and bottom edges (partial tiles), and the whole image.
        for tiles in [
            Rect {
                x0: 1,
                x1: 3,
                y0: 1,
                y1: 2,
            },
            Rect {
                x0: 2,
                x1: 5,
                y0: 3,
                y1: 5,
            },
            Rect {
                x0: 0,
                x1: 5,
                y0: 0,
                y1: 5,
            },
        ] {
            let w = Window::from_tiles(&grid, tiles);
            let mut part = full.clone();
            render_window_into(&splats, &camera, &opts, &w, &mut rast, &mut part);
            assert_eq!(part.raster.rgb.width(), w.width, "window width");
            let mut crop = Image::new(0, 0);
            w.crop(&full.raster.rgb, &mut crop);
            let err = crop
                .data()
                .iter()
                .zip(part.raster.rgb.data())
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-12, "window {w:?}: max pixel difference {err}");
        }
    }

    #[test]
    fn window_gradients_are_the_full_render_s_with_the_outside_held() {
        // A cotangent on the window's pixels only: the window's VJP equals the full VJP with
        // the same cotangent and zeros outside.
        let (splats, camera, opts, mut rast, full) = rendered_scene();
        let w = Window::from_tiles(
            &TileGrid::new(72, 72),
            Rect {
                x0: 1,
                x1: 4,
                y0: 2,
                y1: 5,
            },
        );
        let mut d_full = vec![0.0; 72 * 72 * 3];
        let mut d_win = Vec::new();
        for y in w.y0..w.y0 + w.height {
            for x in w.x0..w.x0 + w.width {
                for c in 0..3 {
                    #[allow(clippy::cast_precision_loss, reason = "small")]
                    let g = ((x * 7 + y * 3 + c) % 11) as f64 / 11.0 - 0.4;
                    d_full[3 * (y * 72 + x) + c] = g;
                    d_win.push(g);
                }
            }
        }
        let g_full = render_tiled_vjp(
            &splats,
            &camera,
            &opts,
            &mut rast,
            &full,
            &PixelGrad {
                rgb: &d_full,
                alpha: None,
                depth: None,
            },
        );
        let mut part = full.clone();
        render_window_into(&splats, &camera, &opts, &w, &mut rast, &mut part);
        let mut g_win: RenderGrad<f64> = g_full.clone();
        render_tiled_vjp_into(
            &splats,
            &camera,
            &opts,
            &mut rast,
            &part,
            &PixelGrad {
                rgb: &d_win,
                alpha: None,
                depth: None,
            },
            &mut g_win,
        );
        let (mut a, mut b) = (Vec::new(), Vec::new());
        g_full.splats.write_flat(&mut a);
        g_win.splats.write_flat(&mut b);
        let scale = a.iter().map(|v| v.abs()).fold(0.0, f64::max);
        assert!(scale > 0.0, "the window sees some Gaussians");
        let err = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(
            err <= 1e-10 * scale,
            "max gradient difference {err} (scale {scale})"
        );
    }

    #[test]
    fn outside_the_footprint_the_gaussians_change_no_pixel() {
        let (splats, camera, opts, mut rast, full) = rendered_scene();
        let ids: Vec<usize> = (0..30).collect();
        let tiles = footprint(&preprocess(&splats, &camera, &opts), ids.iter().copied())
            .expect("some of them are seen");
        let w = Window::from_tiles(&TileGrid::new(72, 72), tiles);
        assert!(w.pixels() < 72 * 72, "the footprint is not the whole image");
        // Hide them (fully transparent) and compare.
        let mut hidden = splats.clone();
        for &i in &ids {
            hidden.opacity_logits[i] = -60.0;
        }
        let without = render_tiled(&hidden, &camera, &opts, &mut rast);
        let mut changed = 0;
        for y in 0..72 {
            for x in 0..72 {
                let (a, b) = (full.raster.rgb.get(x, y), without.raster.rgb.get(x, y));
                #[allow(clippy::float_cmp, reason = "untouched pixels are bitwise equal")]
                if a != b {
                    changed += 1;
                    assert!(
                        w.contains(x, y),
                        "pixel ({x}, {y}) changed outside the footprint"
                    );
                }
            }
        }
        assert!(changed > 0, "the hidden Gaussians were visible");
    }

    #[test]
    fn dilation_clamps_to_the_grid_and_crop_copies_rows() {
        let grid = TileGrid::new(40, 40); // 3 × 3 tiles, the last partial
        let r = Rect {
            x0: 1,
            x1: 2,
            y0: 0,
            y1: 1,
        }
        .dilated(2, &grid);
        assert_eq!(
            r,
            Rect {
                x0: 0,
                x1: 3,
                y0: 0,
                y1: 3
            },
            "dilated and clamped"
        );
        let w = Window::from_tiles(
            &grid,
            Rect {
                x0: 2,
                x1: 3,
                y0: 1,
                y1: 3,
            },
        );
        assert_eq!(
            (w.x0, w.y0, w.width, w.height),
            (32, 16, 8, 24),
            "partial edge tiles"
        );
        let mut img = Image::<f32>::new(40, 40);
        img.set(33, 17, [1.0, 2.0, 3.0]);
        let mut out = Image::new(0, 0);
        w.crop(&img, &mut out);
        #[allow(clippy::float_cmp, reason = "a copied value")]
        let moved = out.get(1, 1) == [1.0, 2.0, 3.0];
        assert!(moved, "pixel moved by the origin");
    }
}
