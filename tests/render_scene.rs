//! Scene files (errors name the field) and the render command end to end.

mod common;
use common::{caoen, caoen_ok};

use std::path::Path;

use caoen::render::{RenderError, Scene};

fn scene_err(json: &str) -> String {
    match Scene::from_json(json, Path::new("examples"), &caoen::Limits::default()) {
        Ok(_) => panic!("accepted {json}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_scene_files_name_the_field() {
    let head = r#"{"format": "caoen-scene/1", "objects": ["#;
    let cases = [
        (
            r#"{"solid": {"polyhedron": "cube", "q": -1}}"#,
            "objects[0].solid.q",
        ),
        (
            r#"{"solid": {"polyhedron": "cube", "level": 0.5}}"#,
            "objects[0].solid.level",
        ),
        (
            r#"{"solid": {"polyhedron": "hexagon"}}"#,
            "objects[0].solid.polyhedron",
        ),
        (
            r#"{"solid": {"polyhedron": "cube", "colour": [1, 0, 0]}}"#,
            "objects[0].solid",
        ),
        (
            r#"{"surface": "builtin:blob", "material": {"colour": [1, "x", 0]}}"#,
            "objects[0].material.colour",
        ),
        (
            r#"{"surface": "builtin:blob", "material": {"specular": -2}}"#,
            "objects[0].material.specular",
        ),
        (r#"{"surface": "builtin:nothing"}"#, "objects[0].surface"),
        (r#"{"surface": "missing-file.json"}"#, "objects[0].surface"),
        (
            r#"{"surface": "builtin:blob", "transform": {"scale": 0}}"#,
            "objects[0].transform.scale",
        ),
        (
            r#"{"surface": "builtin:blob", "solid": {"polyhedron": "cube"}}"#,
            "objects[0]",
        ),
        (
            r#"{"csg": {"op": "union", "operands": [{"solid": {"polyhedron": "cube"}}]}}"#,
            "objects[0].csg.operands",
        ),
        (
            r#"{"csg": {"op": "union", "operands": [{"solid": {"polyhedron": "cube"}}, {"solid": {"polyhedron": "cube", "q": 0}}]}}"#,
            "objects[0].csg.operands[1].solid.q",
        ),
        (
            r#"{"csg": {"op": "xor", "operands": []}}"#,
            "objects[0].csg.op",
        ),
        (
            r#"{"solid": {"planes": [{"normal": [1, 0, 0], "offset": 1}]}}"#,
            "objects[0].solid",
        ),
        (
            r#"{"surface": "builtin:ring", "material": {"texture": "nope.png"}}"#,
            "objects[0].material.texture",
        ),
    ];
    for (obj, field) in cases {
        let e = scene_err(&format!("{head}{obj}]}}"));
        assert!(e.contains(field), "expected `{field}` in: {e}");
    }
    assert!(scene_err(r#"{"format": "caoen-scene/9", "objects": []}"#).contains("format"));
    assert!(scene_err(r#"{"format": "caoen-scene/1", "objects": []}"#).contains("objects"));
    assert!(scene_err(r#"{"format": "caoen-scene/1", "camera": {"fov_deg": 200}, "objects": [{"surface": "builtin:blob"}]}"#)
        .contains("camera.fov_deg"));
    assert!(scene_err(r#"{"format": "caoen-scene/1", "lights": [{"direction": [0, 0, 0]}], "objects": [{"surface": "builtin:blob"}]}"#)
        .contains("lights[0].direction"));
    assert!(matches!(
        Scene::from_json("{", Path::new("."), &caoen::Limits::default()),
        Err(RenderError::Field(_))
    ));
}

/// Bad light fields are refused naming the field, a huge area light's grid before
/// anything is allocated.
#[test]
fn bad_light_fields_name_the_field() {
    let area = |a: &str| format!(r#"{{"position": [0, 0, 3], "area_light": {a}}}"#);
    let cases = [
        (r#"{"position": [0, 0, 3], "fade_distance": 1, "fade_power": -2}"#.to_string(), "lights[0].fade_power"),
        (r#"{"position": [0, 0, 3], "fade_distance": 0, "fade_power": 2}"#.to_string(), "lights[0].fade_distance"),
        (r#"{"position": [0, 0, 3], "fade_power": 2}"#.to_string(), "lights[0].fade_distance"),
        (r#"{"direction": [0, 0, 1], "fade_distance": 1, "fade_power": 2}"#.to_string(), "lights[0].fade_distance"),
        (r#"{"direction": [0, 0, 1], "position": [0, 0, 1]}"#.to_string(), "lights[0]"),
        (r#"{"position": [0, 0, 3], "fade": 2}"#.to_string(), "fade"),
        (r#"{"position": [0, 0, 3], "radius": 20}"#.to_string(), "lights[0].radius"),
        (r#"{"position": [0, 0, 3], "point_at": [0, 0, 3]}"#.to_string(), "lights[0].point_at"),
        (r#"{"position": [0, 0, 3], "point_at": [0, 0, 0], "radius": 30, "falloff": 20}"#.to_string(), "lights[0].falloff"),
        (r#"{"position": [0, 0, 3], "point_at": [0, 0, 0], "tightness": -1}"#.to_string(), "lights[0].tightness"),
        (area(r#"{"axis1": [1, 0, 0], "axis2": [0, 1, 0], "size1": 0, "size2": 4}"#), "lights[0].area_light.size1"),
        (area(r#"{"axis1": [1, 0, 0], "axis2": [0, 1, 0], "size1": 1000000, "size2": 1000000}"#), "lights[0].area_light.size1"),
        (area(r#"{"axis1": [1, 0, 0], "axis2": [0, 1, 0], "size1": 256, "size2": 257}"#), "lights[0].area_light.size2"),
        (area(r#"{"axis1": [0, 0, 0], "axis2": [0, 1, 0], "size1": 4, "size2": 4}"#), "lights[0].area_light.axis1"),
        (area(r#"{"axis1": [1, 0, 0], "axis2": [0, 1, 0], "size1": 1, "size2": 1}"#), "lights[0].area_light"),
        (area(r#"{"axis1": [1, 0, 0], "axis2": [0, 1, 0], "size1": 4, "size2": 4, "adaptive": 99}"#), "lights[0].area_light.adaptive"),
        (area(r#"{"axis1": [1, 0, 0], "axis2": [0, 1, 0], "size1": 4, "size2": 4, "jiter": true}"#), "jiter"),
        (r#"{"direction": [0, 0, 1], "area_light": {"axis1": [1, 0, 0], "axis2": [0, 1, 0], "size1": 4, "size2": 4}}"#.to_string(), "lights[0].area_light"),
    ];
    for (light, field) in cases {
        let e = scene_err(&format!(
            r#"{{"format": "caoen-scene/1", "lights": [{light}], "objects": [{{"frep": {{"sphere": {{"radius": 1}}}}}}]}}"#
        ));
        assert!(e.contains(field), "expected `{field}` in: {e}");
    }
}

#[test]
fn every_example_scene_loads() {
    for f in [
        "solid",
        "csg",
        "textured",
        "torus-freeform",
        "lights-point",
        "lights-spot",
        "lights-area",
    ] {
        Scene::load(
            format!("examples/{f}.scene.json").as_ref(),
            &caoen::Limits::default(),
        )
        .unwrap();
    }
    let s = Scene::load(
        "examples/teapot/teapot.scene.json".as_ref(),
        &caoen::Limits::default(),
    )
    .unwrap();
    assert!(s.objects.len() >= 3);
}

#[test]
fn cli_renders_every_method_and_writes_depth_maps() {
    let dir = common::kept_dir("render-cli");
    let p = |n: &str| dir.join(n).to_string_lossy().into_owned();
    for (i, (input, method)) in [
        ("builtin:blob", "mesh"),
        ("builtin:ring", "depth"),
        ("examples/csg.scene.json", "ray"),
        ("examples/textured-blob.json", "depth"),
    ]
    .into_iter()
    .enumerate()
    {
        // One name per case: an existing output is not replaced without --force.
        let out = p(&format!("{i}-{method}.png"));
        let depth = p(&format!("{i}-{method}-depth.png"));
        let o = caoen_ok(&[
            "--quiet",
            "surface",
            "render",
            input,
            "-o",
            &out,
            "--method",
            method,
            "--size",
            "80x60",
            "--samples",
            "2",
            "--depth-out",
            &depth,
        ]);
        assert!(o.stderr.is_empty(), "-q must silence stderr");
        let img = image::open(&out).unwrap();
        assert_eq!((img.width(), img.height()), (80, 60));
        let d = image::open(&depth).unwrap();
        assert!(
            matches!(d, image::DynamicImage::ImageLuma16(_)),
            "depth map must be 16-bit grey"
        );
        let d = d.to_luma16();
        assert!(d.pixels().any(|v| v[0] == 0) && d.pixels().any(|v| v[0] == 65535));
    }
    let exr = p("d.exr");
    caoen_ok(&[
        "--quiet",
        "surface",
        "render",
        "builtin:blob",
        "-o",
        &p("e.png"),
        "--size",
        "40x30",
        "--depth-out",
        &exr,
    ]);
    assert_eq!(
        &std::fs::read(&exr).unwrap()[..4],
        &[0x76, 0x2f, 0x31, 0x01],
        "OpenEXR magic"
    );
    // Output does not depend on the number of threads.
    let a = p("j1.png");
    let b = p("j2.png");
    for (j, f) in [("1", &a), ("2", &b)] {
        caoen_ok(&[
            "--quiet",
            "-j",
            j,
            "surface",
            "render",
            "builtin:blob",
            "-o",
            f,
            "--method",
            "depth",
            "--size",
            "64x48",
        ]);
    }
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn cli_render_rejects_bad_usage_with_exit_code_2() {
    let out = std::env::temp_dir().join("caoen-never-written.png");
    let o = out.to_string_lossy();
    for (input, output, extra) in [
        ("builtin:blob", &*o, &["--size", "12"][..]),
        ("builtin:blob", "x.bmp", &[]),
        ("builtin:blob", &*o, &["--depth-out", "d.tiff"]),
        ("builtin:blob", &*o, &["--samples", "0"]),
        ("builtin:nope", &*o, &[]),
    ] {
        let args = [&["surface", "render", input, "-o", output][..], extra].concat();
        let r = caoen(&args);
        assert_eq!(
            r.status.code(),
            Some(2),
            "{args:?}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
    }
    // A broken scene file is a failure (1) whose message names the field.
    let bad = std::env::temp_dir().join(format!("caoen-bad-scene-{}.json", std::process::id()));
    std::fs::write(&bad, r#"{"format": "caoen-scene/1", "objects": [{"solid": {"polyhedron": "cube", "q": "sharp"}}]}"#).unwrap();
    let r = caoen(&["surface", "render", &bad.to_string_lossy(), "-o", &o]);
    assert_eq!(r.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&r.stderr).contains("objects[0].solid.q"));
    std::fs::remove_file(&bad).ok();
}

/// An F-rep model file's lights reach its render and its POV-Ray export; a bad one is
/// refused naming the field.
#[test]
fn frep_models_take_every_kind_of_light() {
    let dir = common::fresh_dir("render-frep-lights");
    let model = dir.join("lit.json");
    let lights = serde_json::json!([
        {"position": [1, -1, 2], "fade_distance": 1.5, "fade_power": 2},
        {"position": [-1, -1, 2], "point_at": [0, 0, 0], "radius": 20, "falloff": 30, "tightness": 4},
        {"position": [0, -2, 2], "area_light": {"axis1": [0.5, 0, 0], "axis2": [0, 0, 0.5], "size1": 3, "size2": 3, "jitter": true}}
    ]);
    let write = |lights: &serde_json::Value| {
        let m = serde_json::json!({"format": "caoen-frep/1", "model": {"sphere": {"radius": 0.8}}, "lights": lights});
        std::fs::write(&model, m.to_string()).unwrap();
    };
    write(&lights);
    let (png, pov) = (dir.join("lit.png"), dir.join("lit.pov"));
    let m = model.to_string_lossy().to_string();
    caoen_ok(&[
        "frep",
        "render",
        &m,
        "-o",
        &png.to_string_lossy(),
        "--size",
        "48x36",
    ]);
    caoen_ok(&[
        "frep",
        "export-pov",
        &m,
        "-o",
        &pov.to_string_lossy(),
        "--size",
        "48x36",
    ]);
    let text = std::fs::read_to_string(&pov).unwrap();
    for part in [
        "fade_distance 1.5 fade_power 2.0",
        "spotlight point_at",
        "radius 20.0 falloff 30.0 tightness 4.0",
        "area_light <0.5, 0.0, 0.0>, <0.0, 0.5, 0.0>, 3, 3 jitter }",
    ] {
        assert!(text.contains(part), "no `{part}` in {text}");
    }
    write(&serde_json::json!([{"position": [0, 0, 2], "fade_distance": 1, "fade_power": -1}]));
    let bad = dir.join("bad.png");
    let o = caoen(&["frep", "render", &m, "-o", &bad.to_string_lossy()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("lights[0].fade_power"), "{err}");
}
