//! One writer per folder: [`FolderLock`], an advisory lock on `DIR/.evogs.lock` held by the
//! command that writes into `DIR` (`train`, `study`, `render`, `inject`, `export --times`).
//!
//! The lock is the operating system's (`flock` on Unix, `LockFileEx` on Windows, through
//! the standard library's `File::try_lock`): it is released when the process ends, however
//! it ends, so a lock file left by a killed process never blocks. A second command pointed
//! at a folder that is being written is refused at once, with the holder's process id and
//! command.

use super::error::{CommandError, CommandResult, Context as _};
use std::fs::{File, OpenOptions, TryLockError};
use std::io::{Read as _, Seek as _, Write as _};
use std::path::{Path, PathBuf};

/// The name of the lock file in a locked folder.
pub const LOCK_FILE: &str = ".evogs.lock";

/// The lock of one folder, held until dropped (or until the process ends).
#[derive(Debug)]
pub struct FolderLock {
    // Holding the open file holds the lock.
    _file: File,
    path: PathBuf,
}

impl FolderLock {
    /// Creates `dir` if needed and locks it for `command` (written into the lock file, for
    /// the message another process gets).
    ///
    /// # Errors
    /// Another process holds the folder (its process id and command are named), or the
    /// folder or its lock file cannot be created.
    pub fn acquire(dir: &Path, command: &str) -> CommandResult<Self> {
        if let Some(kind) = evogs::bounded::node_kind(dir).filter(|&k| k != "a folder") {
            return Err(CommandError::at(
                dir,
                format!("this is {kind}; the output of `evogs {command}` is a folder"),
            ));
        }
        std::fs::create_dir_all(dir).doing(dir, "cannot create")?;
        let path = dir.join(LOCK_FILE);
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(&path)
            .doing(&path, "cannot open the folder's lock file")?;
        match file.try_lock() {
            Ok(()) => {
                let me = format!("process {}: evogs {command}\n", std::process::id());
                file.set_len(0)
                    .and_then(|()| file.rewind())
                    .and_then(|()| file.write_all(me.as_bytes()))
                    .doing(&path, "cannot write the folder's lock file")?;
                Ok(Self { _file: file, path })
            }
            Err(TryLockError::WouldBlock) => {
                let mut holder = String::new();
                let _ = file.read_to_string(&mut holder);
                let holder = holder.trim();
                let who = if holder.is_empty() {
                    "another evogs process".to_string()
                } else {
                    format!("another evogs process ({holder})")
                };
                Err(CommandError::at(
                    dir,
                    format!(
                        "{who} is writing to this folder; wait for it to finish or choose \
                         another folder"
                    ),
                ))
            }
            Err(TryLockError::Error(e)) => Err(CommandError::new(e)
                .context("cannot lock the folder")
                .context(dir.display())),
        }
    }

    /// The lock file.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_locked_folder_refuses_a_second_writer_until_released() {
        let dir = std::env::temp_dir().join(format!("evogs-lock-{}", std::process::id()));
        std::fs::remove_dir_all(&dir).ok();
        let first = FolderLock::acquire(&dir, "train --out x").expect("first writer");
        assert!(first.path().is_file(), "the lock file");
        let e = FolderLock::acquire(&dir, "render").expect_err("second writer");
        let msg = e.to_string();
        assert!(
            msg.contains(&format!(
                "process {}: evogs train --out x",
                std::process::id()
            )) && msg.contains("is writing to this folder"),
            "{msg}"
        );
        drop(first);
        // The file stays; the lock went with the holder.
        assert!(dir.join(LOCK_FILE).is_file(), "a stale lock file");
        FolderLock::acquire(&dir, "render").expect("free again");
        std::fs::remove_dir_all(&dir).ok();
    }
}
