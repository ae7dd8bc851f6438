//! PNG input and output (written atomically, [`crate::atomic`]), alpha compositing and box
//! downscaling.

use crate::atomic::AtomicFile;
use evogs_splat::Image;
use image::{ColorType, ImageReader};
use std::path::Path;

/// Why an image could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum ImageIoError {
    /// The file is missing or unreadable.
    #[error("{path}: cannot read image: {msg}")]
    Read {
        /// File.
        path: String,
        /// Cause.
        msg: String,
    },
    /// The file decodes to a colour type we do not accept.
    #[error("{path}: unsupported PNG ({msg})")]
    Unsupported {
        /// File.
        path: String,
        /// What is unsupported.
        msg: String,
    },
    /// The file could not be written.
    #[error("{path}: cannot write image: {msg}")]
    Write {
        /// File.
        path: String,
        /// Cause.
        msg: String,
    },
}

/// Loads a PNG (8- or 16-bit gray, gray+alpha, RGB or RGBA) as RGB in [0, 1], compositing any
/// alpha onto `background`: `rgb·a + bg·(1 − a)`.
///
/// # Errors
/// A missing, corrupt or non-PNG file, or an unsupported colour type.
pub fn load_png_rgb(path: &Path, background: [f32; 3]) -> Result<Image<f32>, ImageIoError> {
    let p = path.display().to_string();
    // A FIFO would block the decoder, a device never end: only regular files are opened.
    crate::bounded::regular_file_size(path, "an image").map_err(|e| ImageIoError::Read {
        path: p.clone(),
        msg: match e {
            crate::bounded::ReadError::NotAFile { kind, .. } => format!("it is {kind}, not a file"),
            crate::bounded::ReadError::Io { source, .. } => source.to_string(),
            other => other.to_string(),
        },
    })?;
    let reader = ImageReader::open(path)
        .map_err(|e| ImageIoError::Read {
            path: p.clone(),
            msg: e.to_string(),
        })?
        .with_guessed_format()
        .map_err(|e| ImageIoError::Read {
            path: p.clone(),
            msg: e.to_string(),
        })?;
    if reader.format() != Some(image::ImageFormat::Png) {
        return Err(ImageIoError::Unsupported {
            path: p,
            msg: "not a PNG file".into(),
        });
    }
    let img = reader.decode().map_err(|e| ImageIoError::Read {
        path: p.clone(),
        msg: e.to_string(),
    })?;
    match img.color() {
        ColorType::L8 | ColorType::La8 | ColorType::Rgb8 | ColorType::Rgba8 => {}
        ColorType::L16 | ColorType::La16 | ColorType::Rgb16 | ColorType::Rgba16 => {}
        other => {
            return Err(ImageIoError::Unsupported {
                path: p,
                msg: format!("colour type {other:?}"),
            });
        }
    }
    let rgba = img.to_rgba32f();
    let (w, h) = (rgba.width() as usize, rgba.height() as usize);
    let mut out = Image::new(w, h);
    for (dst, px) in out.data_mut().chunks_exact_mut(3).zip(rgba.pixels()) {
        let a = px[3];
        for c in 0..3 {
            dst[c] = px[c] * a + background[c] * (1.0 - a);
        }
    }
    Ok(out)
}

/// How an image file becomes a view's image: RGB in [0, 1] with any alpha composited onto
/// `background`, then box-downscaled by `downscale` ([`load_png_rgb`], [`downscale`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameDecode {
    /// Background the alpha is composited onto (opaque RGB frames ignore it).
    pub background: [f32; 3],
    /// Integer box-downscale factor from the file to the view (1: none).
    pub downscale: usize,
}

impl Default for FrameDecode {
    fn default() -> Self {
        Self {
            background: [1.0; 3],
            downscale: 1,
        }
    }
}

impl FrameDecode {
    /// Decodes `path`.
    ///
    /// # Errors
    /// As [`load_png_rgb`].
    pub fn decode(&self, path: &Path) -> Result<Image<f32>, ImageIoError> {
        let img = load_png_rgb(path, self.background)?;
        Ok(if self.downscale > 1 {
            downscale(&img, self.downscale)
        } else {
            img
        })
    }
}

/// Box-filter downscale by an integer factor (the mean of each `f×f` block); trailing rows and
/// columns that do not fill a block are dropped.
#[must_use]
pub fn downscale(img: &Image<f32>, factor: usize) -> Image<f32> {
    if factor <= 1 {
        return img.clone();
    }
    let (w, h) = (img.width() / factor, img.height() / factor);
    let mut out = Image::new(w, h);
    let inv = 1.0 / (factor * factor) as f32;
    for y in 0..h {
        for x in 0..w {
            let mut acc = [0.0_f32; 3];
            for dy in 0..factor {
                for dx in 0..factor {
                    let p = img.get(x * factor + dx, y * factor + dy);
                    for c in 0..3 {
                        acc[c] += p[c];
                    }
                }
            }
            out.set(x, y, [acc[0] * inv, acc[1] * inv, acc[2] * inv]);
        }
    }
    out
}

/// Quantises to 8-bit RGB (clamped to [0, 1], rounded).
#[must_use]
pub fn to_rgb8(img: &Image<f32>) -> Vec<u8> {
    img.data()
        .iter()
        .map(|v| {
            #[allow(clippy::cast_possible_truncation, reason = "clamped to [0, 255]")]
            let b = (v.clamp(0.0, 1.0) * 255.0).round() as u8;
            b
        })
        .collect()
}

/// Writes an 8-bit RGB PNG (values clamped to [0, 1]), atomically.
///
/// # Errors
/// I/O or encoding failures.
pub fn save_png(img: &Image<f32>, path: &Path) -> Result<(), ImageIoError> {
    let buf = image::RgbImage::from_raw(
        u32::try_from(img.width()).unwrap_or(u32::MAX),
        u32::try_from(img.height()).unwrap_or(u32::MAX),
        to_rgb8(img),
    )
    .ok_or_else(|| ImageIoError::Write {
        path: path.display().to_string(),
        msg: "bad image size".into(),
    })?;
    save_rgb8(&buf, path)
}

/// Writes an 8-bit RGB image as a PNG, atomically.
///
/// # Errors
/// I/O or encoding failures.
pub fn save_rgb8(img: &image::RgbImage, path: &Path) -> Result<(), ImageIoError> {
    use image::ImageEncoder as _;
    let err = |msg: String| ImageIoError::Write {
        path: path.display().to_string(),
        msg,
    };
    let mut file = AtomicFile::create(path).map_err(|e| err(e.to_string()))?;
    image::codecs::png::PngEncoder::new(&mut file)
        .write_image(
            img.as_raw(),
            img.width(),
            img.height(),
            image::ExtendedColorType::Rgb8,
        )
        .map_err(|e| err(e.to_string()))?;
    file.commit().map_err(|e| err(e.to_string()))
}

#[cfg(test)]
#[allow(
    clippy::float_cmp,
    reason = "values exactly representable in 8 bits round-trip exactly"
)]
mod tests {
    use super::*;

    #[test]
    fn png_round_trip_and_compositing() {
        let dir = std::env::temp_dir().join(format!("evogs-img-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        // A 2x1 RGBA PNG: opaque red, and fully transparent.
        let rgba =
            image::RgbaImage::from_raw(2, 1, vec![255, 0, 0, 255, 0, 255, 0, 0]).expect("buffer");
        let p = dir.join("a.png");
        rgba.save(&p).expect("save");
        let img = load_png_rgb(&p, [1.0, 1.0, 1.0]).expect("load");
        assert_eq!(img.get(0, 0), [1.0, 0.0, 0.0], "opaque pixel kept");
        assert_eq!(
            img.get(1, 0),
            [1.0, 1.0, 1.0],
            "transparent pixel shows the background"
        );
        let q = dir.join("b.png");
        save_png(&img, &q).expect("save");
        assert_eq!(
            load_png_rgb(&q, [0.0; 3]).expect("reload"),
            img,
            "8-bit round trip of exact values"
        );
        std::fs::write(dir.join("c.png"), b"not a png").expect("write");
        let e = load_png_rgb(&dir.join("c.png"), [0.0; 3]).expect_err("garbage must fail");
        assert!(e.to_string().contains("c.png"), "error names the file: {e}");
        std::fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn downscale_averages_blocks() {
        let mut img = Image::new(4, 2);
        img.set(0, 0, [1.0, 0.0, 0.0]);
        img.set(1, 1, [1.0, 0.0, 0.0]);
        let d = downscale(&img, 2);
        assert_eq!((d.width(), d.height()), (2, 1), "size");
        assert!((d.get(0, 0)[0] - 0.5).abs() < 1e-7, "mean of the block");
    }
}
