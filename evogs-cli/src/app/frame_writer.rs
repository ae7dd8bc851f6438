//! Writing a rendered sequence: numbered PNG frames as they come and, optionally, a GIF
//! streamed beside them, in constant memory whatever the length, and `frames.json`, the
//! index of the frames and their times, last. The sequence owns its folder
//! ([`SequenceFiles::claim`]): an earlier render's frames are refused, or removed with
//! `--force`. Every file is written atomically; an interrupt (SIGINT/SIGTERM) stops after
//! the current frame, keeping the finished frames and leaving no partial GIF and no index.

use super::error::CommandError;
use super::interrupt;
use super::lock::FolderLock;
use super::sequence_folder::SequenceFiles;
use evogs::data::gif_writer::GifWriter;
use evogs::data::image_io;
use evogs_splat::Image;
use std::path::{Path, PathBuf};

/// GIF frame duration.
const GIF_DELAY_MS: u32 = 80;

/// The frames of one sequence being written to a folder.
#[derive(Debug)]
pub struct FrameWriter {
    dir: PathBuf,
    gif: Option<(GifWriter, PathBuf)>,
    written: usize,
    times: Vec<f64>,
    // Held while writing: one writer per folder.
    _lock: FolderLock,
}

/// What a finished sequence left on disk.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FramesWritten {
    /// The folder of the frames `frame_0000.png`, `frame_0001.png`, ...
    pub dir: PathBuf,
    /// How many frames.
    pub count: usize,
    /// The GIF, when one was asked for.
    pub gif: Option<PathBuf>,
}

impl FramesWritten {
    /// The path of frame `i`.
    #[must_use]
    pub fn frame(&self, i: usize) -> PathBuf {
        frame_path(&self.dir, i)
    }
}

/// The files of a rendered sequence.
pub const FRAME_FILES: SequenceFiles = SequenceFiles {
    prefix: "frame_",
    ext: "png",
    others: &[INDEX_FILE, "render.gif", "inject.gif"],
};

/// The index of a rendered sequence, written last.
pub const INDEX_FILE: &str = "frames.json";

/// `frames.json`: the frames of a finished sequence and their times.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameIndex {
    /// Frame files, in order, relative to the folder.
    pub files: Vec<String>,
    /// The time of each frame.
    pub times: Vec<f64>,
    /// The GIF, if one was written (relative to the folder).
    pub gif: Option<String>,
}

fn frame_path(dir: &Path, i: usize) -> PathBuf {
    dir.join(format!("frame_{i:04}.png"))
}

impl FrameWriter {
    /// Creates the folder (and its parents), locks it ([`FolderLock`]), claims it for this
    /// sequence (an earlier one's files are refused, or removed with `force`) and, with
    /// `gif_name`, starts `dir/gif_name`.
    ///
    /// # Errors
    /// The folder or the GIF's temporary file cannot be created, another process is
    /// writing to the folder, or it holds an earlier sequence and `force` is off.
    pub fn create(dir: &Path, gif_name: Option<&str>, force: bool) -> Result<Self, CommandError> {
        let lock = FolderLock::acquire(dir, "render")?;
        FRAME_FILES.claim(dir, force)?;
        let gif = match gif_name {
            Some(name) => {
                let p = dir.join(name);
                let g = GifWriter::create(&p, GIF_DELAY_MS).map_err(CommandError::new)?;
                Some((g, p))
            }
            None => None,
        };
        Ok(Self {
            dir: dir.to_path_buf(),
            gif,
            written: 0,
            times: Vec::new(),
            _lock: lock,
        })
    }

    /// Fails with a clear message if an interrupt was requested, before frame `written`
    /// of `total` (the request is withdrawn: the command has stopped for it).
    ///
    /// # Errors
    /// The interrupt, naming what was kept.
    pub fn check_interrupt(&self, total: usize) -> Result<(), CommandError> {
        if !interrupt::take() {
            return Ok(());
        }
        Err(CommandError::new(format!(
            "interrupted: {} of {total} frames written to {}{}",
            self.written,
            self.dir.display(),
            if self.gif.is_some() {
                "; no GIF written"
            } else {
                ""
            }
        )))
    }

    /// Writes the next frame (`frame_NNNN.png`, the scene at time `t`) and appends it to the
    /// GIF.
    ///
    /// # Errors
    /// I/O or encoding failures, naming the file.
    pub fn push(&mut self, img: &Image<f32>, t: f64) -> Result<(), CommandError> {
        let p = frame_path(&self.dir, self.written);
        image_io::save_png(img, &p).map_err(CommandError::new)?;
        if let Some((g, _)) = &mut self.gif {
            g.push(img).map_err(CommandError::new)?;
        }
        self.written += 1;
        self.times.push(t);
        Ok(())
    }

    /// Completes the GIF, writes the index and reports what was written.
    ///
    /// # Errors
    /// The GIF or the index cannot be written.
    pub fn finish(self) -> Result<FramesWritten, CommandError> {
        let gif = match self.gif {
            Some((g, p)) => {
                g.finish().map_err(CommandError::new)?;
                Some(p)
            }
            None => None,
        };
        let name = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned());
        let index = FrameIndex {
            files: (0..self.written)
                .filter_map(|i| name(&frame_path(&self.dir, i)))
                .collect(),
            times: self.times,
            gif: gif.as_deref().and_then(name),
        };
        let json = serde_json::to_string_pretty(&index).unwrap_or_default();
        evogs::atomic::write_atomic_named(&self.dir.join(INDEX_FILE), json.as_bytes())
            .map_err(CommandError::new)?;
        Ok(FramesWritten {
            dir: self.dir,
            count: self.written,
            gif,
        })
    }
}
