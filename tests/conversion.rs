//! Polygon meshes into implicit models: the conversion, its deviation analysis, the
//! F-rep model it writes, and bad mesh files.

mod common;

use std::path::{Path, PathBuf};

use caoen::conversion::deviation::vertex_deviation;
use caoen::conversion::{
    convert, Conversion, ConvertOptions, ImplicitField, ImplicitModel, InUnitCube, PolygonMesh,
};
use common::{argv, caoen, caoen_ok, repo_path, s};

fn tmpdir(name: &str) -> PathBuf {
    common::fresh_dir(&format!("conv-{name}"))
}

#[test]
fn a_sphere_and_an_ellipsoid_are_the_base_quadric_alone() {
    for radii in [[1.0, 1.0, 1.0], [3.0, 2.0, 1.0]] {
        let mesh = PolygonMesh::ellipsoid(radii, 4);
        let c = convert(&mesh, &ConvertOptions::default(), &mut |_| {});
        assert_eq!(c.model.functions(), 1, "{radii:?}");
        assert!(c.met_target);
        let unit = mesh.transformed(&mesh.unit_frame());
        let d = vertex_deviation(&c.model, &unit, &unit.outward_normals());
        assert!(d.mean_distance < 1e-3 && d.max_distance < 1e-9, "{d:?}");
        // What convert writes, the model reader reads: the base alone, no empty `perturb`.
        let text = c.model.to_frep_json("quadric", mesh.bounds()).to_string();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let node = frep_node(&v["model"]).unwrap_or_else(|e| panic!("{radii:?}: {e}"));
        for p in &mesh.positions {
            assert!(
                node.value(*p).abs() < 1e-6,
                "{radii:?} at {p:?}: {}",
                node.value(*p)
            );
        }
    }
}

/// `mesh` converted with at most `max_functions` functions.
/// The F-rep node of a written model's JSON, read as `caoen frep` reads it.
fn frep_node(v: &serde_json::Value) -> Result<caoen::frep::Node, caoen::json::FieldError> {
    caoen::frep::Node::from_json(v, "model", Path::new("."), &caoen::Limits::default())
}

fn convert_at_most(mesh: &PolygonMesh, max_functions: usize) -> Conversion {
    let opts = ConvertOptions {
        max_functions,
        ..Default::default()
    };
    convert(mesh, &opts, &mut |_| {})
}

#[test]
fn the_written_model_is_the_fitted_function() {
    // A lumpy closed mesh: an ellipsoid with a dent, so perturbations are needed.
    let mut mesh = PolygonMesh::ellipsoid([1.0, 0.8, 0.6], 3);
    for p in &mut mesh.positions {
        let bump = (-((p[0] - 0.5).powi(2) + p[1].powi(2) + (p[2] - 0.4).powi(2)) * 8.0).exp();
        *p = p.map(|v| v * (1.0 - 0.3 * bump));
    }
    let c = convert_at_most(&mesh, 400);
    assert!(c.model.functions() > 1 && c.model.functions() <= 400);
    // The levels lower the mean distance (a level may trade a little of it for the
    // normals' tangent conditions).
    let (first, last) = (c.levels[0], c.levels[c.levels.len() - 1]);
    assert!(c.levels.len() >= 2, "{:?}", c.levels);
    assert!(last.mean_distance < first.mean_distance, "{:?}", c.levels);
    let text = c.model.to_frep_json("lumpy", mesh.bounds()).to_string();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    // The perturbation inside the file is the fit (indexed patches included), and the
    // whole model (cut to the mesh's box and supporting planes, scaled back to the
    // mesh's coordinates) has the signs of the cut model.
    assert!(c.model.supports.is_some());
    let fitted = ImplicitModel::new(c.model.frame, c.model.base, c.model.bumps.clone());
    let inner = &v["model"]["transform"]["intersection"][0];
    let perturb = frep_node(inner).unwrap();
    let node = frep_node(&v["model"]).unwrap();
    let whole = InUnitCube {
        field: &node,
        frame: mesh.unit_frame(),
    };
    let mut seed = 7u64;
    for _ in 0..2000 {
        let mut r = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let p = [r() * 0.9, r() * 0.7, r() * 0.5];
        let (a, ga) = fitted.value_gradient(p);
        let (b, gb) = perturb.value_gradient(p);
        assert!((a - b).abs() < 1e-9 * (1.0 + a.abs()), "{p:?}: {a} {b}");
        for k in 0..3 {
            assert!((ga[k] - gb[k]).abs() < 1e-7 * (1.0 + ga[k].abs()));
        }
        let cut = c.model.value(p);
        if cut.abs() > 1e-9 {
            assert_eq!(cut > 0.0, whole.value(p) > 0.0, "{p:?}");
        }
        // And the analytic gradient is the derivative.
        let h = 1e-6;
        let (mut p1, mut p2) = (p, p);
        p1[0] += h;
        p2[0] -= h;
        let fd = (fitted.value(p1) - fitted.value(p2)) / (2.0 * h);
        assert!(
            (fd - ga[0]).abs() < 1e-5 * (1.0 + ga[0].abs()),
            "{fd} {}",
            ga[0]
        );
    }
}

#[test]
fn spot_converts_and_measures_within_the_targets_through_the_cli() {
    let dir = tmpdir("spot");
    let mesh = repo_path("tests/data/meshes/spot.obj");
    let model = dir.join("spot.json");
    let out = caoen_ok(&argv(
        "convert @ -o @ --json --check-size 128 --target-depth 0.005",
        &[s(&mesh), s(&model)],
    ));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("level 0:"), "progress on stderr: {stderr}");
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let functions = r["functions"].as_u64().unwrap();
    assert!((100..=9000).contains(&functions), "{r}");
    // The summary's verdict is its measures against its targets.
    let dev = &r["deviation"];
    let angle = dev["normal_angle_deg"]["mean"].as_f64().unwrap();
    let depth = dev["depth"]["mean_all_pixels"].as_f64().unwrap();
    assert_eq!(
        r["met_target"].as_bool().unwrap(),
        angle <= 3.0 && depth <= 0.005,
        "{r}"
    );
    assert!(
        r["met_target"].as_bool().unwrap(),
        "spot meets these targets: {r}"
    );
    assert!(r["advice"].is_null(), "{r}");
    // A clean conversion: one part, matched to the mesh.
    let c = &r["components"];
    assert_eq!(
        (c["parts"].as_u64(), c["spurious"].as_array().map(Vec::len)),
        (Some(1), Some(0)),
        "{r}"
    );
    assert_eq!(c["removed"], serde_json::json!([]), "{r}");
    assert!(stderr.contains("connected parts"), "{stderr}");
    // No overwrite without -f.
    let again = caoen(&["convert", s(&mesh), "-o", s(&model)]);
    assert_eq!(again.status.code(), Some(1));
    let picture = dir.join("dev.png");
    let out = caoen_ok(&argv(
        "--quiet deviation @ @ --size 128 --json --picture @",
        &[s(&mesh), s(&model), s(&picture)],
    ));
    assert!(out.stderr.is_empty());
    let d: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let f = |path: &[&str]| path.iter().fold(&d, |v, k| &v[*k]).as_f64().unwrap();
    assert!(f(&["vertex_distance", "mean"]) < 1e-3, "{d}");
    // convert's own summary measured the same model the same way.
    assert!(
        (f(&["depth", "mean_all_pixels"]) - depth).abs() < 1e-6,
        "{d} {r}"
    );
    assert!(
        (f(&["normal_angle_deg", "mean"]) - angle).abs() < 1e-4,
        "{d} {r}"
    );
    assert!(f(&["normal_angle_deg", "mean"]) < 5.0, "{d}");
    assert!(f(&["depth", "mean_all_pixels"]) < 0.005, "{d}");
    assert!(f(&["depth", "mean"]) < 0.008, "{d}");
    assert_eq!(d["depth"]["views"].as_array().unwrap().len(), 6);
    let img = image::open(&picture).unwrap();
    assert_eq!((img.width(), img.height()), (3 * 128, 6 * 128));
    // The baseline measures through the same command, and does worse per number.
    let b = deviation_json(&[s(&mesh), "--rbf", "300", "--size", "64", "--views", "2"]);
    assert!(b["normal_angle_deg"]["mean"].as_f64().unwrap() > f(&["normal_angle_deg", "mean"]));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `caoen convert MESH -o MODEL -f --json --check-size 64 EXTRA`, which must succeed: its
/// JSON summary.
fn convert_json(mesh: &Path, model: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "--quiet",
        "convert",
        s(mesh),
        "-o",
        s(model),
        "-f",
        "--json",
        "--check-size",
        "64",
    ];
    args.extend_from_slice(extra);
    let out = caoen_ok(&args);
    serde_json::from_slice(&out.stdout).unwrap()
}

/// `caoen deviation ARGS --json`, which must succeed: its summary.
fn deviation_json(args: &[&str]) -> serde_json::Value {
    let mut all = vec!["--quiet", "deviation"];
    all.extend_from_slice(args);
    all.push("--json");
    let out = caoen_ok(&all);
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn targets_not_met_say_why_and_the_advice_fits_the_cause() {
    let dir = tmpdir("advice");
    let mesh = repo_path("tests/data/meshes/spot.obj");
    let model = dir.join("m.json");
    let run = |extra: &[&str]| convert_json(&mesh, &model, extra);
    // A small budget is spent: the advice is to raise it.
    let r = run(&["--max-functions", "40"]);
    assert_eq!(r["met_target"], false, "{r}");
    assert_eq!(r["stop"], "Budget", "{r}");
    assert!(
        r["advice"].as_str().unwrap().contains("--max-functions"),
        "{r}"
    );
    // An unreachable angle with budget left: never "raise --max-functions".
    let r = run(&["--target-angle", "0.01", "--max-functions", "9000"]);
    assert_eq!(r["met_target"], false, "{r}");
    assert_ne!(r["stop"], "Budget", "{r}");
    assert!(r["functions"].as_u64().unwrap() < 9000, "{r}");
    let advice = r["advice"].as_str().unwrap();
    assert!(!advice.contains("raise --max-functions"), "{r}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A UV sphere (`n` bands) without the triangles within 30 degrees of its top: a solid
/// with one round hole, as OBJ text.
fn holed_sphere_obj(n: usize) -> String {
    let mut t = String::new();
    let ring = |i: usize, j: usize| 1 + (i - 1) * 2 * n + j % (2 * n);
    for i in 1..n {
        let th = std::f64::consts::PI * i as f64 / n as f64;
        for j in 0..2 * n {
            let ph = std::f64::consts::PI * j as f64 / n as f64;
            t += &format!(
                "v {} {} {}\n",
                th.sin() * ph.cos(),
                th.sin() * ph.sin(),
                th.cos()
            );
        }
    }
    let bottom = (n - 1) * 2 * n + 1;
    t += "v 0 0 -1\n";
    let first = (n as f64 / 6.0).ceil() as usize;
    for j in 0..2 * n {
        t += &format!("f {} {} {}\n", ring(n - 1, j), bottom, ring(n - 1, j + 1));
        for i in first..n - 1 {
            let (a, b) = (ring(i, j), ring(i, j + 1));
            let (c, d) = (ring(i + 1, j), ring(i + 1, j + 1));
            t += &format!("f {a} {c} {d}\nf {a} {d} {b}\n");
        }
    }
    t
}

#[test]
fn a_closed_model_of_a_holed_mesh_says_the_holes_cost_the_depth() {
    let dir = tmpdir("holed");
    let mesh = dir.join("holed.obj");
    std::fs::write(&mesh, holed_sphere_obj(48)).unwrap();
    let r = convert_json(&mesh, &dir.join("m.json"), &["--holes", "close"]);
    assert_eq!(r["open"]["handled_as"], "solid, holes closed", "{r}");
    assert_eq!(r["met_target"], false, "{r}");
    let advice = r["advice"].as_str().unwrap();
    assert!(
        advice.contains("boundary edges (holes)") && advice.contains("along -z looks into them"),
        "{r}"
    );
    assert!(!advice.contains("raise --max-functions"), "{r}");
    // Closed on request: the advice names the other mode.
    assert!(advice.contains("--holes open"), "{r}");
    assert!(r["holes"]["open_depth_mean_all_pixels"].is_null(), "{r}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The all-pixel depth mean of the view `name` in a convert summary.
fn view_depth(r: &serde_json::Value, name: &str) -> f64 {
    r["deviation"]["depth"]["views"]
        .as_array()
        .unwrap()
        .iter()
        .find(|v| v["view"] == name)
        .unwrap_or_else(|| panic!("no view {name}: {r}"))["mean_all_pixels"]
        .as_f64()
        .unwrap()
}

#[test]
fn a_holed_mesh_converts_with_an_opening_the_view_into_it_sees_through() {
    let dir = tmpdir("opening");
    let mesh = dir.join("holed.obj");
    std::fs::write(&mesh, holed_sphere_obj(32)).unwrap();
    let (closed_model, open_model) = (dir.join("closed.json"), dir.join("open.json"));
    let closed = convert_json(&mesh, &closed_model, &["--holes", "close"]);
    let open = convert_json(&mesh, &open_model, &[]);
    assert_eq!(open["open"]["handled_as"], "shell with openings", "{open}");
    assert_eq!(
        (&open["open"]["boundary_loops"], &open["open"]["openings"]),
        (&serde_json::json!(1), &serde_json::json!(1)),
        "{open}"
    );
    // The view from above looks into the hole: the shell shows the inside there.
    let (c, o) = (view_depth(&closed, "-z"), view_depth(&open, "-z"));
    assert!(o < 0.5 * c, "-z: open {o} closed {c}");
    let all = |r: &serde_json::Value| r["deviation"]["depth"]["mean_all_pixels"].as_f64().unwrap();
    assert!(all(&open) < all(&closed), "{open} {closed}");
    // Both were measured on the same fit; the summary keeps both.
    assert_eq!(
        open["holes"]["closed_depth_mean_all_pixels"].as_f64(),
        Some(all(&closed))
    );
    assert_eq!(
        open["holes"]["open_depth_mean_all_pixels"].as_f64(),
        Some(all(&open))
    );
    // The view from below, which does not see the hole, is the same: the outer wall
    // is the closed surface.
    let (c, o) = (view_depth(&closed, "+z"), view_depth(&open, "+z"));
    assert!((o - c).abs() < 1e-9, "+z: open {o} closed {c}");
    // What was written is what was measured.
    // Equal to convert's own measure only at the same size: no bound may shrink it.
    let d = deviation_json(&[s(&mesh), s(&open_model), "--size", "64", "--max-work", "1h"]);
    let written = d["depth"]["mean_all_pixels"].as_f64().unwrap();
    assert!(
        (written - all(&open)).abs() < 1e-12,
        "{written} {}",
        all(&open)
    );
    // The advice never says the model closes the holes it opened.
    if let Some(advice) = open["advice"].as_str() {
        assert!(!advice.contains("which the model closes"), "{open}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A flat square sheet of zero thickness as OBJ text.
fn sheet_obj(n: usize) -> String {
    let mut t = String::new();
    for i in 0..=n {
        for j in 0..=n {
            t += &format!("v {} {} 0\n", i as f64 / n as f64, j as f64 / n as f64);
        }
    }
    let v = |i: usize, j: usize| i * (n + 1) + j + 1;
    for i in 0..n {
        for j in 0..n {
            t += &format!("f {} {} {}\n", v(i, j), v(i + 1, j), v(i + 1, j + 1));
            t += &format!("f {} {} {}\n", v(i, j), v(i + 1, j + 1), v(i, j + 1));
        }
    }
    t
}

#[test]
fn an_open_sheet_is_refused_naming_its_boundary_unless_filled_on_purpose() {
    let dir = tmpdir("sheet");
    let mesh = dir.join("sheet.obj");
    std::fs::write(&mesh, sheet_obj(12)).unwrap();
    let model = dir.join("m.json");
    let out = caoen(&["convert", s(&mesh), "-o", s(&model)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("open sheet") && err.contains("48 boundary edges"),
        "{err}"
    );
    assert!(err.contains("--fill-open"), "{err}");
    assert!(!model.exists());
    // Filled on purpose: written, said so, and never a success.
    let r = convert_json(&mesh, &model, &["--fill-open"]);
    assert_eq!(r["open"]["sheet"], true, "{r}");
    assert_eq!(r["open"]["boundary_edges"], 48, "{r}");
    assert_eq!(r["met_target"], false, "{r}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_shared_open_and_holed_meshes_are_told_apart() {
    // The beetle (a hand-digitised car body, one sheet) is refused naming its
    // boundary; the full Stanford bunny (a scan with holes at the base) is not.
    let models = repo_path("../shared/models");
    let beetle = models.join("beetle.obj");
    if !beetle.exists() {
        assert!(
            std::env::var_os("CI").is_none(),
            "{} is missing",
            beetle.display()
        );
        eprintln!("skipped: {} is missing", beetle.display());
        return;
    }
    let read = |name: &str| {
        caoen::conversion::read(&models.join(name), &caoen::Limits::default()).unwrap()
    };
    let o = read("beetle.obj").openness();
    assert!(o.is_sheet() && o.boundary_edges == 296, "{o:?}");
    let out = caoen(&["convert", s(&beetle), "-o", "never.json"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("296 boundary edges"), "{err}");
    for name in ["stanford-bunny.obj", "bunny-res3.ply"] {
        let o = read(name).openness();
        assert!(o.boundary_edges > 0 && !o.is_sheet(), "{name}: {o:?}");
    }
}

#[test]
fn a_model_far_from_the_mesh_measures_badly() {
    // The deviation can fail: a ball against spot.
    let dir = tmpdir("ball");
    let model = dir.join("ball.json");
    common::write_frep(
        &model,
        serde_json::json!({"sphere": {"centre": [0, 0, 0.4], "radius": 0.5}}),
    );
    let mesh = repo_path("tests/data/meshes/spot.obj");
    let d = deviation_json(&[s(&mesh), s(&model), "--size", "64"]);
    assert!(d["depth"]["mean"].as_f64().unwrap() > 0.05, "{d}");
    assert!(
        d["normal_angle_deg"]["mean"].as_f64().unwrap() > 20.0,
        "{d}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn triangle_strips_in_a_ply_are_read_as_triangles() {
    let m = caoen::conversion::read(
        &repo_path("tests/data/meshes/tetra-strips.ply"),
        &caoen::Limits::default(),
    )
    .unwrap();
    assert_eq!(m.triangles.len(), 4);
    let t = m.topology();
    assert!(t.is_closed(), "{t:?}");
    assert_eq!(t.euler_characteristic(), 2);
}

#[test]
fn broken_meshes_fail_with_clear_errors() {
    let dir = tmpdir("bad");
    let expect = [
        ("bad-index.obj", "face"),
        ("bad-index.ply", "face 0 uses vertex 7"),
        ("nan.obj", "non-finite"),
        ("inf.obj", "non-finite"),
        ("empty.obj", "no triangles"),
        ("zero-bytes.obj", "no triangles"),
        ("one-point.obj", "one point"),
        ("zero-area.obj", "no area"),
        ("garbage.obj", "not a valid OBJ"),
        ("huge-count.ply", "4000000000 declared"),
        (
            "truncated.ply",
            "more than the 20 bytes after the header can hold",
        ),
        ("no-header-end.ply", "end_header"),
        ("not-a-mesh.ply", "no end_header"),
        ("wrong-extension.stl", "unknown mesh format"),
        ("bad-index.off", "face 0 uses vertex 9"),
        ("huge-count.off", "more than the"),
        ("trailing.off", "line 7: data after the 1 faces"),
        ("short-vertex.off", "line 4: vertex 1 has 2 numbers"),
    ];
    for (file, words) in expect {
        let path = repo_path("tests/bad/mesh").join(file);
        let out = caoen(&["convert", s(&path), "-o", s(&dir.join("m.json"))]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{file}: {err}");
        assert!(err.contains(words), "{file}: {err}");
        assert!(!err.contains("panicked"), "{file}: {err}");
    }
    assert!(!dir.join("m.json").exists());
    let missing = caoen(&["convert", "no-such.obj", "-o", s(&dir.join("m.json"))]);
    assert_eq!(missing.status.code(), Some(1));
    for bad in [
        ["--target", "0"],
        ["--target", "nan"],
        ["--max-functions", "0"],
        ["--max-angle", "-1"],
    ] {
        let out = caoen(&["convert", "x.obj", "-o", "m.json", bad[0], bad[1]]);
        assert_eq!(out.status.code(), Some(2), "{bad:?}");
    }
    let out = caoen(&["deviation", "x.obj"]);
    assert_eq!(out.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_rotated_box_is_cut_to_its_faces_exactly() {
    // A box turned off every axis, as a CAD part's faces are: a smooth fit leaves each
    // face by a little between its conditions; the supporting planes put it back.
    let (a, b) = (0.4f64, 0.3f64);
    let r = [
        [a.cos(), -a.sin() * b.cos(), a.sin() * b.sin()],
        [a.sin(), a.cos() * b.cos(), -a.cos() * b.sin()],
        [0.0, b.sin(), b.cos()],
    ];
    let turn = |p: [f64; 3]| [0, 1, 2].map(|j| r[j][0] * p[0] + r[j][1] * p[1] + r[j][2] * p[2]);
    let half = [1.0, 0.6, 0.4];
    let mesh = PolygonMesh::cuboid(half, r);
    let c = convert_at_most(&mesh, 60);
    assert_eq!(c.model.supports.as_ref().map(|s| s.planes.len()), Some(6));
    let v: serde_json::Value =
        serde_json::from_str(&c.model.to_frep_json("box", mesh.bounds()).to_string()).unwrap();
    let node = frep_node(&v["model"]).unwrap();
    // Across every face, a hair outside is outside (and its middle, a little inside, is
    // inside: the cut keeps the solid).
    for k in 0..3 {
        for sign in [-1.0, 1.0] {
            for (u, w) in [(0.0, 0.0), (0.7, 0.7), (-0.9, 0.3), (0.2, -0.95)] {
                let (i, j) = ((k + 1) % 3, (k + 2) % 3);
                let at = |depth: f64| {
                    let mut p = [0.0; 3];
                    p[k] = sign * (half[k] + depth);
                    p[i] = u * half[i];
                    p[j] = w * half[j];
                    turn(p)
                };
                assert!(node.value(at(1e-6)) < 0.0, "face {k} {sign} ({u}, {w})");
                if u == 0.0 {
                    assert!(node.value(at(-0.05)) > 0.0, "face {k} {sign}");
                }
            }
        }
    }
}

/// `mesh` as OBJ text.
fn obj_text(mesh: &PolygonMesh) -> String {
    let mut s = String::new();
    for p in &mesh.positions {
        s += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    for t in &mesh.triangles {
        s += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

/// `part` moved by `at` and appended to `mesh`, without the triangles whose centre
/// `cut` picks (a small opening).
fn add_part(
    mesh: &mut PolygonMesh,
    part: &PolygonMesh,
    at: [f64; 3],
    cut: &dyn Fn([f64; 3]) -> bool,
) {
    let base = mesh.positions.len() as u32;
    let moved: Vec<[f64; 3]> = part
        .positions
        .iter()
        .map(|p| [p[0] + at[0], p[1] + at[1], p[2] + at[2]])
        .collect();
    for t in &part.triangles {
        let c = [0, 1, 2].map(|k| t.iter().map(|&v| moved[v as usize][k]).sum::<f64>() / 3.0);
        if !cut(c) {
            mesh.triangles.push(t.map(|v| v + base));
        }
    }
    mesh.positions.extend(moved);
}

/// A teapot-like mesh: a body with a small opening at the top, a lid resting in it,
/// a spout with a small hole at its tip and a handle, the last two reaching into the
/// body; each part a solid by itself, the whole an open sheet by its winding numbers.
fn teapot_like() -> PolygonMesh {
    let mut mesh = PolygonMesh::default();
    let body = PolygonMesh::ellipsoid([0.5, 0.5, 0.4], 3);
    add_part(&mut mesh, &body, [0.0; 3], &|c| c[2] > 0.385);
    let lid = PolygonMesh::ellipsoid([0.2, 0.2, 0.1], 3);
    add_part(&mut mesh, &lid, [0.0, 0.0, 0.39], &|_| false);
    let spout = PolygonMesh::ellipsoid([0.35, 0.08, 0.08], 3);
    add_part(&mut mesh, &spout, [0.6, 0.0, 0.1], &|c| c[0] > 0.93);
    let handle = PolygonMesh::ellipsoid([0.25, 0.06, 0.2], 3);
    add_part(&mut mesh, &handle, [-0.55, 0.0, 0.0], &|_| false);
    mesh
}

#[test]
fn a_teapot_like_mesh_of_parts_converts_by_default_part_by_part() {
    let dir = tmpdir("teapot");
    let mesh = dir.join("teapot.obj");
    let teapot = teapot_like();
    let open = teapot.openness();
    assert!(open.is_sheet() && open.boundary_edges > 0, "{open:?}");
    std::fs::write(&mesh, obj_text(&teapot)).unwrap();
    let r = convert_json(&mesh, &dir.join("teapot.json"), &[]);
    assert_eq!(r["open"]["parts"], 4, "{r}");
    assert_eq!(r["open"]["sheet"], false, "{r}");
    assert_eq!(r["components"]["spurious"], serde_json::json!([]), "{r}");
    assert_eq!(r["components"]["parts"], 1, "{r}");
    let angle = r["deviation"]["normal_angle_deg"]["mean"].as_f64().unwrap();
    let depth = r["deviation"]["depth"]["mean_all_pixels"].as_f64().unwrap();
    eprintln!(
        "teapot-like: {angle:.2} degrees, depth {:.4}%, {} functions, {:.1} s",
        100.0 * depth,
        r["functions"],
        r["seconds"].as_f64().unwrap()
    );
    assert!(angle <= 3.0 && depth <= 0.002, "{r}");
    assert_eq!(r["met_target"], true, "{r}");
}

/// A square sheet of side 1 bent into a dome 0.2 high, `n` quads a side.
fn curved_patch(n: usize) -> PolygonMesh {
    let mut sheet = PolygonMesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
            let z = 0.2 * (std::f64::consts::PI * x).sin() * (std::f64::consts::PI * y).sin();
            sheet.positions.push([x, y, z]);
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = (j * (n + 1) + i) as u32;
            let (b, c, d) = (a + 1, a + n as u32 + 1, a + n as u32 + 2);
            sheet.triangles.extend([[a, b, d], [a, d, c]]);
        }
    }
    sheet
}

#[test]
fn a_thickened_sheet_is_the_solid_within_the_thickness() {
    let dir = tmpdir("thicken");
    let mesh = dir.join("patch.obj");
    let sheet = curved_patch(12);
    std::fs::write(&mesh, obj_text(&sheet)).unwrap();
    let model = dir.join("patch.json");
    let t = 0.05;
    let r = convert_json(
        &mesh,
        &model,
        &["--thicken", "0.05", "--max-functions", "1500"],
    );
    assert_eq!(r["open"]["thickness"], t, "{r}");
    assert!(
        r["open"]["handled_as"]
            .as_str()
            .unwrap()
            .contains("--thicken"),
        "{r}"
    );
    assert_eq!(r["components"]["spurious"], serde_json::json!([]), "{r}");
    // The model's surface, polygonised, lies at the thickness from the sheet.
    let surface = dir.join("surface.obj");
    caoen_ok(&[
        "--quiet",
        "frep",
        "mesh",
        s(&model),
        "-o",
        s(&surface),
        "-f",
        "--cells",
        "96",
    ]);
    let polygonised = caoen::conversion::read(&surface, &caoen::Limits::default()).unwrap();
    let tree = caoen::conversion::distance::SurfaceDistance::new(&sheet);
    let off: Vec<f64> = polygonised
        .positions
        .iter()
        .map(|p| (tree.distance(*p) - t).abs())
        .collect();
    let mean = off.iter().sum::<f64>() / off.len() as f64;
    let within = off.iter().filter(|d| **d <= 0.2 * t).count() as f64 / off.len() as f64;
    eprintln!(
        "thickened: mean |distance - T| {mean:.5}, {:.1}% within 0.2 T",
        100.0 * within
    );
    assert!(
        mean <= 0.1 * t && within >= 0.95,
        "mean {mean}, within {within}"
    );
    // Thicknesses out of range are refused with the values.
    for (bad, says) in [
        ("0", "above 0"),
        ("-1", "above 0"),
        ("nan", "above 0"),
        ("1e9", "expected a thickness from"),
        ("0.001", "from 1.0000e-2 to 2.5000e-1"),
    ] {
        let flag = format!("--thicken={bad}");
        let out = caoen(&["convert", s(&mesh), "-o", s(&model), "-f", &flag]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success() && err.contains(says), "{bad}: {err}");
    }
    let out = caoen(&[
        "convert",
        s(&mesh),
        "-o",
        s(&model),
        "-f",
        "--thicken",
        "0.05",
        "--fill-open",
    ]);
    assert!(!out.status.success());
}
