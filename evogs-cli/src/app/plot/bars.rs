//! Grouped bars: one group per labelled row, one bar per series, the value written on top.

use super::font::FAMILY;
use super::png::{Area, render_png};
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
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

/// The series' colours, in order (shared with the time plots).
pub(super) const COLORS: [RGBColor; 6] = [
    RGBColor(30, 90, 200),
    RGBColor(220, 110, 30),
    RGBColor(120, 120, 120),
    RGBColor(40, 160, 70),
    RGBColor(170, 50, 160),
    RGBColor(200, 40, 40),
];
const BAR_W: u32 = 26;
const GAP: u32 = 24;
/// Width of the y-axis tick labels.
const MARGIN_L: u32 = 70;
/// Room left of the tick labels for the rotated y-axis label (plotters draws it extending
/// left of its label area, so without this room it is clipped at the image's edge).
const Y_DESC_W: u32 = 2 * TEXT;
const MARGIN_T: u32 = 64;
const PLOT_H: u32 = 300;
const MARGIN_B: u32 = 44;
const TEXT: u32 = 12;

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// The width of `s` in the labels' font.
fn text_width(s: &str) -> u32 {
    (FAMILY, TEXT)
        .into_font()
        .box_size(s)
        .map_or(8 * u32::try_from(s.len()).unwrap_or(0), |b| b.0)
}

/// Draws grouped bars of `groups` (a bar per entry of `series`, coloured in order, with a
/// legend) under `title`, the y axis labelled `y_label`, and writes a PNG.
///
/// # Errors
/// Drawing, encoding or I/O failures.
pub fn save_bars(
    title: &str,
    y_label: &str,
    series: &[&str],
    groups: &[BarGroup],
    path: &Path,
) -> Result<(), String> {
    let fail = |e: String| format!("{}: cannot write the chart: {e}", path.display());
    super::font::register().map_err(fail)?;
    let n_series = u32::try_from(series.len().max(1)).unwrap_or(1);
    let label_w = groups
        .iter()
        .map(|g| text_width(&g.label).max(text_width(&g.sublabel)))
        .max()
        .unwrap_or(0);
    let group_w = (n_series * BAR_W).max(label_w) + GAP;
    let n_groups = u32::try_from(groups.len()).unwrap_or(0);
    let legend_w: u32 = series.iter().map(|s| text_width(s) + 30).sum();
    let width = Y_DESC_W + (MARGIN_L + n_groups * group_w + GAP).max(MARGIN_L + legend_w + 20);
    let height = MARGIN_T + PLOT_H + MARGIN_B;
    render_png(path, (width, height), |root| {
        let layout = Layout {
            group_w,
            n_series,
            plot_w: width - Y_DESC_W - MARGIN_L - GAP / 2,
        };
        draw(root, &layout, title, y_label, series, groups)
    })
    .map_err(fail)
}

/// Pixel sizes of a chart.
struct Layout {
    group_w: u32,
    n_series: u32,
    /// Width of the plotting area.
    plot_w: u32,
}

fn draw(
    root: &Area<'_>,
    layout: &Layout,
    title: &str,
    y_label: &str,
    series: &[&str],
    groups: &[BarGroup],
) -> Result<(), String> {
    let black = RGBColor(30, 30, 30);
    let text = TextStyle::from((FAMILY, TEXT)).color(&black);
    root.draw_text(
        title,
        &TextStyle::from((FAMILY, 16)).color(&black),
        ((Y_DESC_W + MARGIN_L) as i32, 8),
    )
    .map_err(err)?;
    let mut x = (Y_DESC_W + MARGIN_L) as i32;
    for (i, s) in series.iter().enumerate() {
        let c = COLORS[i % COLORS.len()];
        root.draw(&Rectangle::new([(x, 34), (x + 12, 45)], c.filled()))
            .map_err(err)?;
        root.draw_text(s, &text, (x + 16, 33)).map_err(err)?;
        x += i32::try_from(text_width(s) + 30).unwrap_or(0);
    }
    let values: Vec<f64> = groups
        .iter()
        .flat_map(|g| g.values.iter().flatten().copied())
        .filter(|v| v.is_finite())
        .collect();
    let (lo, hi) = axis_range(&values);
    let mut chart = ChartBuilder::on(root)
        .margin_top(MARGIN_T)
        .margin_left(Y_DESC_W)
        .margin_right(GAP / 2)
        .x_label_area_size(MARGIN_B)
        .y_label_area_size(MARGIN_L)
        .build_cartesian_2d(0.0..f64::from(layout.plot_w), lo..hi)
        .map_err(err)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .y_labels(6)
        .y_desc(y_label)
        .label_style(text.clone())
        .axis_desc_style(text.clone())
        .draw()
        .map_err(err)?;
    let bars_w = layout.n_series * BAR_W;
    let above = text.pos(Pos::new(HPos::Center, VPos::Bottom));
    let below = text.pos(Pos::new(HPos::Center, VPos::Top));
    for (gi, g) in groups.iter().enumerate() {
        let gx = GAP / 2 + u32::try_from(gi).unwrap_or(0) * layout.group_w;
        let bx0 = gx + (layout.group_w - GAP - bars_w) / 2;
        for (si, v) in g.values.iter().enumerate() {
            let Some(v) = v.filter(|v| v.is_finite()) else {
                continue;
            };
            let bx = f64::from(bx0 + u32::try_from(si).unwrap_or(0) * BAR_W);
            let top = v.clamp(lo, hi);
            chart
                .draw_series([Rectangle::new(
                    [(bx + 2.0, top), (bx + f64::from(BAR_W) - 2.0, lo)],
                    COLORS[si % COLORS.len()].filled(),
                )])
                .map_err(err)?;
            let (px, py) = chart.backend_coord(&(bx + f64::from(BAR_W) / 2.0, top));
            root.draw_text(&format!("{v:.1}"), &above, (px, py - 2))
                .map_err(err)?;
        }
        let cx = f64::from(gx + (layout.group_w - GAP) / 2);
        let (px, py) = chart.backend_coord(&(cx, lo));
        root.draw_text(&g.label, &below, (px, py + 6))
            .map_err(err)?;
        root.draw_text(&g.sublabel, &below, (px, py + 6 + TEXT as i32 + 2))
            .map_err(err)?;
    }
    Ok(())
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

    /// The number of bars of colour `c`: runs of it along the row just above the x axis,
    /// which every bar crosses and no text does (anti-aliased text has grey pixels too).
    fn bars_of(img: &image::RgbImage, c: RGBColor) -> usize {
        let c = image::Rgb([c.0, c.1, c.2]);
        let y = MARGIN_T + PLOT_H - 3;
        let mut runs = 0;
        let mut inside = false;
        for x in 0..img.width() {
            let on = *img.get_pixel(x, y) == c;
            runs += usize::from(on && !inside);
            inside = on;
        }
        runs
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
        assert_eq!(img.height(), MARGIN_T + PLOT_H + MARGIN_B, "height");
        assert!(img.width() >= MARGIN_L + 2 * 3 * BAR_W, "width");
        assert_eq!(bars_of(&img, COLORS[0]), 2, "two velocity bars");
        assert_eq!(bars_of(&img, COLORS[1]), 2, "two deformation bars");
        assert_eq!(bars_of(&img, COLORS[2]), 1, "one static bar");
        std::fs::remove_dir_all(&dir).ok();
    }
}
