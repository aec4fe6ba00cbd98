//! The memory estimates are upper bounds: each command's peak resident memory is
//! measured (`/usr/bin/time -v`), then the command is run again with a budget just
//! under that peak, and must be refused before it starts (its estimate is over the
//! budget) instead of running. Slow (each command runs in full once): `--ignored`.
//! `--nocapture` prints the table of peaks.

use std::path::{Path, PathBuf};
use std::process::Command;

fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("caoen-memory-peak-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("scratch");
    d
}

/// Peak resident memory of `caoen args` in bytes and its exit code, or `None` without
/// GNU time.
fn peak(args: &[&str]) -> Option<(u64, i32, String)> {
    let out = Command::new("/usr/bin/time")
        .arg("-v")
        .arg(env!("CARGO_BIN_EXE_caoen"))
        .args(args)
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

#[test]
#[ignore = "runs each command in full: minutes"]
fn estimates_are_upper_bounds_of_the_peak() {
    let dir = scratch();
    let big = dir.join("sphere400k.obj");
    sphere_obj(&big, 448);
    let sphere = dir.join("s.frep.json");
    std::fs::write(
        &sphere,
        r#"{"format": "caoen-frep/1", "model": {"sphere": {"centre": [0, 0, 0], "radius": 1}}}"#,
    )
    .expect("model");
    let texture = dir.join("t.png");
    image::RgbImage::from_fn(4000, 4000, |x, y| {
        image::Rgb([x as u8, y as u8, (x ^ y) as u8])
    })
    .save(&texture)
    .expect("texture");
    let o = |n: &str| dir.join(n).display().to_string();
    let (big, sphere, texture) = (
        big.display().to_string(),
        sphere.display().to_string(),
        texture.display().to_string(),
    );
    let cases: Vec<(&str, Vec<String>)> = vec![
        (
            "convert 400k triangles",
            vec!["convert".into(), big.clone(), "-o".into(), o("c.json")],
        ),
        (
            "frep mesh --cells 400",
            vec![
                "frep".into(),
                "mesh".into(),
                sphere.clone(),
                "-o".into(),
                o("m.obj"),
                "--cells".into(),
                "400".into(),
            ],
        ),
        (
            "frep render --method mesh --cells 400",
            vec![
                "frep".into(),
                "render".into(),
                sphere.clone(),
                "-o".into(),
                o("r.png"),
                "--method".into(),
                "mesh".into(),
                "--cells".into(),
                "400".into(),
                "--size".into(),
                "64x48".into(),
            ],
        ),
        (
            "transfer 4000x4000 texture",
            vec![
                "transfer".into(),
                "--texture".into(),
                texture.clone(),
                "--from".into(),
                "builtin:octahedron".into(),
                "--to".into(),
                "builtin:blob".into(),
                "-o".into(),
                o("t.png"),
                "--size".into(),
                "64x48".into(),
            ],
        ),
    ];
    let mut failures = Vec::new();
    for (name, args) in &cases {
        let mut a: Vec<&str> = vec!["-f", "--quiet"];
        a.extend(args.iter().map(String::as_str));
        let Some((p, code, err)) = peak(&a) else {
            eprintln!("skipped: no GNU time at /usr/bin/time");
            return;
        };
        assert_eq!(code, 0, "{name}: {err}");
        // Just under the peak: the estimate must refuse it.
        let under = format!("{}", p * 95 / 100);
        a.extend(["--max-memory", &under]);
        let (_, code2, err2) = peak(&a).expect("ran once");
        let refused = code2 == 1 && err2.contains("over the memory budget");
        eprintln!(
            "{name}: peak {:.0} MiB; with a budget of 95% of it: {}",
            p as f64 / 1048576.0,
            if refused { "refused" } else { "ran" }
        );
        if !refused {
            failures.push(*name);
        }
    }
    std::fs::remove_dir_all(&dir).ok();
    assert!(
        failures.is_empty(),
        "estimates below the peak: {failures:?}"
    );
}
