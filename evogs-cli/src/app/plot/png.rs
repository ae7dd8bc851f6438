//! Rendering a plot into an in-memory RGB buffer with `plotters`' bitmap backend, then writing
//! it as a PNG atomically ([`evogs::data::image_io::save_rgb8`]).

use plotters::coord::Shift;
use plotters::prelude::{BitMapBackend, DrawingArea, IntoDrawingArea, WHITE};

/// The drawing area `draw` paints on.
pub(super) type Area<'a> = DrawingArea<BitMapBackend<'a>, Shift>;

/// Renders a `width`×`height` plot with `draw` (on a white background, with the embedded
/// font registered) and writes it to `path`.
///
/// # Errors
/// A drawing error (as text), an encoding or an I/O failure.
pub(super) fn render_png(
    path: &std::path::Path,
    (width, height): (u32, u32),
    draw: impl FnOnce(&Area<'_>) -> Result<(), String>,
) -> Result<(), String> {
    super::font::register()?;
    let len = usize::try_from(u64::from(width) * u64::from(height) * 3)
        .map_err(|_| "plot too large".to_string())?;
    let mut buf = vec![0u8; len];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        draw(&root)?;
        root.present().map_err(|e| e.to_string())?;
    }
    let img = image::RgbImage::from_raw(width, height, buf)
        .ok_or_else(|| "plot buffer of the wrong size".to_string())?;
    evogs::data::image_io::save_rgb8(&img, path).map_err(|e| e.to_string())
}
