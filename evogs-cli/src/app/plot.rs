//! The training curve as a PNG: loss (log scale) and training PSNR against iterations, drawn
//! with a tiny built-in 5×7 bitmap font for the labels (no plotting dependency).

use crate::train::trainer::LogRow;
use image::{Rgb, RgbImage};
use std::path::Path;

const W: u32 = 720;
const PANEL_H: u32 = 260;
const MARGIN_L: u32 = 70;
const MARGIN_R: u32 = 20;
const MARGIN_T: u32 = 28;
const MARGIN_B: u32 = 30;

/// 5×7 glyphs (one byte per row, the low 5 bits, leftmost pixel = bit 4).
fn glyph(c: char) -> [u8; 7] {
    match c {
        '0' => [14, 17, 19, 21, 25, 17, 14],
        '1' => [4, 12, 4, 4, 4, 4, 14],
        '2' => [14, 17, 1, 2, 4, 8, 31],
        '3' => [31, 2, 4, 2, 1, 17, 14],
        '4' => [2, 6, 10, 18, 31, 2, 2],
        '5' => [31, 16, 30, 1, 1, 17, 14],
        '6' => [6, 8, 16, 30, 17, 17, 14],
        '7' => [31, 1, 2, 4, 8, 8, 8],
        '8' => [14, 17, 17, 14, 17, 17, 14],
        '9' => [14, 17, 17, 15, 1, 2, 12],
        '.' => [0, 0, 0, 0, 0, 12, 12],
        '-' => [0, 0, 0, 31, 0, 0, 0],
        'e' => [0, 0, 14, 17, 31, 16, 14],
        'A' => [14, 17, 17, 31, 17, 17, 17],
        'B' => [30, 17, 17, 30, 17, 17, 30],
        'D' => [28, 18, 17, 17, 17, 18, 28],
        'E' => [31, 16, 16, 30, 16, 16, 31],
        'G' => [14, 17, 16, 23, 17, 17, 15],
        'I' => [14, 4, 4, 4, 4, 4, 14],
        'L' => [16, 16, 16, 16, 16, 16, 31],
        'N' => [17, 17, 25, 21, 19, 17, 17],
        'O' => [14, 17, 17, 17, 17, 17, 14],
        'P' => [30, 17, 17, 30, 16, 16, 16],
        'R' => [30, 17, 17, 30, 20, 18, 17],
        'S' => [15, 16, 16, 14, 1, 1, 30],
        'T' => [31, 4, 4, 4, 4, 4, 4],
        '(' => [2, 4, 8, 8, 8, 4, 2],
        ')' => [8, 4, 2, 2, 2, 4, 8],
        _ => [0; 7],
    }
}

fn text(img: &mut RgbImage, x: u32, y: u32, s: &str, color: Rgb<u8>) {
    for (i, c) in s.chars().enumerate() {
        let g = glyph(c);
        for (r, bits) in g.iter().enumerate() {
            for col in 0..5 {
                if bits >> (4 - col) & 1 == 1 {
                    let (px, py) = (
                        x + u32::try_from(i).unwrap_or(0) * 6 + col,
                        y + u32::try_from(r).unwrap_or(0),
                    );
                    if px < img.width() && py < img.height() {
                        img.put_pixel(px, py, color);
                    }
                }
            }
        }
    }
}

fn line(img: &mut RgbImage, (x0, y0): (f64, f64), (x1, y1): (f64, f64), color: Rgb<u8>) {
    #[allow(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "pixel distances are small and non-negative"
    )]
    let steps = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1);
    for s in 0..=steps {
        #[allow(clippy::cast_precision_loss, reason = "pixel counts")]
        let u = s as f64 / steps as f64;
        let (x, y) = (x0 + u * (x1 - x0), y0 + u * (y1 - y0));
        if x >= 0.0 && y >= 0.0 {
            #[allow(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                reason = "checked non-negative"
            )]
            let (px, py) = (x.round() as u32, y.round() as u32);
            if px < img.width() && py < img.height() {
                img.put_pixel(px, py, color);
            }
        }
    }
}

fn fmt_tick(v: f64) -> String {
    if v.abs() >= 1e-2 && v.abs() < 1e4 {
        let s = format!("{v:.2}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

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
    img.save(path)
        .map_err(|e| format!("{}: cannot write the curve: {e}", path.display()))
}
