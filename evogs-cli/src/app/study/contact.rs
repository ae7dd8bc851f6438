//! The contact sheet of a `future:TAU` protocol: a few held-out frames after the window
//! (evenly spread over the future split, else over the test views after `TAU`), one column
//! each; the first row is the ground truth, then one row per motion in the study's order
//! (its first seed's run). `OUT/study-contact-<protocol>.png`, 4-pixel white gutters.

use super::protocol::{HeldOutSet, StudyProtocol};
use super::runner::PlannedRun;
use crate::app::error::CommandError;
use crate::app::paths::RunFolder;
use evogs::data::Dataset;
use evogs::eval::render_frame;
use evogs::model::Motion;
use evogs::run::checkpoint;
use evogs_math::Par;
use evogs_splat::{Image, PinholeCamera, Splats};
use std::path::{Path, PathBuf};

/// Columns of the sheet (fewer when the set has fewer frames).
const COLUMNS: usize = 4;
/// Gutter between tiles (pixels).
const GUTTER: usize = 4;

/// Writes the contact sheet of protocol `p` (a future protocol whose runs are finished) and
/// returns its path; `None` for other protocols or when no held-out frame lies after the
/// window.
///
/// # Errors
/// A checkpoint or image that cannot be read, or the sheet that cannot be written.
pub(super) fn contact_sheet(
    p: StudyProtocol,
    runs: &[PlannedRun],
    ds: &Dataset,
    sets: &[HeldOutSet],
    motions: &[Motion],
    background: [f32; 3],
    out: &Path,
) -> Result<Option<PathBuf>, CommandError> {
    let StudyProtocol::Future(tau) = p else {
        return Ok(None);
    };
    let beyond = format!("test t > {tau}");
    let Some(set) = sets
        .iter()
        .find(|s| s.name == "future split")
        .or_else(|| sets.iter().find(|s| s.name == beyond))
    else {
        return Ok(None);
    };
    let views = set.views(ds);
    if views.is_empty() {
        return Ok(None);
    }
    let n = views.len().min(COLUMNS);
    let picks: Vec<_> = (0..n)
        .map(|k| views[k * (views.len() - 1) / (n - 1).max(1)])
        .collect();
    let mut rows: Vec<Vec<Image<f32>>> = Vec::new();
    let mut cameras: Vec<PinholeCamera<f32>> = Vec::new();
    let mut truth = Vec::new();
    for v in &picks {
        let img = v
            .image_or_decode()
            .map_err(|e| CommandError::at(&v.file, e.to_string()))?;
        truth.push(img.as_ref().clone());
        cameras.push(v.camera().map_err(|e| CommandError::at(&v.file, e))?);
    }
    rows.push(truth);
    for &m in motions {
        let Some(run) = runs
            .iter()
            .find(|r| r.protocol == p && r.motion == m && r.repeat == 0)
        else {
            continue;
        };
        let path = RunFolder::new(&run.args.out).checkpoint();
        let mut model = checkpoint::load_model(&path)
            .map_err(|e| CommandError::at(&path, e.to_string()))?
            .model;
        model.set_par(Par::best());
        let mut scratch = Splats::default();
        rows.push(
            picks
                .iter()
                .zip(&cameras)
                .map(|(v, cam)| {
                    render_frame(
                        &mut model,
                        cam,
                        v.time,
                        background,
                        Par::best(),
                        &mut scratch,
                    )
                })
                .collect(),
        );
    }
    let path = out.join(format!("study-contact-{}.png", p.slug()));
    save_grid(&rows, &path)?;
    Ok(Some(path))
}

/// Tiles `rows` (every image the size of the first) into one PNG with white gutters.
fn save_grid(rows: &[Vec<Image<f32>>], path: &Path) -> Result<(), CommandError> {
    let (w, h) = (rows[0][0].width(), rows[0][0].height());
    let cols = rows.iter().map(Vec::len).max().unwrap_or(0);
    let width = cols * w + (cols + 1) * GUTTER;
    let height = rows.len() * h + (rows.len() + 1) * GUTTER;
    let mut buf = vec![255_u8; 3 * width * height];
    for (r, row) in rows.iter().enumerate() {
        for (c, img) in row.iter().enumerate() {
            let (x0, y0) = (GUTTER + c * (w + GUTTER), GUTTER + r * (h + GUTTER));
            for y in 0..h.min(img.height()) {
                for x in 0..w.min(img.width()) {
                    let at = 3 * ((y0 + y) * width + x0 + x);
                    for (k, v) in img.get(x, y).into_iter().enumerate() {
                        #[allow(
                            clippy::cast_possible_truncation,
                            clippy::cast_sign_loss,
                            reason = "8-bit colour of a value clamped to [0, 1]"
                        )]
                        let byte = (v.clamp(0.0, 1.0) * 255.0).round() as u8;
                        buf[at + k] = byte;
                    }
                }
            }
        }
    }
    let too_big = || CommandError::at(path, "the contact sheet is too large".to_string());
    let sheet = image::RgbImage::from_raw(
        u32::try_from(width).map_err(|_| too_big())?,
        u32::try_from(height).map_err(|_| too_big())?,
        buf,
    )
    .ok_or_else(too_big)?;
    evogs::data::image_io::save_rgb8(&sheet, path)
        .map_err(|e| CommandError::at(path, e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_tiles_rows_and_columns_with_white_gutters() {
        let tile = |v: f32| Image::filled(3, 2, [v, 0.5, 1.0]);
        let rows = vec![vec![tile(0.0), tile(0.2)], vec![tile(0.6)]];
        let path = std::env::temp_dir().join(format!("evogs-contact-{}.png", std::process::id()));
        save_grid(&rows, &path).expect("written");
        let img = image::open(&path).expect("a PNG").to_rgb8();
        let _ = std::fs::remove_file(&path);
        assert_eq!(img.dimensions(), (2 * 3 + 3 * 4, 2 * 2 + 3 * 4), "size");
        assert_eq!(img.get_pixel(0, 0).0, [255, 255, 255], "gutter");
        assert_eq!(img.get_pixel(4, 4).0, [0, 128, 255], "row 0, column 0");
        assert_eq!(
            img.get_pixel(4 + 3 + 4, 4).0,
            [51, 128, 255],
            "row 0, column 1"
        );
        assert_eq!(
            img.get_pixel(4, 4 + 2 + 4).0,
            [153, 128, 255],
            "row 1, column 0"
        );
        assert_eq!(
            img.get_pixel(11, 10).0,
            [255, 255, 255],
            "an empty cell stays white"
        );
    }
}
