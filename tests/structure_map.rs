//! `docs/STRUCTURE.md` maps every file: each source, test, doc and script appears in
//! the table's first column by its path, or its directory does (a row for `dir/`
//! covers the files directly in it). Data folders (examples, kept findings, seeds,
//! snapshots, plots, the bundled font) need only their own row.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

/// Folders whose contents are data, described by their own row.
const DATA: [&str; 7] = [
    "examples/",
    "tests/bad/",
    "tests/snapshots/",
    "tests/fuzz/seeds/",
    "tests/fuzz/dicts/",
    "docs/bench/",
    "tools/caoen-cli/assets/",
];

/// Not part of the repository: build output, version control, what the README's
/// first command (`cargo run --release`) writes, the built WebAssembly package and the
/// web tests' npm modules (all git-ignored).
const SKIP: [&str; 7] = [
    ".git",
    "target",
    "tests/fuzz/target",
    "tools/python/target",
    "caoen-demo",
    "tools/web/pkg",
    "tools/web/test/node_modules",
];

fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        let rel = p
            .strip_prefix(root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        if SKIP.contains(&rel.as_str()) {
            continue;
        }
        if p.is_dir() {
            if DATA.contains(&format!("{rel}/").as_str()) {
                out.push(format!("{rel}/"));
            } else {
                walk(root, &p, out);
            }
        } else {
            out.push(rel);
        }
    }
}

/// The paths the table's first column names: paths from the repository's root, and
/// names relative to the directory of the cell's first path (`` `a/b.rs`, `c.rs` ``
/// names `a/c.rs`).
fn mapped(root: &Path, structure: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for line in structure.lines() {
        let Some(cell) = line.strip_prefix("| ").and_then(|l| l.split(" | ").next()) else {
            continue;
        };
        let tokens: Vec<&str> = cell.split('`').skip(1).step_by(2).collect();
        let Some(first) = tokens.first() else {
            continue;
        };
        let base = if first.ends_with('/') {
            PathBuf::from(first)
        } else {
            Path::new(first)
                .parent()
                .map(Path::to_path_buf)
                .unwrap_or_default()
        };
        for t in &tokens {
            let name = if root.join(t).exists() {
                t.to_string()
            } else {
                base.join(t).to_string_lossy().replace('\\', "/")
            };
            out.insert(name);
        }
    }
    out
}

#[test]
fn structure_map_covers_every_file() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let structure = std::fs::read_to_string(root.join("docs/STRUCTURE.md")).unwrap();
    let rows = mapped(root, &structure);
    let mut files = Vec::new();
    walk(root, root, &mut files);
    assert!(files.len() > 100, "walked only {} files", files.len());
    let missing: Vec<&String> = files
        .iter()
        .filter(|f| {
            let parent = Path::new(f.trim_end_matches('/'))
                .parent()
                .map(|p| format!("{}/", p.to_string_lossy()))
                .unwrap_or_default();
            !rows.contains(*f) && !rows.contains(&parent)
        })
        .collect();
    assert!(
        missing.is_empty(),
        "docs/STRUCTURE.md does not map {} files: {missing:?}",
        missing.len()
    );
}
