//! Solids to print: relief depth on every face of a base, meshes of `frep mesh`,
//! `relief` and `carve` closed and manifold without zero-area triangles or specks
//! (checked by caoen, and by `admesh` and Python `trimesh` where installed), binary STL
//! read back with the OBJ's volume, and empty meshes refused.

mod common;
#[path = "frep_print/mesh_quality.rs"]
mod mesh_quality;
#[path = "frep_print/print_files.rs"]
mod print_files;
use common::{assert_ok, caoen, hostile, repo_root, s, stderr, tool_present};

use std::path::{Path, PathBuf};
use std::process::Command;

use caoen::frep::Node;
use caoen::geometry::printable::{bad_edges, min_height, volume};
use caoen::render::mesh_io::read_stl;
use serde_json::json;

fn node(v: serde_json::Value) -> Node {
    Node::from_json(&v, "model", &repo_root(), &caoen::Limits::default()).unwrap()
}

/// The relief's height over one face of a box: the largest distance along the face's
/// outward normal from the face to the relief's outermost surface, over a 24x24 grid
/// of points inset by a tenth of the face, searching `reach` out and in.
fn face_depth(
    relief: &dyn Fn([f64; 3]) -> f64,
    centre: [f64; 3],
    half: [f64; 3],
    axis: usize,
    side: f64,
) -> f64 {
    let (a, b) = ((axis + 1) % 3, (axis + 2) % 3);
    let reach = 0.25;
    let mut worst: f64 = 0.0;
    for i in 0..24 {
        for j in 0..24 {
            let mut p = centre;
            p[axis] += side * half[axis];
            p[a] += half[a] * 0.8 * (2.0 * (i as f64 + 0.5) / 24.0 - 1.0);
            p[b] += half[b] * 0.8 * (2.0 * (j as f64 + 0.5) / 24.0 - 1.0);
            let at = |t: f64| {
                let mut q = p;
                q[axis] += side * t;
                relief(q)
            };
            // From outside inwards, the first step where the solid begins.
            let steps = 500;
            let mut prev = reach;
            for s in 1..=steps {
                let t = reach - 2.0 * reach * s as f64 / steps as f64;
                if at(t) >= 0.0 {
                    let (mut lo, mut hi) = (t, prev);
                    for _ in 0..50 {
                        let m = 0.5 * (lo + hi);
                        if at(m) >= 0.0 {
                            lo = m
                        } else {
                            hi = m
                        }
                    }
                    worst = if lo.abs() > worst.abs() { lo } else { worst };
                    break;
                }
                prev = t;
            }
        }
    }
    worst
}

/// Relief depth per face of a 1 x 0.8 x 0.3 box for both projections that reach a
/// box's faces, as (face name, depth) with depth 0.05 and a picture reaching white.
/// With `old`, the displacement as `f + gain h`, `gain` the depth times the base's mean
/// gradient length near its surface (the form reliefs had before the warp).
fn box_relief_depths(projection: &str, old: bool) -> Vec<(String, f64)> {
    let (centre, size) = ([0.0, 0.0, 0.0], [1.0, 0.8, 0.3]);
    let half = size.map(|s| 0.5 * s);
    let base = json!({"box": {"centre": centre, "size": size}});
    let relief = node(json!({"relief": base,
        "image": "examples/distort/input.png", "projection": projection, "depth": 0.05,
        "interp": "bilinear"}));
    let base = node(base);
    let b = base.bounds().unwrap();
    let rect = match projection {
        "planar" => json!([b.lo[0], b.lo[1], b.hi[0], b.hi[1]]),
        _ => json!([
            -std::f64::consts::PI,
            -std::f64::consts::FRAC_PI_2,
            std::f64::consts::PI,
            std::f64::consts::FRAC_PI_2
        ]),
    };
    let pattern = node(json!({"pattern": {"image": "examples/distort/input.png",
        "projection": projection, "rect": rect, "level": 0.0, "interp": "bilinear"}}));
    let gain = 0.05 * caoen::frep::node::mean_surface_gradient(&base, &b);
    let f = |p: [f64; 3]| {
        if old {
            base.value(p) + gain * pattern.value(p)
        } else {
            relief.value(p)
        }
    };
    let relief = &f;
    let mut out = Vec::new();
    for (axis, name) in ["x", "y", "z"].iter().enumerate() {
        for (side, s) in [(1.0, "+"), (-1.0, "-")] {
            out.push((
                format!("{s}{name}"),
                face_depth(&relief, centre, half, axis, side),
            ));
        }
    }
    out
}

/// A planar relief raises the top face by `depth` times the grey level (at most the
/// depth) and leaves the bottom face alone (no mirrored copy); the sides move by
/// nothing. A spherical relief moves every face outwards by at most the depth.
#[test]
fn relief_depth_is_the_same_on_every_face() {
    for old in [true, false] {
        for projection in ["planar", "spherical"] {
            let d = box_relief_depths(projection, old);
            let d: Vec<String> = d.iter().map(|(f, v)| format!("{f} {v:.4}")).collect();
            eprintln!(
                "{} {projection}: {}",
                if old { "f + gain h" } else { "warp" },
                d.join(", ")
            );
        }
    }
    let planar = box_relief_depths("planar", false);
    let spherical = box_relief_depths("spherical", false);
    let get = |v: &[(String, f64)], n: &str| v.iter().find(|f| f.0 == n).unwrap().1;
    // The image's brightest grey on the top face reaches close to the full depth.
    assert!(get(&planar, "+z") > 0.04 && get(&planar, "+z") <= 0.05 + 1e-9);
    for f in ["-z", "+x", "-x", "+y", "-y"] {
        assert!(get(&planar, f).abs() < 1e-9, "{f}: {}", get(&planar, f));
    }
    for (f, d) in &spherical {
        assert!(*d > 0.01 && *d <= 0.05 + 1e-9, "{f}: {d}");
    }
}

fn tmpdir(name: &str) -> PathBuf {
    common::fresh_dir(&format!("print-{name}"))
}

/// What the outside checkers say about a mesh file: (admesh, trimesh) lines, each None
/// when the tool is missing.
struct External {
    admesh: Option<String>,
    trimesh: Option<String>,
}

fn has_admesh() -> bool {
    Command::new("admesh").arg("--version").output().is_ok()
}

fn has_trimesh() -> bool {
    Command::new("python3")
        .args(["-c", "import trimesh"])
        .output()
        .is_ok_and(|o| o.status.success())
}

/// `admesh` on an STL: its counts of what it had to fix, which must all be zero.
fn admesh_check(stl: &Path) -> String {
    let o = Command::new("admesh").arg(stl).output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout).to_string();
    let field = |name: &str| -> i64 {
        let line = text
            .lines()
            .find(|l| l.trim_start().starts_with(name))
            .unwrap_or_else(|| panic!("admesh printed no `{name}`:\n{text}"));
        line.split(':')
            .nth(1)
            .unwrap()
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    let fixed = [
        "Degenerate facets",
        "Edges fixed",
        "Facets removed",
        "Facets added",
        "Facets reversed",
        "Backwards edges",
    ]
    .map(|n| (n, field(n)));
    for (n, v) in fixed {
        assert_eq!(v, 0, "{}: admesh {n} {v}\n{text}", stl.display());
    }
    format!("admesh: 0 fixes, {} parts", field("Number of parts"))
}

/// Python trimesh on the STL and the OBJ: watertight, consistently wound, no zero-area
/// face, and the same volume from both files. Returns (volume, its line).
fn trimesh_check(stl: &Path, obj: &Path) -> (f64, String) {
    let script = r#"
import sys, trimesh
a = trimesh.load(sys.argv[1], force="mesh")
b = trimesh.load(sys.argv[2], force="mesh", process=False)
print(a.is_watertight, a.is_winding_consistent, b.is_watertight, b.is_winding_consistent,
      float(a.area_faces.min()), float(b.area_faces.min()), repr(float(a.volume)), repr(float(b.volume)),
      len(a.faces), len(b.faces))
"#;
    let o = Command::new("python3")
        .args(["-c", script, s(stl), s(obj)])
        .output()
        .unwrap();
    assert_ok(&o);
    let out = String::from_utf8_lossy(&o.stdout).to_string();
    let w: Vec<&str> = out.split_whitespace().collect();
    assert_eq!(&w[..4], ["True"; 4], "{}: trimesh {out}", stl.display());
    let num = |k: usize| w[k].parse::<f64>().unwrap();
    assert!(
        num(4) > 0.0 && num(5) > 0.0,
        "{}: zero-area faces: {out}",
        stl.display()
    );
    let (va, vb) = (num(6), num(7));
    assert!(
        (va - vb).abs() <= 1e-5 * vb.abs(),
        "{}: STL volume {va} vs OBJ {vb}",
        stl.display()
    );
    assert_eq!(w[8], w[9], "{}: face counts {out}", stl.display());
    (
        vb,
        format!("trimesh: watertight, wound consistently, volume STL {va:.6} OBJ {vb:.6}"),
    )
}

/// Checks the STL and OBJ meshes of one run: caoen's own reading of the STL, then the
/// outside tools. Returns a line for the log.
fn check_mesh_files(stl: &Path, obj: &Path, ext: &External) -> String {
    let m = read_stl(&std::fs::read(stl).unwrap()).unwrap();
    assert!(!m.triangles.is_empty(), "{}: empty", stl.display());
    assert_eq!(
        bad_edges(&m.triangles),
        0,
        "{}: open or non-manifold",
        stl.display()
    );
    let thinnest = m
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            min_height(a, b, c)
        })
        .fold(f64::INFINITY, f64::min);
    assert!(thinnest > 0.0, "{}: a zero-area triangle", stl.display());
    let v = volume(&m.positions, &m.triangles);
    assert!(v > 0.0, "{}: volume {v}", stl.display());
    let mut line = format!(
        "{}: {} triangles, closed, thinnest {thinnest:.2e}, volume {v:.6}",
        stl.file_name().unwrap().to_string_lossy(),
        m.triangles.len()
    );
    if ext.admesh.is_some() {
        line += &format!("; {}", admesh_check(stl));
    }
    if ext.trimesh.is_some() {
        let (vobj, t) = trimesh_check(stl, obj);
        assert!(
            (vobj - v).abs() <= 1e-5 * v,
            "caoen's STL volume {v} vs OBJ {vobj}"
        );
        line += &format!("; {t}");
    }
    line
}

fn externals() -> External {
    External {
        admesh: tool_present(has_admesh(), "admesh").then(String::new),
        trimesh: tool_present(has_trimesh(), "python3 trimesh").then(String::new),
    }
}

/// Runs a caoen command writing `out` (.stl) and the same with .obj.
fn mesh_both(args: &[&str], out: &Path) -> (PathBuf, PathBuf) {
    let obj = out.with_extension("obj");
    for o in [out, obj.as_path()] {
        let mut a: Vec<&str> = args.to_vec();
        a.extend(["-o", s(o)]);
        let r = caoen(&a);
        assert!(
            r.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
    }
    (out.to_path_buf(), obj)
}

/// The bases reliefs and carvings go on: a box, a ball, a cylinder.
fn bases(dir: &Path) -> Vec<PathBuf> {
    [
        ("box", json!({"box": {"size": [1.6, 1.2, 0.6]}})),
        ("ball", json!({"sphere": {"radius": 0.8}})),
        (
            "cylinder",
            json!({"cylinder": {"radius": 0.6, "length": 1.4}}),
        ),
    ]
    .map(|(name, model)| {
        let p = dir.join(format!("{name}.json"));
        std::fs::write(
            &p,
            json!({"format": "caoen-frep/1", "name": name, "model": model}).to_string(),
        )
        .unwrap();
        p
    })
    .to_vec()
}

/// Every picture use on every base, at `cells`: relief (bilinear and the command's
/// bicubic), carving, and carving a shell; each mesh checked.
fn print_pictures(dir: &Path, pictures: &[PathBuf], cells: &str, ext: &External) {
    for base in bases(dir) {
        let bname = base.file_stem().unwrap().to_string_lossy().to_string();
        for picture in pictures {
            let pname = picture.file_stem().unwrap().to_string_lossy().to_string();
            for (what, extra) in [
                ("relief", vec!["--depth", "0.05", "--projection", "planar"]),
                (
                    "relief",
                    vec!["--depth", "0.05", "--projection", "spherical"],
                ),
                (
                    "relief",
                    vec!["--depth", "-0.05", "--projection", "cylindrical"],
                ),
                ("carve", vec!["--projection", "cylindrical"]),
                ("carve", vec!["--projection", "planar", "--shell", "0.08"]),
            ] {
                let out = dir.join(format!(
                    "{what}-{bname}-{pname}-{}.stl",
                    extra[1..].join("")
                ));
                let mut args = vec![what, s(picture), "--on", s(&base), "--cells", cells];
                args.extend(&extra);
                let (stl, obj) = mesh_both(&args, &out);
                eprintln!("{}", check_mesh_files(&stl, &obj, ext));
            }
        }
    }
}

/// `frep mesh` of every example model, and reliefs and carvings of a picture on a box,
/// a ball and a cylinder, are closed manifolds without zero-area triangles, in caoen's
/// reading of the STL, in `admesh` and in trimesh (which also finds the STL's volume
/// equal to the OBJ's).
#[test]
fn meshes_are_closed_manifolds_without_zero_area_triangles() {
    let ext = externals();
    let dir = tmpdir("meshes");
    let examples = repo_root().join("examples/frep");
    let mut models: Vec<PathBuf> = std::fs::read_dir(&examples)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        // Model files, not the scenes of several objects beside them.
        .filter(|p| {
            std::fs::read_to_string(p)
                .unwrap()
                .contains("\"caoen-frep/1\"")
        })
        .collect();
    models.sort();
    assert!(models.len() >= 6);
    for m in &models {
        let out = dir.join(m.file_name().unwrap()).with_extension("stl");
        let (stl, obj) = mesh_both(&["frep", "mesh", s(m), "--cells", "40"], &out);
        eprintln!("{}", check_mesh_files(&stl, &obj, &ext));
    }
    print_pictures(
        &dir,
        &[repo_root().join("examples/distort/input.png")],
        "32",
        &ext,
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// As above on every photograph of `../shared/photos` (when present), at 48 cells: run
/// with `cargo test --test frep_print -- --ignored`.
#[test]
#[ignore]
fn every_photo_prints() {
    let ext = externals();
    let photos = repo_root().join("../shared/photos");
    // Run by hand beside the shared data: without it the test fails, it does not pass.
    let list = std::fs::read_dir(&photos).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (the photographs this test meshes)",
            photos.display()
        )
    });
    let mut pictures: Vec<PathBuf> = list
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    pictures.sort();
    let dir = tmpdir("photos");
    print_pictures(&dir, &pictures, "48", &ext);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A solid thinner than a cell has no mesh: `frep mesh` says so and fails, and writes
/// nothing.
#[test]
fn empty_meshes_are_refused() {
    let dir = tmpdir("empty");
    let model = dir.join("hair.json");
    common::write_frep(&model, json!({"box": {"size": [1e6, 1e-9, 1e-9]}}));
    let out = dir.join("hair.stl");
    let o = caoen(&["frep", "mesh", s(&model), "-o", s(&out), "--cells", "16"]);
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("the mesh is empty"), "{err}");
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A binary STL holds every triangle's corners as written, and reads back to the same
/// closed mesh (corners welded by their 32-bit coordinates).
#[test]
fn stl_round_trip() {
    let n = node(json!({"sphere": {"radius": 1.0}}));
    let b = n.bounds().unwrap();
    let (m, rep) = caoen::frep::polygonise::solid_mesh(&n, &b, 24).unwrap();
    assert_eq!(rep.bad_edges, 0);
    let mut bytes = Vec::new();
    caoen::render::mesh_io::write_stl(&m, &mut bytes).unwrap();
    assert_eq!(bytes.len(), 84 + 50 * m.triangles.len());
    let back = read_stl(&bytes).unwrap();
    assert_eq!(back.triangles.len(), m.triangles.len());
    assert_eq!(back.positions.len(), m.positions.len());
    assert_eq!(bad_edges(&back.triangles), 0);
    let (v0, v1) = (
        volume(&m.positions, &m.triangles),
        volume(&back.positions, &back.triangles),
    );
    assert!((v0 - v1).abs() < 1e-6 * v0, "{v0} vs {v1}");
    // The ball's volume, 4 pi / 3, to the mesh's accuracy at 24 cells.
    assert!(
        (v0 - 4.0 * std::f64::consts::PI / 3.0).abs() < 0.02 * v0,
        "{v0}"
    );
    assert!(read_stl(&bytes[..100]).is_err());
}

#[test]
fn the_documented_lithophane_command_works() {
    let d = tmpdir("lithophane");
    let stl = d.join("lithophane.stl");
    // README and docs/frep.md (hostile third round D4), on a coarser grid.
    let run = |depth: &str, out: &Path| {
        let plate = hostile("third-D4-plate.json");
        let picture = hostile("third-D4-input.png");
        caoen(&[
            "relief",
            &picture,
            "--on",
            &plate,
            "--projection",
            "planar",
            "--depth",
            depth,
            "-o",
            s(out),
            "--cells",
            "40",
        ])
    };
    let out = run("-0.06", &stl);
    assert_ok(&out);
    let mesh = read_stl(&std::fs::read(&stl).unwrap()).unwrap();
    assert!(!mesh.triangles.is_empty());
    // Deeper than before (2/3 of the plate) and up to its floor.
    assert_ok(&run("-0.09", &d.join("deep.stl")));
    // Through the plate, the refusal names what it checks.
    let refused = d.join("refused.stl");
    let out = run("-0.1", &refused);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("must leave a floor"), "{err}");
    assert!(!refused.exists());
}
