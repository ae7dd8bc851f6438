//! Reading a file whole, bounded: every reader of an outside file goes through here, so that
//! a path that is not a regular file (a folder, a FIFO that would block, a device such as
//! `/dev/zero` that never ends, a symbolic-link loop) is refused by name before it is opened,
//! and a file larger than its format can be is refused before it is read.
//!
//! Text loses a leading UTF-8 byte-order mark (editors on some systems write one; TOML and
//! JSON readers would reject it with an unhelpful message), and text that is not UTF-8 is
//! refused with the offset of the first bad byte.

use std::io::Read as _;
use std::path::Path;

/// 1 MiB: configuration files (`config.toml`, `--config`).
pub const CONFIG_BYTES: u64 = 1 << 20;
/// 256 MiB: JSON and text metadata (D-NeRF transforms, frame times, reference vectors,
/// study records).
pub const METADATA_BYTES: u64 = 256 << 20;
/// 64 GiB: point clouds and checkpoints (a field refused above 64 GiB by the configuration,
/// Gaussians as many as memory holds).
pub const ARRAY_BYTES: u64 = 64 << 30;

/// Why a file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The path could not be examined or read.
    #[error("{path}: {what}: {source}")]
    Io {
        /// The file.
        path: String,
        /// What it was read as.
        what: String,
        /// The cause.
        source: std::io::Error,
    },
    /// The path is not a regular file.
    #[error("{path}: {what} must be a regular file, and this is {kind}")]
    NotAFile {
        /// The file.
        path: String,
        /// What it was read as.
        what: String,
        /// What it is instead (`a folder`, `a FIFO`, `a device`, ...).
        kind: &'static str,
    },
    /// The file is larger than its format can be.
    #[error("{path}: {size} bytes is more than {what} can hold (at most {limit} bytes)")]
    TooLarge {
        /// The file.
        path: String,
        /// What it was read as.
        what: String,
        /// Its size (or how far it was read).
        size: u64,
        /// The bound.
        limit: u64,
    },
    /// Text that is not UTF-8.
    #[error("{path}: {what} is not UTF-8 text (invalid byte at offset {offset})")]
    NotUtf8 {
        /// The file.
        path: String,
        /// What it was read as.
        what: String,
        /// Offset of the first invalid byte.
        offset: usize,
    },
}

/// What kind of node a file type is, in words (`a folder`, `a FIFO (named pipe)`,
/// `a device`, `a socket`; `not a regular file` for anything else that is not a file).
pub(crate) fn kind_of(t: std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt as _;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if t.is_dir() {
        "a folder"
    } else {
        "not a regular file"
    }
}

/// Whether anything is at `path` (a file, a folder, a FIFO, a link, even a broken one). A
/// reader that treats a missing optional file as absent asks this, not
/// [`Path::is_file`], so that a folder or a FIFO in the file's place is refused by name
/// instead of silently taken for "no file".
#[must_use]
pub fn present(path: &Path) -> bool {
    std::fs::symlink_metadata(path).is_ok()
}

/// What is at `path`, following links, in words (`a regular file`, `a folder`, `a FIFO
/// (named pipe)`, `a device`, `a socket`); `None` when nothing is there.
#[must_use]
pub fn node_kind(path: &Path) -> Option<&'static str> {
    let meta = std::fs::metadata(path).ok()?;
    Some(if meta.is_file() {
        "a regular file"
    } else {
        kind_of(meta.file_type())
    })
}

/// Checks that `path` is a regular file (following symbolic links) and returns its size.
///
/// # Errors
/// A missing path, a symbolic-link loop, or a node that is not a regular file.
pub fn regular_file_size(path: &Path, what: &str) -> Result<u64, ReadError> {
    let io = |source: std::io::Error| {
        let source = if source.raw_os_error() == Some(40) {
            std::io::Error::other("a loop of symbolic links")
        } else {
            source
        };
        ReadError::Io {
            path: path.display().to_string(),
            what: what.to_string(),
            source,
        }
    };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(ReadError::NotAFile {
            path: path.display().to_string(),
            what: what.to_string(),
            kind: kind_of(meta.file_type()),
        });
    }
    Ok(meta.len())
}

/// Reads the regular file `path` (`what` names it in errors: "a configuration file"),
/// refusing anything else and anything longer than `limit` bytes. The read itself is
/// capped too, for a file that grows while it is read.
///
/// # Errors
/// See [`ReadError`].
pub fn read_bytes(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>, ReadError> {
    let size = regular_file_size(path, what)?;
    let too_large = |size: u64| ReadError::TooLarge {
        path: path.display().to_string(),
        what: what.to_string(),
        size,
        limit,
    };
    if size > limit {
        return Err(too_large(size));
    }
    let io = |source| ReadError::Io {
        path: path.display().to_string(),
        what: what.to_string(),
        source,
    };
    let file = std::fs::File::open(path).map_err(io)?;
    let mut bytes = Vec::with_capacity(usize::try_from(size).unwrap_or(0));
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// [`read_bytes`] as UTF-8 text, without a leading byte-order mark.
///
/// # Errors
/// See [`ReadError`].
pub fn read_text(path: &Path, limit: u64, what: &str) -> Result<String, ReadError> {
    let mut bytes = read_bytes(path, limit, what)?;
    if bytes.starts_with(&[0xef, 0xbb, 0xbf]) {
        bytes.drain(..3);
    }
    String::from_utf8(bytes).map_err(|e| ReadError::NotUtf8 {
        path: path.display().to_string(),
        what: what.to_string(),
        offset: e.utf8_error().valid_up_to(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("evogs-bounded-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).expect("temp folder");
        d
    }

    #[test]
    fn a_regular_file_reads_back_and_loses_its_byte_order_mark() {
        let d = dir("bom");
        let p = d.join("a.toml");
        std::fs::write(&p, b"\xef\xbb\xbfseed = 1\n").expect("write");
        assert_eq!(read_text(&p, 100, "a file").expect("reads"), "seed = 1\n");
        assert_eq!(read_bytes(&p, 100, "a file").expect("reads").len(), 12);
    }

    #[test]
    fn folders_devices_and_oversized_files_are_named() {
        let d = dir("kinds");
        let e = read_text(&d, 100, "a configuration file").expect_err("a folder");
        assert!(e.to_string().contains("is a folder"), "{e}");
        #[cfg(unix)]
        {
            let e = read_bytes(Path::new("/dev/zero"), 100, "a checkpoint").expect_err("device");
            assert!(e.to_string().contains("is a device"), "{e}");
        }
        let p = d.join("big");
        std::fs::write(&p, [b'x'; 101]).expect("write");
        let e = read_bytes(&p, 100, "a configuration file").expect_err("too large");
        assert!(e.to_string().contains("101 bytes"), "{e}");
        assert!(e.to_string().contains("at most 100"), "{e}");
        std::fs::write(&p, [b'a', 0xff, b'b']).expect("write");
        let e = read_text(&p, 100, "a configuration file").expect_err("not UTF-8");
        assert!(e.to_string().contains("offset 1"), "{e}");
        let e = read_text(&d.join("missing"), 100, "a file").expect_err("missing");
        assert!(e.to_string().contains("missing"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn a_symbolic_link_loop_is_named_and_a_link_to_a_file_is_read_through() {
        let d = dir("links");
        let (a, b) = (d.join("a"), d.join("b"));
        std::os::unix::fs::symlink(&b, &a).expect("link");
        std::os::unix::fs::symlink(&a, &b).expect("link");
        let e = read_text(&a, 100, "a file").expect_err("loop");
        assert!(e.to_string().contains("loop of symbolic links"), "{e}");
        let (f, l) = (d.join("f"), d.join("l"));
        std::fs::write(&f, b"x").expect("write");
        std::os::unix::fs::symlink(&f, &l).expect("link");
        assert_eq!(read_text(&l, 100, "a file").expect("through the link"), "x");
    }

    #[cfg(unix)]
    #[test]
    fn a_fifo_is_refused_without_blocking() {
        let d = dir("fifo");
        let p = d.join("pipe");
        let made = std::process::Command::new("mkfifo").arg(&p).status();
        if !made.is_ok_and(|s| s.success()) {
            eprintln!("skipped: mkfifo is not available");
            return;
        }
        let e = read_text(&p, 100, "a file").expect_err("a FIFO");
        assert!(e.to_string().contains("FIFO"), "{e}");
    }
}
