//! What a run was trained on, independent of where the dataset lies: a fingerprint of the
//! training split (layout, and for every view its file name relative to the dataset folder,
//! its file size, time, camera and image size). Checkpoints record it, so that a resume, an
//! evaluation or a study can tell the same scene moved elsewhere (same fingerprint) from
//! another scene (a different one) without decoding an image.
//!
//! The fingerprint is an identity check (FNV-1a), not a cryptographic hash: it tells
//! datasets apart, it does not defend against a forged one.

use super::dataset::{Dataset, View};
use crate::fnv::Fnv1a;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The identity of a dataset's training split, and where it was read from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DataIdentity {
    /// FNV-1a of the training split, 16 hex digits.
    pub fingerprint: String,
    /// Number of training views.
    pub train_views: usize,
    /// The dataset folder it was read from (absolute where it could be resolved).
    pub folder: String,
}

impl DataIdentity {
    /// The identity of `ds` (its training split; the images are not read, only their
    /// files' sizes).
    #[must_use]
    pub fn of(ds: &Dataset) -> Self {
        let folder = std::fs::canonicalize(&ds.root).unwrap_or_else(|_| ds.root.clone());
        Self {
            fingerprint: format!(
                "{:016x}",
                fingerprint(ds.format.as_str(), &ds.root, &ds.train)
            ),
            train_views: ds.train.len(),
            folder: folder.display().to_string(),
        }
    }

    /// Whether `other` is the same training data (wherever it lies).
    #[must_use]
    pub fn same_data(&self, other: &Self) -> bool {
        self.fingerprint == other.fingerprint && self.train_views == other.train_views
    }

    /// The note for a checkpoint written before the data was recorded: the data in
    /// `folder` cannot be compared with it.
    #[must_use]
    pub fn unrecorded_note(folder: &str) -> String {
        format!(
            "note: the checkpoint does not record its training data (written by an earlier \
             evogs), so {folder} cannot be compared with it"
        )
    }

    /// One line naming both, for errors: `FOLDER (N training views, fingerprint F)`.
    #[must_use]
    pub fn describe(&self) -> String {
        format!(
            "{} ({} training views, fingerprint {})",
            self.folder, self.train_views, self.fingerprint
        )
    }
}

/// FNV-1a over a split's views, in order: the layout's name, then per view its file name
/// relative to `root`, the file's size (`u64::MAX` when it cannot be read), the time, the
/// camera matrix, the field of view and the image size, every number as its bits.
fn fingerprint(layout: &str, root: &Path, views: &[View]) -> u64 {
    let mut h = Fnv1a::default();
    h.write(layout.as_bytes());
    h.write(&(views.len() as u64).to_le_bytes());
    for v in views {
        let name = v.file.strip_prefix(root).unwrap_or(&v.file);
        let name = name.to_string_lossy();
        h.write(&(name.len() as u64).to_le_bytes());
        h.write(name.as_bytes());
        let size = std::fs::metadata(&v.file).map_or(u64::MAX, |m| m.len());
        h.write(&size.to_le_bytes());
        h.write(&v.time.to_bits().to_le_bytes());
        for x in v.c2w.iter().flatten() {
            h.write(&x.to_bits().to_le_bytes());
        }
        h.write(&v.fov_x.to_bits().to_le_bytes());
        h.write(&(v.width as u64).to_le_bytes());
        h.write(&(v.height as u64).to_le_bytes());
    }
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::image_io::FrameDecode;
    use std::path::PathBuf;

    fn view(root: &Path, name: &str, time: f64) -> View {
        View {
            file: root.join(name),
            time,
            c2w: [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 4.0],
                [0.0, 0.0, 0.0, 1.0],
            ],
            fov_x: 0.7,
            width: 8,
            height: 6,
            image: None,
            decode: FrameDecode::default(),
        }
    }

    #[test]
    fn the_same_views_under_another_folder_are_the_same_data() {
        let (a, b) = (PathBuf::from("/data/a"), PathBuf::from("/elsewhere/b"));
        let va = [
            view(&a, "train/r_0.png", 0.0),
            view(&a, "train/r_1.png", 0.5),
        ];
        let vb = [
            view(&b, "train/r_0.png", 0.0),
            view(&b, "train/r_1.png", 0.5),
        ];
        assert_eq!(fingerprint("dnerf", &a, &va), fingerprint("dnerf", &b, &vb));
    }

    #[test]
    fn every_recorded_property_changes_the_fingerprint() {
        let root = PathBuf::from("/data/a");
        let base = vec![
            view(&root, "train/r_0.png", 0.0),
            view(&root, "train/r_1.png", 0.5),
        ];
        let h0 = fingerprint("dnerf", &root, &base);
        assert_ne!(h0, fingerprint("n3dv", &root, &base), "layout");
        assert_ne!(h0, fingerprint("dnerf", &root, &base[..1]), "count");
        let edits: [fn(&mut View); 6] = [
            |v| v.file.set_file_name("r_9.png"),
            |v| v.time = 0.25,
            |v| v.c2w[0][3] = 1e-9,
            |v| v.fov_x = 0.71,
            |v| v.width = 9,
            |v| v.height = 7,
        ];
        for (k, edit) in edits.iter().enumerate() {
            let mut views = base.clone();
            edit(&mut views[1]);
            assert_ne!(h0, fingerprint("dnerf", &root, &views), "edit {k}");
        }
        let mut swapped = base.clone();
        swapped.swap(0, 1);
        assert_ne!(h0, fingerprint("dnerf", &root, &swapped), "order");
    }
}
