//! The plots' font: a subset of `DejaVu Sans` 2.37 (printable ASCII and a few symbols),
//! embedded in the binary and registered with `plotters` as its `sans-serif` family, so the
//! plots look the same on every machine and need no system font. Provenance and licence:
//! `evogs-cli/assets/fonts/`.

use plotters::style::FontStyle;
use std::sync::OnceLock;

/// The font family name the plots ask for.
pub(super) const FAMILY: &str = "sans-serif";

/// The embedded font file.
const DEJAVU_SANS: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans-subset.ttf");

/// Registers the embedded font (once per process).
///
/// # Errors
/// The embedded file is not a font `ab_glyph` can read (a build problem, not an input one).
pub(super) fn register() -> Result<(), String> {
    static DONE: OnceLock<bool> = OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        plotters::style::register_font(FAMILY, FontStyle::Normal, DEJAVU_SANS).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err("the embedded plot font cannot be read".into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_font_registers() {
        register().expect("readable font");
        register().expect("twice");
    }
}
