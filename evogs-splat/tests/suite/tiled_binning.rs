//! The tile binning: its boxes contain every pixel where a Gaussian passes the α ≥ 1/255
//! rule (so binning never drops a contribution, partial edge tiles included), the lists are
//! the stable (tile, depth) order, and the per-Gaussian entry index is consistent.

use crate::tiled_common;

use evogs_math::{Par, Real};
use evogs_splat::{
    Binning, Preprocessed, RadiusMode, RasterMode, RenderOptions, TILE_SIZE, TileGrid, preprocess,
    splat_alpha,
};
use tiled_common::scene;

/// Asserts that every pixel where a valid Gaussian passes the skip rules lies in its pixel
/// box and in a binned tile; returns the number of such (Gaussian, pixel) pairs.
fn check_boxes<T: Real>(pre: &Preprocessed<T>) -> usize {
    let grid = TileGrid::new(pre.width, pre.height);
    let mut hits = 0;
    for &g in &pre.order {
        let g = g as usize;
        let tiles = grid.tile_rect(pre.means2d[g], pre.radii[g]);
        let pixels = grid.pixel_rect(pre.means2d[g], pre.radii[g]);
        for row in 0..pre.height {
            for col in 0..pre.width {
                let (px, py) = evogs_splat::raster_ref::pixel_center::<T>(col, row);
                if splat_alpha(pre.means2d[g], pre.conics[g], pre.opacities[g], px, py).is_none() {
                    continue;
                }
                hits += 1;
                assert!(
                    pixels.contains(col, row),
                    "Gaussian {g}: visible pixel ({col}, {row}) outside its pixel box {pixels:?}"
                );
                assert!(
                    tiles.contains(col / TILE_SIZE, row / TILE_SIZE),
                    "Gaussian {g}: visible pixel ({col}, {row}) outside its tiles {tiles:?}"
                );
            }
        }
    }
    hits
}

#[test]
fn every_visible_pixel_lies_in_the_binned_tiles() {
    let mut hits = 0;
    for (k, seed) in (0..24_u64).enumerate() {
        let (w, h) = (17 + (k * 7) % 50, 5 + (k * 11) % 45);
        let (splats, cam) = scene(w, h, 40, 0, seed);
        for radius in [RadiusMode::Plain, RadiusMode::OpacityAware] {
            for mode in [RasterMode::Classic, RasterMode::Antialiased] {
                let opts = RenderOptions {
                    radius,
                    mode,
                    ..RenderOptions::default()
                };
                hits += check_boxes(&preprocess(&splats, &cam, &opts));
                let opts32 = RenderOptions {
                    eps2d: 0.3_f32,
                    radius,
                    mode,
                    sh_degree: 1,
                    background: [0.0; 3],
                    par: opts.par,
                };
                hits += check_boxes(&preprocess(&splats.cast(), &cam.cast(), &opts32));
            }
        }
    }
    assert!(
        hits > 100_000,
        "the scenes exercise the boxes ({hits} visible pairs)"
    );
}

#[test]
fn tile_ranges_follow_the_gsplat_formula() {
    let grid = TileGrid::new(40, 20); // 3 × 2 tiles, partial last column and row
    assert_eq!((grid.tiles_x, grid.tiles_y), (3, 2), "tile grid");
    let r = grid.tile_rect(evogs_math::Vec2::new(16.0_f64, 7.5), [3, 2]);
    // [floor(13/16), ceil(19/16)) × [floor(5.5/16), ceil(9.5/16)).
    assert_eq!((r.x0, r.x1, r.y0, r.y1), (0, 2, 0, 1), "interior box");
    let r = grid.tile_rect(evogs_math::Vec2::new(-2.0_f64, 19.0), [5, 4]);
    assert_eq!(
        (r.x0, r.x1, r.y0, r.y1),
        (0, 1, 0, 2),
        "clamped at the borders"
    );
    let r = grid.tile_rect(evogs_math::Vec2::new(300.0_f64, 7.0), [5, 4]);
    assert_eq!(r.area(), 0, "off the image");
    let p = grid.pixel_rect(evogs_math::Vec2::new(16.0_f64, 7.5), [3, 2]);
    // Centres c + ½ in [13, 19] × [5.5, 9.5].
    assert_eq!((p.x0, p.x1, p.y0, p.y1), (13, 19, 5, 10), "pixel box");
}

#[test]
fn lists_are_stable_and_the_entry_index_is_consistent() {
    for (k, seed) in (0..8_u64).enumerate() {
        let (w, h) = (23 + 9 * k, 61 - 5 * k);
        let (splats, cam) = scene(w, h, 150, 0, seed);
        let pre = preprocess(&splats, &cam, &RenderOptions::default());
        let mut bins = Binning::default();
        bins.bin(&pre, Par::best());
        let grid = bins.grid();
        assert_eq!(grid, TileGrid::new(w, h), "grid");
        let mut total = 0;
        for t in 0..grid.n_tiles() {
            let list = bins.tile_entries(t);
            assert!(
                list.windows(2).all(|p| p[0] < p[1]),
                "tile {t}: list not in compositing order"
            );
            for &k in list {
                assert!(
                    bins.rect(k as usize)
                        .contains(t % grid.tiles_x, t / grid.tiles_x),
                    "tile {t} lists Gaussian {k} outside its rectangle"
                );
            }
            total += list.len();
        }
        assert_eq!(total, bins.n_entries(), "entry count");
        let mut expected = 0;
        for k in 0..pre.order.len() {
            let r = bins.rect(k);
            expected += r.area();
            let entries = bins.splat_entries(k);
            assert_eq!(entries.len(), r.area(), "Gaussian {k}: one entry per tile");
            // In tile order, each pointing back to k.
            let tiles: Vec<usize> = entries
                .iter()
                .map(|&e| {
                    let e = e as usize;
                    (0..grid.n_tiles())
                        .find(|&t| bins.tile_range(t).contains(&e))
                        .expect("entry belongs to a tile")
                })
                .collect();
            assert!(tiles.windows(2).all(|p| p[0] < p[1]), "tile order");
            for (&e, &t) in entries.iter().zip(&tiles) {
                let pos = e as usize - bins.tile_range(t).start;
                assert_eq!(bins.tile_entries(t)[pos] as usize, k, "entry points back");
            }
        }
        assert_eq!(expected, bins.n_entries(), "Σ rectangle areas");
    }
}
