//! Plots as PNG files, drawn with `plotters`: the training curve, the study's grouped bars,
//! and metrics against time. Text uses an embedded `DejaVu Sans` subset (no system font is looked up), and each
//! plot is rendered into memory and written atomically.

mod bars;
mod curve;
mod font;
mod png;
mod ticks;
mod time;

pub use bars::{BarGroup, save_bars};
pub use curve::save_curve;
pub use time::{TimePanel, TimeSeries, TrainingMarks, save_time_plot};
