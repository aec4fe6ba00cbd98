//! `examples/library-user/`, a crate outside the workspace that depends on `caoen` by
//! path, builds and runs as a downstream user's program: it encodes and decodes a PNG
//! through the root re-exports and opens the `.cae` with `image::open`.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use caoen::{ChannelLayout, DecodeOptions, Raster, SampleFormat};

/// Copies the crate (manifest and sources) to `to`, its path dependency made absolute,
/// with the workspace's `Cargo.lock` so it builds with the same versions and the build
/// writes nothing into `examples/`.
fn copy_crate(root: &Path, to: &Path) {
    let from = root.join("examples/library-user");
    let _ = std::fs::remove_dir_all(to);
    std::fs::create_dir_all(to.join("src")).unwrap();
    let manifest = std::fs::read_to_string(from.join("Cargo.toml")).unwrap();
    let codec = root
        .join("codec/caoen")
        .display()
        .to_string()
        .replace('\\', "/");
    assert!(manifest.contains("path = \"../../codec/caoen\""));
    let manifest = manifest.replace(
        "path = \"../../codec/caoen\"",
        &format!("path = \"{codec}\""),
    );
    std::fs::write(to.join("Cargo.toml"), manifest).unwrap();
    std::fs::copy(from.join("src/main.rs"), to.join("src/main.rs")).unwrap();
    std::fs::copy(root.join("Cargo.lock"), to.join("Cargo.lock")).unwrap();
}

#[test]
fn library_user_encodes_decodes_and_opens_with_the_image_crate() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let main = std::fs::read_to_string(root.join("examples/library-user/src/main.rs")).unwrap();
    assert!(
        main.lines().count() <= 15,
        "the program is at most 15 lines"
    );
    let base = root.join("target/library-user");
    let krate = base.join("crate");
    copy_crate(&root, &krate);
    let work = base.join(format!("run-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&work);
    std::fs::create_dir_all(&work).unwrap();
    let (w, h) = (67u32, 45u32);
    let samples = (0..w * h * 3)
        .map(|i| {
            let (x, y, c) = ((i % w) as f32, ((i / w) % h) as f32, (i / (w * h)) as f32);
            (0.5 + 0.4 * (x * 0.13 + c).sin() * (y * 0.09 - c).cos()) * 255.0
        })
        .map(|v| v.round() / 255.0)
        .collect();
    let photo = Raster::new(w, h, ChannelLayout::Rgb, SampleFormat::U8, samples).unwrap();
    caoen::save(&photo, &work.join("photo.png")).unwrap();

    let out = Command::new(env!("CARGO"))
        .args(["run", "--offline", "--quiet", "--manifest-path"])
        .arg(krate.join("Cargo.toml"))
        .arg("--")
        .arg(&work)
        .env("CARGO_TARGET_DIR", base.join("target"))
        .output()
        .expect("run cargo");
    common::assert_ok(&out);

    // The `.cae` decodes here to what the program saved and what `image::open` read.
    let cae = std::fs::read(work.join("photo.cae")).unwrap();
    let reference = caoen::decode(&cae, &DecodeOptions::default()).unwrap();
    let expected = caoen::image_io::to_dynamic8(&reference).to_rgb8();
    for name in ["decoded.png", "opened.png"] {
        let got = image::open(work.join(name)).unwrap().to_rgb8();
        assert_eq!(got.dimensions(), (w, h), "{name}");
        assert!(got == expected, "{name} differs from caoen::decode");
    }
    std::fs::remove_dir_all(&work).ok();
}
