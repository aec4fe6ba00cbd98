//! End-to-end tests of `caoen encode|decode|info` and the demo.

mod common;
use common::{argv, assert_ok, caoen, caoen_ok, s};

use std::path::{Path, PathBuf};

fn tmpdir(name: &str) -> PathBuf {
    common::fresh_dir(&format!("cli-codec-{name}"))
}

/// A small photo-like PNG from the corpus.
fn input_png(dir: &Path) -> PathBuf {
    scene_png(dir, "photo.png", 96, 64, 2)
}

/// The corpus scene of `seed`, `w x h`, written as `dir/name`.
fn scene_png(dir: &Path, name: &str, w: u32, h: u32, seed: u64) -> PathBuf {
    let img = caoen_corpus::generate(caoen_corpus::Class::Scene, w, h, seed);
    let p = dir.join(name);
    img.to_dynamic_image().save(&p).unwrap();
    p
}

#[test]
fn encode_decode_info_round_trip_and_overwrite_rules() {
    let d = tmpdir("roundtrip");
    let png = input_png(&d);
    let out = caoen_ok(&["encode", s(&png), "-q", "80", "--quiet"]);
    assert!(out.stderr.is_empty(), "--quiet prints nothing");
    let cae = d.join("photo.cae");
    assert!(cae.exists(), "default output is the input's stem with .cae");
    // The default-named output is not overwritten without -f.
    let again = caoen(&["encode", s(&png)]);
    assert_eq!(again.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&again.stderr).contains("--force"));
    caoen_ok(&["encode", s(&png), "-f", "--quiet"]);
    // Validate only, then decode to PNG, then info.
    let v = caoen(&["decode", s(&cae)]);
    assert!(v.status.success() && String::from_utf8_lossy(&v.stderr).contains("valid"));
    let back = d.join("back.png");
    caoen_ok(&["decode", s(&cae), "-o", s(&back)]);
    let img = image::open(&back).unwrap();
    assert_eq!((img.width(), img.height()), (96, 64));
    let info = caoen(&["info", s(&cae), "--json"]);
    let j: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(j["width"], 96);
    // The default encode laps its detail layer, and says by how much.
    assert_eq!(j["lapping"]["weight"], 46.0 / 256.0, "{j}");
    // Colour is coded with luma as its first channel.
    assert_eq!(j["colour_basis"], "luma opponent", "{j}");
    // Its detail steps follow an activity field of 16-pixel regions.
    assert_eq!(j["adaptive_steps"]["activity_field_region_px"], 16, "{j}");
    // The restoration filters are listed where the file has their section.
    let restored = j["sections"]
        .as_array()
        .unwrap()
        .iter()
        .any(|s| s["tag"] == "R");
    assert_eq!(j["restoration"].is_array(), restored, "{j}");
    // The deringing strengths, in steps of each plane kind, where the header has them.
    let text = caoen(&["info", s(&cae)]);
    let text = String::from_utf8_lossy(&text.stdout);
    let line = text
        .lines()
        .find(|l| l.starts_with("deringing:"))
        .expect("a deringing line");
    match j["deringing"].as_object() {
        Some(d) => assert!(
            d.contains_key("luma") && d.contains_key("chroma") && line.contains("Y ("),
            "{j} {line}"
        ),
        None => assert!(line.ends_with("none"), "{j} {line}"),
    }
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
    caoen_ok(&["compare", s(&png), s(&cae), "--json"]);
}

#[test]
fn output_bytes_do_not_depend_on_threads() {
    let d = tmpdir("threads");
    let png = input_png(&d);
    let (a, b) = (d.join("a.cae"), d.join("b.cae"));
    for (out, threads) in [(&a, "1"), (&b, "2")] {
        caoen_ok(&["encode", s(&png), "-o", s(out), "-j", threads, "--quiet"]);
    }
    assert_eq!(std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
}

#[test]
fn target_size_keypoint_map_and_json() {
    let d = tmpdir("target");
    let png = input_png(&d);
    let cae = d.join("t.cae");
    let map = d.join("map.png");
    let out = caoen_ok(&argv(
        "encode @ -o @ --target-size 700 --keypoint-map @ --json --quiet",
        &[s(&png), s(&cae), s(&map)],
    ));
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
    caoen_ok(&["encode", s(&png), "-o", s(&cae), "--quiet"]);
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
    let (bmp, missing) = (d.join("x.bmp"), d.join("missing.cae"));
    let cases: [(&[&str], i32); 7] = [
        (&["encode", s(&junk), "-o", s(&cae)], 1),
        (&["encode", s(&png), "-q", "150"], 2),
        (&["encode", s(&png), "--frobnicate"], 2),
        (&["decode", s(&cae), "--supersample", "9"], 2),
        (&["decode", s(&cae), "--max-pixels", "10"], 1),
        (&["decode", s(&cae), "-o", s(&bmp)], 2),
        (&["info", s(&missing)], 1),
    ];
    for (args, code) in cases {
        assert_eq!(caoen(args).status.code(), Some(code), "{args:?}");
    }
}

#[test]
fn demo_runs_on_built_in_data() {
    let d = tmpdir("demo");
    let out = caoen_ok(&["demo", "-o", s(&d), "--quiet"]);
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

/// Pixels of a PNG as 8-bit RGB.
fn rgb8(p: &Path) -> image::RgbImage {
    image::open(p).unwrap().to_rgb8()
}

#[test]
fn png_compression_levels_keep_the_pixels() {
    let d = tmpdir("png-levels");
    let png = scene_png(&d, "scene.png", 384, 256, 4);
    let cae = d.join("p.cae");
    caoen_ok(&["encode", s(&png), "-o", s(&cae), "--quiet"]);
    let mut sizes = Vec::new();
    // `cae` decoded to `out` at the PNG compression `level`.
    let decode = |out: &Path, level: &str, more: &[&str]| {
        let args = ["decode", s(&cae), "-o", s(out), "--png-compression", level];
        caoen(&[&args[..], more].concat())
    };
    for level in ["fast", "default", "best"] {
        let out = d.join(format!("{level}.png"));
        assert_ok(&decode(&out, level, &["--quiet"]));
        sizes.push(std::fs::metadata(&out).unwrap().len());
        assert_eq!(
            rgb8(&out),
            rgb8(&d.join("fast.png")),
            "{level}: same pixels"
        );
        // The same bytes again (deterministic at every level).
        let again = d.join(format!("{level}-again.png"));
        assert_ok(&decode(&again, level, &["--quiet", "-j", "1"]));
        assert_eq!(
            std::fs::read(&out).unwrap(),
            std::fs::read(&again).unwrap(),
            "{level}"
        );
    }
    println!("PNG sizes fast/default/best: {sizes:?}");
    assert!(
        sizes[2] < sizes[0],
        "best compresses more than fast: {sizes:?}"
    );
    assert_eq!(decode(&d.join("x.png"), "max", &[]).status.code(), Some(2));
}

#[test]
fn supersampling_anti_aliases_downscaled_decodes() {
    // At the coded size --supersample changes nothing (same bytes); at a quarter of the
    // size, 2x2 samples per pixel come closer to the full-size decode box-filtered down
    // than one sample per pixel.
    let d = tmpdir("supersample");
    let png = scene_png(&d, "scene.png", 384, 256, 4);
    let cae = d.join("scene.cae");
    caoen_ok(&["encode", s(&png), "-o", s(&cae), "-q", "90", "--quiet"]);
    let dec = |name: &str, extra: &[&str]| {
        let out = d.join(name);
        let mut args = vec!["decode", s(&cae), "-o", s(&out), "--quiet"];
        args.extend(extra);
        caoen_ok(&args);
        out
    };
    let plain = dec("plain.png", &[]);
    let s2 = dec("s2.png", &["--supersample", "2"]);
    assert_eq!(std::fs::read(&plain).unwrap(), std::fs::read(&s2).unwrap());
    // The reference: the full-size decode averaged over 4x4 blocks in linear light.
    let full = rgb8(&plain);
    let lin = |v: u8| {
        let c = v as f64 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let enc = |l: f64| {
        let c = if l <= 0.0031308 {
            l * 12.92
        } else {
            1.055 * l.powf(1.0 / 2.4) - 0.055
        };
        (c * 255.0).round().clamp(0.0, 255.0) as u8
    };
    let reference = image::RgbImage::from_fn(96, 64, |x, y| {
        let mut sum = [0.0; 3];
        for j in 0..4 {
            for i in 0..4 {
                let p = full.get_pixel(4 * x + i, 4 * y + j);
                for k in 0..3 {
                    sum[k] += lin(p[k]);
                }
            }
        }
        image::Rgb(sum.map(|v| enc(v / 16.0)))
    });
    let one = common::psnr_rgb8(&reference, &rgb8(&dec("q1.png", &["--scale", "0.25"])));
    let two = common::psnr_rgb8(
        &reference,
        &rgb8(&dec("q2.png", &["--scale", "0.25", "--supersample", "2"])),
    );
    println!("quarter-size decode against the box-filtered full decode: S=1 {one:.2} dB, S=2 {two:.2} dB");
    assert!(two > one + 1.0, "S=1 {one:.2} dB, S=2 {two:.2} dB");
}

/// A 48x24 JPEG stored on its side (EXIF orientation 6) with a 200-byte ICC profile
/// and an XMP packet: displayed, it is 24x48 with its red quarter at the top right.
fn oriented_jpeg(dir: &Path) -> PathBuf {
    let jpeg = common::quarter_jpeg(48, 24, [220, 30, 30], [30, 30, 220]);
    let segment = |marker: u8, payload: &[u8]| {
        let mut out = vec![0xff, marker];
        out.extend_from_slice(&(payload.len() as u16 + 2).to_be_bytes());
        out.extend_from_slice(payload);
        out
    };
    // IFD0 holding the orientation, 6.
    let mut exif = b"Exif\0\0II*\0\x08\0\0\0\x01\0".to_vec();
    exif.extend_from_slice(&[0x12, 0x01, 3, 0, 1, 0, 0, 0, 6, 0, 0, 0, 0, 0, 0, 0]);
    // An RGB profile's header (size, colour space, signature); the rest filler.
    let mut icc = vec![7u8; 200];
    icc[..4].copy_from_slice(&200u32.to_be_bytes());
    icc[16..20].copy_from_slice(b"RGB ");
    icc[36..40].copy_from_slice(b"acsp");
    let icc = [b"ICC_PROFILE\0\x01\x01".as_slice(), &icc].concat();
    let xmp = b"http://ns.adobe.com/xap/1.0/\0<x:xmpmeta xmlns:x=\"adobe:ns:meta/\"/>";
    let bytes = [
        &jpeg[..2],
        &segment(0xe1, &exif),
        &segment(0xe2, &icc),
        &segment(0xe1, xmp),
        &jpeg[2..],
    ]
    .concat();
    let p = dir.join("sideways.jpg");
    std::fs::write(&p, bytes).unwrap();
    p
}

fn encode_json(args: &[&str]) -> serde_json::Value {
    let out = caoen_ok(&[&["encode", "--json", "--quiet"], args].concat());
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn encode_turns_photos_upright_and_keeps_the_metadata_asked_for() {
    let d = tmpdir("metadata");
    let jpg = oriented_jpeg(&d);
    let cae = d.join("up.cae");
    let j = encode_json(&[s(&jpg), "-o", s(&cae), "-q", "90"]);
    assert_eq!(
        (j["width"].as_u64(), j["height"].as_u64()),
        (Some(24), Some(48))
    );
    let m = &j["metadata"];
    assert_eq!(m["icc"]["bytes"], 200);
    assert_eq!(m["exif"]["orientation"], 1, "kept EXIF says upright");
    assert!(m["xmp"]["bytes"].as_u64().unwrap() > 10);
    let icc = encode_json(&[s(&jpg), "-o", s(&d.join("icc.cae")), "--metadata", "icc"]);
    let m = &icc["metadata"];
    assert_eq!(
        (
            m["icc"]["bytes"].as_u64(),
            m["exif"].is_null(),
            m["xmp"].is_null()
        ),
        (Some(200), true, true)
    );
    for strip in [&["--strip"][..], &["--metadata", "none"]] {
        let out = d.join(format!("strip{}.cae", strip.len()));
        let none = encode_json(&[&[s(&jpg), "-o", s(&out)], strip].concat());
        let m = &none["metadata"];
        assert!(m["icc"].is_null() && m["exif"].is_null() && m["xmp"].is_null());
    }
    // The decoded picture is upright: red top right, blue top left.
    let png = d.join("up.png");
    caoen_ok(&["decode", s(&cae), "-o", s(&png), "--strip"]);
    let img = rgb8(&png);
    assert_eq!(img.dimensions(), (24, 48));
    let (tr, tl) = (img.get_pixel(18, 6), img.get_pixel(6, 6));
    assert!(tr[0] > 150 && tr[2] < 100, "top right {tr:?}");
    assert!(tl[0] < 100 && tl[2] > 150, "top left {tl:?}");
    // compare reads the JPEG upright too, so the two line up.
    caoen_ok(&["compare", s(&jpg), s(&png), "--json"]);
    let info = caoen(&["info", s(&cae)]);
    assert!(String::from_utf8_lossy(&info.stdout).contains("metadata:"));
    let info = caoen(&["info", s(&cae), "--json"]);
    let j: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert!(j["metadata"].is_object());
    // A bad choice and a contradiction are usage errors.
    let bad = caoen(&["encode", s(&jpg), "--metadata", "some"]);
    assert_eq!(bad.status.code(), Some(2));
    let both = caoen(&["encode", s(&jpg), "--strip", "--metadata", "icc"]);
    assert_eq!(both.status.code(), Some(2));
}

/// A stream whose magic number is wrong is refused after those bytes: `/dev/zero`, and a
/// pipe that stays open and never ends, get the magic error without being read on.
#[test]
fn a_wrong_magic_number_stops_the_reading() {
    use std::io::Write;
    use std::process::{Command, Stdio};
    for cmd in [&["info", "-"][..], &["decode", "-", "-o", "-"][..]] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_caoen"))
            .args(cmd)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut stdin = child.stdin.take().unwrap();
        stdin.write_all(b"RIFF\0\0\0\0WEBP").unwrap();
        stdin.flush().unwrap();
        // The pipe stays open: a reader that went on would wait here for ever.
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(30);
        let status = loop {
            if let Some(status) = child.try_wait().unwrap() {
                break status;
            }
            if std::time::Instant::now() > deadline {
                let _ = child.kill();
                panic!("{cmd:?} went on reading past a wrong magic number");
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        };
        drop(stdin);
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(status.code(), Some(1), "{cmd:?}: {err}");
        assert!(err.contains("not a caoen file"), "{cmd:?}: {err}");
    }
    for cmd in [
        &["info", "/dev/zero"][..],
        &["decode", "/dev/zero", "-o", "-"][..],
    ] {
        let out = caoen(cmd);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{cmd:?}: {err}");
        assert!(err.contains("magic"), "{cmd:?}: {err}");
    }
}

#[test]
fn a_half_size_file_says_so_and_decodes_at_the_image_size() {
    let d = tmpdir("half");
    let png = scene_png(&d, "scene.png", 130, 90, 4);
    let cae = d.join("scene.cae");
    // The encode's JSON report at quality 40 and `--resampling resampling`.
    let encode = |out: &Path, resampling: &str| -> serde_json::Value {
        let args = ["encode", s(&png), "-o", s(out), "-q", "40", "--resampling"];
        let o = caoen_ok(&[&args[..], &[resampling, "--json"]].concat());
        serde_json::from_slice(&o.stdout).unwrap()
    };
    let j = encode(&cae, "half");
    assert_eq!(
        (&j["width"], &j["height"]),
        (&130.into(), &90.into()),
        "{j}"
    );
    assert_eq!(
        (&j["coded_width"], &j["coded_height"]),
        (&65.into(), &45.into()),
        "{j}"
    );
    let text = caoen(&["info", s(&cae)]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("130x90 (coded at 65x45)"));
    let info: serde_json::Value =
        serde_json::from_slice(&caoen(&["info", s(&cae), "--json"]).stdout).unwrap();
    assert_eq!(
        (&info["width"], &info["coded_width"]),
        (&130.into(), &65.into()),
        "{info}"
    );
    // The decoder's default size and its --scale are the image's.
    let back = d.join("back.png");
    caoen_ok(&["decode", s(&cae), "-o", s(&back)]);
    assert_eq!(image::image_dimensions(&back).unwrap(), (130, 90));
    let half = d.join("half.png");
    caoen_ok(&["decode", s(&cae), "-o", s(&half), "--scale", "0.5"]);
    assert_eq!(image::image_dimensions(&half).unwrap(), (65, 45));
    // `image::open` reads it at the image's size too, through the hooks.
    caoen::register_image_hooks();
    let opened = image::open(&cae).unwrap();
    assert_eq!((opened.width(), opened.height()), (130, 90));
    // Off keeps the image's size in the file.
    let j = encode(&d.join("full.cae"), "off");
    assert_eq!(j["coded_width"], 130, "{j}");
    // Any size in tenths per side: 0.7 of 130x90 is 91x63.
    let j = encode(&d.join("seven.cae"), "0.7");
    assert_eq!(
        (&j["coded_width"], &j["coded_height"]),
        (&91.into(), &63.into()),
        "{j}"
    );
    for bad in ["0.75", "1.5", "0", "quarter"] {
        let out = caoen(&argv(
            "encode @ -o @ --resampling @",
            &[s(&png), s(&d.join("bad.cae")), bad],
        ));
        assert_eq!(out.status.code(), Some(2), "--resampling {bad}");
        assert!(
            String::from_utf8_lossy(&out.stderr).contains("tenths"),
            "--resampling {bad}"
        );
        assert!(!d.join("bad.cae").exists());
    }
}
