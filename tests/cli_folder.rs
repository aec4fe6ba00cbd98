//! End-to-end tests of folder mode: `caoen encode DIR -o OUT` and `caoen decode DIR -o
//! OUT` keep the tree's layout, give each file the single-file command's bytes, skip
//! complete outputs with `--resume`, and go on past a failed file to exit 1 naming it.

mod common;
use common::{caoen, caoen_ok, s, stderr};

use std::path::{Path, PathBuf};
use std::process::Output;

/// The corpus scene of `seed`, `w x h`, written as `dir/name` (folders created).
fn scene(dir: &Path, name: &str, w: u32, h: u32, seed: u64) -> PathBuf {
    let img = caoen_corpus::generate(caoen_corpus::Class::Scene, w, h, seed);
    let p = dir.join(name);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    img.to_dynamic_image().save(&p).unwrap();
    p
}

/// A fresh directory for the test `name` and, in it, a tree of three images (PNG and
/// JPEG, one in a sub-folder) and a text file: (directory, tree).
fn tree(name: &str) -> (PathBuf, PathBuf) {
    let d = common::fresh_dir(name);
    let src = d.join("in");
    scene(&src, "a.png", 64, 48, 1);
    scene(&src, "sub/b.jpg", 48, 40, 2);
    scene(&src, "sub/deeper/c.png", 40, 40, 3);
    std::fs::write(src.join("notes.txt"), "not an image").unwrap();
    (d, src)
}

/// Runs `caoen [global..] command from -o to [rest..]`, a folder run.
fn run(global: &[&str], command: &str, from: &Path, to: &Path, rest: &[&str]) -> Output {
    let mut args = global.to_vec();
    args.extend([command, s(from), "-o", s(to)]);
    args.extend(rest);
    caoen(&args)
}

/// [`run`], asserting that it succeeded.
fn run_ok(global: &[&str], command: &str, from: &Path, to: &Path, rest: &[&str]) -> Output {
    let out = run(global, command, from, to, rest);
    common::assert_ok(&out);
    out
}

/// Every file under `root`, by its path below it.
fn files(root: &Path) -> Vec<(String, Vec<u8>)> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<(String, Vec<u8>)>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                let rel = p.strip_prefix(root).unwrap().to_string_lossy().into_owned();
                out.push((rel, std::fs::read(&p).unwrap()));
            }
        }
    }
    let mut out = Vec::new();
    walk(root, root, &mut out);
    out.sort();
    out
}

fn json(out: &std::process::Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("{e}: {}", stderr(out)))
}

/// Encodes the folder `src` to `cae` at quality `q`, then decodes that to `png`.
fn encode_decode(src: &Path, cae: &Path, png: &Path, q: &str) {
    run_ok(&["--quiet"], "encode", src, cae, &["-q", q]);
    run_ok(&["--quiet"], "decode", cae, png, &[]);
}

/// The totals of `caoen command from -o to [rest..] --resume --json`, run again over
/// outputs that are there already.
fn resumed_totals(command: &str, from: &Path, to: &Path, rest: &[&str]) -> serde_json::Value {
    let rest = [rest, &["--resume", "--json"]].concat();
    json(&run_ok(&[], command, from, to, &rest))["totals"].clone()
}

/// `out` ended with exit code `code` and `needle` in its standard error.
fn assert_fails_with(out: &std::process::Output, code: i32, needle: &str) {
    assert_eq!(out.status.code(), Some(code));
    let err = stderr(out);
    assert!(err.contains(needle), "{err}");
}

#[test]
fn a_folder_encodes_to_the_single_file_bytes_in_the_same_layout() {
    let (d, src) = tree("cli-folder-encode");
    let out = d.join("out");
    let result = run_ok(&[], "encode", &src, &out, &["-q", "60", "--json"]);
    let names: Vec<String> = files(&out).into_iter().map(|(n, _)| n).collect();
    assert_eq!(names, ["a.cae", "sub/b.cae", "sub/deeper/c.cae"]);
    for (rel, bytes) in files(&out) {
        let input = ["png", "jpg"]
            .iter()
            .map(|e| src.join(&rel).with_extension(e))
            .find(|p| p.exists())
            .unwrap();
        let single = d.join("single.cae");
        caoen_ok(&["-f", "encode", s(&input), "-q", "60", "-o", s(&single)]);
        assert_eq!(bytes, std::fs::read(&single).unwrap(), "{rel}");
    }
    let j = json(&result);
    assert_eq!(j["totals"]["files"], 3);
    assert_eq!(j["totals"]["encoded"], 3);
    assert_eq!(j["totals"]["failed"], 0);
    let first = &j["files"][0];
    assert_eq!(first["status"], "encoded");
    let bytes_out = first["bytes_out"].as_u64().unwrap();
    assert_eq!(
        bytes_out,
        std::fs::metadata(out.join("a.cae")).unwrap().len()
    );
    let bpp = first["bpp"].as_f64().unwrap();
    assert!(
        (bpp - bytes_out as f64 * 8.0 / (64.0 * 48.0)).abs() < 1e-9,
        "{first}"
    );
    assert!(first["seconds"].as_f64().unwrap() >= 0.0);
}

#[test]
fn resume_skips_complete_outputs_and_existing_ones_need_force() {
    let (d, src) = tree("cli-folder-resume");
    let out = d.join("out");
    run_ok(&["--quiet"], "encode", &src, &out, &["-q", "50"]);
    let before = files(&out);
    let stamp = |p: &Path| std::fs::metadata(p).unwrap().modified().unwrap();
    let t = stamp(&out.join("a.cae"));
    // A second run with --resume does nothing.
    let totals = resumed_totals("encode", &src, &out, &["-q", "50"]);
    assert_eq!(totals["skipped"], 3);
    assert_eq!(stamp(&out.join("a.cae")), t);
    // An output cut short is not complete: --resume does not skip it, and it is not
    // replaced without -f.
    let cut = &before[0].1[..before[0].1.len() / 2];
    std::fs::write(out.join("a.cae"), cut).unwrap();
    let refused = run(&[], "encode", &src, &out, &["-q", "50", "--resume"]);
    assert_eq!(refused.status.code(), Some(1));
    assert!(stderr(&refused).contains("--force"), "{}", stderr(&refused));
    assert_eq!(std::fs::read(out.join("a.cae")).unwrap(), cut);
    run_ok(&["-f"], "encode", &src, &out, &["-q", "50", "--resume"]);
    assert_eq!(files(&out), before);
    // Without --resume or -f every existing output is refused.
    let all = run(&[], "encode", &src, &out, &["-q", "50"]);
    assert_fails_with(&all, 1, "3 of 3 files failed");
}

#[test]
fn a_damaged_file_is_named_and_the_rest_are_encoded() {
    let (d, src) = tree("cli-folder-damaged");
    std::fs::write(src.join("sub/broken.png"), b"\x89PNG\r\n\x1a\nnot really").unwrap();
    let out = d.join("out");
    let result = run(&[], "encode", &src, &out, &["--json"]);
    assert_eq!(result.status.code(), Some(1), "{}", stderr(&result));
    let err = stderr(&result);
    assert!(err.contains("broken.png"), "{err}");
    assert!(err.contains("1 of 4 files failed"), "{err}");
    let names: Vec<String> = files(&out).into_iter().map(|(n, _)| n).collect();
    assert_eq!(
        names,
        ["a.cae", "sub/b.cae", "sub/deeper/c.cae"],
        "no half-written or temporary file"
    );
    let j = json(&result);
    assert_eq!(j["totals"]["failed"], 1);
    let failed: Vec<_> = j["files"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|f| f["status"] == "failed")
        .collect();
    assert!(failed[0]["input"].as_str().unwrap().ends_with("broken.png"));
    assert!(failed[0]["error"].as_str().unwrap().contains("broken.png"));
}

#[test]
fn a_folder_decodes_to_the_single_file_images() {
    let (d, src) = tree("cli-folder-decode");
    let (cae, png) = (d.join("cae"), d.join("png"));
    encode_decode(&src, &cae, &png, "70");
    let decoded = files(&png);
    let names: Vec<&str> = decoded.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["a.png", "sub/b.png", "sub/deeper/c.png"]);
    for (rel, bytes) in &decoded {
        let single = d.join("single.png");
        let input = cae.join(rel).with_extension("cae");
        run_ok(&["-f"], "decode", &input, &single, &[]);
        assert_eq!(*bytes, std::fs::read(&single).unwrap(), "{rel}");
    }
    let totals = resumed_totals("decode", &cae, &png, &[]);
    assert_eq!(totals["skipped"], 3);
}

#[test]
fn folder_usage_errors() {
    let (d, src) = tree("cli-folder-usage");
    let no_output = caoen(&["encode", s(&src)]);
    assert_eq!(no_output.status.code(), Some(2));
    assert!(stderr(&no_output).contains("-o OUT_DIR"));
    let file = src.join("a.png");
    let onto_file = run(&[], "encode", &src, &file, &[]);
    assert_eq!(onto_file.status.code(), Some(2));
    let resume_file = caoen(&["encode", s(&file), "--resume"]);
    assert_eq!(resume_file.status.code(), Some(2));
    // Two inputs with one output: the first in name order has it, the other fails.
    scene(&src, "a.jpg", 32, 32, 4);
    let out = d.join("out");
    let twice = run(&[], "encode", &src, &out, &[]);
    assert_fails_with(&twice, 1, "same output as");
}

#[test]
fn the_output_folder_inside_the_input_is_not_an_input() {
    let (_, src) = tree("cli-folder-inside");
    let (out, png) = (src.join("encoded"), src.join("encoded/decoded"));
    encode_decode(&src, &out, &png, "40");
    // A second encode would take the decoded PNGs as inputs unless it skipped `encoded/`.
    let totals = resumed_totals("encode", &src, &out, &["-q", "40"]);
    assert_eq!(totals["files"], 3);
}
