//! End-to-end tests of `caoen compare`: data on stdout, messages on stderr, exit codes
//! 0 (measured), 1 (bad or mismatched inputs), 2 (usage).

mod common;
use common::{caoen, caoen_ok, s};

use std::path::{Path, PathBuf};
use std::process::Output;

use caoen::image_io;
use caoen::metrics;
use caoen::raster::Raster;
use caoen_corpus::{generate, Class};

fn tmpdir(name: &str) -> PathBuf {
    common::fresh_dir(&format!("compare-{name}"))
}

/// A corpus image written as a file, and its raster.
fn corpus_file(dir: &Path, class: Class, seed: u64, w: u32, h: u32) -> (PathBuf, Raster) {
    let img = generate(class, w, h, seed);
    let ext = img.sample_format().extension();
    let path = dir.join(format!("{class}-{seed}-{w}x{h}.{ext}"));
    img.save(&path).unwrap();
    let r = image_io::load(&path).unwrap();
    (path, r)
}

/// The raster with every sample nudged by a fixed pattern, saved next to it.
fn distorted(dir: &Path, r: &Raster, name: &str) -> (PathBuf, Raster) {
    let samples = r
        .samples()
        .iter()
        .enumerate()
        .map(|(i, &v)| (v + [0.0, 0.02, -0.03, 0.05][i % 4]).clamp(0.0, 1.0))
        .collect();
    let d = Raster::new(r.width(), r.height(), r.layout(), r.format(), samples).unwrap();
    let path = dir.join(name);
    image_io::save(&d, &path).unwrap();
    let back = image_io::load(&path).unwrap();
    (path, back)
}

fn json(out: &Output) -> serde_json::Value {
    assert!(
        out.status.success(),
        "exit {:?}: {}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

#[test]
fn identical_files_are_infinite_psnr_and_ssim_one() {
    let d = tmpdir("same");
    let (a, _) = corpus_file(&d, Class::Scene, 0, 48, 40);
    let v = json(&caoen(&["compare", s(&a), s(&a), "--json"]));
    assert_eq!(v["identical"], true);
    assert!(v["psnr"].is_null() && v["psnr_y"].is_null());
    assert_eq!(v["ssim"].as_f64().unwrap(), 1.0);
    assert!((v["ssimulacra2"].as_f64().unwrap() - 100.0).abs() < 1e-6);
    assert_eq!(
        (v["width"].as_u64(), v["height"].as_u64()),
        (Some(48), Some(40))
    );
    // Text mode says "inf".
    let out = caoen_ok(&["compare", s(&a), s(&a)]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("inf dB"));
}

#[test]
fn measured_values_equal_the_library_metrics() {
    let d = tmpdir("values");
    for (class, seed) in [
        (Class::Natural, 0),
        (Class::Texture, 4),
        (Class::EdgeCases, 3),
    ] {
        let (a, ra) = corpus_file(&d, class, seed, 33, 21);
        let (b, rb) = distorted(&d, &ra, &format!("{class}-{seed}-distorted.png"));
        let want = metrics::compare(&ra, &rb).unwrap();
        let v = json(&caoen(&["compare", s(&a), s(&b), "--json"]));
        assert_eq!(v["psnr"].as_f64().unwrap(), want.psnr, "{class}");
        assert_eq!(v["psnr_y"].as_f64().unwrap(), want.psnr_y, "{class}");
        assert_eq!(v["ssim"].as_f64().unwrap(), want.ssim, "{class}");
        assert_eq!(v["ssimulacra2"].as_f64(), want.ssimulacra2, "{class}");
        assert_eq!(v["scale"], "display");
        assert!(want.psnr > 20.0 && want.psnr < 40.0, "{}", want.psnr);
    }
}

#[test]
fn text_on_stdout_messages_on_stderr_quiet_silences() {
    let d = tmpdir("text");
    let (a, ra) = corpus_file(&d, Class::Scene, 1, 32, 32);
    let (b, _) = distorted(&d, &ra, "b.png");
    let out = caoen_ok(&["compare", s(&a), s(&b)]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    for key in ["PSNR", "Y-PSNR", "SSIM", "SSIMULACRA2"] {
        assert!(stdout.contains(key), "{stdout}");
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("32x32 RGB 8-bit"), "{stderr}");
    let quiet = caoen(&["compare", s(&a), s(&b), "--quiet"]);
    assert!(quiet.stderr.is_empty());
    assert_eq!(quiet.stdout, out.stdout);
}

#[test]
fn hdr_files_compare_on_the_log_scale() {
    let d = tmpdir("hdr");
    let (a, ra) = corpus_file(&d, Class::Hdr, 0, 24, 16);
    // Double every value: one stop everywhere, about 30.1 dB on the log scale.
    let doubled: Vec<f32> = ra.samples().iter().map(|v| v * 2.0).collect();
    let rb = Raster::new(24, 16, ra.layout(), ra.format(), doubled).unwrap();
    let b = d.join("doubled.exr");
    image_io::save(&rb, &b).unwrap();
    let v = json(&caoen(&["compare", s(&a), s(&b), "--json"]));
    assert_eq!(v["scale"], "log-hdr");
    assert!((v["psnr"].as_f64().unwrap() - 30.1).abs() < 0.1, "{v}");
    assert!(v["ssimulacra2"].is_null());
}

#[test]
fn failures_exit_1_with_a_message() {
    let d = tmpdir("fail");
    let (a, _) = corpus_file(&d, Class::Scene, 0, 32, 32);
    let (b, _) = corpus_file(&d, Class::Scene, 0, 32, 31);
    let bad = common::repo_path("tests/bad");
    let cae = d.join("garbage.cae");
    std::fs::write(&cae, b"not a caoen file").unwrap();
    let cases: Vec<(Vec<String>, &str)> = vec![
        (vec![s(&a).into(), s(&b).into()], "differ in size"),
        (
            vec![s(&a).into(), "/nonexistent/x.png".into()],
            "/nonexistent/x.png",
        ),
        (
            vec![s(&a).into(), s(&bad.join("nan.exr")).into()],
            "channel G at pixel (2, 1)",
        ),
        (
            vec![s(&a).into(), s(&bad.join("truncated.png")).into()],
            "truncated",
        ),
        (vec![s(&a).into(), s(&cae).into()], "garbage.cae"),
    ];
    for (args, needle) in cases {
        let mut full = vec!["compare"];
        full.extend(args.iter().map(String::as_str));
        let out = caoen(&full);
        assert_eq!(out.status.code(), Some(1), "{args:?}");
        assert!(out.stdout.is_empty(), "{args:?}: no data on failure");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn usage_errors_exit_2() {
    assert_eq!(caoen(&["compare"]).status.code(), Some(2));
    assert_eq!(caoen(&["compare", "a.png"]).status.code(), Some(2));
    assert_eq!(
        caoen(&["compare", "a.png", "b.png", "--bogus"])
            .status
            .code(),
        Some(2)
    );
}

/// A caoen file is decoded with the codec's own decoder and measured like an image.
#[test]
fn cae_files_are_decoded() {
    let d = tmpdir("cae");
    let (a, ra) = corpus_file(&d, Class::Scene, 0, 64, 48);
    let bytes = caoen::codec::encode(&ra, &Default::default()).unwrap();
    let cae = d.join("scene.cae");
    std::fs::write(&cae, &bytes).unwrap();
    let decoded = caoen::codec::decode(&bytes, &Default::default()).unwrap();
    let want = metrics::compare(&ra, &decoded).unwrap();
    let v = json(&caoen(&["compare", s(&a), s(&cae), "--json"]));
    assert_eq!(v["psnr"].as_f64().unwrap(), want.psnr);
    assert_eq!(v["ssim"].as_f64().unwrap(), want.ssim);
}
