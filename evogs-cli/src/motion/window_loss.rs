//! The photometric loss of a view with one body's members moved, equal to the full image's,
//! from a render of a window around the members (`evogs_splat::window`).
//!
//! The searches score thousands of placements of one body and refit it view by view; a whole
//! 400×400 render per placement spends almost all its time on pixels the body never reaches.
//! With `ℓ(q)` the loss of value `q` (three per pixel) and `N = 3·W·H`,
//!
//! ```text
//! L = (1/N) Σ_q ℓ(q),   ℓ(q) = (1 − λ)·|a_q − b_q| + λ·(1 − s_q)      (s: the SSIM map)
//! ```
//!
//! is the 3DGS loss `(1 − λ)·L1 + λ·(1 − SSIM)`. Outside the tiles the members are binned into
//! (their footprint), a placement renders exactly as the *base*, the view with the members
//! hidden; the SSIM of a pixel reads pixels at most `r = 5` away. So only the values within
//! `r` of the footprint differ from the base's, and
//!
//! ```text
//! L(placement) = L(base) + (1/N) Σ_{q ∈ I} [ℓ(q) − ℓ_base(q)],   I = footprint grown by r,
//! ```
//!
//! where `ℓ(q)` on `I` needs pixels at most `2r` from the footprint: the window is the
//! footprint grown by one tile (16 ≥ 2r), and the window's zero-padded SSIM edges lie outside
//! `I`. [`WindowLoss::set_base`] renders the base once per view; [`WindowLoss::loss`] then
//! costs the preprocessing of the Gaussians and the window's pixels. For gradients the same
//! window serves ([`WindowLoss::grad_into`]): only pixels within `r` of the footprint depend
//! on the members, so the window's loss, weighted by its share of the values, has the full
//! loss's gradient with respect to every member.

use crate::train::step::ViewData;
use evogs_math::Real;
use evogs_splat::loss::{photometric_loss, photometric_loss_and_grad};
use evogs_splat::ssim::{SSIM_WINDOW, SsimWorkspace};
use evogs_splat::window::{Window, footprint, to_window};
use evogs_splat::{
    Image, PixelGrad, Preprocessed, Rect, Render, RenderGrad, RenderOptions, Splats, TILE_SIZE,
    TileGrid, TiledRasterizer, preprocess_into, render_tiled_into, render_tiled_vjp_into,
};

/// How far the SSIM of a pixel reads (pixels).
const REACH: usize = SSIM_WINDOW / 2;
const _: () = assert!(
    2 * REACH <= TILE_SIZE,
    "one tile of margin holds the SSIM's reach"
);

/// Buffers and the base of one view (see the module docs).
#[derive(Debug)]
pub(crate) struct WindowLoss {
    rast: TiledRasterizer<f32>,
    ssim: SsimWorkspace<f32>,
    fwd: Render<f32>,
    /// `ℓ_base` of every value of the full image.
    base: Vec<f32>,
    /// `Σ ℓ_base`.
    base_sum: f64,
    /// The view's image in the current window.
    target: Image<f32>,
    /// The SSIM map (or the pixel gradient) of the current window.
    map: Image<f32>,
    /// Render settings.
    opts: RenderOptions<f32>,
    /// The D-SSIM weight λ.
    lambda: f32,
}

impl WindowLoss {
    /// Empty buffers for renders with `opts` and the loss of D-SSIM weight `lambda`.
    pub(crate) fn new(opts: RenderOptions<f32>, lambda: f32) -> Self {
        let background = opts.background;
        Self {
            rast: TiledRasterizer::new(),
            ssim: SsimWorkspace::default(),
            fwd: Render {
                pre: Preprocessed::default(),
                raster: evogs_splat::RasterOutput::new(0, 0, background),
            },
            base: Vec::new(),
            base_sum: 0.0,
            target: Image::new(0, 0),
            map: Image::new(0, 0),
            opts,
            lambda,
        }
    }

    /// The loss of `st` at `view`, rendered whole.
    pub(crate) fn full_loss(&mut self, view: &ViewData<f32>, st: &Splats<f32>) -> f64 {
        let opts = &self.opts;
        render_tiled_into(st, &view.camera, opts, &mut self.rast, &mut self.fwd);
        let rgb = &self.fwd.raster.rgb;
        f64::from(photometric_loss(&mut self.ssim, rgb, &view.image, self.lambda, opts.par).total)
    }

    /// Renders `st` at `view` with `members` hidden and keeps its per-value loss: the base of
    /// the placements [`loss`](Self::loss) scores next.
    pub(crate) fn set_base(&mut self, view: &ViewData<f32>, st: &Splats<f32>, members: &[usize]) {
        let (opts, lambda) = (&self.opts, self.lambda);
        preprocess_into(st, &view.camera, opts, &mut self.fwd.pre);
        hide(&mut self.fwd.pre, members);
        self.rast.forward_into(
            &self.fwd.pre,
            opts.background,
            opts.par,
            &mut self.fwd.raster,
        );
        let rgb = &self.fwd.raster.rgb;
        fit(&mut self.map, rgb.width(), rgb.height());
        self.ssim
            .ssim_map(rgb, &view.image, &mut self.map, opts.par);
        self.base.clear();
        self.base.extend(
            rgb.data()
                .iter()
                .zip(view.image.data())
                .zip(self.map.data())
                .map(|((&a, &b), &s)| value_loss(a, b, s, lambda)),
        );
        self.base_sum = self.base.iter().map(|&v| f64::from(v)).sum();
    }

    /// The full image's loss of `probe` at `view`: the base's Gaussians with `members`
    /// placed anywhere (the same view and members as the last [`set_base`](Self::set_base)).
    pub(crate) fn loss(
        &mut self,
        view: &ViewData<f32>,
        probe: &Splats<f32>,
        members: &[usize],
    ) -> f64 {
        let (w, h) = (view.image.width(), view.image.height());
        #[allow(clippy::cast_precision_loss, reason = "a pixel count")]
        let n = (3 * w * h) as f64;
        let Some((win, fp)) = self.render_window(view, probe, members) else {
            return self.base_sum / n;
        };
        let (opts, lambda) = (&self.opts, self.lambda);
        let rgb = &self.fwd.raster.rgb;
        self.ssim
            .ssim_map(rgb, &self.target, &mut self.map, opts.par);
        // I: the footprint's pixels grown by the SSIM's reach, clipped to the image.
        let fp_px = Window::from_tiles(&TileGrid::new(w, h), fp);
        let (x0, x1) = (
            fp_px.x0.saturating_sub(REACH),
            (fp_px.x0 + fp_px.width + REACH).min(w),
        );
        let (y0, y1) = (
            fp_px.y0.saturating_sub(REACH),
            (fp_px.y0 + fp_px.height + REACH).min(h),
        );
        let mut diff = 0.0f64;
        let (a, b, s) = (rgb.data(), self.target.data(), self.map.data());
        for y in y0..y1 {
            let local = 3 * ((y - win.y0) * win.width + (x0 - win.x0));
            let full = 3 * (y * w + x0);
            let len = 3 * (x1 - x0);
            for k in 0..len {
                let l = value_loss(a[local + k], b[local + k], s[local + k], lambda);
                diff += f64::from(l) - f64::from(self.base[full + k]);
            }
        }
        (self.base_sum + diff) / n
    }

    /// Adds `g·∂L/∂(probe's parameters)` for the members into `grad.splats` (which is
    /// overwritten; entries of Gaussians whose pixels the window cuts off are not the full
    /// image's) through a window around them, `L` the full image's loss of `probe` at `view`.
    /// `false` if no member is seen (then `grad.splats` is zero).
    pub(crate) fn grad_into(
        &mut self,
        view: &ViewData<f32>,
        probe: &Splats<f32>,
        members: &[usize],
        grad: &mut RenderGrad<f32>,
    ) -> bool {
        let (w, h) = (view.image.width(), view.image.height());
        let Some((win, _)) = self.render_window(view, probe, members) else {
            if grad.splats.len() == probe.len() && grad.splats.sh_degree == probe.sh_degree {
                grad.splats.fill_zero();
            } else {
                grad.splats = probe.zeros_like();
            }
            return false;
        };
        let (opts, lambda) = (&self.opts, self.lambda);
        let rgb = &self.fwd.raster.rgb;
        self.map.data_mut().fill(0.0);
        #[allow(clippy::cast_precision_loss, reason = "pixel counts")]
        let share = win.pixels() as f32 / (w * h) as f32;
        photometric_loss_and_grad(
            &mut self.ssim,
            rgb,
            &self.target,
            lambda,
            share,
            &mut self.map,
            opts.par,
        );
        render_tiled_vjp_into(
            probe,
            &view.camera,
            opts,
            &mut self.rast,
            &self.fwd,
            &PixelGrad {
                rgb: self.map.data(),
                alpha: None,
                depth: None,
            },
            grad,
        );
        true
    }

    /// Preprocesses `probe` for the full image and renders the window of the members'
    /// footprint grown by a tile, with the view's image cropped to it and the map buffer
    /// sized to it; the window and the footprint (tiles), or `None` if no member touches a
    /// tile.
    fn render_window(
        &mut self,
        view: &ViewData<f32>,
        probe: &Splats<f32>,
        members: &[usize],
    ) -> Option<(Window, Rect)> {
        let opts = &self.opts;
        preprocess_into(probe, &view.camera, opts, &mut self.fwd.pre);
        let fp = footprint(&self.fwd.pre, members.iter().copied())?;
        let grid = TileGrid::new(view.image.width(), view.image.height());
        let win = Window::from_tiles(&grid, fp.dilated(1, &grid));
        to_window(&mut self.fwd.pre, &win);
        self.rast.forward_into(
            &self.fwd.pre,
            opts.background,
            opts.par,
            &mut self.fwd.raster,
        );
        win.crop(&view.image, &mut self.target);
        fit(&mut self.map, win.width, win.height);
        Some((win, fp))
    }
}

/// Resizes `img` to `w × h` if it is not that size (its values are then overwritten).
fn fit(img: &mut Image<f32>, w: usize, h: usize) {
    if img.width() != w || img.height() != h {
        *img = Image::new(w, h);
    }
}

/// `ℓ = (1 − λ)·|a − b| + λ·(1 − s)`.
#[inline]
fn value_loss(a: f32, b: f32, s: f32, lambda: f32) -> f32 {
    (1.0 - lambda) * (a - b).abs() + lambda * (1.0 - s)
}

/// Culls `ids` from `pre`: rendered as if they were not there.
fn hide<T: Real>(pre: &mut Preprocessed<T>, ids: &[usize]) {
    for &i in ids {
        pre.valid[i] = false;
        pre.radii[i] = [0; 2];
    }
    let valid = &pre.valid;
    pre.order.retain(|&g| valid[g as usize]);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::train::step::render_options;
    use evogs_math::{Par, Vec3};
    use evogs_splat::loss::photometric_loss;
    use evogs_splat::{PinholeCamera, random_scene, render_tiled, render_tiled_vjp};

    /// A scene whose corner `x, y > 0.25` is the body, a view of it (96 × 80: partial edge
    /// tiles) and a target that differs from it everywhere.
    fn setup() -> (Splats<f32>, ViewData<f32>, Vec<usize>, RenderOptions<f32>) {
        let (splats, camera): (Splats<f32>, PinholeCamera<f32>) =
            random_scene(600, 96, 4, [0.01, 0.06], [0.4, 0.95]);
        let camera = PinholeCamera {
            height: 80,
            cy: camera.cy - 8.0,
            ..camera
        };
        let opts = render_options([1.0; 3], splats.sh_degree, Par::Seq);
        let members: Vec<usize> = (0..splats.len())
            .filter(|&i| splats.means[i].x > 0.25 && splats.means[i].y > 0.25)
            .collect();
        let mut other = splats.clone();
        for m in &mut other.means {
            *m += Vec3::new(0.03, -0.02, 0.0);
        }
        let image = render_tiled(&other, &camera, &opts, &mut TiledRasterizer::new())
            .raster
            .rgb;
        let view = ViewData {
            camera,
            time: 0.0,
            image: image.into(),
        };
        (splats, view, members, opts)
    }

    /// `splats` with the members moved by `d`.
    fn placed(splats: &Splats<f32>, members: &[usize], d: Vec3<f32>) -> Splats<f32> {
        let mut p = splats.clone();
        for &i in members {
            p.means[i] += d;
        }
        p
    }

    #[test]
    fn the_window_loss_is_the_full_image_s() {
        let (splats, view, members, opts) = setup();
        assert!(members.len() > 20, "{} members", members.len());
        let mut wl = WindowLoss::new(opts, 0.2);
        wl.set_base(&view, &splats, &members);
        let mut rast = TiledRasterizer::new();
        let mut ssim = SsimWorkspace::default();
        // In place, moved, moved to the image's edge, out of sight, and on a fine grid of
        // shifts, so that the body's edges fall at every offset within a tile.
        let mut shifts = vec![
            Vec3::zero(),
            Vec3::new(-0.3, -0.1, 0.2),
            Vec3::new(-0.9, 0.2, 0.0),
            Vec3::new(60.0, 0.0, 0.0),
        ];
        for i in 0..6 {
            for j in 0..6 {
                #[allow(clippy::cast_precision_loss, reason = "small")]
                shifts.push(Vec3::new(-0.02 * i as f32, -0.02 * j as f32, 0.0));
            }
        }
        for d in shifts {
            let p = placed(&splats, &members, d);
            let full = render_tiled(&p, &view.camera, &opts, &mut rast);
            let want = f64::from(
                photometric_loss(&mut ssim, &full.raster.rgb, &view.image, 0.2, Par::Seq).total,
            );
            let got = wl.loss(&view, &p, &members);
            assert!(
                (got - want).abs() <= 4e-6 * want,
                "shift {d:?}: window {got}, full {want}"
            );
        }
    }

    #[test]
    fn the_window_gradient_is_the_full_image_s_for_the_members() {
        let (splats, view, members, opts) = setup();
        let p = placed(&splats, &members, Vec3::new(-0.2, 0.05, 0.0));
        let mut rast = TiledRasterizer::new();
        let full = render_tiled(&p, &view.camera, &opts, &mut rast);
        let mut d = Image::new(96, 80);
        photometric_loss_and_grad(
            &mut SsimWorkspace::default(),
            &full.raster.rgb,
            &view.image,
            0.2,
            1.0,
            &mut d,
            Par::Seq,
        );
        let want = render_tiled_vjp(
            &p,
            &view.camera,
            &opts,
            &mut rast,
            &full,
            &PixelGrad {
                rgb: d.data(),
                alpha: None,
                depth: None,
            },
        );
        let mut got = want.clone();
        let mut wl = WindowLoss::new(opts, 0.2);
        assert!(wl.grad_into(&view, &p, &members, &mut got), "members seen");
        let mut max_err = 0.0f32;
        let mut scale = 0.0f32;
        for &i in &members {
            let pairs = [
                (
                    want.splats.means[i].to_array(),
                    got.splats.means[i].to_array(),
                ),
                (
                    want.splats.log_scales[i].to_array(),
                    got.splats.log_scales[i].to_array(),
                ),
                (
                    [want.splats.opacity_logits[i]; 3],
                    [got.splats.opacity_logits[i]; 3],
                ),
            ];
            for (a, b) in pairs {
                for k in 0..3 {
                    scale = scale.max(a[k].abs());
                    max_err = max_err.max((a[k] - b[k]).abs());
                }
            }
            for (a, b) in want.splats.sh_coeffs(i).iter().zip(got.splats.sh_coeffs(i)) {
                for k in 0..3 {
                    max_err = max_err.max((a[k] - b[k]).abs());
                }
            }
        }
        assert!(scale > 0.0, "the members have a gradient");
        assert!(
            max_err <= 1e-4 * scale,
            "max error {max_err} (scale {scale})"
        );
    }

    #[test]
    fn no_member_in_sight_gives_the_base_and_no_gradient() {
        let (splats, view, members, opts) = setup();
        let mut wl = WindowLoss::new(opts, 0.2);
        wl.set_base(&view, &splats, &members);
        let away = placed(&splats, &members, Vec3::new(60.0, 0.0, 0.0));
        let mut g = render_tiled_vjp(
            &away,
            &view.camera,
            &opts,
            &mut TiledRasterizer::new(),
            &render_tiled(&away, &view.camera, &opts, &mut TiledRasterizer::new()),
            &PixelGrad {
                rgb: &vec![0.0; 96 * 80 * 3],
                alpha: None,
                depth: None,
            },
        );
        assert!(!wl.grad_into(&view, &away, &members, &mut g), "unseen");
    }
}
