//! Metrics against time: one panel per metric (e.g. whole-image and dynamic-region PSNR), a
//! line per series (points at the evaluated frames' times), the training window shaded and
//! the training times as ticks along the bottom of each panel.

use super::bars::COLORS;
use super::font::FAMILY;
use super::png::{Area, render_png};
use plotters::prelude::*;
use std::path::Path;

const W: u32 = 760;
const PANEL_H: u32 = 290;
const HEADER_H: u32 = 44;
/// Shade of the training window.
const WINDOW: RGBColor = RGBColor(225, 238, 225);
/// Height of the legend row above each panel.
const LEGEND_H: u32 = 26;
/// Where the legend row starts and its middle line (panel coordinates).
const LEGEND_X: i32 = 90;
const LEGEND_Y: i32 = 14;
/// Colour of the training-time ticks.
const TICK: RGBColor = RGBColor(40, 130, 60);

/// One line: a name and `(time, value)` points (non-finite values are skipped).
#[derive(Clone, Debug, PartialEq)]
pub struct TimeSeries {
    /// The legend's name.
    pub name: String,
    /// Points, in any order (drawn sorted by time).
    pub points: Vec<(f64, f64)>,
}

/// One panel: a y-axis label and its lines (coloured by their index, as the bars are).
#[derive(Clone, Debug, PartialEq)]
pub struct TimePanel {
    /// The y axis (e.g. `PSNR (dB)`).
    pub y_label: String,
    /// The lines.
    pub series: Vec<TimeSeries>,
}

/// What the run trained on, marked on every panel.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TrainingMarks {
    /// The smallest and largest supervised time (shaded).
    pub window: Option<(f64, f64)>,
    /// The distinct supervised times (ticks).
    pub times: Vec<f64>,
}

/// The width of `s` in the legend's font.
fn text_width(s: &str) -> u32 {
    (FAMILY, 12)
        .into_font()
        .box_size(s)
        .map_or(7 * u32::try_from(s.len()).unwrap_or(0), |b| b.0)
}

fn err(e: impl std::fmt::Display) -> String {
    e.to_string()
}

/// The finite points of a series, sorted by time.
fn sorted(s: &TimeSeries) -> Vec<(f64, f64)> {
    let mut p: Vec<(f64, f64)> = s
        .points
        .iter()
        .copied()
        .filter(|(t, v)| t.is_finite() && v.is_finite())
        .collect();
    p.sort_by(|a, b| a.0.total_cmp(&b.0));
    p
}

/// The x range: the frames' times and the training window, at least [0, 1] wide enough.
fn x_range(panels: &[TimePanel], marks: &TrainingMarks) -> (f64, f64) {
    let mut lo = 0.0f64;
    let mut hi = 1.0f64;
    for s in panels.iter().flat_map(|p| &p.series) {
        for (t, _) in sorted(s) {
            lo = lo.min(t);
            hi = hi.max(t);
        }
    }
    if let Some((a, b)) = marks.window {
        lo = lo.min(a);
        hi = hi.max(b);
    }
    let pad = 0.02 * (hi - lo);
    (lo - pad, hi + pad)
}

/// The y range of a panel's values, padded (half a unit at least).
fn y_range(p: &TimePanel) -> (f64, f64) {
    let (lo, hi) = p
        .series
        .iter()
        .flat_map(sorted)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), (_, v)| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = ((hi - lo) * 0.08).max(0.5);
    (lo - pad, hi + pad)
}

/// Draws `panels` stacked under `title` against time, with the training marks, and writes a
/// PNG.
///
/// # Errors
/// Drawing, encoding or I/O failures.
pub fn save_time_plot(
    title: &str,
    panels: &[TimePanel],
    marks: &TrainingMarks,
    path: &Path,
) -> Result<(), String> {
    let n = u32::try_from(panels.len().max(1)).unwrap_or(1);
    render_png(path, (W, HEADER_H + n * PANEL_H), |root| {
        let black = RGBColor(30, 30, 30);
        root.draw_text(title, &TextStyle::from((FAMILY, 16)).color(&black), (12, 8))
            .map_err(err)?;
        let note = match marks.window {
            Some((a, b)) => format!(
                "shaded: training window [{a:.3}, {b:.3}]; green ticks: the {} training times",
                marks.times.len()
            ),
            None => String::from("no training times known"),
        };
        root.draw_text(
            &note,
            &TextStyle::from((FAMILY, 12)).color(&black),
            (12, 27),
        )
        .map_err(err)?;
        let (_, body) = root.split_vertically(HEADER_H);
        let xr = x_range(panels, marks);
        for (i, area) in body
            .split_evenly((panels.len().max(1), 1))
            .iter()
            .enumerate()
        {
            if let Some(p) = panels.get(i) {
                panel(area, p, marks, xr)?;
            }
        }
        Ok(())
    })
    .map_err(|e| format!("{}: cannot write the plot: {e}", path.display()))
}

fn panel(
    area: &Area<'_>,
    p: &TimePanel,
    marks: &TrainingMarks,
    (x0, x1): (f64, f64),
) -> Result<(), String> {
    let (y0, y1) = y_range(p);
    let text = TextStyle::from((FAMILY, 12)).color(&RGBColor(30, 30, 30));
    let mut chart = ChartBuilder::on(area)
        .margin(10)
        .margin_top(LEGEND_H)
        .margin_left(14)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(err)?;
    if let Some((a, b)) = marks.window {
        chart
            .draw_series([Rectangle::new([(a, y0), (b, y1)], WINDOW.filled())])
            .map_err(err)?;
    }
    chart
        .configure_mesh()
        .x_labels(8)
        .y_labels(6)
        .x_desc("time")
        .y_desc(p.y_label.as_str())
        .label_style(text.clone())
        .axis_desc_style(text.clone())
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(err)?;
    let tick = (y1 - y0) * 0.05;
    chart
        .draw_series(
            marks
                .times
                .iter()
                .map(|&t| PathElement::new(vec![(t, y0), (t, y0 + tick)], TICK.stroke_width(2))),
        )
        .map_err(err)?;
    for (k, s) in p.series.iter().enumerate() {
        let c = COLORS[k % COLORS.len()];
        let pts = sorted(s);
        chart
            .draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))
            .map_err(err)?
            .label(s.name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], c.stroke_width(2)));
        chart
            .draw_series(pts.iter().map(|&q| Circle::new(q, 3, c.filled())))
            .map_err(err)?;
    }
    // The legend, in a row above the panel (never over the data).
    let mut x = LEGEND_X;
    for (k, s) in p.series.iter().enumerate() {
        let c = COLORS[k % COLORS.len()];
        area.draw(&PathElement::new(
            vec![(x, LEGEND_Y), (x + 18, LEGEND_Y)],
            c.stroke_width(3),
        ))
        .map_err(err)?;
        area.draw(&Circle::new((x + 9, LEGEND_Y), 3, c.filled()))
            .map_err(err)?;
        area.draw_text(&s.name, &text, (x + 24, LEGEND_Y - 7))
            .map_err(err)?;
        x += 24 + i32::try_from(text_width(&s.name)).unwrap_or(60) + 18;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn near(p: &image::Rgb<u8>, c: RGBColor) -> bool {
        p.0.iter()
            .zip([c.0, c.1, c.2])
            .all(|(&a, b)| a.abs_diff(b) < 30)
    }

    #[test]
    fn a_time_plot_has_its_lines_window_and_ticks() {
        let dir = std::env::temp_dir().join(format!("evogs-time-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("time.png");
        let line = |name: &str, f: fn(f64) -> f64| TimeSeries {
            name: name.into(),
            points: (0..=20)
                .map(|k| {
                    let t = f64::from(k) / 20.0;
                    (t, f(t))
                })
                .collect(),
        };
        let panels = vec![
            TimePanel {
                y_label: "PSNR (dB)".into(),
                series: vec![
                    line("velocity", |t| 25.0 - 4.0 * t),
                    line("static", |_| 22.0),
                ],
            },
            TimePanel {
                y_label: "dynamic-region PSNR (dB)".into(),
                series: vec![line("velocity", |t| 18.0 - t), line("static", |_| 12.0)],
            },
        ];
        let marks = TrainingMarks {
            window: Some((0.0, 0.75)),
            times: vec![0.0, 0.25, 0.5, 0.75],
        };
        save_time_plot("PSNR against time", &panels, &marks, &path).expect("written");
        let img = image::open(&path).expect("readable PNG").to_rgb8();
        assert_eq!(img.dimensions(), (W, HEADER_H + 2 * PANEL_H), "size");
        let count = |c: RGBColor, top: bool| {
            img.enumerate_pixels()
                .filter(|(_, y, p)| ((*y < HEADER_H + PANEL_H) == top) && near(p, c))
                .count()
        };
        for top in [true, false] {
            assert!(count(COLORS[0], top) > 200, "first line (top {top})");
            assert!(count(COLORS[1], top) > 200, "second line (top {top})");
            assert!(count(WINDOW, top) > 5000, "the window (top {top})");
            assert!(count(TICK, top) > 20, "the ticks (top {top})");
        }
        // Nothing to draw still gives a picture.
        save_time_plot("empty", &[], &TrainingMarks::default(), &path).expect("empty");
        std::fs::remove_dir_all(&dir).ok();
    }
}
