//! A folder that one sequence owns (`render` and `inject` frames, `export --times` PLY
//! files): before a sequence is written, the files an earlier one left (its numbered files,
//! its index, its GIF) are refused, or removed with `--force`, so that a folder never holds
//! the frames of two sequences mixed. The sequence's index is written last, so a folder with
//! an index holds the whole sequence it lists.

use super::error::{CommandError, CommandResult, Context as _};
use std::path::{Path, PathBuf};

/// The files of one kind of sequence: `PREFIX` + digits + `.EXT`, and some fixed names.
#[derive(Clone, Copy, Debug)]
pub struct SequenceFiles {
    /// The numbered files' prefix (`frame_`).
    pub prefix: &'static str,
    /// Their extension, without the dot (`png`, `ply`).
    pub ext: &'static str,
    /// The other files a sequence writes (index, GIF).
    pub others: &'static [&'static str],
}

impl SequenceFiles {
    /// Whether a file name belongs to such a sequence.
    #[must_use]
    pub fn owns(&self, name: &str) -> bool {
        if self.others.contains(&name) {
            return true;
        }
        name.strip_prefix(self.prefix)
            .and_then(|rest| rest.strip_suffix(self.ext))
            .and_then(|rest| rest.strip_suffix('.'))
            .is_some_and(|digits| !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()))
    }

    /// The files of an earlier sequence in `dir`, sorted (none if the folder is missing).
    fn found(&self, dir: &Path) -> Vec<PathBuf> {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return Vec::new();
        };
        let mut out: Vec<PathBuf> = entries
            .flatten()
            .filter(|e| self.owns(&e.file_name().to_string_lossy()))
            .map(|e| e.path())
            .collect();
        out.sort();
        out
    }

    /// Makes `dir` ready for a new sequence: an earlier sequence's files are refused (the
    /// error names the folder, how many and the first), or removed with `force`.
    ///
    /// # Errors
    /// Files of an earlier sequence without `force`, or a file that cannot be removed.
    pub fn claim(&self, dir: &Path, force: bool) -> CommandResult<()> {
        let old = self.found(dir);
        if old.is_empty() {
            return Ok(());
        }
        if !force {
            let first = old[0]
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            return Err(CommandError::at(
                dir,
                format!(
                    "holds {} file(s) of an earlier sequence ({first}, ...); pass --force to \
                     replace them, or choose another --out",
                    old.len()
                ),
            ));
        }
        for p in &old {
            std::fs::remove_file(p).doing(p, "cannot remove for --force")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FRAMES: SequenceFiles = SequenceFiles {
        prefix: "frame_",
        ext: "png",
        others: &["frames.json", "render.gif"],
    };

    #[test]
    fn only_the_sequence_files_are_owned() {
        for name in [
            "frame_0000.png",
            "frame_12345.png",
            "frames.json",
            "render.gif",
        ] {
            assert!(FRAMES.owns(name), "{name}");
        }
        for name in [
            "frame_.png",
            "frame_00a1.png",
            "frame_0000.ply",
            "frame_0000.png.bak",
            "notes.txt",
            "my_frame_0000.png",
        ] {
            assert!(!FRAMES.owns(name), "{name}");
        }
    }

    #[test]
    fn an_earlier_sequence_is_refused_or_removed_and_other_files_stay() {
        let dir = std::env::temp_dir().join(format!("evogs-seq-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        assert!(
            FRAMES.claim(&dir, false).is_ok(),
            "a missing folder is free"
        );
        std::fs::create_dir_all(&dir).expect("folder");
        for name in [
            "frame_0000.png",
            "frame_0001.png",
            "frames.json",
            "notes.txt",
        ] {
            std::fs::write(dir.join(name), b"x").expect("write");
        }
        let e = FRAMES.claim(&dir, false).expect_err("refused");
        assert!(e.to_string().contains("3 file(s)"), "{e}");
        assert!(e.to_string().contains("frame_0000.png"), "{e}");
        assert!(
            dir.join("frame_0001.png").is_file(),
            "nothing removed without --force"
        );
        FRAMES.claim(&dir, true).expect("removed");
        let left: Vec<String> = std::fs::read_dir(&dir)
            .expect("list")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(left, ["notes.txt"]);
        std::fs::remove_dir_all(&dir).ok();
    }
}
