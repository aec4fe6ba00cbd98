//! Picture outputs take their format from the extension (`.png`, `.jpg`, `.jpeg`, any
//! case) and refuse any other, naming it, before the work: a render written as
//! `x.jpg` is a JPEG file, not PNG bytes under a JPEG name.

mod common;
use common::{caoen, caoen_ok, s};

use std::path::{Path, PathBuf};

// Both tests write here at once, so it is not cleared.
fn tmpdir() -> PathBuf {
    common::kept_dir("picture-format")
}

/// The format the file's bytes are in, by signature.
fn sniff(path: &Path) -> image::ImageFormat {
    let bytes = std::fs::read(path).unwrap();
    image::guess_format(&bytes).unwrap()
}

#[test]
fn render_commands_write_the_format_the_extension_names() {
    let dir = tmpdir();
    let model = dir.join("ball.json");
    common::write_frep(&model, serde_json::json!({"sphere": {"radius": 1}}));
    for (name, want) in [
        ("a.jpg", image::ImageFormat::Jpeg),
        ("b.JPEG", image::ImageFormat::Jpeg),
        ("c.png", image::ImageFormat::Png),
    ] {
        let out = dir.join(format!("surface-{name}"));
        caoen_ok(&[
            "surface",
            "render",
            "builtin:blob",
            "-o",
            s(&out),
            "--size",
            "64x48",
            "--samples",
            "1",
        ]);
        assert_eq!(sniff(&out), want, "{name}");
        let img = image::open(&out).unwrap();
        assert_eq!((img.width(), img.height()), (64, 48));

        let out = dir.join(format!("frep-{name}"));
        caoen_ok(&[
            "frep",
            "render",
            s(&model),
            "-o",
            s(&out),
            "--size",
            "40x30",
            "--samples",
            "1",
        ]);
        assert_eq!(sniff(&out), want, "{name}");
    }
    // A JPEG of a render is close to its PNG (quality 92): mean error a few levels.
    let (a, b) = (
        image::open(dir.join("surface-a.jpg")).unwrap().to_rgb8(),
        image::open(dir.join("surface-c.png")).unwrap().to_rgb8(),
    );
    let mean = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(x, y)| (*x as f64 - *y as f64).abs())
        .sum::<f64>()
        / a.as_raw().len() as f64;
    assert!(mean < 3.0, "{mean}");
}

#[test]
fn other_extensions_are_refused_before_the_work() {
    let dir = tmpdir();
    // The model does not exist: refusing the extension first means the message is
    // about the extension, not the model.
    let missing = dir.join("missing.json");
    for args in [
        vec!["surface", "render", s(&missing), "-o"],
        vec!["frep", "render", s(&missing), "-o"],
        vec!["heightfield", s(&missing), "-o"],
    ] {
        for (out, ext) in [
            ("x.bmp", "`.bmp`"),
            ("x.tiff", "`.tiff`"),
            ("x", "no extension"),
        ] {
            let out = dir.join(out);
            let mut a = args.clone();
            a.push(s(&out));
            let o = caoen(&a);
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{a:?}: {err}");
            assert!(
                err.contains(ext) && err.contains(".jpg") && !err.contains("missing.json"),
                "{a:?}: {err}"
            );
            assert!(!out.exists());
        }
    }
}
