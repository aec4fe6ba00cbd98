//! The memory estimates are upper bounds: each command's peak resident memory is
//! measured (`/usr/bin/time -v`) with its largest estimate (`CAOEN_REPORT_BUDGET`), then
//! the command is run again with a budget just under that peak, and must be refused
//! before it starts (its estimate is over the budget) instead of running. Slow (each
//! command runs in full once): `--ignored`. `--nocapture` prints the table of
//! estimates and peaks. The largest mesh of `../shared/models` (beside the clone) is
//! one of the inputs: without it the test fails, it does not pass.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("caoen-memory-peak-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("scratch");
    d
}

/// Peak resident memory of `caoen args` in bytes, its exit code and its standard error
/// (with the largest estimate it checked), or `None` without GNU time.
fn peak(args: &[&str]) -> Option<(u64, i32, String)> {
    let out = Command::new("/usr/bin/time")
        .arg("-v")
        .arg(env!("CARGO_BIN_EXE_caoen"))
        .args(args)
        .env("CAOEN_REPORT_BUDGET", "1")
        .output()
        .ok()?;
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    let kb: u64 = err
        .lines()
        .find_map(|l| {
            l.trim()
                .strip_prefix("Maximum resident set size (kbytes): ")
        })?
        .trim()
        .parse()
        .ok()?;
    Some((kb * 1024, out.status.code().unwrap_or(-1), err))
}

/// A `w x h` photograph-like picture: smooth colour fields with, when `dense`, fine
/// grain in every pixel (each detail block of a q100 encode then codes most of its
/// coefficients).
fn photo_like(w: u32, h: u32, dense: bool) -> image::RgbImage {
    image::RgbImage::from_fn(w, h, |x, y| {
        let (fx, fy) = (x as f64, y as f64);
        let grain = if dense {
            let k = (x.wrapping_mul(73_856_093) ^ y.wrapping_mul(19_349_663))
                .wrapping_mul(2_654_435_761);
            (k >> 24) as f64 / 255.0 * 24.0 - 12.0
        } else {
            0.0
        };
        let c = |v: f64| (v + grain).clamp(0.0, 255.0) as u8;
        image::Rgb([
            c(128.0 + 80.0 * (fx / 97.0).sin() * (fy / 53.0).cos()),
            c(128.0 + 60.0 * ((fx + fy) / 151.0).sin()),
            c(100.0 + 50.0 * (fx / 37.0 + fy / 71.0).cos()),
        ])
    })
}

/// A UV sphere of about `n` triangles as OBJ text.
fn sphere_obj(path: &Path, rings: usize) {
    use std::fmt::Write as _;
    let seg = rings;
    let mut s = String::new();
    let _ = writeln!(s, "v 0 0 1");
    for i in 1..rings {
        let th = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..seg {
            let ph = std::f64::consts::TAU * j as f64 / seg as f64;
            let _ = writeln!(
                s,
                "v {} {} {}",
                th.sin() * ph.cos() * (1.0 + 0.1 * (5.0 * ph).sin()),
                th.sin() * ph.sin(),
                th.cos()
            );
        }
    }
    let _ = writeln!(s, "v 0 0 -1");
    let last = 1 + (rings - 1) * seg + 1;
    for j in 0..seg {
        let _ = writeln!(s, "f 1 {} {}", 2 + j, 2 + (j + 1) % seg);
    }
    for i in 0..rings - 2 {
        for j in 0..seg {
            let a = 2 + i * seg + j;
            let b = 2 + i * seg + (j + 1) % seg;
            let (c, d) = (a + seg, b + seg);
            let _ = writeln!(s, "f {a} {c} {d}\nf {a} {d} {b}");
        }
    }
    let base = 2 + (rings - 2) * seg;
    for j in 0..seg {
        let _ = writeln!(s, "f {} {last} {}", base + j, base + (j + 1) % seg);
    }
    std::fs::write(path, s).expect("mesh");
}

/// The largest estimate a run reported (`CAOEN_REPORT_BUDGET`).
fn estimate(stderr: &str) -> u64 {
    stderr
        .lines()
        .find_map(|l| l.strip_prefix("budget: largest estimate "))
        .and_then(|l| l.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no estimate reported: {stderr}"))
}

/// The largest mesh file of `../shared/models` beside the clone.
fn largest_shared_mesh() -> PathBuf {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/models");
    let mesh = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e} (the shared models are an input)", dir.display()))
        .map(|e| e.expect("entry").path())
        .filter(|p| {
            p.extension()
                .is_some_and(|x| x.eq_ignore_ascii_case("obj") || x.eq_ignore_ascii_case("ply"))
        })
        .max_by_key(|p| std::fs::metadata(p).map_or(0, |m| m.len()));
    mesh.unwrap_or_else(|| panic!("{}: no OBJ or PLY mesh", dir.display()))
}

#[test]
#[ignore = "runs each command in full: minutes"]
fn estimates_are_upper_bounds_of_the_peak() {
    let dir = scratch();
    let big = dir.join("sphere400k.obj");
    sphere_obj(&big, 448);
    // Over MAX_FIT_VERTICES: the fit works on a spread subset of the vertices.
    let huge = dir.join("sphere1m.obj");
    sphere_obj(&huge, 708);
    let shared = largest_shared_mesh();
    let sphere = dir.join("s.frep.json");
    std::fs::write(
        &sphere,
        r#"{"format": "caoen-frep/1", "model": {"sphere": {"centre": [0, 0, 0], "radius": 1}}}"#,
    )
    .expect("model");
    // A closed surface meshed at the finest detail a model may ask for, as a field.
    let surface = dir.join("surface.frep.json");
    std::fs::write(
        &surface,
        r#"{"format": "caoen-frep/1", "model": {"caoen_surface": {"file": "blob.json", "detail": 7}}}"#,
    )
    .expect("model");
    let texture = dir.join("t.png");
    image::RgbImage::from_fn(4000, 4000, |x, y| {
        image::Rgb([x as u8, y as u8, (x ^ y) as u8])
    })
    .save(&texture)
    .expect("texture");
    let small = dir.join("small.png");
    image::RgbImage::from_fn(640, 480, |x, y| {
        image::Rgb([x as u8, y as u8, (x ^ y) as u8])
    })
    .save(&small)
    .expect("picture");
    let o = |n: &str| dir.join(n).display().to_string();
    let setup = |args: &[&str]| {
        common::caoen_ok(args);
    };
    // Decodes of dense files (every detail block coded, as fine texture at q100 makes
    // them) and flat ones (no detail layer to speak of), at 1, 12 and 48 MP.
    let mut decodes = Vec::new();
    for (mp, (w, h)) in [(1, (1200, 900)), (12, (4000, 3000)), (48, (8000, 6000))] {
        for dense in [true, false] {
            let name = format!("{}-{mp}mp", if dense { "dense" } else { "flat" });
            let png = dir.join(format!("{name}.png"));
            photo_like(w, h, dense).save(&png).expect("picture");
            let cae = o(&format!("{name}.cae"));
            let quality = if dense { "100" } else { "60" };
            let png = png.display().to_string();
            setup(&[
                "-f",
                "encode",
                &png,
                "-q",
                quality,
                "-e",
                "1",
                "--max-memory",
                "4G",
                "-o",
                &cae,
            ]);
            std::fs::remove_file(&png).ok();
            decodes.push((name, cae));
        }
    }
    setup(&[
        "-f",
        "surface",
        "export",
        "builtin:blob",
        "-o",
        &o("blob.json"),
    ]);
    setup(&[
        "-f",
        "encode",
        &small.display().to_string(),
        "-o",
        &o("small.cae"),
    ]);
    let (big, huge, shared, sphere, surface, texture, small) = (
        big.display().to_string(),
        huge.display().to_string(),
        shared.display().to_string(),
        sphere.display().to_string(),
        surface.display().to_string(),
        texture.display().to_string(),
        small.display().to_string(),
    );
    let shared_name = Path::new(&shared)
        .file_name()
        .expect("name")
        .to_string_lossy()
        .into_owned();
    let v = |a: &[&str]| a.iter().map(|s| s.to_string()).collect::<Vec<String>>();
    let cases: Vec<(String, Vec<String>)> = vec![
        (
            "convert 400k triangles".into(),
            v(&["convert", &big, "-o", &o("c.json")]),
        ),
        (
            "convert 1M triangles".into(),
            v(&["convert", &huge, "-o", &o("c1m.json")]),
        ),
        (
            format!("convert {shared_name}"),
            v(&["convert", &shared, "-o", &o("c2.json")]),
        ),
        (
            "frep mesh --cells 400".into(),
            v(&["frep", "mesh", &sphere, "-o", &o("m.obj"), "--cells", "400"]),
        ),
        (
            "frep render --method mesh --cells 400".into(),
            v(&[
                "frep",
                "render",
                &sphere,
                "-o",
                &o("r.png"),
                "--method",
                "mesh",
                "--cells",
                "400",
                "--size",
                "64x48",
            ]),
        ),
        (
            "frep render (ray, 1024x768, 3x3 samples)".into(),
            v(&[
                "frep",
                "render",
                &sphere,
                "-o",
                &o("r2.png"),
                "--size",
                "1024x768",
                "--samples",
                "3",
            ]),
        ),
        (
            "frep render caoen_surface detail 7".into(),
            v(&[
                "frep",
                "render",
                &surface,
                "-o",
                &o("r3.png"),
                "--size",
                "64x48",
            ]),
        ),
        (
            "relief 640x480 picture (default render)".into(),
            v(&["relief", &small, "--on", &sphere, "-o", &o("r4.png")]),
        ),
        (
            "transfer 4000x4000 texture".into(),
            v(&[
                "transfer",
                "--texture",
                &texture,
                "--from",
                "builtin:octahedron",
                "--to",
                "builtin:blob",
                "-o",
                &o("transfer.png"),
                "--size",
                "64x48",
            ]),
        ),
        (
            "decode 640x480 to 4096x3072 (EXR)".into(),
            v(&[
                "decode",
                &o("small.cae"),
                "--size",
                "4096x3072",
                "-o",
                &o("d.exr"),
            ]),
        ),
        (
            "decode 640x480 to 4096x3072 supersample 2 (PNG)".into(),
            v(&[
                "decode",
                &o("small.cae"),
                "--size",
                "4096x3072",
                "--supersample",
                "2",
                "-o",
                &o("d.png"),
            ]),
        ),
    ];
    let cases: Vec<(String, Vec<String>)> = cases
        .into_iter()
        .chain(decodes.iter().map(|(name, cae)| {
            (
                format!("decode {name} (PNG)"),
                v(&["decode", cae, "-o", &o(&format!("{name}.png"))]),
            )
        }))
        .collect();
    let mut failures = Vec::new();
    let mut table = vec![
        "| command | estimate | peak RSS | estimate / peak | at 95% of the peak |".to_string(),
        "|---|---|---|---|---|".to_string(),
    ];
    let mib = |b: u64| b as f64 / 1048576.0;
    for (name, args) in &cases {
        let mut a: Vec<&str> = vec!["-f", "--quiet"];
        a.extend(args.iter().map(String::as_str));
        let (p, code, err) = peak(&a).expect("GNU time at /usr/bin/time (Debian package `time`)");
        assert_eq!(code, 0, "{name}: {err}");
        let e = estimate(&err);
        // Just under the peak: the estimate must refuse it.
        let under = format!("{}", p * 95 / 100);
        a.extend(["--max-memory", &under]);
        let (_, code2, err2) = peak(&a).expect("ran once");
        let refused = code2 == 1 && err2.contains("over the memory budget");
        table.push(format!(
            "| {name} | {:.0} MiB | {:.0} MiB | {:.2} | {} |",
            mib(e),
            mib(p),
            e as f64 / p as f64,
            if refused { "refused" } else { "ran" }
        ));
        if !refused {
            failures.push(name.clone());
        }
    }
    eprintln!("{}", table.join("\n"));
    std::fs::remove_dir_all(&dir).ok();
    assert!(
        failures.is_empty(),
        "estimates below the peak: {failures:?}"
    );
}
