//! End-to-end tests of `caoen surface ...` and `caoen demo`.

mod common;
use common::{argv, caoen, caoen_ok, s};

fn tmpdir(name: &str) -> std::path::PathBuf {
    common::fresh_dir(&format!("test-{name}"))
}

#[test]
fn eval_prints_the_golden_diagonal_point() {
    let s = 1.0 / 3f64.sqrt();
    let out = caoen_ok(&argv(
        "surface eval builtin:six-point --at @ --json",
        &[&format!("{s},{s},{s}")],
    ));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // Exponential, q = 3: y = (e^{3(s-1)} - e^{3(-s-1)}) (1, 1, 1).
    let want = (3.0 * (s - 1.0)).exp() - (3.0 * (-s - 1.0)).exp();
    let y = v[0]["y"].as_array().unwrap();
    assert!(
        y.iter().all(|c| (c.as_f64().unwrap() - want).abs() < 1e-14),
        "{y:?}"
    );
}

#[test]
fn export_then_info_round_trips_a_model_file() {
    let d = tmpdir("export");
    let f = d.join("ring.json");
    caoen_ok(&["surface", "export", "builtin:ring", "-o", s(&f)]);
    let out = caoen_ok(&["surface", "info", s(&f), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["key_points"], 48);
    assert_eq!(v["input_dim"], 4);
}

#[test]
fn mesh_writes_a_closed_obj() {
    let d = tmpdir("mesh");
    let f = d.join("blob.obj");
    let out = caoen_ok(&argv("surface mesh builtin:blob -o @ --detail 3", &[s(&f)]));
    let text = std::fs::read_to_string(&f).unwrap();
    let verts = text.lines().filter(|l| l.starts_with("v ")).count();
    let faces = text.lines().filter(|l| l.starts_with("f ")).count();
    // Icosphere level 3: 642 vertices, 1280 triangles; V - E + F = 2 with E = 3F/2.
    assert_eq!((verts, faces), (642, 1280));
    assert!(String::from_utf8_lossy(&out.stderr).contains("Euler characteristic 2"));
}

#[test]
fn bad_input_fails_cleanly_with_the_right_exit_code() {
    let d = tmpdir("bad");
    let bad = d.join("bad.json");
    std::fs::write(&bad, r#"{"format":"caoen-surface/1","domain":{"kind":"sphere","dim":3},"key_points":[{"source":[1,0,0],"shape":[1],"q":-1}]}"#).unwrap();
    let out = caoen(&["surface", "info", s(&bad)]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("key_points[0].q"), "{err}");
    assert!(!err.contains("panicked"));
    // Missing file, unknown built-in, bad numbers, unknown options, NaN input.
    let (missing, stl) = (d.join("missing.json"), d.join("x.stl"));
    let cases: [(&[&str], i32); 6] = [
        (&["surface", "info", s(&missing)], 1),
        (&["surface", "info", "builtin:nope"], 2),
        (&["surface", "eval", "builtin:blob", "--at", "1,x,0"], 2),
        (&["surface", "eval", "builtin:blob", "--at", "NaN,0,1"], 1),
        (&["surface", "info", "builtin:blob", "--frobnicate"], 2),
        (&["surface", "mesh", "builtin:blob", "-o", s(&stl)], 2),
    ];
    for (args, code) in cases {
        assert_eq!(caoen(args).status.code(), Some(code), "{args:?}");
    }
}

#[test]
fn every_command_has_help() {
    for args in [
        vec!["--help"],
        vec!["surface", "--help"],
        vec!["surface", "eval", "--help"],
        vec!["demo", "--help"],
    ] {
        let out = caoen(&args);
        assert!(out.status.success() && !out.stdout.is_empty(), "{args:?}");
    }
}

#[test]
fn a_closed_stdout_is_not_a_panic() {
    use std::io::Read;
    // Both print far more than a pipe holds, so they meet the closed pipe mid-write.
    for args in [
        &["surface", "eval", "builtin:blob", "--grid", "400x400"][..],
        &["corpus", "--list", "--seeds", "5000"][..],
    ] {
        let mut child = common::spawn_piped(args);
        let mut first = [0u8; 64];
        child.stdout.take().unwrap().read_exact(&mut first).unwrap(); // then drop: the pipe closes
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.is_empty(), "{args:?}: {err}");
        assert!(out.status.success(), "{args:?}");
    }
}

#[test]
fn trailing_data_after_a_surface_or_scene_is_refused() {
    let bad = common::repo_path("tests/bad");
    let d = tmpdir("trailing");
    for (args, what) in [
        (vec!["surface", "info"], "surface-trailing-garbage.json"),
        (
            vec!["surface", "render", "--size", "8x6"],
            "scene-trailing-garbage.scene.json",
        ),
    ] {
        let file = bad.join(what);
        let png = d.join("out.png");
        let mut args = args.clone();
        args.insert(2, s(&file));
        if args[1] == "render" {
            args.extend(["-o", s(&png)]);
        }
        let out = caoen(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
        // The file, then where the trailing data starts.
        assert!(
            err.contains(what) && err.contains("trailing characters at line"),
            "{err}"
        );
        assert!(!png.exists());
    }
}
