//! Helpers shared by the end-to-end and property tests.

// Each test crate includes this module and uses only part of it.
#![allow(dead_code)]

// One home for what the library's tests and these both need: property-test settings,
// the repository's paths, thread pools.
#[path = "../../codec/caoen/tests/common/mod.rs"]
mod library;
#[allow(unused_imports)] // Each test crate calls only some.
pub use library::{proptest_config, repo_path, repo_root, with_threads};

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// An empty directory for one test, `caoen-{name}-{pid}` under the system's temporary
/// directory: the process id keeps concurrent runs apart, and whatever an earlier run of
/// the same test left there is removed first.
pub fn fresh_dir(name: &str) -> PathBuf {
    let d = temp_path(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `caoen-{name}-{pid}` under the system's temporary directory, created if missing but
/// not cleared, for tests that run in parallel in the same directory.
pub fn kept_dir(name: &str) -> PathBuf {
    let d = temp_path(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn temp_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("caoen-{name}-{}", std::process::id()))
}

/// A path as a command-line argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The arguments of the command `line`, split at white space, with each `@` standing
/// for the next of `paths` (kept whole, spaces and all): a command as typed.
pub fn argv<'a>(line: &'a str, paths: &[&'a str]) -> Vec<&'a str> {
    let mut paths = paths.iter();
    let args = line
        .split_whitespace()
        .map(|w| {
            if w == "@" {
                *paths.next().expect("a path per @")
            } else {
                w
            }
        })
        .collect();
    assert!(paths.next().is_none(), "more paths than @ in {line}");
    args
}

/// Writes the F-rep model file `path` holding `model` (a `caoen-frep/1` file).
pub fn write_frep(path: &Path, model: serde_json::Value) {
    let file = serde_json::json!({"format": "caoen-frep/1", "model": model});
    std::fs::write(path, file.to_string()).unwrap();
}

/// The `name` of each entry of the JSON array `list`.
pub fn names(list: &serde_json::Value) -> Vec<&str> {
    let entries = list.as_array().expect("a JSON array");
    entries
        .iter()
        .map(|e| e["name"].as_str().unwrap())
        .collect()
}

/// A run's stderr as text.
pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Asserts that a run succeeded, showing its stderr if it did not.
pub fn assert_ok(out: &Output) {
    assert!(out.status.success(), "{}", stderr(out));
}

/// Runs `caoen` with `args` and asserts that it succeeded; its output.
pub fn caoen_ok(args: &[&str]) -> Output {
    let out = caoen(args);
    assert!(out.status.success(), "{args:?}: {}", stderr(&out));
    out
}

/// Runs the `caoen` binary built for these tests with `args`.
pub fn caoen(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_caoen"))
        .args(args)
        .output()
        .expect("run caoen")
}

/// Whether a real tool a test needs is there (`ok`). `.ci/run` installs every such tool,
/// so under `CI=true` its absence fails the test; elsewhere the test is skipped, saying so.
pub fn tool_present(ok: bool, what: &str) -> bool {
    if !ok {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "{what} is missing in CI"
        );
        eprintln!("skipped: {what} is not installed (.ci/run installs it)");
    }
    ok
}

/// A `w x h` JPEG (quality 95) in the colour `rest` but for its top-left quarter, in
/// `quarter`.
pub fn quarter_jpeg(w: u32, h: u32, quarter: [u8; 3], rest: [u8; 3]) -> Vec<u8> {
    let img = image::RgbImage::from_fn(w, h, |x, y| {
        image::Rgb(if x < w / 2 && y < h / 2 {
            quarter
        } else {
            rest
        })
    });
    let mut out = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut out, 95)
        .encode_image(&img)
        .unwrap();
    out
}

/// RGB PSNR (peak 1) of two renders, through `caoen::metrics`.
pub fn psnr_render(
    a: &caoen::render::framebuffer::RgbImage,
    b: &caoen::render::framebuffer::RgbImage,
) -> f64 {
    let flat = |i: &caoen::render::framebuffer::RgbImage| -> Vec<f32> {
        i.pixels.iter().flatten().copied().collect()
    };
    caoen::metrics::psnr_from_mse(caoen::metrics::mse(&flat(a), &flat(b)), 1.0)
}

/// RGB PSNR of two 8-bit images, through `caoen::metrics`.
pub fn psnr_rgb8(a: &image::RgbImage, b: &image::RgbImage) -> f64 {
    let flat = |i: &image::RgbImage| -> Vec<f32> {
        i.as_raw().iter().map(|&v| f32::from(v) / 255.0).collect()
    };
    caoen::metrics::psnr_from_mse(caoen::metrics::mse(&flat(a), &flat(b)), 1.0)
}

/// A deterministic stream of numbers in [-1, 1) (xorshift), for many-sample checks.
pub struct Stream(pub u64);

impl Stream {
    /// The next number.
    pub fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// Whether POV-Ray is installed (see [`tool_present`]).
pub fn has_povray() -> bool {
    let probe = Command::new("povray").arg("--version").output();
    tool_present(
        probe.is_ok_and(|o| o.status.success() || !o.stderr.is_empty()),
        "POV-Ray",
    )
}

/// A fresh directory `name` (see [`fresh_dir`]) for a test that compares with
/// POV-Ray, or None when POV-Ray is not installed and the test is skipped.
pub fn povray_dir(name: &str) -> Option<PathBuf> {
    has_povray().then(|| fresh_dir(name))
}

/// Exports the model or scene `model` to the POV-Ray scene `pov` with `caoen frep
/// export-pov`, `side` pixels square.
pub fn export_pov(model: &Path, pov: &Path, side: u32) {
    caoen_ok(&[
        "frep",
        "export-pov",
        s(model),
        "-o",
        s(pov),
        "--size",
        &format!("{side}x{side}"),
    ]);
}

/// POV-Ray rendering `pov` to the PNG `out`, `side` pixels square, antialiasing `aa`,
/// without a display.
fn povray_command(pov: &std::path::Path, out: &std::path::Path, side: u32, aa: &str) -> Command {
    let mut c = Command::new("povray");
    c.args([
        &format!("+I{}", pov.display()),
        &format!("+W{side}"),
        &format!("+H{side}"),
        aa,
        "-D",
        "+FN",
        &format!("+O{}", out.display()),
    ]);
    c
}

/// Renders the POV-Ray scene `pov` to the PNG `out`, `side` pixels square, with the
/// antialiasing switch `aa` (e.g. `+A0.1`); the seconds POV-Ray took.
pub fn povray(pov: &std::path::Path, out: &std::path::Path, side: u32, aa: &str) -> f64 {
    let started = std::time::Instant::now();
    let o = povray_command(pov, out, side, aa)
        .output()
        .expect("run povray");
    let seconds = started.elapsed().as_secs_f64();
    assert!(
        o.status.success(),
        "povray: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    seconds
}

/// Runs `cmd` to its end, its output discarded; whether it succeeded, what it wrote
/// to standard error, and the CPU seconds (user and system, every thread) it used.
// The child is reaped by wait4, which clippy does not see.
#[allow(clippy::zombie_processes)]
pub fn run_cpu(cmd: &mut Command) -> (bool, String, f64) {
    let err = tempfile_path("stderr");
    let child = cmd
        .stdout(std::process::Stdio::null())
        .stderr(std::fs::File::create(&err).unwrap())
        .spawn()
        .expect("run the command");
    let (mut status, mut usage) = (0, unsafe { std::mem::zeroed::<libc::rusage>() });
    // wait4 reports the child's own usage, where getrusage would add every other
    // test's children too.
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    assert_eq!(pid, child.id() as i32, "wait4");
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    let text = std::fs::read_to_string(&err).unwrap_or_default();
    let _ = std::fs::remove_file(&err);
    (
        libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0,
        text,
        secs(usage.ru_utime) + secs(usage.ru_stime),
    )
}

/// A path for a scratch file of this process, unique to the call.
fn tempfile_path(what: &str) -> PathBuf {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    std::env::temp_dir().join(format!("caoen-{what}-{}-{n}", std::process::id()))
}

/// [`povray`] timed by CPU: the seconds of every thread POV-Ray used.
pub fn povray_cpu(pov: &std::path::Path, out: &std::path::Path, side: u32, aa: &str) -> f64 {
    let (ok, err, cpu) = run_cpu(&mut povray_command(pov, out, side, aa));
    assert!(ok, "povray: {err}");
    cpu
}

/// A render's silhouette: the pixels whose colour differs from the top-left corner's
/// (the background) by more than 24 levels summed over the channels.
pub fn silhouette(img: &image::RgbImage) -> Vec<bool> {
    let bg = *img.get_pixel(0, 0);
    img.pixels()
        .map(|q| {
            (0..3)
                .map(|k| (q[k] as i32 - bg[k] as i32).abs())
                .sum::<i32>()
                > 24
        })
        .collect()
}

/// Intersection over union of two silhouettes, and the union's pixel count.
pub fn iou(a: &[bool], b: &[bool]) -> (f64, usize) {
    let inter = a.iter().zip(b).filter(|(x, y)| **x && **y).count();
    let union = a.iter().zip(b).filter(|(x, y)| **x || **y).count();
    (inter as f64 / union.max(1) as f64, union)
}

/// A file of `tests/bad/hostile/` (inputs that once broke caoen), as a command argument.
pub fn hostile(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/bad/hostile")
        .join(name)
        .display()
        .to_string()
}

/// Starts `caoen` with `args`, its standard output and error piped, without waiting.
pub fn spawn_piped(args: &[&str]) -> std::process::Child {
    Command::new(env!("CARGO_BIN_EXE_caoen"))
        .args(args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run caoen")
}
