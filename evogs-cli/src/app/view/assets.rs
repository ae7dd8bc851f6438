//! The page and its vendored JavaScript (`evogs-cli/assets/viewer`, see its
//! `PROVENANCE.md`), embedded in the binary so that the viewer works offline and from any
//! folder.

use include_dir::{Dir, File};

/// The viewer's files: `index.html`, `viewer.js`, `viewer.css` and `vendor/` (three.js and
/// Spark with their licences).
static ASSETS: Dir<'static> = include_dir::include_dir!("$CARGO_MANIFEST_DIR/assets/viewer");

/// The embedded file at `path` (relative, `/`-separated; `""` is `index.html`).
#[must_use]
pub fn asset(path: &str) -> Option<&'static File<'static>> {
    let path = if path.is_empty() { "index.html" } else { path };
    if path.split('/').any(|p| p.is_empty() || p == "..") {
        return None;
    }
    ASSETS.get_file(path)
}

/// Every embedded file, for a static export.
#[must_use]
pub fn all_assets() -> Vec<&'static File<'static>> {
    fn walk(d: &'static Dir<'static>, out: &mut Vec<&'static File<'static>>) {
        out.extend(d.files());
        for sub in d.dirs() {
            walk(sub, out);
        }
    }
    let mut v = Vec::new();
    walk(&ASSETS, &mut v);
    v
}

/// The `Content-Type` of a file name by its extension.
#[must_use]
pub fn content_type(name: &str) -> &'static str {
    match name.rsplit('.').next().unwrap_or_default() {
        "html" => "text/html; charset=utf-8",
        "js" => "text/javascript; charset=utf-8",
        "css" => "text/css; charset=utf-8",
        "json" => "application/json",
        "bin" => "application/octet-stream",
        _ => "text/plain; charset=utf-8",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_and_its_modules_are_embedded_and_paths_cannot_escape() {
        for p in [
            "",
            "viewer.js",
            "vendor/spark/spark.module.min.js",
            "vendor/three/build/three.module.min.js",
            "vendor/three/build/three.core.min.js",
            "vendor/three/examples/jsm/controls/OrbitControls.js",
            "vendor/three/examples/jsm/postprocessing/Pass.js",
            "vendor/spark/LICENSE",
            "vendor/three/LICENSE",
        ] {
            assert!(asset(p).is_some(), "{p}");
        }
        assert!(asset("../Cargo.toml").is_none());
        assert!(asset("vendor//spark").is_none());
        assert_eq!(content_type("a/b.js"), "text/javascript; charset=utf-8");
    }
}
