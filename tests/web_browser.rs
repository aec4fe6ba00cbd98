//! The viewer in a real browser: headless Chromium (Debian's `chromium`) driven by
//! `playwright-core` (`tools/web/test/browser.mjs`) opens the viewer from `caoen view`
//! with `?src=`, and the canvas's pixels at fit, 4x and 32x zoom (by the wheel) and
//! after a drag equal the command line's decode of the region the page shows at the
//! page's size, each channel within 1; a damaged file shows the error state with
//! caoen's message. The page's decode time of the 768x512 image is reported beside the
//! native single-threaded decode. Missing tools (node, chromium, `npm ci` in
//! `tools/web/test`, wasm-bindgen, the wasm32 target) skip it, or fail it under `CI=true`.

mod common;
mod web_common;

use common::s;
use serde_json::{json, Value};
use std::io::BufRead;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use web_common::cli_rgba;

/// A `caoen view` server, stopped when dropped.
struct Server(Child, String);

impl Server {
    fn start(cae: &Path) -> Server {
        let mut child = Command::new(env!("CARGO_BIN_EXE_caoen"))
            .args(["view", s(cae)])
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap();
        let mut line = String::new();
        std::io::BufReader::new(child.stdout.take().unwrap())
            .read_line(&mut line)
            .unwrap();
        assert!(
            line.starts_with("http://127.0.0.1:"),
            "caoen view printed {line:?}"
        );
        Server(child, line.trim().to_string())
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
fn the_viewer_draws_the_native_decode_of_what_it_shows() {
    let (Some(()), Some(browser), Some(())) = (
        web_common::node(),
        web_common::chromium(),
        web_common::playwright(),
    ) else {
        return;
    };
    let Some(_pkg) = web_common::build_pkg() else {
        return;
    };
    let dir = common::fresh_dir("web-browser");
    // A photograph when ../shared/photos has one, else a corpus scene of its size.
    let photo = common::repo_root().join("../shared/photos/photo-002.png");
    let cae = if photo.is_file() {
        web_common::encode(&photo, &dir, "photo", 80)
    } else {
        web_common::scene_cae(&dir, "photo", (768, 512), 7, 80)
    };
    let bytes = std::fs::read(&cae).unwrap();
    let bad = dir.join("damaged.cae");
    std::fs::write(&bad, &bytes[..bytes.len() / 2]).unwrap();
    let (good, damaged) = (Server::start(&cae), Server::start(&bad));
    let screenshot = std::env::var_os("CAOEN_WEB_SCREENSHOT");
    let spec = dir.join("spec.json");
    let spec_json = json!({
        "chromium": s(&browser),
        "profile": s(&dir.join("profile")),
        "url": good.1,
        "bad_url": damaged.1,
        "out": s(&dir),
        "screenshot": screenshot.as_ref().and_then(|p| p.to_str()),
    });
    std::fs::write(&spec, spec_json.to_string()).unwrap();
    let out = Command::new("node")
        .arg(common::repo_path("tools/web/test/browser.mjs"))
        .arg(&spec)
        .output()
        .unwrap();
    drop((good, damaged));
    let steps: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("steps.json")).unwrap_or_else(|_| "{}".into()),
    )
    .unwrap();
    assert!(
        out.status.success(),
        "browser.mjs failed: {}\n{steps:#}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(
        common::names(&steps["steps"]),
        ["fit", "zoom4", "zoom32", "panned"]
    );
    for step in steps["steps"].as_array().unwrap() {
        let name = step["name"].as_str().unwrap();
        assert_eq!(step["state"], "ready", "{name}: {steps:#}");
        let v = &step["view"];
        let r: Vec<String> = v["region"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.to_string())
            .collect();
        let (w, h) = (v["width"].as_u64().unwrap(), v["height"].as_u64().unwrap());
        let png = dir.join(format!("{name}.png"));
        let (cw, ch, want) = cli_rgba(
            &cae,
            &["--region", &r.join(","), "--size", &format!("{w}x{h}")],
            &png,
        );
        assert_eq!((u64::from(cw), u64::from(ch)), (w, h));
        let got = std::fs::read(step["rgba"].as_str().unwrap()).unwrap();
        assert_eq!(got.len(), want.len(), "{name}");
        let worst = got
            .iter()
            .zip(&want)
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap();
        eprintln!(
            "{name}: zoom {:.3}, region {}, {w}x{h}: largest difference {worst}",
            v["zoom"],
            r.join(",")
        );
        assert!(worst <= 1, "{name}: a channel differs by {worst}");
    }
    assert_eq!(steps["bad_state"], "error", "{steps:#}");
    let message = steps["bad_message"].as_str().unwrap();
    assert!(message.contains("invalid caoen file"), "{message}");
    // The page's decode of the whole image beside the native one on one thread.
    let native = common::with_threads(1, || {
        let opts = caoen::DecodeOptions::default();
        let mut times: Vec<f64> = (0..3)
            .map(|_| {
                let t = std::time::Instant::now();
                caoen::decode(&bytes, &opts).unwrap();
                t.elapsed().as_secs_f64() * 1000.0
            })
            .collect();
        times.sort_by(f64::total_cmp);
        times[1]
    });
    let page = steps["bench_ms"].as_f64().unwrap();
    eprintln!(
        "768x512 decode: page {page:.0} ms, native single-threaded {native:.0} ms ({:.2}x)",
        page / native
    );
}
