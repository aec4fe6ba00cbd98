//! `-o -` is standard output for every command that writes one file, in the format the
//! command picks for a name without an extension; outputs that are folders refuse it
//! with a usage error; no command leaves a file named `-` (hostile third round D3, M9).

mod common;
use common::{argv, hostile, s, stderr};

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
    let out = stdout_of("pov", &argv("frep export-pov @ -o - --quiet", &[&plate()]));
    let text = String::from_utf8(out).unwrap();
    assert!(
        text.contains("camera") && text.contains("isosurface"),
        "{text}"
    );
}

#[test]
fn convert_writes_the_model_and_the_summary_on_stderr() {
    let model = hostile("third-D3-octahedron.obj");
    let args = argv("convert @ -o - --check-size 32", &[&model]);
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
    let model = hostile("third-D3-octahedron.obj");
    let line = "deviation @ --rbf 20 --picture - --size 32 --views 1 --quiet";
    let out = stdout_of("deviation", &argv(line, &[&model]));
    assert!(out.starts_with(b"\x89PNG\r\n\x1a\n"));
    image::load_from_memory(&out).unwrap();
}

/// Runs the command `line` as typed (`@` standing for each of `paths`) with `-o - --size
/// 32x24 --samples 1` after it; the 32x24 PNG it writes on standard output.
fn render_of(name: &str, line: &str, paths: &[&str]) -> image::DynamicImage {
    let line = format!("{line} -o - --size 32x24 --samples 1");
    png(&stdout_of(name, &argv(&line, paths)), 32, 24)
}

#[test]
fn frep_render_writes_png() {
    render_of("frep-render", "frep render @", &[&plate()]);
}

#[test]
fn surface_render_writes_png_and_the_depth_map_on_its_own() {
    render_of("surface-render", "surface render builtin:blob", &[]);
    let args = argv("surface render builtin:blob --size 32x24 --samples 1", &[]);
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
        render_of(what, &format!("{what} @ --on @"), &[&picture(), &plate()]);
    }
}

#[test]
fn frep_mesh_writes_binary_stl() {
    let out = stdout_of(
        "frep-mesh",
        &argv("frep mesh @ -o - --cells 24", &[&plate()]),
    );
    assert_binary_stl(&out);
}

#[test]
fn surface_mesh_writes_obj() {
    let args = argv("surface mesh builtin:blob -o - --detail 2", &[]);
    let text = String::from_utf8(stdout_of("surface-mesh", &args)).unwrap();
    assert!(text.lines().any(|l| l.starts_with("v ")), "{text}");
    assert!(text.lines().any(|l| l.starts_with("f ")), "{text}");
    assert!(!text.contains("mtllib"), "no material without a file name");
}

#[test]
fn transfer_writes_its_render() {
    let line = "transfer --texture @ --from builtin:blob --to builtin:blob --bake-size 32x16";
    render_of("transfer", line, &[&picture()]);
}

#[test]
fn heightfield_writes_its_render() {
    render_of("heightfield", "heightfield @", &[&picture()]);
}

#[test]
fn distort_writes_the_picture_or_the_model() {
    let input = image::open(picture()).unwrap();
    let line = "distort @ --move 4,4:5,5 -o - --quiet";
    let out = stdout_of("distort", &argv(line, &[&picture()]));
    png(&out, input.width(), input.height());
    let line = "distort builtin:blob --move 0,0,0:0.05,0,0 -o - --quiet";
    let out = stdout_of("distort-surface", &argv(line, &[]));
    assert!(json(&out).is_object());
}

#[test]
fn encode_and_decode_write_their_files() {
    let pic = picture();
    let cae = stdout_of("encode", &argv("encode @ -o - --quiet", &[&pic]));
    assert!(cae.len() > 8);
    let d = common::fresh_dir("cli-stdout-encoded");
    let (cae_path, map_path) = (d.join("in.cae"), d.join("k.cae"));
    std::fs::write(&cae_path, &cae).unwrap();
    let out = stdout_of("decode", &argv("decode @ -o - --quiet", &[s(&cae_path)]));
    let input = image::open(&pic).unwrap();
    png(&out, input.width(), input.height());
    let line = "encode @ -o @ --keypoint-map - --quiet";
    let map = stdout_of("keypoint-map", &argv(line, &[&pic, s(&map_path)]));
    png(&map, input.width(), input.height());
    // The statistics as JSON would share standard output with the file.
    for args in [
        argv("encode @ -o - --json", &[&pic]),
        argv("decode @ -o - --json", &[s(&cae_path)]),
    ] {
        let (out, dir) = run_in("json", &args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert!(out.stdout.is_empty(), "{args:?}");
        assert_no_dash(&dir);
    }
}

#[test]
fn surface_export_writes_the_model() {
    let args = argv("surface export builtin:blob -o -", &[]);
    assert!(json(&stdout_of("surface-export", &args)).is_object());
}

#[test]
fn folder_outputs_refuse_standard_output() {
    for (name, line) in [
        (
            "morph",
            "morph builtin:blob builtin:six-point --frames 2 -o -",
        ),
        ("examples", "examples --out -"),
        ("demo", "demo --out-dir -"),
        ("corpus", "corpus --out -"),
        ("bench-keep", "bench --keep -"),
        ("bench-plot", "bench --plot -"),
    ] {
        let args = argv(line, &[]);
        let (out, d) = run_in(name, &args);
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
    let plate = plate();
    let mesh = argv("frep mesh @ -o - --cells 24 --quiet", &[&plate]);
    let out = Command::new(env!("CARGO_BIN_EXE_caoen"))
        .args(&mesh)
        .stdout(Stdio::from(full))
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.starts_with("error: standard output: "), "{err}");
    // A reader that stops at once: the pipe breaks, which is not an error.
    let mut child = common::spawn_piped(&mesh);
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
}
