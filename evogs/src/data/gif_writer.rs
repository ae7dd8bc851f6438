//! Animated GIFs written one frame at a time: nothing but the encoder's buffers is kept, so
//! a render of any length runs in constant memory, and the file appears under its name
//! only when the last frame is in ([`crate::atomic`]).

use super::image_io::{ImageIoError, to_rgb8};
use crate::atomic::AtomicFile;
use evogs_splat::Image;
use std::path::Path;

/// A looping GIF being written frame by frame; [`finish`](Self::finish) completes it,
/// dropping it unfinished leaves no file.
///
/// ```
/// use evogs::data::gif_writer::GifWriter;
/// use evogs_splat::Image;
/// let dir = std::env::temp_dir().join(format!("evogs-gif-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// let path = dir.join("a.gif");
/// let mut gif = GifWriter::create(&path, 80).unwrap();
/// for k in 0..3 {
///     let mut img = Image::new(4, 2);
///     img.set(k, 0, [1.0, 0.0, 0.0]);
///     gif.push(&img).unwrap();
/// }
/// assert!(!path.exists()); // not before the end
/// gif.finish().unwrap();
/// assert!(std::fs::read(&path).unwrap().starts_with(b"GIF89a"));
/// std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub struct GifWriter {
    path: String,
    delay_cs: u16,
    size: Option<(u16, u16)>,
    encoder: Option<gif::Encoder<AtomicFile>>,
    file: Option<AtomicFile>,
}

impl std::fmt::Debug for GifWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GifWriter")
            .field("path", &self.path)
            .field("size", &self.size)
            .finish_non_exhaustive()
    }
}

impl GifWriter {
    /// Starts a GIF at `path` (whose folder must exist) showing each frame `delay_ms`.
    ///
    /// # Errors
    /// The temporary file cannot be created.
    pub fn create(path: &Path, delay_ms: u32) -> Result<Self, ImageIoError> {
        let file = AtomicFile::create(path).map_err(|e| ImageIoError::Write {
            path: path.display().to_string(),
            msg: e.to_string(),
        })?;
        Ok(Self {
            path: path.display().to_string(),
            delay_cs: u16::try_from(delay_ms.div_ceil(10)).unwrap_or(u16::MAX),
            size: None,
            encoder: None,
            file: Some(file),
        })
    }

    fn err(&self, msg: impl ToString) -> ImageIoError {
        ImageIoError::Write {
            path: self.path.clone(),
            msg: msg.to_string(),
        }
    }

    /// Appends a frame (values clamped to [0, 1]); every frame has the first one's size.
    ///
    /// # Errors
    /// A frame of another size or larger than 65535 pixels a side, or an I/O failure.
    pub fn push(&mut self, img: &Image<f32>) -> Result<(), ImageIoError> {
        let (w, h) = match (u16::try_from(img.width()), u16::try_from(img.height())) {
            (Ok(w), Ok(h)) if w > 0 && h > 0 => (w, h),
            _ => {
                return Err(self.err(format!(
                    "a {}x{} frame cannot be a GIF frame (1 to 65535 pixels a side)",
                    img.width(),
                    img.height()
                )));
            }
        };
        if self.encoder.is_none() {
            let file = self
                .file
                .take()
                .ok_or_else(|| self.err("already finished"))?;
            let mut enc = gif::Encoder::new(file, w, h, &[]).map_err(|e| self.err(e))?;
            enc.set_repeat(gif::Repeat::Infinite)
                .map_err(|e| self.err(e))?;
            self.encoder = Some(enc);
            self.size = Some((w, h));
        }
        if self.size != Some((w, h)) {
            let (w0, h0) = self.size.unwrap_or_default();
            return Err(self.err(format!(
                "GIF frames differ in size ({w0}x{h0}, then {w}x{h})"
            )));
        }
        let mut frame = gif::Frame::from_rgb_speed(w, h, &to_rgb8(img), 10);
        frame.delay = self.delay_cs;
        let Some(enc) = self.encoder.as_mut() else {
            return Err(self.err("already finished"));
        };
        let res = enc.write_frame(&frame);
        res.map_err(|e| self.err(e))
    }

    /// Writes the trailer and puts the file under its name.
    ///
    /// # Errors
    /// No frame was pushed, or an I/O failure.
    pub fn finish(mut self) -> Result<(), ImageIoError> {
        let enc = self
            .encoder
            .take()
            .ok_or_else(|| self.err("a GIF needs at least one frame"))?;
        let file = enc.into_inner().map_err(|e| self.err(e))?;
        file.commit().map_err(|e| self.err(e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_of_another_size_and_empty_gifs_are_refused_without_leaving_files() {
        let dir = std::env::temp_dir().join(format!("evogs-gif-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        let p = dir.join("b.gif");
        let mut g = GifWriter::create(&p, 50).expect("create");
        g.push(&Image::new(3, 2)).expect("first frame");
        let e = g.push(&Image::new(2, 3)).expect_err("other size");
        assert!(
            e.to_string().contains("b.gif") && e.to_string().contains("differ"),
            "{e}"
        );
        drop(g);
        let e = GifWriter::create(&p, 50)
            .expect("create")
            .finish()
            .expect_err("no frames");
        assert!(e.to_string().contains("at least one frame"), "{e}");
        assert_eq!(
            std::fs::read_dir(&dir).expect("list").count(),
            0,
            "nothing left"
        );
        std::fs::remove_dir_all(dir).ok();
    }

    #[test]
    fn a_finished_gif_decodes_to_its_frames() {
        let dir = std::env::temp_dir().join(format!("evogs-gif2-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        let p = dir.join("c.gif");
        let mut g = GifWriter::create(&p, 80).expect("create");
        for k in 0..4 {
            let mut img = Image::new(5, 3);
            img.set(k, 1, [1.0, 1.0, 1.0]);
            g.push(&img).expect("frame");
        }
        g.finish().expect("finish");
        let mut opts = gif::DecodeOptions::new();
        opts.set_color_output(gif::ColorOutput::RGBA);
        let mut dec = opts
            .read_info(std::fs::File::open(&p).expect("open"))
            .expect("header");
        let mut n = 0;
        while let Some(f) = dec.read_next_frame().expect("frame") {
            assert_eq!((f.width, f.height, f.delay), (5, 3, 8));
            assert_eq!(f.buffer[(5 + n) * 4], 255, "frame {n}: its white pixel");
            n += 1;
        }
        assert_eq!(n, 4);
        std::fs::remove_dir_all(dir).ok();
    }
}
