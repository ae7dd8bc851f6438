//! The training curve as a PNG: loss (log scale) and training PSNR against iterations.

use super::canvas::{fmt_tick, line, text};
use crate::train::trainer::LogRow;
use image::{Rgb, RgbImage};
use std::path::Path;

const W: u32 = 720;
const PANEL_H: u32 = 260;
const MARGIN_L: u32 = 70;
const MARGIN_R: u32 = 20;
const MARGIN_T: u32 = 28;
const MARGIN_B: u32 = 30;

/// Draws one panel: `ys` against `xs`, optionally on a log axis.
fn panel(
    img: &mut RgbImage,
    top: u32,
    title: &str,
    xs: &[f64],
    ys: &[f64],
    log: bool,
    color: Rgb<u8>,
) {
    let grey = Rgb([200, 200, 200]);
    let black = Rgb([30, 30, 30]);
    let (x0, x1) = (f64::from(MARGIN_L), f64::from(W - MARGIN_R));
    let (y0, y1) = (
        f64::from(top + MARGIN_T),
        f64::from(top + PANEL_H - MARGIN_B),
    );
    text(img, MARGIN_L, top + 8, title, black);
    let tr = |v: f64| if log { v.max(1e-12).log10() } else { v };
    let pts: Vec<(f64, f64)> = xs
        .iter()
        .zip(ys)
        .filter(|(_, y)| y.is_finite())
        .map(|(&x, &y)| (x, tr(y)))
        .collect();
    if pts.is_empty() {
        return;
    }
    let (xmin, xmax) = (
        pts.first().map_or(0.0, |p| p.0),
        pts.last().map_or(1.0, |p| p.0).max(pts[0].0 + 1.0),
    );
    let (mut ymin, mut ymax) = pts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
    if ymax - ymin < 1e-9 {
        ymin -= 0.5;
        ymax += 0.5;
    }
    let px = |x: f64| x0 + (x - xmin) / (xmax - xmin) * (x1 - x0);
    let py = |y: f64| y1 - (y - ymin) / (ymax - ymin) * (y1 - y0);
    for k in 0..=4 {
        let v = ymin + (ymax - ymin) * f64::from(k) / 4.0;
        line(img, (x0, py(v)), (x1, py(v)), grey);
        let label = fmt_tick(if log { 10f64.powf(v) } else { v });
        #[allow(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "inside the image"
        )]
        text(img, 4, (py(v) as u32).saturating_sub(3), &label, black);
        let xv = xmin + (xmax - xmin) * f64::from(k) / 4.0;
        #[allow(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "inside the image"
        )]
        text(
            img,
            (px(xv) as u32).saturating_sub(12),
            top + PANEL_H - MARGIN_B + 8,
            &fmt_tick(xv.round()),
            black,
        );
    }
    line(img, (x0, y0), (x0, y1), black);
    line(img, (x0, y1), (x1, y1), black);
    for w in pts.windows(2) {
        line(
            img,
            (px(w[0].0), py(w[0].1)),
            (px(w[1].0), py(w[1].1)),
            color,
        );
    }
}

/// Writes the loss and PSNR curves of a training log.
///
/// # Errors
/// Encoding or I/O failures.
pub fn save_curve(log: &[LogRow], path: &Path) -> Result<(), String> {
    let mut img = RgbImage::from_pixel(W, 2 * PANEL_H, Rgb([255, 255, 255]));
    #[allow(clippy::cast_precision_loss, reason = "iteration counts")]
    let xs: Vec<f64> = log.iter().map(|r| r.iteration as f64).collect();
    let loss: Vec<f64> = log.iter().map(|r| r.loss).collect();
    let psnr: Vec<f64> = log.iter().map(|r| r.psnr).collect();
    panel(
        &mut img,
        0,
        "LOSS (LOG)",
        &xs,
        &loss,
        true,
        Rgb([200, 40, 40]),
    );
    panel(
        &mut img,
        PANEL_H,
        "TRAIN PSNR (DB)",
        &xs,
        &psnr,
        false,
        Rgb([30, 90, 200]),
    );
    crate::data::image_io::save_rgb8(&img, path)
        .map_err(|e| format!("{}: cannot write the curve: {e}", path.display()))
}
