//! Plots as PNG files: the training curve and the study's grouped bars.

mod bars;
mod canvas;
mod curve;

pub use bars::{BarGroup, save_bars};
pub use curve::save_curve;
