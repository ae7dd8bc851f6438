//! The shipped scene is embedded in the binary: written out (as an installed `evogs` does when
//! the repository is not beside it), it is file for file the repository's `data/toys-mini`
//! and loads as the same dataset; a second extraction reuses the complete copy.

use crate::common;

use evogs::data::{Dataset, LoadOptions};
use evogs_cli::app::paths::{extract_shipped, shipped_scene};
use std::path::Path;

fn files(root: &Path) -> Vec<(String, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("list").flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.file_name().is_some_and(|n| n != ".complete") {
                let rel = p.strip_prefix(root).expect("inside").display().to_string();
                out.push((rel, std::fs::read(&p).expect("read")));
            }
        }
    }
    out.sort();
    out
}

#[test]
fn the_embedded_scene_is_the_repository_scene() {
    let dir = common::scratch("shipped").join("toys-mini");
    extract_shipped(&dir).expect("extract");
    assert!(
        files(&dir) == files(&shipped_scene()),
        "the same files, byte for byte"
    );
    let a = Dataset::load(&dir, &LoadOptions::default()).expect("embedded copy loads");
    let b = Dataset::load(&shipped_scene(), &LoadOptions::default()).expect("repository");
    assert_eq!((a.train.len(), a.test.len()), (b.train.len(), b.test.len()));
    // A complete copy is reused, not rewritten.
    let marker = dir.join(".complete");
    let before = std::fs::metadata(&marker)
        .and_then(|m| m.modified())
        .expect("marker");
    extract_shipped(&dir).expect("again");
    assert_eq!(
        std::fs::metadata(&marker)
            .and_then(|m| m.modified())
            .expect("marker"),
        before
    );
    std::fs::remove_dir_all(dir.parent().expect("scratch")).ok();
}
