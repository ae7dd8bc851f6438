//! Grouped bars: one group per labelled row, one bar per series, the value written on top.

use super::canvas::{fill, fmt_tick, line, text, text_width};
use image::{Rgb, RgbImage};
use std::path::Path;

/// One group of bars: a two-line label and a value per series (`None`: no bar).
#[derive(Clone, Debug, PartialEq)]
pub struct BarGroup {
    /// First label line (e.g. the protocol).
    pub label: String,
    /// Second label line (e.g. the held-out set).
    pub sublabel: String,
    /// One value per series, in the series' order.
    pub values: Vec<Option<f64>>,
}

const COLORS: [Rgb<u8>; 6] = [
    Rgb([30, 90, 200]),
    Rgb([220, 110, 30]),
    Rgb([120, 120, 120]),
    Rgb([40, 160, 70]),
    Rgb([170, 50, 160]),
    Rgb([200, 40, 40]),
];
const BAR_W: u32 = 26;
const GAP: u32 = 24;
const MARGIN_L: u32 = 60;
const MARGIN_T: u32 = 50;
const PLOT_H: u32 = 300;
const MARGIN_B: u32 = 40;

/// Draws grouped bars of `groups` (a bar per entry of `series`, coloured in order, with a
/// legend) under `title`, the y axis labelled `y_label`, and writes a PNG.
///
/// # Errors
/// Encoding or I/O failures.
pub fn save_bars(
    title: &str,
    y_label: &str,
    series: &[&str],
    groups: &[BarGroup],
    path: &Path,
) -> Result<(), String> {
    let n_series = u32::try_from(series.len().max(1)).unwrap_or(1);
    let label_w = groups
        .iter()
        .map(|g| text_width(&g.label).max(text_width(&g.sublabel)))
        .max()
        .unwrap_or(0);
    let group_w = (n_series * BAR_W).max(label_w) + GAP;
    let n_groups = u32::try_from(groups.len()).unwrap_or(0);
    let legend_w: u32 = series.iter().map(|s| text_width(s) + 30).sum();
    let width = (MARGIN_L + n_groups * group_w + GAP).max(MARGIN_L + legend_w + 20);
    let height = MARGIN_T + PLOT_H + MARGIN_B;
    let mut img = RgbImage::from_pixel(width, height, Rgb([255, 255, 255]));
    let black = Rgb([30, 30, 30]);
    let grey = Rgb([215, 215, 215]);
    text(&mut img, MARGIN_L, 8, title, black);
    let mut x = MARGIN_L;
    for (i, s) in series.iter().enumerate() {
        let c = COLORS[i % COLORS.len()];
        fill(&mut img, (x, 24), (x + 12, 31), c);
        text(&mut img, x + 16, 24, s, black);
        x += text_width(s) + 30;
    }
    let values: Vec<f64> = groups
        .iter()
        .flat_map(|g| g.values.iter().flatten().copied())
        .filter(|v| v.is_finite())
        .collect();
    let (lo, hi) = axis_range(&values);
    let (y0, y1) = (f64::from(MARGIN_T), f64::from(MARGIN_T + PLOT_H));
    let py = |v: f64| y1 - (v - lo) / (hi - lo) * (y1 - y0);
    let (x0, x1) = (f64::from(MARGIN_L), f64::from(width - GAP / 2));
    for k in 0..=5 {
        let v = lo + (hi - lo) * f64::from(k) / 5.0;
        line(&mut img, (x0, py(v)), (x1, py(v)), grey);
        #[allow(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "inside the image"
        )]
        text(
            &mut img,
            4,
            (py(v) as u32).saturating_sub(3),
            &fmt_tick(v),
            black,
        );
    }
    text(&mut img, 4, MARGIN_T - 14, y_label, black);
    for (gi, g) in groups.iter().enumerate() {
        let gx = MARGIN_L + GAP / 2 + u32::try_from(gi).unwrap_or(0) * group_w;
        let bars_w = n_series * BAR_W;
        let bx0 = gx + (group_w - GAP - bars_w) / 2;
        for (si, v) in g.values.iter().enumerate() {
            let Some(v) = v.filter(|v| v.is_finite()) else {
                continue;
            };
            let bx = bx0 + u32::try_from(si).unwrap_or(0) * BAR_W;
            #[allow(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                reason = "clamped inside the plot"
            )]
            let top = py(v.clamp(lo, hi)).round() as u32;
            fill(
                &mut img,
                (bx + 2, top),
                (bx + BAR_W - 2, MARGIN_T + PLOT_H),
                COLORS[si % COLORS.len()],
            );
            let label = format!("{v:.1}");
            let lx = (bx + BAR_W / 2).saturating_sub(text_width(&label) / 2);
            text(&mut img, lx, top.saturating_sub(10), &label, black);
        }
        let cx = gx + (group_w - GAP) / 2;
        let ly = MARGIN_T + PLOT_H + 8;
        text(
            &mut img,
            cx.saturating_sub(text_width(&g.label) / 2),
            ly,
            &g.label,
            black,
        );
        text(
            &mut img,
            cx.saturating_sub(text_width(&g.sublabel) / 2),
            ly + 11,
            &g.sublabel,
            black,
        );
    }
    line(&mut img, (x0, y0), (x0, y1), black);
    line(&mut img, (x0, y1), (x1, y1), black);
    crate::data::image_io::save_rgb8(&img, path)
        .map_err(|e| format!("{}: cannot write the chart: {e}", path.display()))
}

/// A y range that shows the differences between the bars: from a whole number below the
/// smallest value (by a tenth of the spread, at least 1) to one above the largest.
fn axis_range(values: &[f64]) -> (f64, f64) {
    let (mn, mx) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    if !mn.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((mx - mn) * 0.1).max(1.0);
    let lo = (mn - pad).floor().max(0.0);
    let hi = (mx + pad).ceil();
    if hi - lo < 1e-9 {
        (lo, lo + 1.0)
    } else {
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_axis_holds_every_bar_with_room_above() {
        let (lo, hi) = axis_range(&[22.3, 25.9, 18.4]);
        assert!(lo <= 18.4 - 1.0 && hi >= 25.9 + 0.5, "({lo}, {hi})");
        assert!(lo >= 0.0, "PSNR axes start at or above 0");
        assert_eq!(axis_range(&[]), (0.0, 1.0), "no values");
    }

    #[test]
    fn a_chart_is_written_with_one_bar_per_value() {
        let dir = std::env::temp_dir().join(format!("evogs-bars-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("bars.png");
        let groups = vec![
            BarGroup {
                label: "full".into(),
                sublabel: "test".into(),
                values: vec![Some(25.0), Some(24.0), None],
            },
            BarGroup {
                label: "future:0.75".into(),
                sublabel: "test t > 0.75".into(),
                values: vec![Some(21.0), Some(20.5), Some(18.0)],
            },
        ];
        save_bars(
            "PSNR",
            "dB",
            &["velocity", "deformation", "static"],
            &groups,
            &path,
        )
        .expect("written");
        let img = image::open(&path).expect("readable PNG").to_rgb8();
        // The first series' colour appears (its bars are drawn) and so does the third's
        // (one bar, in the second group).
        let count = |c: Rgb<u8>| img.pixels().filter(|p| **p == c).count();
        assert!(count(COLORS[0]) > 2 * 200, "two velocity bars");
        assert!(count(COLORS[2]) > 100, "one static bar");
        std::fs::remove_dir_all(&dir).ok();
    }
}
