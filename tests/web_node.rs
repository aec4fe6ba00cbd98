//! The WebAssembly decoder in Node: `tools/web/build.sh` builds it, `tools/web/test/node.mjs`
//! loads it with `initSync` and compares `decode`, `decodeRegion` and `info` with the
//! command line's decodes of the same files (the photographs of `../shared/photos` at
//! q40 and q80 when present, and corpus scenes), and checks that bad input throws an
//! `Error` with caoen's message. Missing tools (node, wasm-bindgen, the wasm32 target)
//! skip it, or fail it under `CI=true`.

mod common;
mod web_common;

use common::s;
use serde_json::{json, Value};
use std::path::Path;
use std::process::Command;
use web_common::{cli_rgba, need, runs};

/// Photographs of `../shared/photos` the test codes (all of them with
/// `CAOEN_WEB_PHOTOS=all`).
const PHOTOS: usize = 2;

/// The cases of one file: the whole image at its size and two others, three regions.
fn cases(cae: &Path, dir: &Path, tag: &str, (w, h): (u32, u32), tolerance: u8) -> Vec<Value> {
    let mut out = Vec::new();
    let sizes = [None, Some((w / 2, h / 2)), Some((w * 3 / 2 + 1, h * 4 / 3))];
    for (i, size) in sizes.into_iter().enumerate() {
        let png = dir.join(format!("{tag}-size{i}.png"));
        let arg = size.map(|(a, b)| format!("{a}x{b}"));
        let args: Vec<&str> = arg.iter().flat_map(|a| ["--size", a.as_str()]).collect();
        let (ow, oh, rgba) = cli_rgba(cae, &args, &png);
        let raw = dir.join(format!("{tag}-size{i}.rgba"));
        std::fs::write(&raw, rgba).unwrap();
        let js_args = size.map_or(json!([]), |(a, b)| json!([a, b]));
        out.push(
            json!({"name": format!("{tag} decode {size:?}"), "cae": s(cae),
            "call": "decode", "args": js_args, "expect": s(&raw), "width": ow, "height": oh,
            "tolerance": tolerance, "info": null, "error": null}),
        );
    }
    let (fw, fh) = (f64::from(w), f64::from(h));
    let regions = [
        ([0.0, 0.0, fw, fh], (w, h)),
        ([fw / 4.0, fh / 4.0, fw / 2.0, fh / 2.0], (w / 2, h / 2)),
        (
            [
                fw * 0.3 + 0.5,
                fh * 0.2 + 0.25,
                fw * 0.3 + 20.5,
                fh * 0.2 + 15.25,
            ],
            (320, 240),
        ),
    ];
    for (i, (r, (ow, oh))) in regions.into_iter().enumerate() {
        let png = dir.join(format!("{tag}-region{i}.png"));
        let region = format!("{},{},{},{}", r[0], r[1], r[2], r[3]);
        let size = format!("{ow}x{oh}");
        let (cw, ch, rgba) = cli_rgba(cae, &["--region", &region, "--size", &size], &png);
        assert_eq!((cw, ch), (ow, oh));
        let raw = dir.join(format!("{tag}-region{i}.rgba"));
        std::fs::write(&raw, rgba).unwrap();
        out.push(
            json!({"name": format!("{tag} decodeRegion {region} at {size}"), "cae": s(cae),
            "call": "decodeRegion", "args": [r[0], r[1], r[2], r[3], ow, oh], "expect": s(&raw),
            "width": ow, "height": oh, "tolerance": tolerance, "info": null, "error": null}),
        );
    }
    out
}

#[test]
fn the_wasm_decoder_in_node_equals_the_command_line() {
    let Some(()) = need(runs("node", "--version"), "node is not installed") else {
        return;
    };
    let Some(pkg) = web_common::build_pkg() else {
        return;
    };
    let dir = common::fresh_dir("web-node");
    let mut all = Vec::new();
    // Corpus scenes: 8-bit colour, and the same as 16-bit grey through the encoder.
    let scene = web_common::scene_cae(&dir, "scene", (96, 64), 3, 70);
    all.extend(cases(&scene, &dir, "scene", (96, 64), 0));
    let grey16 = dir.join("grey16.png");
    image::open(dir.join("scene.png"))
        .unwrap()
        .into_luma16()
        .save(&grey16)
        .unwrap();
    let grey = web_common::encode(&grey16, &dir, "grey16", 80);
    // The command line writes 16 bits, the page gets 8: within 1.
    all.extend(cases(&grey, &dir, "grey16", (96, 64), 1));
    let photos = common::repo_root().join("../shared/photos");
    let take = if std::env::var("CAOEN_WEB_PHOTOS").is_ok_and(|v| v == "all") {
        usize::MAX
    } else {
        PHOTOS
    };
    let mut names: Vec<_> = std::fs::read_dir(&photos)
        .map(|d| d.filter_map(|e| e.ok().map(|e| e.path())).collect())
        .unwrap_or_default();
    names.retain(|p: &std::path::PathBuf| p.extension().is_some_and(|e| e == "png"));
    names.sort();
    if names.is_empty() {
        eprintln!("no photographs in {}: corpus scenes only", photos.display());
    }
    for photo in names.iter().take(take) {
        let stem = photo.file_stem().unwrap().to_string_lossy().into_owned();
        let size = image::image_dimensions(photo).unwrap();
        for q in [40, 80] {
            let tag = format!("{stem}-q{q}");
            let cae = web_common::encode(photo, &dir, &tag, q);
            all.extend(cases(&cae, &dir, &tag, size, 0));
        }
    }
    // info, and errors: a damaged file, a truncated one, bad sizes and regions.
    all.push(
        json!({"name": "info", "cae": s(&scene), "call": "info", "args": [],
        "expect": null, "width": 0, "height": 0, "tolerance": 0, "error": null,
        "info": {"width": 96, "height": 64, "channels": 3, "bits": 8,
                 "bytes": std::fs::metadata(&scene).unwrap().len()}}),
    );
    let bytes = std::fs::read(&scene).unwrap();
    let damaged = dir.join("damaged.cae");
    let mut d = bytes.clone();
    let mid = d.len() / 2;
    d[mid] ^= 0x55;
    std::fs::write(&damaged, d).unwrap();
    let cut = dir.join("cut.cae");
    std::fs::write(&cut, &bytes[..bytes.len() / 3]).unwrap();
    let junk = dir.join("junk.cae");
    std::fs::write(&junk, b"PNG? no").unwrap();
    // The command line's own messages for the damaged files.
    let cli_error = |f: &Path| {
        let out = common::caoen(&["decode", s(f)]);
        assert!(!out.status.success());
        let err = common::stderr(&out);
        // "caoen: FILE: MESSAGE": the message is the library's.
        let msg = err
            .lines()
            .next()
            .unwrap()
            .rsplit(": invalid")
            .next()
            .unwrap()
            .to_string();
        format!("invalid{msg}")
    };
    let error = |name: &str, f: &Path, call: &str, args: Value, says: String| {
        json!({"name": name, "cae": s(f), "call": call, "args": args, "expect": null,
            "width": 0, "height": 0, "tolerance": 0, "info": null, "error": says})
    };
    all.push(error(
        "damaged",
        &damaged,
        "decode",
        json!([]),
        cli_error(&damaged),
    ));
    all.push(error(
        "truncated",
        &cut,
        "decode",
        json!([]),
        cli_error(&cut),
    ));
    all.push(error(
        "truncated info",
        &cut,
        "info",
        json!([]),
        "invalid caoen file".into(),
    ));
    all.push(error(
        "not caoen",
        &junk,
        "decode",
        json!([]),
        "not a caoen file".into(),
    ));
    all.push(error(
        "zero width",
        &scene,
        "decode",
        json!([0, 10]),
        "width".into(),
    ));
    all.push(error(
        "fraction",
        &scene,
        "decode",
        json!([10.5, 10]),
        "width".into(),
    ));
    all.push(error(
        "one side",
        &scene,
        "decode",
        json!([10]),
        "both".into(),
    ));
    all.push(error(
        "region out",
        &scene,
        "decodeRegion",
        json!([0, 0, 97, 10, 10, 10]),
        "within the image".into(),
    ));
    all.push(error(
        "region NaN",
        &scene,
        "decodeRegion",
        json!([0, 0, "NaN", 10, 10, 10]),
        "finite".into(),
    ));
    all.push(error(
        "too many pixels",
        &scene,
        "decode",
        json!([16384, 16384]),
        "limit exceeded".into(),
    ));
    let spec = dir.join("cases.json");
    std::fs::write(&spec, json!({"pkg": s(&pkg), "cases": all}).to_string()).unwrap();
    let script = common::repo_path("tools/web/test/node.mjs");
    let out = Command::new("node")
        .arg(&script)
        .arg(&spec)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let results: Vec<Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let failed: Vec<&Value> = results.iter().filter(|r| r["ok"] != true).collect();
    let ms: f64 = results.iter().filter_map(|r| r["ms"].as_f64()).sum();
    eprintln!("{} cases in {ms:.0} ms of decoding in Node", results.len());
    assert!(
        out.status.success() && failed.is_empty() && results.len() == all.len(),
        "{failed:#?}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
