//! End-to-end tests of `caoen bench` on a tiny corpus (2 images, 2 rates): the
//! report's structure, sizes from the real files, and PSNR equal to what
//! `caoen compare` measures on the same files.
//!
//! The peer-codec tests need the `peers` feature:
//! `cargo test --features peers --test cli_bench` (CI runs it).

mod common;
use common::{caoen, caoen_ok, s};

use std::path::{Path, PathBuf};

use serde_json::Value;

fn tmpdir(name: &str) -> PathBuf {
    common::fresh_dir(&format!("bench-{name}"))
}

/// Two small corpus images (a scene and a natural texture) with their manifest.
fn tiny_corpus(dir: &Path) -> PathBuf {
    let corpus = dir.join("corpus");
    caoen_ok(&[
        "corpus",
        "--out",
        s(&corpus),
        "--size",
        "96",
        "--classes",
        "scene,natural",
        "--seeds",
        "1",
        "--quiet",
    ]);
    corpus
}

#[test]
fn usage_errors_exit_2() {
    let cases: [(&[&str], &str); 5] = [
        (&["bench", "--rates", "fast"], "bad rate"),
        (&["bench", "--rates", "q120"], "bad quality"),
        (&["bench", "--codecs", "heic"], "unknown codec `heic`"),
        (
            &["bench", "--codecs", "caoen", "--reference", "webp"],
            "not among",
        ),
        (&["bench", "--plot", "rd.gif"], ".png or .svg"),
    ];
    for (args, needle) in cases {
        let out = caoen(args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    let out = caoen(&["bench", "--classes", "portraits"]);
    assert_eq!(out.status.code(), Some(2));
}

#[cfg(not(feature = "peers"))]
#[test]
fn without_peers_the_user_is_told_how_to_enable_them() {
    let out = caoen(&["bench", "--codecs", "caoen,jpeg"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--features peers"), "{err}");
}

/// caoen alone, on a generated corpus: every point is either measured or listed as a
/// failure, and the exit code says which (1 while the encoder is unfinished).
#[test]
fn caoen_only_accounts_for_every_point() {
    let d = tmpdir("caoen-only");
    let report = d.join("report.json");
    // A hand-written page whose generated part sits between the markers.
    let page = d.join("page.md");
    std::fs::write(
        &page,
        "# Title\n\n<!-- caoen bench: begin -->\nold table\n<!-- caoen bench: end -->\n\nAfter.\n",
    )
    .unwrap();
    let out = caoen(&[
        "bench",
        "--codecs",
        "caoen",
        "--classes",
        "smooth",
        "--seeds",
        "1",
        "--size",
        "24",
        "--rates",
        "q30,q80",
        "--report",
        s(&report),
        "--markdown",
        s(&page),
        // The page exists: splicing the tables into it replaces it.
        "--force",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
    if !cfg!(feature = "peers") {
        assert!(err.contains("--features peers"), "{err}");
    }
    let v: Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    assert_eq!(v["format"], "caoen-bench/1");
    let measured = v["measurements"].as_array().unwrap().len();
    let failed = v["failures"].as_array().unwrap().len();
    assert_eq!(v["images"].as_array().unwrap().len(), 1);
    assert!(measured + failed <= 2 && measured + failed >= 1);
    assert_eq!(
        out.status.code(),
        Some(if failed == 0 { 0 } else { 1 }),
        "{err}"
    );
    let page = std::fs::read_to_string(&page).unwrap();
    assert!(
        page.starts_with("# Title\n\n<!-- caoen bench: begin -->\n"),
        "{page}"
    );
    assert!(
        page.ends_with("<!-- caoen bench: end -->\n\nAfter.\n"),
        "{page}"
    );
    assert!(
        !page.contains("old table") && page.contains("### smooth"),
        "{page}"
    );
    // Only the reference: no codec to compare by rate window.
    assert!(!page.contains("by rate window"), "{page}");
}

/// Runs the tiny benchmark with `codecs` and checks everything the report claims
/// against the files it kept and against `caoen compare`.
#[cfg(feature = "peers")]
fn check_tiny_run(name: &str, codecs: &str) {
    let d = tmpdir(name);
    let corpus = tiny_corpus(&d);
    let (report, plot, keep) = (d.join("r.json"), d.join("rd.png"), d.join("keep"));
    let out = caoen(&[
        "bench",
        s(&corpus),
        "--codecs",
        codecs,
        "--rates",
        "0.5,1.5",
        "--report",
        s(&report),
        "--plot",
        s(&plot),
        "--keep",
        s(&keep),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    for heading in [
        "### scene (1 images)",
        "### natural (1 images)",
        "### all classes (2 images)",
    ] {
        assert!(stdout.contains(heading), "{stdout}");
    }
    // Each class's BD-rates by rate window: one table per class, a row per codec
    // compared with the reference.
    let window_head = "BD-rate vs jpeg by rate window:\n\n\
                       | codec | 0.05–0.3 bpp | 0.3–0.8 bpp | 0.8–2 bpp |\n|---|---|---|---|\n";
    assert_eq!(stdout.matches(window_head).count(), 3, "{stdout}");
    let v: Value = serde_json::from_slice(&std::fs::read(&report).unwrap()).unwrap();
    let names: Vec<&str> = codecs.split(',').collect();

    // Structure.
    assert_eq!(v["format"], "caoen-bench/1");
    assert_eq!(v["reference"], "jpeg");
    assert_eq!(common::names(&v["codecs"]), names);
    let images = v["images"].as_array().unwrap();
    assert_eq!(images.len(), 2);
    assert_eq!(images[0]["class"], "natural"); // corpus order: natural before scene
    assert_eq!(images[1]["class"], "scene");
    assert!(v["failures"].as_array().unwrap().is_empty());
    assert!(v["skipped"].as_array().unwrap().is_empty());
    let ms = v["measurements"].as_array().unwrap();
    // 2 images x codecs x 2 rates (a point whose file equals another's is measured once).
    assert!(
        ms.len() <= 2 * names.len() * 2 && ms.len() >= 2 * names.len(),
        "{}",
        ms.len()
    );

    for m in ms {
        let image = m["image"].as_str().unwrap();
        let codec = m["codec"].as_str().unwrap();
        // Size: the real file's, bpp from it.
        let file = keep.join(m["file"].as_str().unwrap());
        let bytes = std::fs::metadata(&file).unwrap().len();
        assert_eq!(m["bytes"].as_u64().unwrap(), bytes);
        let info = images.iter().find(|i| i["name"] == image).unwrap();
        let pixels = info["width"].as_u64().unwrap() * info["height"].as_u64().unwrap();
        assert_eq!(
            m["bpp"].as_f64().unwrap(),
            bytes as f64 * 8.0 / pixels as f64
        );
        assert!(m["encode_ms"].as_f64().unwrap() > 0.0);
        assert!(m["decode_ms"].as_f64().unwrap() > 0.0);
        // Quality: what `caoen compare` says on the same files. A caoen file is
        // decoded by compare itself; a peer's output through the decoded image the
        // benchmark kept (compare reads JPEG with another decoder).
        let test = if codec == "caoen" {
            file.clone()
        } else {
            keep.join(m["decoded_file"].as_str().unwrap())
        };
        let c = caoen_ok(&["compare", s(&corpus.join(image)), s(&test), "--json"]);
        let c: Value = serde_json::from_slice(&c.stdout).unwrap();
        for key in ["psnr", "psnr_y", "ssim", "ssimulacra2"] {
            assert_eq!(m[key], c[key], "{image} {codec} {key}");
        }
        assert!(m["psnr"].as_f64().unwrap() > 15.0);
    }

    // Summaries: deltas against jpeg for every other codec on both images.
    assert!(v["metrics"].as_str().unwrap().contains("bd_rate_windows"));
    let per_image = v["per_image"].as_array().unwrap();
    assert_eq!(per_image.len(), 2 * names.len());
    let bounds = |windows: &Value| -> Vec<(f64, f64)> {
        windows
            .as_array()
            .unwrap()
            .iter()
            .map(|w| (w["lo"].as_f64().unwrap(), w["hi"].as_f64().unwrap()))
            .collect()
    };
    let windows = [(0.05, 0.3), (0.3, 0.8), (0.8, 2.0)];
    for p in per_image {
        assert_eq!(bounds(&p["bd_rate_windows"]), windows, "{p}");
        let figures = p["bd_rate_windows"].as_array().unwrap();
        if p["codec"] == "jpeg" {
            assert!(p["bd_rate"].is_null());
            assert!(figures.iter().all(|w| w["bd_rate"].is_null()), "{p}");
        } else {
            assert!(p["bd_rate"].is_f64() || p["bd_note"].is_string(), "{p}");
            // A window needs the overlap the whole-range figure needs.
            for w in figures {
                assert!(w["bd_rate"].is_f64() || w["bd_rate"].is_null(), "{p}");
                assert!(w["bd_rate"].is_null() || p["bd_rate"].is_f64(), "{p}");
            }
        }
    }
    let classes = v["classes"].as_array().unwrap();
    for class in ["natural", "scene", "all"] {
        for codec in &names {
            let row = classes
                .iter()
                .find(|c| c["class"] == class && c["codec"] == *codec)
                .unwrap_or_else(|| panic!("no {class}/{codec} row"));
            let at = row["psnr_at"].as_array().unwrap();
            let rates: Vec<f64> = at.iter().map(|p| p["bpp"].as_f64().unwrap()).collect();
            assert_eq!(rates, [0.1, 0.25, 0.5, 1.0]);
            // Window means: the per-image figures of the class, averaged and counted.
            assert_eq!(bounds(&row["bd_rate_windows"]), windows, "{row}");
            for (i, w) in row["bd_rate_windows"]
                .as_array()
                .unwrap()
                .iter()
                .enumerate()
            {
                let figures: Vec<f64> = per_image
                    .iter()
                    .filter(|p| p["codec"] == *codec && (class == "all" || p["class"] == class))
                    .filter_map(|p| p["bd_rate_windows"][i]["bd_rate"].as_f64())
                    .collect();
                assert_eq!(
                    w["images"].as_u64().unwrap() as usize,
                    figures.len(),
                    "{row}"
                );
                match w["bd_rate"].as_f64() {
                    None => assert!(figures.is_empty(), "{row}"),
                    Some(m) => {
                        let expect = figures.iter().sum::<f64>() / figures.len() as f64;
                        assert!((m - expect).abs() < 1e-9, "{row}");
                        // The Markdown cell of this mean.
                        let cell = format!("{m:+.1}% ({})", figures.len());
                        assert!(stdout.contains(&cell), "{cell}: {stdout}");
                    }
                }
            }
        }
    }

    // Plots: one PNG per class.
    for class in ["natural", "scene"] {
        let p = d.join(format!("rd-{class}.png"));
        let img = image::open(&p).unwrap();
        assert_eq!((img.width(), img.height()), (800, 560));
    }
}

#[cfg(feature = "peers")]
#[test]
fn tiny_corpus_jpeg_and_webp() {
    check_tiny_run("peers", "jpeg,webp");
}

/// The benchmark the issue asks for: caoen beside JPEG.
#[cfg(feature = "peers")]
#[test]
fn tiny_corpus_caoen_and_jpeg() {
    check_tiny_run("caoen-jpeg", "caoen,jpeg");
}

#[cfg(feature = "peers")]
#[test]
fn every_peer_round_trips_every_layout() {
    use caoen::raster::{ChannelLayout, Raster, SampleFormat};
    use caoen_cli::bench::codecs::{by_name, Setting};
    let w = 17;
    let h = 9;
    for layout in [
        ChannelLayout::Grey,
        ChannelLayout::GreyAlpha,
        ChannelLayout::Rgb,
        ChannelLayout::Rgba,
    ] {
        for format in [SampleFormat::U8, SampleFormat::U16] {
            let n = (w * h) as usize * layout.channels();
            let samples = (0..n).map(|i| ((i * 37) % 256) as f32 / 255.0).collect();
            let img = Raster::new(w, h, layout, format, samples).unwrap();
            for name in ["jpeg", "mozjpeg", "jpeg-image", "webp"] {
                let codec = by_name(name, None).unwrap();
                if let Err(why) = codec.supports(&img) {
                    assert!(layout.has_alpha() && name.contains("jpeg"), "{name}: {why}");
                    continue;
                }
                let bytes = codec.encode(&img, Setting::Quality(90.0)).unwrap();
                let back = codec.decode(&bytes, &img).unwrap();
                assert_eq!(back.layout(), layout, "{name}");
                assert_eq!((back.width(), back.height()), (w, h));
                // Same bytes every time: the peers are deterministic.
                assert_eq!(codec.encode(&img, Setting::Quality(90.0)).unwrap(), bytes);
                // A truncated file gives an error or a (partly grey) image, never a panic.
                let _ = codec.decode(&bytes[..bytes.len() / 3], &img);
                assert!(codec.decode(b"garbage", &img).is_err(), "{name}");
            }
        }
    }
    // Float input is skipped by every peer.
    let hdr = Raster::new(2, 2, ChannelLayout::Rgb, SampleFormat::F32, vec![2.0; 12]).unwrap();
    for name in ["jpeg", "mozjpeg", "jpeg-image", "webp"] {
        assert!(by_name(name, None).unwrap().supports(&hdr).is_err());
    }
}

/// The command-line peers (AVIF 4:2:0 and 4:4:4, JPEG XL) on every layout: the decoded
/// image has the input's layout and size, encodes repeat byte for byte, bad files fail.
#[test]
fn command_line_peers_round_trip_every_layout() {
    use caoen::raster::{ChannelLayout, Raster, SampleFormat};
    use caoen_cli::bench::codecs::{by_name, Setting};
    let (w, h) = (17u32, 9u32);
    for name in ["avif", "avif444", "jxl"] {
        let codec = match by_name(name, None) {
            Ok(c) => c,
            Err(why) => {
                assert!(why.contains("not on PATH"), "{why}");
                if !common::tool_present(false, &format!("{name}'s tools")) {
                    continue;
                }
                unreachable!()
            }
        };
        for layout in [
            ChannelLayout::Grey,
            ChannelLayout::GreyAlpha,
            ChannelLayout::Rgb,
            ChannelLayout::Rgba,
        ] {
            // Smooth ramps, a different one per channel: 4:2:0 and quality 90 keep them.
            let pixels = (w * h) as usize;
            let samples = (0..pixels * layout.channels())
                .map(|i| {
                    let (c, p) = (i / pixels, i % pixels);
                    let (x, y) = ((p % w as usize) as f32, (p / w as usize) as f32);
                    ((40.0 + 9.0 * x + (4.0 + c as f32) * y) / 255.0).min(1.0)
                })
                .collect();
            let img = Raster::new(w, h, layout, SampleFormat::U8, samples).unwrap();
            codec.supports(&img).unwrap();
            let (bytes, ms) = codec.encode_timed(&img, Setting::Quality(90.0)).unwrap();
            assert!(ms > 0.0 && !bytes.is_empty());
            let (back, _) = codec.decode_timed(&bytes, &img).unwrap();
            assert_eq!(back.layout(), layout, "{name}");
            assert_eq!((back.width(), back.height()), (w, h));
            let psnr = caoen::metrics::psnr(&img, &back).unwrap();
            assert!(psnr > 35.0, "{name} {layout:?}: {psnr} dB at quality 90");
            assert_eq!(codec.encode(&img, Setting::Quality(90.0)).unwrap(), bytes);
            let err = codec.decode(b"garbage", &img).unwrap_err();
            assert!(err.contains("failed"), "{name}: {err}");
        }
        let hdr = Raster::new(2, 2, ChannelLayout::Rgb, SampleFormat::F32, vec![2.0; 12]).unwrap();
        assert!(codec.supports(&hdr).is_err());
    }
}

/// Folders and files that would make the bench read outside its corpus, write into it,
/// or drop the user's text are refused before any encoding, with what is wrong.
#[test]
fn lying_corpora_and_unspliceable_markdown_are_refused() {
    let d = tmpdir("refusals");
    let corpus = tiny_corpus(&d);
    let manifest = corpus.join("manifest.json");
    let good = std::fs::read_to_string(&manifest).unwrap();
    let run = |extra: &[&str]| {
        let mut args = vec!["bench", s(&corpus), "--codecs", "caoen", "--rates", "q50"];
        args.extend_from_slice(extra);
        caoen(&args)
    };

    std::fs::write(&manifest, &good[..good.len() / 2]).unwrap();
    let out = run(&[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("manifest.json"), "{err}");

    let first = good.split("\"file\": \"").nth(1).unwrap();
    let name = &first[..first.find('"').unwrap()];
    std::fs::write(&manifest, good.replace(name, "../../x.png")).unwrap();
    let out = run(&[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("outside the corpus folder"), "{err}");
    std::fs::write(&manifest, &good).unwrap();

    let before: Vec<_> = std::fs::read_dir(&corpus)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    let out = run(&["--keep", s(&corpus)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("corpus folder"), "{err}");
    let after: Vec<_> = std::fs::read_dir(&corpus)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(before, after);

    let md = d.join("notes.md");
    let text = "# My notes\n\n<!-- caoen bench: begin -->\nold tables\n";
    std::fs::write(&md, text).unwrap();
    let out = run(&["--markdown", s(&md), "-f"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("no end marker"), "{err}");
    assert_eq!(std::fs::read_to_string(&md).unwrap(), text);
}
