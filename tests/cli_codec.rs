//! End-to-end tests of `caoen encode|decode|info` and the demo.

mod common;
use common::caoen;

use std::path::{Path, PathBuf};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("caoen-cli-codec-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A small photo-like PNG from the corpus.
fn input_png(dir: &Path) -> PathBuf {
    let img = caoen_corpus::generate(caoen_corpus::Class::Scene, 96, 64, 2);
    let p = dir.join("photo.png");
    img.to_dynamic_image().save(&p).unwrap();
    p
}

#[test]
fn encode_decode_info_round_trip_and_overwrite_rules() {
    let d = tmpdir("roundtrip");
    let png = input_png(&d);
    let out = caoen(&["encode", s(&png), "-q", "80", "--quiet"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.stderr.is_empty(), "--quiet prints nothing");
    let cae = d.join("photo.cae");
    assert!(cae.exists(), "default output is the input's stem with .cae");
    // The default-named output is not overwritten without -f.
    let again = caoen(&["encode", s(&png)]);
    assert_eq!(again.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&again.stderr).contains("--force"));
    assert!(caoen(&["encode", s(&png), "-f", "--quiet"])
        .status
        .success());
    // Validate only, then decode to PNG, then info.
    let v = caoen(&["decode", s(&cae)]);
    assert!(v.status.success() && String::from_utf8_lossy(&v.stderr).contains("valid"));
    let back = d.join("back.png");
    assert!(caoen(&["decode", s(&cae), "-o", s(&back)]).status.success());
    let img = image::open(&back).unwrap();
    assert_eq!((img.width(), img.height()), (96, 64));
    let info = caoen(&["info", s(&cae), "--json"]);
    let j: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(j["width"], 96);
    let total: u64 = j["sections"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["bytes"].as_u64().unwrap())
        .sum();
    assert_eq!(
        total + 5,
        j["bytes"].as_u64().unwrap(),
        "sections plus magic and version make the file"
    );
    // compare agrees that the decoded file is close to the original.
    let cmp = caoen(&["compare", s(&png), s(&cae), "--json"]);
    assert!(
        cmp.status.success(),
        "{}",
        String::from_utf8_lossy(&cmp.stderr)
    );
}

#[test]
fn output_bytes_do_not_depend_on_threads() {
    let d = tmpdir("threads");
    let png = input_png(&d);
    let (a, b) = (d.join("a.cae"), d.join("b.cae"));
    assert!(
        caoen(&["encode", s(&png), "-o", s(&a), "-j", "1", "--quiet"])
            .status
            .success()
    );
    assert!(
        caoen(&["encode", s(&png), "-o", s(&b), "-j", "2", "--quiet"])
            .status
            .success()
    );
    assert_eq!(std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
}

#[test]
fn target_size_keypoint_map_and_json() {
    let d = tmpdir("target");
    let png = input_png(&d);
    let cae = d.join("t.cae");
    let map = d.join("map.png");
    let out = caoen(&[
        "encode",
        s(&png),
        "-o",
        s(&cae),
        "--target-size",
        "700",
        "--keypoint-map",
        s(&map),
        "--json",
        "--quiet",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let bytes = j["bytes"].as_f64().unwrap();
    assert!(
        (bytes / 700.0 - 1.0).abs() < 0.05,
        "{bytes} bytes for a 700-byte target"
    );
    assert_eq!(image::open(&map).unwrap().width(), 96);
}

#[test]
fn bad_input_and_usage_fail_cleanly() {
    let d = tmpdir("bad");
    let png = input_png(&d);
    let cae = d.join("x.cae");
    assert!(caoen(&["encode", s(&png), "-o", s(&cae), "--quiet"])
        .status
        .success());
    let mut bytes = std::fs::read(&cae).unwrap();
    bytes.truncate(bytes.len() / 2);
    let cut = d.join("cut.cae");
    std::fs::write(&cut, &bytes).unwrap();
    let out = caoen(&["decode", s(&cut)]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("truncated") && !err.contains("panicked"),
        "{err}"
    );
    let junk = d.join("junk.png");
    std::fs::write(&junk, b"not a png at all").unwrap();
    assert_eq!(
        caoen(&["encode", s(&junk), "-o", s(&cae)]).status.code(),
        Some(1)
    );
    assert_eq!(
        caoen(&["encode", s(&png), "-q", "150"]).status.code(),
        Some(2)
    );
    assert_eq!(
        caoen(&["encode", s(&png), "--frobnicate"]).status.code(),
        Some(2)
    );
    assert_eq!(
        caoen(&["decode", s(&cae), "--supersample", "9"])
            .status
            .code(),
        Some(2)
    );
    assert_eq!(
        caoen(&["decode", s(&cae), "--max-pixels", "10"])
            .status
            .code(),
        Some(1)
    );
    assert_eq!(
        caoen(&["decode", s(&cae), "-o", s(&d.join("x.bmp"))])
            .status
            .code(),
        Some(2)
    );
    assert_eq!(
        caoen(&["info", s(&d.join("missing.cae"))]).status.code(),
        Some(1)
    );
}

#[test]
fn demo_runs_on_built_in_data() {
    let d = tmpdir("demo");
    let out = caoen(&["demo", "-o", s(&d), "--quiet"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("bpp") && text.contains("PSNR"), "{text}");
    for f in ["scene.cae", "scene-decoded.png", "scene-original.png"] {
        assert!(d.join(f).exists(), "{f}");
    }
}

#[test]
fn an_error_names_the_bad_file_once() {
    let d = tmpdir("named-once");
    let junk = d.join("junk.png");
    std::fs::write(&junk, b"\x89PNG\r\n\x1a\nnot really").unwrap();
    let out = d.join("out.png");
    for args in [
        vec!["encode", s(&junk), "-o", s(&d.join("x.cae"))],
        vec!["compare", s(&junk), s(&junk)],
        vec!["distort", s(&junk), "-o", s(&out), "--move", "1,1:2,2"],
        vec![
            "surface",
            "render",
            "builtin:blob",
            "-o",
            s(&out),
            "--texture",
            s(&junk),
        ],
    ] {
        let o = caoen(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert_eq!(err.matches("junk.png").count(), 1, "{args:?}: {err}");
    }
}
