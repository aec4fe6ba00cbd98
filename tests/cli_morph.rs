//! `caoen morph`: end frames are the two models' renders exactly, animations play,
//! bad input is refused.

mod common;
use common::{caoen, caoen_ok, s};

use std::path::{Path, PathBuf};

fn tmpdir(name: &str) -> PathBuf {
    common::fresh_dir(&format!("morph-{name}"))
}

#[test]
fn end_frames_are_the_models_and_animations_play() {
    let d = tmpdir("frames");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let (a, b) = (
        root.join("examples/morph-a.json"),
        root.join("examples/morph-b.json"),
    );
    // Five frames of A to B, 160x120, into `out`.
    let morph = |out: &Path, more: &[&str]| {
        let args = ["morph", s(&a), s(&b), "--frames", "5", "--size", "160x120"];
        caoen_ok(&[&args[..], &["-o", s(out)], more].concat())
    };
    let dir = d.join("frames");
    let o = morph(&dir, &["--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for k in 0..5 {
        assert!(dir.join(format!("frame-{k:03}.png")).exists());
    }
    assert!(dir.join("contact.png").exists());
    // The same camera in a scene file: `caoen surface render` of A and of B gives the
    // first and the last frame byte for byte.
    for (model, frame) in [(&a, "frame-000.png"), (&b, "frame-004.png")] {
        let scene = d.join("scene.json");
        let text = serde_json::json!({
            "format": "caoen-scene/1",
            "camera": {"eye": v["camera"]["eye"], "target": v["camera"]["target"],
                       "up": v["camera"]["up"], "fov_deg": v["camera"]["fov_deg"]},
            "objects": [{"surface": s(model)}]
        });
        std::fs::write(&scene, text.to_string()).unwrap();
        let out = d.join("single.png");
        caoen_ok(&[
            "-f",
            "surface",
            "render",
            s(&scene),
            "-o",
            s(&out),
            "--size",
            "160x120",
            "--samples",
            "2",
            "--detail",
            "5",
        ]);
        assert_eq!(
            std::fs::read(&out).unwrap(),
            std::fs::read(dir.join(frame)).unwrap(),
            "{frame} equals the render of {}",
            model.display()
        );
    }
    // The in-between frames differ from both ends and from each other.
    let frames: Vec<Vec<u8>> = (0..5)
        .map(|k| {
            image::open(dir.join(format!("frame-{k:03}.png")))
                .unwrap()
                .to_rgb8()
                .into_raw()
        })
        .collect();
    for i in 0..5 {
        for j in 0..i {
            assert_ne!(frames[i], frames[j], "frames {j} and {i}");
        }
    }
    // Animations decode to the frames' count, and their frames move.
    for anim in ["m.gif", "m.png"] {
        let path = d.join(anim);
        morph(&path, &[]);
        use image::AnimationDecoder;
        let file = std::io::BufReader::new(std::fs::File::open(&path).unwrap());
        let decoded: Vec<image::Frame> = if anim.ends_with(".gif") {
            image::codecs::gif::GifDecoder::new(file)
                .unwrap()
                .into_frames()
                .collect_frames()
                .unwrap()
        } else {
            image::codecs::png::PngDecoder::new(file)
                .unwrap()
                .apng()
                .unwrap()
                .into_frames()
                .collect_frames()
                .unwrap()
        };
        assert_eq!(decoded.len(), 5, "{anim}");
        assert_ne!(
            decoded[0].buffer().as_raw(),
            decoded[4].buffer().as_raw(),
            "{anim}"
        );
        if anim.ends_with(".png") {
            // APNG frames are lossless: the first is frame-000.png exactly.
            let first = image::DynamicImage::ImageRgba8(decoded[0].buffer().clone()).to_rgb8();
            assert_eq!(first.into_raw(), frames[0]);
        }
    }
}

#[test]
fn bad_morphs_are_refused() {
    let d = tmpdir("bad");
    let (gif, mp4) = (d.join("x.gif"), d.join("x.mp4"));
    let (blob, octahedron) = ("builtin:blob", "builtin:octahedron");
    // Too large for the memory budget.
    let large = [
        "--max-memory",
        "1M",
        "morph",
        blob,
        octahedron,
        "--size",
        "4000x4000",
    ];
    let cases: [(&[&str], &Path, i32, &str); 4] = [
        (&["morph", blob, "builtin:ring"], &gif, 1, "domain"),
        (&["morph", blob, octahedron, "--frames", "1"], &gif, 2, ""),
        (&["morph", blob, octahedron], &mp4, 2, ""),
        (&large, &gif, 1, ""),
    ];
    for (args, out, code, needle) in cases {
        let args = [args, &["-o", s(out)]].concat();
        let o = caoen(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(code), "{args:?}: {err}");
        assert!(
            err.contains(needle) && !err.contains("panicked"),
            "{args:?}: {err}"
        );
    }
}
