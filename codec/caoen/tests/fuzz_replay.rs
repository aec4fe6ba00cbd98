//! Replays the fuzz targets' seeds (`tests/fuzz/seeds/<target>/`) and the kept
//! findings (`tests/bad/<target>/`) through the same target bodies the fuzzer runs
//! (`tests/fuzz/src/lib.rs`, compiled in here), without AFL: none may panic, and each
//! must finish within a time bound. The targets' own checks decide what a panic is; a
//! finding must end in an error or in a success the targets' checks accept.
//! See `docs/fuzzing.md`.

mod common;

use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::Duration;

#[path = "../../../tests/fuzz/src/lib.rs"]
// `single_thread` is for the fuzz binaries only.
#[allow(dead_code)]
mod harness;

/// Hang guard per file; far above any expected run (milliseconds), so only a hang or a
/// runaway trips it, never a slow machine.
const TIME_BOUND: Duration = Duration::from_secs(20);

fn files(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut v: Vec<PathBuf> = entries
        .map(|e| e.expect("directory entry").path())
        // Dot files keep empty directories in git.
        .filter(|p| {
            p.is_file()
                && !p
                    .file_name()
                    .is_some_and(|n| n.to_string_lossy().starts_with('.'))
        })
        .collect();
    v.sort();
    v
}

/// How one replay ended, if not well.
fn replay_one(body: harness::Target, path: &Path) -> Option<String> {
    let data = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (tx, rx) = mpsc::channel();
    // A thread, so a hang can be reported instead of stalling the suite; a hung thread
    // is left behind and ends with the test process.
    std::thread::spawn(move || {
        let r = std::panic::catch_unwind(|| body(&data));
        let _ = tx.send(r);
    });
    match rx.recv_timeout(TIME_BOUND) {
        Ok(Ok(_)) => None,
        Ok(Err(panic)) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "a panic".into());
            Some(format!("{}: panicked: {what}", path.display()))
        }
        Err(_) => Some(format!(
            "{}: did not finish within {} s",
            path.display(),
            TIME_BOUND.as_secs()
        )),
    }
}

/// Replays every seed and finding of `target`; fails naming each file that panicked or
/// hung. Returns the number of files replayed.
fn replay(target: &str) -> usize {
    let root = common::repo_root();
    let (_, body) = harness::TARGETS
        .iter()
        .find(|(name, _)| *name == target)
        .unwrap_or_else(|| panic!("no target {target}"));
    let seeds = files(&root.join("tests/fuzz/seeds").join(target));
    assert!(!seeds.is_empty(), "no seeds for {target}");
    let bad = files(&root.join("tests/bad").join(target));
    let failures: Vec<String> = seeds
        .iter()
        .chain(&bad)
        .filter_map(|p| replay_one(*body, p))
        .collect();
    assert!(
        failures.is_empty(),
        "{} of {} files failed:\n{}",
        failures.len(),
        seeds.len() + bad.len(),
        failures.join("\n")
    );
    seeds.len() + bad.len()
}

#[test]
fn every_target_is_replayed() {
    let names: Vec<&str> = harness::TARGETS.iter().map(|(n, _)| *n).collect();
    assert_eq!(
        names,
        [
            "decode",
            "container",
            "image",
            "surface",
            "scene",
            "distort",
            "frep",
            "obj",
            "ply",
            "scene_frep",
            "jpeg_meta",
            "png_meta",
            "exif",
            "icc",
            "xmp"
        ],
        "a target without a replay test below"
    );
}

#[test]
fn decode() {
    replay("decode");
}

#[test]
fn container() {
    replay("container");
}

#[test]
fn image() {
    replay("image");
}

#[test]
fn surface() {
    replay("surface");
}

#[test]
fn scene() {
    replay("scene");
}

#[test]
fn distort() {
    replay("distort");
}

#[test]
fn frep() {
    replay("frep");
}

#[test]
fn obj() {
    replay("obj");
}

#[test]
fn ply() {
    replay("ply");
}

#[test]
fn scene_frep() {
    replay("scene_frep");
}

#[test]
fn jpeg_meta() {
    replay("jpeg_meta");
}

#[test]
fn png_meta() {
    replay("png_meta");
}

#[test]
fn exif() {
    replay("exif");
}

#[test]
fn icc() {
    replay("icc");
}

#[test]
fn xmp() {
    replay("xmp");
}
