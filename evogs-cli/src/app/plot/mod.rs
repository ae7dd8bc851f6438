//! Plots as PNG files, drawn with `plotters`: the training curve and the study's grouped
//! bars. Text uses an embedded `DejaVu Sans` subset (no system font is looked up), and each
//! plot is rendered into memory and written atomically.

mod bars;
mod curve;
mod font;
mod png;
mod ticks;

pub use bars::{BarGroup, save_bars};
pub use curve::save_curve;
