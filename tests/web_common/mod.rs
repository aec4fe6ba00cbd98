//! What the WebAssembly tests share: finding their tools (a missing one skips the test
//! with its reason, or fails it where `CI=true`), building the package once, and test
//! files made by the command line.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common::{self, caoen_ok, s};

/// Whether the tests run under CI, where a missing tool is a failure.
pub fn ci() -> bool {
    std::env::var("CI").is_ok_and(|v| v == "true")
}

/// `Some(())` if `what` is there; otherwise a skip (printing `why`), or a failure under
/// CI.
pub fn need(present: bool, why: &str) -> Option<()> {
    if present {
        return Some(());
    }
    assert!(!ci(), "CI=true and {why}");
    eprintln!("skipped: {why}");
    None
}

/// Whether `program --version` runs.
pub fn runs(program: &str, arg: &str) -> bool {
    Command::new(program)
        .arg(arg)
        .output()
        .is_ok_and(|o| o.status.success())
}

/// The built package folder (`tools/web/pkg/`), after `tools/web/build.sh`, or `None`
/// (skipped) when its tools are missing.
pub fn build_pkg() -> Option<PathBuf> {
    let web = common::repo_path("tools/web");
    let want = String::from_utf8(
        Command::new(web.join("build.sh"))
            .arg("--bindgen-version")
            .output()
            .unwrap()
            .stdout,
    )
    .unwrap();
    let have = Command::new("wasm-bindgen")
        .arg("--version")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
        .unwrap_or_default();
    need(
        have.split_whitespace().nth(1) == Some(want.trim()),
        &format!(
            "wasm-bindgen {} is not installed (cargo install wasm-bindgen-cli --version {0})",
            want.trim()
        ),
    )?;
    let targets = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
        .unwrap_or_default();
    need(
        targets.lines().any(|l| l.trim() == "wasm32-unknown-unknown"),
        "the wasm32-unknown-unknown target is not installed (rustup target add wasm32-unknown-unknown)",
    )?;
    // One build at a time: the two test binaries may run side by side.
    let lock = common::repo_path("target").join("caoen-web-build.lock");
    let _guard = FileLock::take(&lock);
    let out = Command::new(web.join("build.sh")).output().unwrap();
    assert!(
        out.status.success(),
        "tools/web/build.sh failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(web.join("pkg"))
}

/// A lock held while its file exists (made with `create_new`, removed on drop; one
/// older than ten minutes is a crashed run's and is taken over).
struct FileLock(PathBuf);

impl FileLock {
    fn take(path: &Path) -> Self {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        let start = std::time::Instant::now();
        loop {
            if std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(path)
                .is_ok()
            {
                return FileLock(path.to_path_buf());
            }
            let stale = std::fs::metadata(path)
                .and_then(|m| m.modified())
                .is_ok_and(|t| t.elapsed().is_ok_and(|e| e.as_secs() > 600));
            if stale || start.elapsed().as_secs() > 900 {
                let _ = std::fs::remove_file(path);
            }
            std::thread::sleep(std::time::Duration::from_millis(200));
        }
    }
}

impl Drop for FileLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.0);
    }
}

/// A corpus scene `w x h` of `seed` coded at quality `q` into `dir/name.cae`.
pub fn scene_cae(dir: &Path, name: &str, (w, h): (u32, u32), seed: u64, q: u32) -> PathBuf {
    let png = dir.join(format!("{name}.png"));
    caoen_corpus::generate(caoen_corpus::Class::Scene, w, h, seed)
        .to_dynamic_image()
        .save(&png)
        .unwrap();
    encode(&png, dir, name, q)
}

/// `png` coded at quality `q` into `dir/name.cae`.
pub fn encode(png: &Path, dir: &Path, name: &str, q: u32) -> PathBuf {
    let cae = dir.join(format!("{name}.cae"));
    caoen_ok(&[
        "encode",
        s(png),
        "-o",
        s(&cae),
        "-q",
        &q.to_string(),
        "--quiet",
        "-f",
    ]);
    cae
}

/// The command line's decode of `cae` with `args` (`--size`, `--region`), as RGBA
/// samples: the PNG it writes, read back (16-bit PNGs rounded to 8 bits).
pub fn cli_rgba(cae: &Path, args: &[&str], out: &Path) -> (u32, u32, Vec<u8>) {
    let mut all = vec!["decode", s(cae), "-o", s(out), "--quiet", "-f"];
    all.extend_from_slice(args);
    caoen_ok(&all);
    let img = image::open(out).unwrap().to_rgba8();
    (img.width(), img.height(), img.into_raw())
}
