//! The layout is the architecture: inside every crate of the workspace, the files' imports
//! form no circle (a file never depends, directly or through others, on a file that depends
//! on it), the core crates depend only downwards (math ← ode, math ← splat), and the crates
//! form layers: the core crates, the method library `evogs`, `evogs-verify`, `evogs-cli`.
//!
//! A file's dependencies are the modules its `crate::`, `super::` and `self::` paths name
//! (in `use` trees, braces expanded, and inline), each resolved to the deepest module file
//! that exists. A parent's `mod` declarations and the `pub use` re-exports of a `mod.rs` or
//! `lib.rs` (a facade, not a use) are not dependencies, a child naming its own ancestor
//! module is not a circle through that facade, and a file's unit tests are not part of its
//! dependencies.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Module path (`["field", "chunk"]`) of every source file of a crate.
fn modules(src: &Path) -> BTreeMap<Vec<String>, PathBuf> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).expect("source folder").flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
                continue;
            }
            if p.extension().and_then(|x| x.to_str()) != Some("rs") {
                continue;
            }
            let rel = p.strip_prefix(src).expect("inside src");
            let mut parts: Vec<String> = rel
                .iter()
                .map(|c| c.to_string_lossy().trim_end_matches(".rs").to_string())
                .collect();
            if matches!(
                parts.last().map(String::as_str),
                Some("mod" | "lib" | "main")
            ) {
                parts.pop();
            }
            if rel.iter().count() == 1 && parts.first().is_some_and(|f| f == "main") {
                continue;
            }
            out.insert(parts, p);
        }
    }
    out
}

/// The text without comments (line comments and doc comments; block comments are not used)
/// and without the unit tests (the `#[cfg(test)]` module at the end of a file).
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or("");
    text.lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Expands a `use` tree (`a::{b, c::{d, e}}`) into its paths.
fn expand(tree: &str) -> Vec<String> {
    let tree = tree.trim();
    let Some(open) = tree.find('{') else {
        return vec![tree.split(" as ").next().unwrap_or("").trim().to_string()];
    };
    let prefix = tree[..open].trim_end_matches("::").trim();
    let inner = &tree[open + 1..tree.rfind('}').unwrap_or(tree.len())];
    let mut parts = Vec::new();
    let (mut depth, mut start) = (0, 0);
    for (i, ch) in inner.char_indices() {
        match ch {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(&inner[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    parts.push(&inner[start..]);
    parts
        .into_iter()
        .filter(|p| !p.trim().is_empty())
        .flat_map(expand)
        .map(|p| {
            if p == "self" {
                prefix.to_string()
            } else {
                format!("{prefix}::{p}")
            }
        })
        .collect()
}

/// Every `crate::`/`super::`/`self::` path of a file's code, as segments.
fn paths(code: &str, facade: bool) -> Vec<Vec<String>> {
    let mut out = Vec::new();
    for stmt in code.split(';') {
        let s = stmt.trim();
        let (is_use, body) = if let Some(b) = s.strip_prefix("pub use ") {
            (true, Some((true, b)))
        } else if let Some(b) = s.strip_prefix("pub(crate) use ") {
            (true, Some((false, b)))
        } else if let Some(b) = s.strip_prefix("use ") {
            (true, Some((false, b)))
        } else {
            (false, None)
        };
        if let (true, Some((public, body))) = (is_use, body) {
            if public && facade {
                continue;
            }
            out.extend(expand(body).into_iter().map(|p| segments(&p)));
            continue;
        }
        // Inline paths.
        let bytes = s.as_bytes();
        for head in ["crate::", "super::", "self::"] {
            let mut from = 0;
            while let Some(i) = s[from..].find(head) {
                let at = from + i;
                let boundary = at == 0
                    || !(bytes[at - 1].is_ascii_alphanumeric()
                        || bytes[at - 1] == b'_'
                        || bytes[at - 1] == b':');
                let end = s[at..]
                    .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == ':'))
                    .map_or(s.len(), |e| at + e);
                if boundary {
                    out.push(segments(&s[at..end]));
                }
                from = end.max(at + head.len());
            }
        }
    }
    out
}

fn segments(p: &str) -> Vec<String> {
    p.split("::")
        .map(str::trim)
        .filter(|x| !x.is_empty())
        .map(str::to_string)
        .collect()
}

/// The module a path names, relative to the file's module `me` (whose own module is `me`;
/// for a `mod.rs`/`lib.rs` file it is the folder's module).
fn resolve(
    path: &[String],
    me: &[String],
    mods: &BTreeMap<Vec<String>, PathBuf>,
) -> Option<Vec<String>> {
    let mut base: Vec<String> = Vec::new();
    let mut rest = path;
    match path.first().map(String::as_str) {
        Some("crate") => rest = &path[1..],
        Some("self") => {
            base = me.to_vec();
            rest = &path[1..];
        }
        Some("super") => {
            base = me.to_vec();
            while rest.first().map(String::as_str) == Some("super") {
                base.pop();
                rest = &rest[1..];
            }
        }
        _ => return None,
    }
    let mut full = base;
    full.extend(rest.iter().cloned());
    (0..=full.len())
        .rev()
        .map(|k| full[..k].to_vec())
        .find(|m| mods.contains_key(m))
}

/// The circles of a dependency graph (strongly connected components with two or more files).
fn circles(graph: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) -> Vec<Vec<Vec<String>>> {
    // Kosaraju: order by finish time, then collect on the reversed graph.
    let nodes: Vec<&Vec<String>> = graph.keys().collect();
    let mut seen = BTreeSet::new();
    let mut order = Vec::new();
    for &n in &nodes {
        let mut stack = vec![(n, false)];
        while let Some((v, done)) = stack.pop() {
            if done {
                order.push(v);
                continue;
            }
            if !seen.insert(v) {
                continue;
            }
            stack.push((v, true));
            for w in &graph[v] {
                if !seen.contains(w) {
                    stack.push((w, false));
                }
            }
        }
    }
    let mut rev: BTreeMap<&Vec<String>, Vec<&Vec<String>>> = BTreeMap::new();
    for (v, ws) in graph {
        for w in ws {
            rev.entry(w).or_default().push(v);
        }
    }
    let mut assigned = BTreeSet::new();
    let mut out = Vec::new();
    for &v in order.iter().rev() {
        if assigned.contains(v) {
            continue;
        }
        let mut comp = Vec::new();
        let mut stack = vec![v];
        assigned.insert(v);
        while let Some(x) = stack.pop() {
            comp.push(x.clone());
            for &y in rev.get(x).map(Vec::as_slice).unwrap_or_default() {
                if assigned.insert(y) {
                    stack.push(y);
                }
            }
        }
        if comp.len() > 1 {
            comp.sort();
            out.push(comp);
        }
    }
    out
}

/// The file-level import graph of one crate.
fn graph(src: &Path) -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let mods = modules(src);
    let mut g: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for (me, file) in &mods {
        let name = file.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let facade = matches!(name, "mod.rs" | "lib.rs");
        let text = code(&std::fs::read_to_string(file).expect("source"));
        let deps = g.entry(me.clone()).or_default();
        for p in paths(&text, facade) {
            if let Some(target) = resolve(&p, me, &mods) {
                // Naming one's own module or an ancestor (the facade) is not a dependency.
                if !me.starts_with(&target) {
                    deps.insert(target);
                }
            }
        }
    }
    g
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

#[test]
fn no_crate_has_an_import_circle() {
    let mut found = Vec::new();
    for krate in [
        "evogs-math",
        "evogs-ode",
        "evogs-splat",
        "evogs",
        "evogs-verify",
        "evogs-cli",
    ] {
        let g = graph(&root().join(krate).join("src"));
        assert!(g.len() > 5, "{krate}: read {} modules", g.len());
        for c in circles(&g) {
            let names: Vec<String> = c.iter().map(|m| m.join("::")).collect();
            found.push(format!("{krate}: {}", names.join(" <-> ")));
        }
    }
    assert!(found.is_empty(), "import circles:\n{}", found.join("\n"));
}

#[test]
fn the_checker_sees_a_circle_and_resolves_paths() {
    // A made-up crate with a circle a -> b -> a, a facade that re-exports, and a child
    // naming its parent.
    let dir = std::env::temp_dir().join(format!("evogs-cycles-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("p")).expect("tmp");
    std::fs::write(
        dir.join("lib.rs"),
        "pub mod a;\npub mod b;\npub mod p;\npub use a::X;\n",
    )
    .expect("w");
    std::fs::write(
        dir.join("a.rs"),
        "use crate::b::{Y, self as bee};\npub struct X;\n",
    )
    .expect("w");
    std::fs::write(
        dir.join("b.rs"),
        "pub struct Y;\nfn f() { let _ = crate::a::X; }\n",
    )
    .expect("w");
    std::fs::write(
        dir.join("p/mod.rs"),
        "pub mod q;\npub use q::Z;\npub struct W;\n",
    )
    .expect("w");
    std::fs::write(
        dir.join("p/q.rs"),
        "use super::W;\n// use crate::a::X;\npub struct Z;\n",
    )
    .expect("w");
    let g = graph(&dir);
    let c = circles(&g);
    assert_eq!(
        c,
        vec![vec![vec!["a".to_string()], vec!["b".to_string()]]],
        "{g:?}"
    );
    assert!(
        g[&vec!["p".to_string(), "q".to_string()]].is_empty(),
        "parent and comment ignored"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn core_crates_depend_only_downwards() {
    let deps = |krate: &str| -> String {
        std::fs::read_to_string(root().join(krate).join("Cargo.toml")).expect("manifest")
    };
    let has = |krate: &str, dep: &str| {
        deps(krate).lines().any(|l| {
            l.trim_start().starts_with(&format!("{dep} "))
                || l.trim_start().starts_with(&format!("{dep}="))
        })
    };
    assert!(!has("evogs-math", "evogs-ode") && !has("evogs-math", "evogs-splat"));
    assert!(!has("evogs-ode", "evogs-splat") && !has("evogs-splat", "evogs-ode"));
    assert!(has("evogs-ode", "evogs-math") && has("evogs-splat", "evogs-math"));
}

#[test]
fn the_crates_depend_one_way() {
    // math <- ode, math <- splat; the method library above them; verification above the
    // library; the commands on top. Each crate names only crates of lower layers.
    let layers: [&[&str]; 5] = [
        &["evogs-math"],
        &["evogs-ode", "evogs-splat"],
        &["evogs"],
        &["evogs-verify"],
        &["evogs-cli"],
    ];
    let manifest = |krate: &str| -> String {
        std::fs::read_to_string(root().join(krate).join("Cargo.toml")).expect("manifest")
    };
    let names = |krate: &str| -> Vec<String> {
        manifest(krate)
            .lines()
            .filter_map(|l| l.split_whitespace().next())
            .filter(|w| w.starts_with("evogs"))
            .map(str::to_string)
            .collect()
    };
    for (level, crates) in layers.iter().enumerate() {
        for krate in *crates {
            for dep in names(krate) {
                let Some(dep_level) = layers.iter().position(|l| l.contains(&dep.as_str())) else {
                    continue;
                };
                assert!(
                    dep_level < level,
                    "{krate} (layer {level}) depends on {dep} (layer {dep_level})"
                );
            }
        }
    }
    let lib = names("evogs");
    for low in ["evogs-math", "evogs-ode", "evogs-splat"] {
        assert!(lib.iter().any(|d| d == low), "evogs builds on {low}");
    }
}
