//! Atomic output files: every file evogs writes (checkpoints, PLY, PNG, GIF, JSON, CSV,
//! TOML, NPY) goes to a temporary file beside its destination and is renamed over it only
//! once complete, so a reader, a crash or an interrupt never leaves half a file under the
//! final name, and an older complete file stays until the new one replaces it.
//!
//! The temporary name is `.NAME.tmp-PID` in the destination's folder (the same file system,
//! so the rename is atomic). It is removed when writing fails and when an [`AtomicFile`] is
//! dropped without [`commit`](AtomicFile::commit); a process killed outright (SIGKILL) can
//! leave it behind, never the destination half-written.
//!
//! ```
//! use evogs::atomic::{AtomicFile, write_atomic};
//! use std::io::Write;
//! let dir = std::env::temp_dir().join(format!("evogs-atomic-doc-{}", std::process::id()));
//! std::fs::create_dir_all(&dir).unwrap();
//! let path = dir.join("out.txt");
//! write_atomic(&path, b"old").unwrap();
//! let mut f = AtomicFile::create(&path).unwrap();
//! f.write_all(b"new").unwrap();
//! assert_eq!(std::fs::read(&path).unwrap(), b"old"); // not replaced before the commit
//! f.commit().unwrap();
//! assert_eq!(std::fs::read(&path).unwrap(), b"new");
//! assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1); // no temporary file left
//! std::fs::remove_dir_all(&dir).unwrap();
//! ```

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

/// A file being written under a temporary name; [`commit`](Self::commit) renames it to
/// its destination, dropping it uncommitted removes it.
#[derive(Debug)]
pub struct AtomicFile {
    path: PathBuf,
    tmp: PathBuf,
    file: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Opens the temporary file for `path` (whose folder must exist). A symbolic link is
    /// written through: its target is replaced, and the link stays. A destination that exists
    /// and is not a regular file (a folder, a FIFO, a device, a socket) is refused, never
    /// replaced.
    ///
    /// # Errors
    /// The temporary file cannot be created (no folder, no permission, a path without a
    /// file name), or the destination is not a regular file or a loop of links.
    pub fn create(path: &Path) -> io::Result<Self> {
        let path = &destination(path)?;
        let name = path.file_name().ok_or_else(|| {
            io::Error::new(io::ErrorKind::InvalidInput, "the path has no file name")
        })?;
        let mut tmp_name = std::ffi::OsString::from(".");
        tmp_name.push(name);
        tmp_name.push(format!(".tmp-{}", std::process::id()));
        let tmp = path.with_file_name(tmp_name);
        let file = File::create(&tmp)?;
        Ok(Self {
            path: path.to_path_buf(),
            tmp,
            file: Some(BufWriter::new(file)),
        })
    }

    /// The destination.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Flushes, syncs the data to disk and renames the file to its destination.
    ///
    /// # Errors
    /// Any I/O failure (the temporary file is then removed and the destination untouched).
    pub fn commit(mut self) -> io::Result<()> {
        let res = self.finish();
        if res.is_err() {
            std::fs::remove_file(&self.tmp).ok();
        }
        res
    }

    fn finish(&mut self) -> io::Result<()> {
        let w = self
            .file
            .take()
            .ok_or_else(|| io::Error::other("already committed"))?;
        let file = w.into_inner().map_err(io::IntoInnerError::into_error)?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&self.tmp, &self.path)
    }

    fn writer(&mut self) -> io::Result<&mut BufWriter<File>> {
        self.file
            .as_mut()
            .ok_or_else(|| io::Error::other("already committed"))
    }
}

/// The file `path` names: `path` itself, or the end of its chain of symbolic links (a link
/// that points nowhere yet names the file to create). Refuses a destination that exists and
/// is not a regular file, and a loop of links.
fn destination(path: &Path) -> io::Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        let Ok(meta) = std::fs::symlink_metadata(&p) else {
            return Ok(p);
        };
        let t = meta.file_type();
        if t.is_symlink() {
            let target = std::fs::read_link(&p)?;
            p = match p.parent() {
                Some(dir) if target.is_relative() => dir.join(target),
                _ => target,
            };
            continue;
        }
        if t.is_file() {
            return Ok(p);
        }
        let kind = crate::bounded::kind_of(t);
        let what = if p == path {
            format!("it is {kind}")
        } else {
            format!("it links to {}, which is {kind}", p.display())
        };
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{what}; evogs writes regular files and does not replace it"),
        ));
    }
    Err(io::Error::new(
        io::ErrorKind::InvalidInput,
        "it is a loop of symbolic links",
    ))
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.writer()?.write(buf)
    }
    fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        self.writer()?.write_all(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.writer()?.flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.file.take().is_some() {
            std::fs::remove_file(&self.tmp).ok();
        }
    }
}

/// Writes `bytes` to `path` atomically ([`AtomicFile`]).
///
/// # Errors
/// Any I/O failure; the destination is then untouched and no temporary file remains.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes)?;
    f.commit()
}

/// [`write_atomic`] with the error as one line naming the file.
///
/// # Errors
/// `"PATH: cannot write: REASON"`.
pub fn write_atomic_named(path: &Path, bytes: &[u8]) -> Result<(), String> {
    write_atomic(path, bytes).map_err(|e| format!("{}: cannot write: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(unix)]
    #[test]
    fn a_link_is_written_through_and_special_nodes_are_refused() {
        use std::os::unix::fs::symlink;
        let d = scratch("nodes");
        let (target, link) = (d.join("target.ply"), d.join("link.ply"));
        std::fs::write(&target, b"old").expect("write");
        symlink("target.ply", &link).expect("link");
        write_atomic(&link, b"new").expect("through the link");
        assert_eq!(std::fs::read(&target).expect("read"), b"new");
        assert!(
            std::fs::symlink_metadata(&link)
                .expect("meta")
                .file_type()
                .is_symlink()
        );
        let dangling = d.join("dangling.ply");
        symlink("created.ply", &dangling).expect("link");
        write_atomic(&dangling, b"x").expect("creates the target");
        assert_eq!(std::fs::read(d.join("created.ply")).expect("read"), b"x");
        let folder = d.join("folder.ply");
        std::fs::create_dir(&folder).expect("folder");
        let e = write_atomic(&folder, b"x").expect_err("a folder");
        assert!(e.to_string().contains("it is a folder"), "{e}");
        let to_folder = d.join("to-folder.ply");
        symlink(&folder, &to_folder).expect("link");
        let e = write_atomic(&to_folder, b"x").expect_err("a link to a folder");
        assert!(e.to_string().contains("which is a folder"), "{e}");
        let e = write_atomic(Path::new("/dev/null"), b"x").expect_err("a device");
        assert!(e.to_string().contains("a device"), "{e}");
        let (a, b) = (d.join("a"), d.join("b"));
        symlink(&b, &a).expect("link");
        symlink(&a, &b).expect("link");
        let e = write_atomic(&a, b"x").expect_err("a loop");
        assert!(e.to_string().contains("loop"), "{e}");
        let fifo = d.join("pipe.ply");
        if std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .is_ok_and(|s| s.success())
        {
            let e = write_atomic(&fifo, b"x").expect_err("a FIFO");
            assert!(e.to_string().contains("FIFO"), "{e}");
            let t = std::fs::symlink_metadata(&fifo)
                .expect("still there")
                .file_type();
            assert!(!t.is_file(), "the FIFO was not replaced");
        }
        let mut names = entries(&d);
        names.retain(|n| n.contains(".tmp-"));
        assert!(names.is_empty(), "{names:?}");
    }

    fn scratch(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("evogs-atomic-{tag}-{}", std::process::id()));
        std::fs::remove_dir_all(&d).ok();
        std::fs::create_dir_all(&d).expect("scratch");
        d
    }

    fn entries(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn dropped_without_commit_leaves_the_old_file_and_no_temporary() {
        let d = scratch("drop");
        let p = d.join("a.json");
        write_atomic(&p, b"complete").expect("write");
        {
            let mut f = AtomicFile::create(&p).expect("create");
            f.write_all(b"half").expect("write");
            assert_eq!(
                entries(&d).len(),
                2,
                "the temporary file exists while writing"
            );
        }
        assert_eq!(std::fs::read(&p).expect("read"), b"complete");
        assert_eq!(entries(&d), vec!["a.json".to_string()]);
        std::fs::remove_dir_all(d).ok();
    }

    #[test]
    fn failures_name_the_file_and_leave_nothing() {
        let d = scratch("fail");
        let missing = d.join("no-such-folder").join("x.png");
        let e = write_atomic_named(&missing, b"x").expect_err("no folder");
        assert!(e.contains("x.png"), "{e}");
        let e = AtomicFile::create(Path::new("/")).expect_err("no file name");
        assert_eq!(e.kind(), io::ErrorKind::InvalidInput);
        assert!(entries(&d).is_empty());
        std::fs::remove_dir_all(d).ok();
    }
}
