//! The per-frame metrics as CSV: `metrics-<split>.csv`, a row per evaluated frame in
//! evaluation order, with the columns `time, camera, psnr, ssim, dynamic_psnr, dynamic_ssim,
//! mask_fraction` (a frame without a motion mask leaves the last three empty; a frame whose
//! mask is empty leaves the dynamic metrics empty and writes fraction 0).

use super::FrameMetrics;
use std::fmt::Write as _;

/// The CSV header line.
pub const CSV_HEADER: &str = "time,camera,psnr,ssim,dynamic_psnr,dynamic_ssim,mask_fraction";

/// The per-frame CSV of `frames` (header and a line per frame, full precision).
#[must_use]
pub fn frames_csv(frames: &[FrameMetrics]) -> String {
    let opt = |v: Option<f64>| v.map(|x| x.to_string()).unwrap_or_default();
    let mut s = String::from(CSV_HEADER);
    s.push('\n');
    for f in frames {
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{}",
            f.time,
            csv_field(&f.camera),
            f.psnr,
            f.ssim,
            opt(f.dynamic_psnr),
            opt(f.dynamic_ssim),
            opt(f.mask_fraction)
        );
    }
    s
}

/// A CSV field, quoted when it holds a comma, a quote or a line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}
