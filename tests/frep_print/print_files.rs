//! Print files: the documented lithophane as 3MF and STL at its size (trimesh reads the
//! unit and the extents, admesh and trimesh find the STL closed), lithophane thickness
//! by each transmission curve, `--units`, `--size`, `--scale` and ASCII STL, and the
//! options' bad values refused.

use super::*;

/// Whether Python's trimesh can read 3MF (it needs lxml and networkx for that).
fn has_trimesh_3mf() -> bool {
    Command::new("python3")
        .args(["-c", "import trimesh, lxml, networkx"])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// What trimesh reads from a mesh file: its unit (null for STL), extents, bounds,
/// watertightness, winding and face count.
fn trimesh_facts(path: &Path) -> serde_json::Value {
    let script = r#"
import sys, json, trimesh
m = trimesh.load(sys.argv[1], force="mesh")
print(json.dumps({"units": m.units, "extents": [float(v) for v in m.extents],
    "lo": [float(v) for v in m.bounds[0]], "hi": [float(v) for v in m.bounds[1]],
    "watertight": bool(m.is_watertight), "winding": bool(m.is_winding_consistent),
    "faces": len(m.faces)}))
"#;
    let o = Command::new("python3")
        .args(["-c", script, s(path)])
        .output()
        .unwrap();
    assert_ok(&o);
    serde_json::from_slice(&o.stdout).unwrap()
}

fn num(v: &serde_json::Value, k: &str, i: usize) -> f64 {
    v[k][i].as_f64().unwrap()
}

/// The lithophane command as `docs/frep.md` gives it (the README gives the same).
fn documented_lithophane() -> String {
    let docs = std::fs::read_to_string(repo_root().join("docs/frep.md")).unwrap();
    let line = docs
        .lines()
        .find(|l| l.starts_with("caoen lithophane ") && l.contains(".png") && l.contains(".3mf"))
        .expect("docs/frep.md gives a lithophane command writing 3MF")
        .to_string();
    let readme = std::fs::read_to_string(repo_root().join("README.md")).unwrap();
    assert!(
        readme.contains(&line),
        "README.md differs from docs/frep.md: {line}"
    );
    line
}

/// The heights of a mesh's top surface over the rectangle `[x0, x1] x [y0, y1]`: the z
/// of every vertex there above the bottom face.
fn top_heights(m: &caoen::geometry::mesh::Mesh, [x0, y0, x1, y1]: [f64; 4]) -> Vec<f64> {
    m.positions
        .iter()
        .filter(|p| p[0] > x0 && p[0] < x1 && p[1] > y0 && p[1] < y1 && p[2] > 0.05)
        .map(|p| p[2])
        .collect()
}

/// The documented command writes a 3MF and an STL that trimesh reads as 150 mm wide
/// (within 0.5%), 0.8 mm to 3 mm thick, in millimetres; both closed, the STL clean in
/// admesh.
#[test]
fn the_documented_lithophane_prints_at_its_size() {
    let ok = tool_present(has_trimesh_3mf(), "python3 trimesh with lxml and networkx");
    let admesh = tool_present(has_admesh(), "admesh");
    let dir = tmpdir("documented-lithophane");
    let line = documented_lithophane();
    let root = repo_root();
    // The picture is in the repository; the files go to the test's directory.
    let args: Vec<String> = line
        .split_whitespace()
        .skip(1)
        .map(|w| match w.rsplit_once('.').map(|(_, e)| e) {
            Some("png") => root.join(w).display().to_string(),
            Some("3mf" | "stl") => dir.join(w).display().to_string(),
            _ => w.to_string(),
        })
        .collect();
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let out = caoen(&args);
    assert_ok(&out);
    eprintln!("{}", stderr(&out));
    let (tmf, stl) = (dir.join("lithophane.3mf"), dir.join("lithophane.stl"));
    let m = read_stl(&std::fs::read(&stl).unwrap()).unwrap();
    let all: Vec<f64> = m.positions.iter().map(|p| p[2]).collect();
    let top = all.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let bottom = all.iter().copied().fold(f64::INFINITY, f64::min);
    let inner = top_heights(&m, [10.0, 10.0, 140.0, 80.0]);
    let thinnest = inner.iter().copied().fold(f64::INFINITY, f64::min);
    eprintln!("STL: z {bottom:.4} to {top:.4}, thinnest inside the frame {thinnest:.4}");
    assert!(
        bottom.abs() < 1e-3 && (top - 3.0).abs() < 5e-3,
        "{bottom} {top}"
    );
    assert!((0.8 - 5e-3..0.9).contains(&thinnest), "{thinnest}");
    if admesh {
        eprintln!("{}", admesh_check(&stl));
    }
    if !ok {
        return;
    }
    for f in [&tmf, &stl] {
        let t = trimesh_facts(f);
        eprintln!("{}: {t}", f.display());
        let w = num(&t, "extents", 0);
        assert!(
            (w - 150.0).abs() <= 0.005 * 150.0,
            "{}: width {w}",
            f.display()
        );
        let (lo, hi) = (num(&t, "lo", 2), num(&t, "hi", 2));
        assert!(lo.abs() < 1e-3 && (hi - 3.0).abs() < 5e-3, "{lo} {hi}");
        assert_eq!(t["watertight"], true, "{t}");
        assert_eq!(t["winding"], true, "{t}");
        assert_eq!(t["faces"].as_u64(), Some(m.triangles.len() as u64));
    }
    assert_eq!(trimesh_facts(&tmf)["units"], "millimeter");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Three bands, white, mid grey and black: each band's top is flat at the thickness
/// its curve gives (linear, and Beer-Lambert with mu = 1.5 per mm), white at exactly
/// the thinnest and black at the thickest.
#[test]
fn lithophane_thickness_follows_the_curve() {
    let dir = tmpdir("lithophane-curve");
    let picture = dir.join("bands.png");
    let img =
        image::GrayImage::from_fn(60, 20, |x, _| image::Luma([[255, 128, 0][x as usize / 20]]));
    img.save(&picture).unwrap();
    let g = 128.0 / 255.0;
    let mu: f64 = 1.5;
    let beer = -(((-mu * 3.0).exp() * (1.0 - g) + (-mu * 0.8).exp() * g).ln()) / mu;
    for (curve, mid) in [("linear", 3.0 - 2.2 * g), ("beer-lambert", beer)] {
        let out = dir.join(format!("{curve}.stl"));
        let o = caoen(&[
            "lithophane",
            s(&picture),
            "--width",
            "60mm",
            "--thinnest",
            "0.8mm",
            "--thickest",
            "3mm",
            "--curve",
            curve,
            "--absorption",
            "1.5",
            "--cells",
            "120",
            // The grid's vertices, many on each band's top (decimation keeps a few).
            "--no-decimate",
            "-o",
            s(&out),
        ]);
        assert_ok(&o);
        let m = read_stl(&std::fs::read(&out).unwrap()).unwrap();
        // Sample pitch 60/59 mm; the bands' insides keep clear of the steps.
        let pitch = 60.0 / 59.0;
        for (band, want) in [(0.0, 0.8), (1.0, mid), (2.0, 3.0)] {
            let x0 = band * 20.0 * pitch;
            let z = top_heights(
                &m,
                [x0 + 3.0, 3.0, x0 + 20.0 * pitch - 4.0, 19.0 * pitch - 3.0],
            );
            assert!(z.len() > 20, "{curve} band {band}: {} vertices", z.len());
            let worst = z.iter().map(|v| (v - want).abs()).fold(0.0, f64::max);
            eprintln!(
                "{curve} band {band}: {} top vertices at {want:.4} mm, worst {worst:.2e}",
                z.len()
            );
            assert!(worst < 2e-3, "{curve} band {band}: {worst}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--units`, `--size` and `--scale` scale every mesh output; ASCII STL holds the
/// binary's triangles, on a file or standard output; 3MF names its unit.
#[test]
fn units_sizes_and_ascii_stl() {
    let trimesh = tool_present(has_trimesh_3mf(), "python3 trimesh with lxml and networkx");
    let admesh = tool_present(has_admesh(), "admesh");
    let dir = tmpdir("units");
    let model = repo_root().join("examples/frep/blend.json");
    let run = |extra: &[&str], out: &Path| {
        let mut a = vec!["frep", "mesh", s(&model), "--cells", "24", "-o", s(out)];
        a.extend(extra);
        let o = caoen(&a);
        assert_ok(&o);
        o
    };
    let bin = dir.join("bin.stl");
    run(&[], &bin);
    let b = read_stl(&std::fs::read(&bin).unwrap()).unwrap();
    let ascii = dir.join("ascii.stl");
    run(&["--ascii"], &ascii);
    let text = std::fs::read_to_string(&ascii).unwrap();
    assert!(text.starts_with("solid caoen\n"));
    assert_eq!(text.matches("facet normal").count(), b.triangles.len());
    let o = run(&["--ascii"], Path::new("-"));
    assert_eq!(o.stdout, text.as_bytes());
    let scaled = dir.join("scaled.stl");
    run(&["--scale", "10"], &scaled);
    let sc = read_stl(&std::fs::read(&scaled).unwrap()).unwrap();
    for (p, q) in b.positions.iter().zip(&sc.positions) {
        for k in 0..3 {
            assert!(
                (q[k] - 10.0 * p[k]).abs() < 1e-5 * (1.0 + q[k].abs()),
                "{p:?} {q:?}"
            );
        }
    }
    let inch = dir.join("inch.3mf");
    run(&["--units", "in", "--size", "2in"], &inch);
    let cm = dir.join("cm.3mf");
    run(&["--units", "cm", "--size", "150mm"], &cm);
    let mm = dir.join("mm.stl");
    run(&["--size", "6in"], &mm);
    let m = read_stl(&std::fs::read(&mm).unwrap()).unwrap();
    let largest = (0..3)
        .map(|k| {
            let (lo, hi) = m
                .positions
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
                    (l.min(p[k]), h.max(p[k]))
                });
            hi - lo
        })
        .fold(0.0, f64::max);
    assert!((largest - 152.4).abs() < 1e-3, "{largest}");
    if admesh {
        eprintln!("ASCII STL: {}", admesh_check(&ascii));
    }
    if trimesh {
        for (f, unit, size) in [(&inch, "inch", 2.0), (&cm, "centimeter", 15.0)] {
            let t = trimesh_facts(f);
            assert_eq!(t["units"], unit, "{t}");
            let e = (0..3).map(|k| num(&t, "extents", k)).fold(0.0, f64::max);
            assert!((e - size).abs() < 1e-4 * size, "{}: {e}", f.display());
            assert_eq!(t["watertight"], true);
        }
        let t = trimesh_facts(&ascii);
        assert_eq!(t["faces"].as_u64(), Some(b.triangles.len() as u64));
        assert_eq!(t["watertight"], true);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Bad print options fail with the reason (exit 2 for the command line, 1 otherwise)
/// and write nothing; an existing file stays without `-f`.
#[test]
fn bad_print_options_are_refused() {
    let dir = tmpdir("bad-print");
    let model = repo_root().join("examples/frep/blend.json");
    let picture = repo_root().join("examples/distort/input.png");
    let out = dir.join("out.stl");
    let (m, p, o) = (s(&model), s(&picture), s(&out));
    for (args, says) in [
        (
            vec!["frep", "mesh", m, "--size", "-150mm", "-o", o],
            "a length must be above 0",
        ),
        (
            vec!["frep", "mesh", m, "--size", "150parsec", "-o", o],
            "expected a length",
        ),
        (
            vec!["frep", "mesh", m, "--units", "ft", "-o", o],
            "possible values: mm, cm, in",
        ),
        (
            vec!["frep", "mesh", m, "--scale", "0", "-o", o],
            "expected a number above 0",
        ),
        (
            vec!["frep", "mesh", m, "--scale", "2", "--size", "1mm", "-o", o],
            "cannot be used with",
        ),
        (
            vec!["frep", "mesh", m, "--ascii", "-o", "x.3mf"],
            "--ascii is for STL",
        ),
        (
            vec!["frep", "mesh", m, "-o", "x.off"],
            "must end in .stl, .3mf",
        ),
        (
            vec!["lithophane", p, "--thinnest", "0mm", "-o", o],
            "a length must be above 0",
        ),
        (
            vec!["lithophane", p, "--thickest", "-3mm", "-o", o],
            "a length must be above 0",
        ),
        (
            vec![
                "lithophane",
                p,
                "--thinnest",
                "3mm",
                "--thickest",
                "2mm",
                "-o",
                o,
            ],
            "must be below --thickest",
        ),
        (
            vec![
                "lithophane",
                p,
                "--width",
                "10mm",
                "--frame",
                "5mm",
                "-o",
                o,
            ],
            "twice it must be below --width",
        ),
        (
            vec!["lithophane", p, "--absorption", "-1", "-o", o],
            "expected a number above 0",
        ),
        (
            vec!["relief", p, "--on", m, "--size", "512x384", "-o", o],
            "expected a length",
        ),
        (
            vec!["relief", p, "--on", m, "--scale", "2", "-o", "x.png"],
            "are for mesh outputs",
        ),
    ] {
        let r = caoen(&args);
        let err = stderr(&r);
        assert!(matches!(r.status.code(), Some(1 | 2)), "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
        assert!(!out.exists() && !Path::new("x.3mf").exists());
    }
    let tmf = dir.join("kept.3mf");
    std::fs::write(&tmf, "keep").unwrap();
    let r = caoen(&[
        "lithophane",
        p,
        "--cells",
        "16",
        "-o",
        s(&out),
        "-o",
        s(&tmf),
    ]);
    assert_eq!(r.status.code(), Some(1), "{}", stderr(&r));
    assert_eq!(std::fs::read_to_string(&tmf).unwrap(), "keep");
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}
