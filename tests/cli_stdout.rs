//! `-o -` is standard output for every command that writes one file, in the format the
//! command picks for a name without an extension; outputs that are folders refuse it
//! with a usage error; no command leaves a file named `-` (hostile third round D3, M9).

mod common;
use common::{hostile, s, stderr};

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

/// Runs `caoen args` in a fresh directory; its output and the directory.
fn run_in(name: &str, args: &[&str]) -> (Output, PathBuf) {
    let d = common::fresh_dir(&format!("cli-stdout-{name}"));
    let out = Command::new(env!("CARGO_BIN_EXE_caoen"))
        .args(args)
        .current_dir(&d)
        .output()
        .expect("run caoen");
    (out, d)
}

/// Runs `caoen args` in a fresh directory, asserts success and that no file named `-`
/// was made; the bytes on standard output.
fn stdout_of(name: &str, args: &[&str]) -> Vec<u8> {
    let (out, d) = run_in(name, args);
    assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    assert_no_dash(&d);
    assert!(
        !out.stdout.is_empty(),
        "{args:?}: nothing on standard output"
    );
    out.stdout
}

fn assert_no_dash(d: &Path) {
    assert!(
        std::fs::symlink_metadata(d.join("-")).is_err(),
        "a file named `-` was made in {}",
        d.display()
    );
}

/// The PNG on standard output, decoded; asserts its size.
fn png(bytes: &[u8], w: u32, h: u32) -> image::DynamicImage {
    assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "not a PNG");
    let img = image::load_from_memory_with_format(bytes, image::ImageFormat::Png).unwrap();
    assert_eq!((img.width(), img.height()), (w, h));
    img
}

/// Asserts `bytes` is a binary STL whose triangle count matches its length.
fn assert_binary_stl(bytes: &[u8]) {
    assert!(bytes.len() >= 84, "too short for a binary STL");
    let n = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as usize;
    assert!(n > 0, "no triangles");
    assert_eq!(bytes.len(), 84 + 50 * n, "{n} triangles");
}

fn json(bytes: &[u8]) -> serde_json::Value {
    serde_json::from_slice(bytes).expect("JSON on standard output")
}

fn plate() -> String {
    hostile("third-D4-plate.json")
}

fn picture() -> String {
    hostile("small.png")
}

#[test]
fn export_pov_writes_the_scene() {
    let out = stdout_of(
        "pov",
        &["frep", "export-pov", &plate(), "-o", "-", "--quiet"],
    );
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.contains("camera") && text.contains("isosurface"),
        "{text}"
    );
}

#[test]
fn convert_writes_the_model_and_the_summary_on_stderr() {
    let args = [
        "convert",
        &hostile("third-D3-octahedron.obj"),
        "-o",
        "-",
        "--check-size",
        "32",
    ];
    let (out, d) = run_in("convert", &args);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_no_dash(&d);
    let v = json(&out.stdout);
    assert_eq!(v["format"], "caoen-frep/1");
    assert!(stderr(&out).contains("functions"), "{}", stderr(&out));
    // The summary as JSON would share standard output with the model.
    let (out, d) = run_in("convert-json", &[&args[..], &["--json"]].concat());
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert_no_dash(&d);
}

#[test]
fn deviation_writes_the_picture() {
    let out = stdout_of(
        "deviation",
        &[
            "deviation",
            &hostile("third-D3-octahedron.obj"),
            "--rbf",
            "20",
            "--picture",
            "-",
            "--size",
            "32",
            "--views",
            "1",
            "--quiet",
        ],
    );
    assert!(out.starts_with(b"\x89PNG\r\n\x1a\n"));
    image::load_from_memory(&out).unwrap();
}

#[test]
fn frep_render_writes_png() {
    let out = stdout_of(
        "frep-render",
        &[
            "frep",
            "render",
            &plate(),
            "-o",
            "-",
            "--size",
            "32x24",
            "--samples",
            "1",
        ],
    );
    png(&out, 32, 24);
}

#[test]
fn surface_render_writes_png_and_the_depth_map_on_its_own() {
    let args = [
        "surface",
        "render",
        "builtin:blob",
        "--size",
        "32x24",
        "--samples",
        "1",
    ];
    png(
        &stdout_of("surface-render", &[&args[..], &["-o", "-"]].concat()),
        32,
        24,
    );
    let (out, d) = run_in(
        "surface-depth",
        &[&args[..], &["-o", "r.png", "--depth-out", "-"]].concat(),
    );
    assert!(out.status.success(), "{}", stderr(&out));
    assert_no_dash(&d);
    assert!(matches!(
        png(&out.stdout, 32, 24),
        image::DynamicImage::ImageLuma16(_)
    ));
    // Two outputs cannot share standard output.
    let (out, d) = run_in(
        "surface-two",
        &[&args[..], &["-o", "-", "--depth-out", "-"]].concat(),
    );
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("standard output"), "{}", stderr(&out));
    assert_no_dash(&d);
}

#[test]
fn relief_and_carve_write_their_render() {
    for what in ["relief", "carve"] {
        let out = stdout_of(
            what,
            &[
                what,
                &picture(),
                "--on",
                &plate(),
                "-o",
                "-",
                "--size",
                "32x24",
                "--samples",
                "1",
            ],
        );
        png(&out, 32, 24);
    }
}

#[test]
fn frep_mesh_writes_binary_stl() {
    let out = stdout_of(
        "frep-mesh",
        &["frep", "mesh", &plate(), "-o", "-", "--cells", "24"],
    );
    assert_binary_stl(&out);
}

#[test]
fn surface_mesh_writes_obj() {
    let out = stdout_of(
        "surface-mesh",
        &[
            "surface",
            "mesh",
            "builtin:blob",
            "-o",
            "-",
            "--detail",
            "2",
        ],
    );
    let text = String::from_utf8(out).unwrap();
    assert!(text.lines().any(|l| l.starts_with("v ")), "{text}");
    assert!(text.lines().any(|l| l.starts_with("f ")), "{text}");
    assert!(!text.contains("mtllib"), "no material without a file name");
}

#[test]
fn transfer_writes_its_render() {
    let out = stdout_of(
        "transfer",
        &[
            "transfer",
            "--texture",
            &picture(),
            "--from",
            "builtin:blob",
            "--to",
            "builtin:blob",
            "-o",
            "-",
            "--size",
            "32x24",
            "--samples",
            "1",
            "--bake-size",
            "32x16",
        ],
    );
    png(&out, 32, 24);
}

#[test]
fn heightfield_writes_its_render() {
    let out = stdout_of(
        "heightfield",
        &[
            "heightfield",
            &picture(),
            "-o",
            "-",
            "--size",
            "32x24",
            "--samples",
            "1",
        ],
    );
    png(&out, 32, 24);
}

#[test]
fn distort_writes_the_picture_or_the_model() {
    let input = image::open(picture()).unwrap();
    let out = stdout_of(
        "distort",
        &[
            "distort",
            &picture(),
            "--move",
            "4,4:5,5",
            "-o",
            "-",
            "--quiet",
        ],
    );
    png(&out, input.width(), input.height());
    let out = stdout_of(
        "distort-surface",
        &[
            "distort",
            "builtin:blob",
            "--move",
            "0,0,0:0.05,0,0",
            "-o",
            "-",
            "--quiet",
        ],
    );
    assert!(json(&out).is_object());
}

#[test]
fn encode_and_decode_write_their_files() {
    let cae = stdout_of("encode", &["encode", &picture(), "-o", "-", "--quiet"]);
    assert!(cae.len() > 8);
    let d = common::fresh_dir("cli-stdout-encoded");
    std::fs::write(d.join("in.cae"), &cae).unwrap();
    let out = stdout_of(
        "decode",
        &["decode", s(&d.join("in.cae")), "-o", "-", "--quiet"],
    );
    let input = image::open(picture()).unwrap();
    png(&out, input.width(), input.height());
    let map = stdout_of(
        "keypoint-map",
        &[
            "encode",
            &picture(),
            "-o",
            s(&d.join("k.cae")),
            "--keypoint-map",
            "-",
            "--quiet",
        ],
    );
    png(&map, input.width(), input.height());
    // The statistics as JSON would share standard output with the file.
    for args in [
        &["encode", &picture(), "-o", "-", "--json"][..],
        &["decode", s(&d.join("in.cae")), "-o", "-", "--json"][..],
    ] {
        let (out, dir) = run_in("json", args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert!(out.stdout.is_empty(), "{args:?}");
        assert_no_dash(&dir);
    }
}

#[test]
fn surface_export_writes_the_model() {
    let out = stdout_of(
        "surface-export",
        &["surface", "export", "builtin:blob", "-o", "-"],
    );
    assert!(json(&out).is_object());
}

#[test]
fn folder_outputs_refuse_standard_output() {
    for (name, args) in [
        (
            "morph",
            &[
                "morph",
                "builtin:blob",
                "builtin:six-point",
                "--frames",
                "2",
                "-o",
                "-",
            ][..],
        ),
        ("examples", &["examples", "--out", "-"][..]),
        ("demo", &["demo", "--out-dir", "-"][..]),
        ("corpus", &["corpus", "--out", "-"][..]),
        ("bench-keep", &["bench", "--keep", "-"][..]),
        ("bench-plot", &["bench", "--plot", "-"][..]),
    ] {
        let (out, d) = run_in(name, args);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains("standard output"), "{args:?}: {err}");
        assert!(out.stdout.is_empty(), "{args:?}");
        assert_no_dash(&d);
    }
}

#[test]
#[cfg(unix)]
fn a_write_error_fails_and_an_early_reader_does_not() {
    let full = std::fs::OpenOptions::new().write(true).open("/dev/full");
    if !common::tool_present(full.is_ok(), "/dev/full") {
        return;
    }
    let full = full.unwrap();
    let mesh = [
        "frep",
        "mesh",
        &plate(),
        "-o",
        "-",
        "--cells",
        "24",
        "--quiet",
    ];
    let out = Command::new(env!("CARGO_BIN_EXE_caoen"))
        .args(mesh)
        .stdout(Stdio::from(full))
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.starts_with("error: standard output: "), "{err}");
    // A reader that stops at once: the pipe breaks, which is not an error.
    let mut child = Command::new(env!("CARGO_BIN_EXE_caoen"))
        .args(mesh)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
}
