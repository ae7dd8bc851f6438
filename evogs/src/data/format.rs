//! The dataset layouts evogs reads, and how a folder's layout is recognised.

use super::error::DataError;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A dataset layout.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DataFormat {
    /// Recognise the layout from the folder: `transforms_train.json` is D-NeRF,
    /// `poses_bounds.npy` is N3DV.
    #[default]
    Auto,
    /// Monocular D-NeRF: `transforms_{train,val,test}.json`, RGBA frames.
    Dnerf,
    /// Multi-view video in the N3DV / `DyNeRF` layout after frame extraction:
    /// `poses_bounds.npy` and `camXX/images/TTTT.png`.
    N3dv,
}

impl DataFormat {
    /// Lowercase name (`auto`, `dnerf`, `n3dv`).
    #[must_use]
    pub const fn as_str(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Dnerf => "dnerf",
            Self::N3dv => "n3dv",
        }
    }

    /// The layout of `root`: this one unless it is [`Auto`](Self::Auto), else recognised from
    /// the folder's files.
    ///
    /// # Errors
    /// A missing folder, a folder with neither marker file, or one with both (then the
    /// format must be named).
    pub fn resolve(self, root: &Path) -> Result<Self, DataError> {
        if std::fs::metadata(root).is_ok_and(|m| !m.is_dir()) {
            return Err(DataError::Invalid {
                path: root.display().to_string(),
                msg: "this is a file; a dataset is a folder (with transforms_train.json, or \
                      poses_bounds.npy and camXX/ folders)"
                    .into(),
            });
        }
        if !root.is_dir() {
            return Err(DataError::Missing {
                path: root.display().to_string(),
                what: "dataset folder",
            });
        }
        if self != Self::Auto {
            return Ok(self);
        }
        // Present as any node: one that is not a regular file is named by its reader.
        let present = |name: &str| crate::bounded::present(&root.join(name));
        let (dnerf, n3dv) = (
            present("transforms_train.json"),
            present("poses_bounds.npy"),
        );
        match (dnerf, n3dv) {
            (true, false) => Ok(Self::Dnerf),
            (false, true) => Ok(Self::N3dv),
            (true, true) => Err(DataError::Invalid {
                path: root.display().to_string(),
                msg: "holds both transforms_train.json (D-NeRF) and poses_bounds.npy (N3DV); \
                      choose one with --format dnerf or --format n3dv"
                    .into(),
            }),
            (false, false) => Err(DataError::Invalid {
                path: root.display().to_string(),
                msg: "not a dataset: transforms_train.json (D-NeRF layout) and \
                      poses_bounds.npy (N3DV layout, with camXX/images/*.png) are both missing"
                    .into(),
            }),
        }
    }
}

impl std::fmt::Display for DataFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

impl std::str::FromStr for DataFormat {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            "dnerf" => Ok(Self::Dnerf),
            "n3dv" => Ok(Self::N3dv),
            _ => Err(format!("unknown dataset format `{s}` (auto, dnerf, n3dv)")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_layout_is_recognised_from_the_folder() {
        let dir = std::env::temp_dir().join(format!("evogs-format-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        let e = DataFormat::Auto.resolve(&dir).expect_err("empty folder");
        assert!(e.to_string().contains("poses_bounds.npy"), "{e}");
        std::fs::write(dir.join("poses_bounds.npy"), b"").expect("write");
        assert_eq!(
            DataFormat::Auto.resolve(&dir).expect("n3dv"),
            DataFormat::N3dv
        );
        std::fs::write(dir.join("transforms_train.json"), b"").expect("write");
        let e = DataFormat::Auto.resolve(&dir).expect_err("both");
        assert!(e.to_string().contains("--format"), "{e}");
        assert_eq!(
            DataFormat::Dnerf.resolve(&dir).expect("named"),
            DataFormat::Dnerf,
            "a named format is kept"
        );
        std::fs::remove_file(dir.join("poses_bounds.npy")).expect("rm");
        assert_eq!(
            DataFormat::Auto.resolve(&dir).expect("dnerf"),
            DataFormat::Dnerf
        );
        assert!(
            DataFormat::N3dv.resolve(&dir.join("nope")).is_err(),
            "missing folder"
        );
        for f in [DataFormat::Auto, DataFormat::Dnerf, DataFormat::N3dv] {
            assert_eq!(f.as_str().parse::<DataFormat>(), Ok(f), "round trip");
        }
        assert!("llff".parse::<DataFormat>().is_err(), "unknown name");
        std::fs::remove_dir_all(dir).ok();
    }
}
