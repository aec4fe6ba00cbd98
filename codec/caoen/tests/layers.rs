//! The library's layers: Cargo keeps the crates from depending on each other in a
//! cycle; inside each crate, the graph of which top-level module uses which (every
//! `crate::` path in their sources) has no cycle either, and no library source file
//! is over 800 lines (a generated table whose first lines say `@generated` excepted).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

mod common;

/// Top-level module of a source file, from its path under `src/`.
fn module_of(rel: &Path) -> Option<String> {
    let first = rel.components().next()?.as_os_str().to_str()?;
    let name = first.strip_suffix(".rs").unwrap_or(first);
    (name != "lib").then(|| name.to_string())
}

/// The top-level modules named by the `crate::` paths in `src`, including those in
/// grouped imports (`use crate::{a::X, b};`).
fn uses(src: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    for (i, _) in src.match_indices("crate::") {
        let rest = &src[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // Top-level names of the group: those at brace depth 0 after a comma or the start.
            let mut depth = 0;
            let mut start = true;
            for (j, c) in group.char_indices() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => start = true,
                    c if start && (c.is_ascii_alphabetic() || c == '_') => {
                        out.insert(ident(&group[j..]));
                        start = false;
                    }
                    _ => {}
                }
            }
        } else {
            out.insert(ident(rest));
        }
    }
    out
}

fn walk(dir: &Path, files: &mut Vec<std::path::PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            walk(&p, files);
        } else if p.extension().is_some_and(|x| x == "rs") {
            files.push(p);
        }
    }
}

/// The library crates' source folders: every `codec/*/src`.
fn crate_sources() -> Vec<std::path::PathBuf> {
    let mut out: Vec<_> = std::fs::read_dir(common::repo_path("codec"))
        .unwrap()
        .map(|e| e.unwrap().path().join("src"))
        .filter(|p| p.is_dir())
        .collect();
    out.sort();
    out
}

/// Module -> the other top-level modules it uses, in the crate whose sources are `src`.
fn graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    walk(src, &mut files);
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in files {
        let Some(m) = module_of(f.strip_prefix(src).unwrap()) else {
            continue;
        };
        // Unit tests may use any module of their crate: only what the code uses counts.
        if f.file_name().is_some_and(|n| n == "tests.rs") {
            continue;
        }
        let text = std::fs::read_to_string(&f).unwrap();
        let text = text.split("#[cfg(test)]").next().unwrap_or_default();
        let entry = g.entry(m.clone()).or_default();
        entry.extend(uses(text).into_iter().filter(|u| *u != m && !u.is_empty()));
    }
    g
}

/// A cycle in `g`, if there is one, as the list of modules around it.
fn find_cycle(g: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        g: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(n) {
            Some(2) => return None,
            Some(1) => {
                let at = stack.iter().position(|s| s == n).unwrap();
                let mut cycle = stack[at..].to_vec();
                cycle.push(n.to_string());
                return Some(cycle);
            }
            _ => {}
        }
        state.insert(n.to_string(), 1);
        stack.push(n.to_string());
        for d in g.get(n).into_iter().flatten() {
            if let Some(c) = visit(d, g, state, stack) {
                return Some(c);
            }
        }
        stack.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in g.keys() {
        if let Some(c) = visit(n, g, &mut state, &mut Vec::new()) {
            return Some(c);
        }
    }
    None
}

#[test]
fn grouped_and_plain_paths_are_both_seen() {
    let u = uses("use crate::{a::X, b, c::{d, e}};\nfn f() { crate::g::h(); }");
    let want: BTreeSet<String> = ["a", "b", "c", "g"].iter().map(|s| s.to_string()).collect();
    assert_eq!(u, want);
}

#[test]
fn a_cycle_is_found_when_there_is_one() {
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    g.entry("a".into()).or_default().insert("b".into());
    g.entry("b".into()).or_default().insert("c".into());
    g.entry("c".into()).or_default().insert("a".into());
    assert_eq!(find_cycle(&g).unwrap().len(), 4);
    g.get_mut("c").unwrap().clear();
    assert_eq!(find_cycle(&g), None);
}

#[test]
fn top_level_modules_have_no_import_cycle() {
    let crates = crate_sources();
    assert!(
        crates.len() >= 10,
        "too few library crates found: {crates:?}"
    );
    for src in crates {
        let g = graph(&src);
        if let Some(cycle) = find_cycle(&g) {
            let edges: Vec<String> = g
                .iter()
                .map(|(m, d)| {
                    format!(
                        "{m} -> {}",
                        d.iter().cloned().collect::<Vec<_>>().join(", ")
                    )
                })
                .collect();
            panic!(
                "import cycle in {}: {}\nthe graph:\n{}",
                src.display(),
                cycle.join(" -> "),
                edges.join("\n")
            );
        }
    }
}

/// The most lines a library source file may have.
const MAX_LINES: usize = 800;

/// Whether a file's first lines mark it as generated.
fn generated(text: &str) -> bool {
    text.lines().take(5).any(|l| l.contains("@generated"))
}

#[test]
fn no_library_source_file_is_over_800_lines() {
    let mut long = Vec::new();
    let mut files = Vec::new();
    for src in crate_sources() {
        walk(&src, &mut files);
    }
    assert!(
        files.len() > 100,
        "too few library sources found: {}",
        files.len()
    );
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        let lines = text.lines().count();
        if lines > MAX_LINES && !generated(&text) {
            long.push(format!("{} ({lines} lines)", f.display()));
        }
    }
    assert!(
        long.is_empty(),
        "library sources over {MAX_LINES} lines:\n{}",
        long.join("\n")
    );
}

#[test]
fn the_line_check_sees_long_files_and_generated_tables() {
    assert!(generated("//! Trained tables.\n//! @generated by a test\n"));
    assert!(!generated("//! Hand-written.\n"));
}

/// The names in the `[dependencies]` table of `crate_dir`'s manifest, each with whether
/// it is optional.
fn dependencies(crate_dir: &str) -> Vec<(String, bool)> {
    let manifest =
        std::fs::read_to_string(common::repo_path(crate_dir).join("Cargo.toml")).unwrap();
    let mut out = Vec::new();
    let mut inside = false;
    for line in manifest.lines().map(str::trim) {
        if line.starts_with('[') {
            inside = line == "[dependencies]";
        } else if inside && !line.is_empty() && !line.starts_with('#') {
            let name = line.split(['=', '.', ' ']).next().unwrap().to_string();
            out.push((name, line.contains("optional = true")));
        }
    }
    out
}

#[test]
fn the_decoder_depends_on_nothing_it_does_not_need() {
    // What a program that only decodes links: no image or mesh formats, no command
    // line, and a thread pool only when asked for.
    let allowed = [
        (
            "codec/caoen-decoder",
            &[
                "caoen-base",
                "thiserror",
                "constriction",
                "crc32fast",
                "leb128",
                "pulp",
            ][..],
        ),
        (
            "codec/caoen-base",
            &["thiserror", "crc32fast", "miniz_oxide"][..],
        ),
    ];
    for (dir, names) in allowed {
        let deps = dependencies(dir);
        assert!(
            deps.len() >= 3,
            "{dir}: too few dependencies read: {deps:?}"
        );
        for (name, optional) in deps {
            assert!(
                names.contains(&name.as_str()) || optional,
                "{dir} depends on {name}, which a decoder does not need"
            );
        }
    }
    let rayon = dependencies("codec/caoen-decoder")
        .into_iter()
        .find(|(n, _)| n == "rayon");
    assert_eq!(
        rayon,
        Some(("rayon".to_string(), true)),
        "rayon is the decoder's option"
    );
}
