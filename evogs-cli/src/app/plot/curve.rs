//! The training curve as a PNG: loss (log scale) and training PSNR against iterations.

use super::font::FAMILY;
use super::png::{Area, render_png};
use super::ticks::{distinct_labels, log_ticks};
use evogs::train::trainer::LogRow;
use plotters::prelude::*;
use std::path::Path;

const W: u32 = 720;
const PANEL_H: u32 = 260;
const LOSS: RGBColor = RGBColor(200, 40, 40);
const PSNR: RGBColor = RGBColor(30, 90, 200);

/// The finite points of `ys` against `xs` (positive ones only for a log axis).
fn points(xs: &[u64], ys: &[f64], log: bool) -> Vec<(u64, f64)> {
    xs.iter()
        .zip(ys)
        .filter(|(_, y)| y.is_finite() && (!log || **y > 0.0))
        .map(|(&x, &y)| (x, y))
        .collect()
}

/// The iteration range of `pts` (at least one iteration wide).
fn x_range(pts: &[(u64, f64)]) -> std::ops::Range<u64> {
    let lo = pts.first().map_or(0, |p| p.0);
    let hi = pts.last().map_or(1, |p| p.0).max(lo + 1);
    lo..hi
}

/// The value range of `pts`, widened when flat (by half a unit, or a factor on a log axis).
fn y_range(pts: &[(u64, f64)], log: bool) -> (f64, f64) {
    let (lo, hi) = pts
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
            (a.min(p.1), b.max(p.1))
        });
    match (log, hi - lo > 1e-9 * hi.abs().max(1e-300)) {
        (_, true) => (lo, hi),
        (true, false) => (lo / 1.5, hi * 1.5),
        (false, false) => (lo - 0.5, hi + 0.5),
    }
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// The loss panel: a log axis with round ticks, labelled without repeats.
fn loss_panel(area: &Area<'_>, xs: &[u64], ys: &[f64]) -> Result<(), String> {
    let pts = points(xs, ys, true);
    let mut b = ChartBuilder::on(area);
    b.caption("loss (log scale)", (FAMILY, 16))
        .margin(10)
        .x_label_area_size(28)
        .y_label_area_size(64);
    if pts.is_empty() {
        return Ok(());
    }
    let (lo, hi) = y_range(&pts, true);
    let ticks = log_ticks(lo, hi);
    let labels = distinct_labels(&ticks);
    let label = |v: &f64| -> String {
        ticks
            .iter()
            .zip(&labels)
            .min_by(|a, b| (a.0 - v).abs().total_cmp(&(b.0 - v).abs()))
            .map(|(_, l)| l.clone())
            .unwrap_or_default()
    };
    let mut chart = b
        .build_cartesian_2d(
            x_range(&pts),
            (lo..hi).log_scale().with_key_points(ticks.clone()),
        )
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_labels(6)
        .y_label_formatter(&label)
        .label_style((FAMILY, 12))
        .draw()
        .map_err(err)?;
    chart
        .draw_series(LineSeries::new(pts, LOSS.stroke_width(2)))
        .map_err(err)?;
    Ok(())
}

/// The PSNR panel: a linear axis.
fn psnr_panel(area: &Area<'_>, xs: &[u64], ys: &[f64]) -> Result<(), String> {
    let pts = points(xs, ys, false);
    let mut b = ChartBuilder::on(area);
    b.caption("train PSNR (dB)", (FAMILY, 16))
        .margin(10)
        .x_label_area_size(28)
        .y_label_area_size(64);
    if pts.is_empty() {
        return Ok(());
    }
    let (lo, hi) = y_range(&pts, false);
    let mut chart = b.build_cartesian_2d(x_range(&pts), lo..hi).map_err(err)?;
    chart
        .configure_mesh()
        .x_labels(6)
        .y_labels(6)
        .label_style((FAMILY, 12))
        .draw()
        .map_err(err)?;
    chart
        .draw_series(LineSeries::new(pts, PSNR.stroke_width(2)))
        .map_err(err)?;
    Ok(())
}

/// Writes the loss and PSNR curves of a training log.
///
/// # Errors
/// Drawing, encoding or I/O failures.
pub fn save_curve(log: &[LogRow], path: &Path) -> Result<(), String> {
    let xs: Vec<u64> = log.iter().map(|r| r.iteration).collect();
    let loss: Vec<f64> = log.iter().map(|r| r.loss).collect();
    let psnr: Vec<f64> = log.iter().map(|r| r.psnr).collect();
    render_png(path, (W, 2 * PANEL_H), |root| {
        let (top, bottom) = root.split_vertically(PANEL_H);
        loss_panel(&top, &xs, &loss)?;
        psnr_panel(&bottom, &xs, &psnr)
    })
    .map_err(|e| format!("{}: cannot write the curve: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(iteration: u64, loss: f64, psnr: f64) -> LogRow {
        LogRow {
            iteration,
            loss,
            psnr,
            ..LogRow::default()
        }
    }

    #[test]
    fn a_curve_is_written_with_both_lines() {
        let dir = std::env::temp_dir().join(format!("evogs-curve-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("curve.png");
        let log: Vec<LogRow> = (1u32..=50)
            .map(|i| {
                let x = f64::from(i);
                row(u64::from(i) * 10, 0.2 / x, 15.0 + x.ln() * 3.0)
            })
            .collect();
        save_curve(&log, &path).expect("written");
        let img = image::open(&path).expect("readable PNG").to_rgb8();
        assert_eq!(img.dimensions(), (W, 2 * PANEL_H), "size");
        let near = |p: &image::Rgb<u8>, c: RGBColor| {
            p.0.iter()
                .zip([c.0, c.1, c.2])
                .all(|(&a, b)| a.abs_diff(b) < 30)
        };
        let top = img
            .enumerate_pixels()
            .filter(|(_, y, p)| *y < PANEL_H && near(p, LOSS))
            .count();
        let bottom = img
            .enumerate_pixels()
            .filter(|(_, y, p)| *y >= PANEL_H && near(p, PSNR))
            .count();
        assert!(
            top > 300,
            "the loss line is drawn in the top panel ({top} px)"
        );
        assert!(
            bottom > 300,
            "the PSNR line is drawn in the bottom panel ({bottom} px)"
        );
        let dark = img
            .pixels()
            .filter(|p| p.0.iter().all(|&c| c < 100))
            .count();
        assert!(dark > 500, "axes and labels are drawn ({dark} px)");
        // Flat, single-row and non-finite logs still give a picture.
        save_curve(&[row(1, 0.1, 20.0), row(2, 0.1, 20.0)], &path).expect("flat");
        save_curve(&[row(1, f64::NAN, f64::INFINITY)], &path).expect("nothing to draw");
        std::fs::remove_dir_all(&dir).ok();
    }
}
