//! Run-folder layout and the shipped scene.

use super::error::{CommandError, CommandResult, Context as _};
use std::path::{Path, PathBuf};

/// The files of a run folder.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RunFolder {
    /// The folder.
    pub dir: PathBuf,
}

impl RunFolder {
    /// A run folder at `dir`.
    #[must_use]
    pub fn new(dir: &Path) -> Self {
        Self {
            dir: dir.to_path_buf(),
        }
    }
    /// The resolved configuration (TOML).
    #[must_use]
    pub fn config(&self) -> PathBuf {
        self.dir.join("config.toml")
    }
    /// The checkpoint to read: `checkpoint.safetensors` (its path is returned whether or not
    /// the file exists, so errors name the file expected).
    #[must_use]
    pub fn checkpoint(&self) -> PathBuf {
        self.checkpoint_to_write()
    }
    /// Where checkpoints are written: `checkpoint.safetensors` (docs/checkpoints.md).
    #[must_use]
    pub fn checkpoint_to_write(&self) -> PathBuf {
        self.dir.join("checkpoint.safetensors")
    }
    /// The training log (CSV).
    #[must_use]
    pub fn log(&self) -> PathBuf {
        self.dir.join("log.csv")
    }
    /// The loss/PSNR curve (PNG).
    #[must_use]
    pub fn curve(&self) -> PathBuf {
        self.dir.join("curve.png")
    }
    /// Metrics of a split.
    #[must_use]
    pub fn metrics(&self, split: &str) -> PathBuf {
        self.dir.join(format!("metrics-{split}.json"))
    }
    /// Where the dataset path of the run is recorded.
    #[must_use]
    pub fn data_ref(&self) -> PathBuf {
        self.dir.join("data.txt")
    }
    /// Removes what a training run leaves in the folder (checkpoint, configuration, dataset
    /// record, log, curve, metrics, renders, study record), before `--force` trains anew;
    /// other files are left alone.
    ///
    /// # Errors
    /// A file that cannot be removed (named).
    pub fn clear(&self) -> CommandResult<()> {
        let Ok(entries) = std::fs::read_dir(&self.dir) else {
            return Ok(());
        };
        for e in entries.flatten() {
            let p = e.path();
            let name = e.file_name().to_string_lossy().into_owned();
            let ours = matches!(
                name.as_str(),
                "checkpoint.safetensors"
                    | "checkpoint.bin"
                    | "config.toml"
                    | "data.txt"
                    | "log.csv"
                    | "curve.png"
                    | "study-run.json"
            ) || (name.starts_with("metrics-")
                && [".json", ".csv", ".png"].iter().any(|x| name.ends_with(x)));
            let res = if name == "render" && p.is_dir() {
                std::fs::remove_dir_all(&p)
            } else if ours {
                std::fs::remove_file(&p)
            } else {
                Ok(())
            };
            res.doing(&p, "cannot remove for --force")?;
        }
        Ok(())
    }

    /// The dataset folder recorded by `evogs train`.
    ///
    /// # Errors
    /// A missing or unreadable record.
    pub fn data_dir(&self) -> CommandResult<PathBuf> {
        let p = self.data_ref();
        evogs::bounded::read_text(&p, 1 << 16, "the run's dataset record")
            .map(|s| PathBuf::from(s.trim()))
            .map_err(|e| CommandError::new(format!("{e} (pass --data)")))
    }
}

/// The shipped scene (`data/toys-mini`, 2.8 MB), embedded in the binary so that an installed
/// `evogs` trains on it from any folder.
static SHIPPED: include_dir::Dir<'static> =
    include_dir::include_dir!("$CARGO_MANIFEST_DIR/../data/toys-mini");

/// The shipped scene (`data/toys-mini`): in the working directory if run from the repository
/// root, else beside this crate's sources if they are still there, else the copy embedded in
/// the binary, written once to `evogs-VERSION/toys-mini` in the user's cache folder
/// (`$XDG_CACHE_HOME`, `~/.cache`, or the temporary folder).
#[must_use]
pub fn shipped_scene() -> PathBuf {
    let local = PathBuf::from("data/toys-mini");
    if local.join("transforms_train.json").is_file() {
        return local;
    }
    let sources = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/toys-mini");
    if sources.join("transforms_train.json").is_file() {
        return sources;
    }
    let cache = std::env::var_os("XDG_CACHE_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
        .unwrap_or_else(std::env::temp_dir)
        .join(format!("evogs-{}", env!("CARGO_PKG_VERSION")))
        .join("toys-mini");
    match extract_shipped(&cache) {
        Ok(()) => cache,
        // Loading will then name the missing folder.
        Err(_) => sources,
    }
}

/// Writes the embedded scene into `dir` unless a complete copy is there (the marker file is
/// written last).
///
/// # Errors
/// I/O failures.
pub fn extract_shipped(dir: &Path) -> std::io::Result<()> {
    let marker = dir.join(".complete");
    if marker.is_file() {
        return Ok(());
    }
    std::fs::create_dir_all(dir)?;
    SHIPPED.extract(dir)?;
    evogs::atomic::write_atomic(&marker, env!("CARGO_PKG_VERSION").as_bytes())
}

/// The multi-view scene shipped in the repository (`data/toys-mv-mini`, N3DV layout), found
/// like [`shipped_scene`].
#[must_use]
pub fn shipped_multiview_scene() -> PathBuf {
    let local = PathBuf::from("data/toys-mv-mini");
    if local.join("poses_bounds.npy").is_file() {
        return local;
    }
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/toys-mv-mini")
}
