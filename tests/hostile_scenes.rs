//! Scenes and models that ask for hours of work (`tests/bad/hostile/third-D8*`,
//! `lights-D8e*` (area lights' samples), `third-M8*`): a render is refused before it starts, naming its estimate, the limit
//! and the option that raises it, and renders with the limit raised; `deviation`
//! measures a costly model on a grid that fits its limit and says so.

mod common;

use std::time::Instant;

use common::{caoen, caoen_ok, fresh_dir, hostile as bad, s, stderr};

const SCENES: [&str; 5] = [
    "third-D8-1000-lights.scene.json",
    "third-D8b-1000-mirrors.scene.json",
    "third-D8c-10-nested-glass.scene.json",
    "third-D8d-1000-glass-balls.scene.json",
    "lights-D8e-area-256x256.scene.json",
];

#[test]
fn costly_scenes_are_refused_with_their_estimate() {
    let dir = fresh_dir("hostile-scenes-refused");
    let out = dir.join("l.png");
    for scene in SCENES {
        for command in [&["frep", "render"][..], &["surface", "render"][..]] {
            let file = bad(scene);
            let mut args = command.to_vec();
            args.extend_from_slice(&[&file, "-o", s(&out)]);
            let start = Instant::now();
            let run = caoen(&args);
            let err = stderr(&run);
            assert_eq!(run.status.code(), Some(1), "{args:?}: {err}");
            assert!(start.elapsed().as_secs_f64() < 10.0, "{args:?} took long");
            for part in [
                "of CPU time",
                "ray-object tests",
                "the limit is 2.0m",
                "--max-work",
            ] {
                assert!(err.contains(part), "{args:?}: no `{part}` in {err}");
            }
            assert!(!err.contains("panicked"), "{err}");
            assert_eq!(err.trim_end().lines().count(), 1, "{err}");
            assert!(!out.exists(), "{args:?} wrote {}", out.display());
        }
    }
}

#[test]
fn costly_scenes_render_small_with_a_raised_limit() {
    let dir = fresh_dir("hostile-scenes-raised");
    for (i, scene) in SCENES.into_iter().enumerate() {
        let out = dir.join(format!("{i}.png"));
        let file = bad(scene);
        caoen_ok(&[
            "frep",
            "render",
            &file,
            "-o",
            s(&out),
            "--size",
            "8x6",
            "--samples",
            "1",
            "--max-work",
            "100h",
        ]);
        let img = image::open(&out).expect("a PNG caoen reads back");
        assert_eq!((img.width(), img.height()), (8, 6), "{scene}");
    }
}

#[test]
fn max_work_is_checked_as_a_time() {
    let file = bad(SCENES[0]);
    for bad_time in ["0", "-1s", "ten", "5x", "1e12h"] {
        let run = caoen(&[
            "frep",
            "render",
            &file,
            "-o",
            "x.png",
            "--max-work",
            bad_time,
        ]);
        assert_eq!(run.status.code(), Some(2), "{bad_time}: {}", stderr(&run));
    }
}

#[test]
fn deviation_of_a_costly_model_follows_its_cost() {
    let dir = fresh_dir("hostile-deviation-bound");
    let model = bad("third-M8-noise-63-deep.json");
    let mesh = dir.join("m8.obj");
    caoen_ok(&["frep", "mesh", &model, "-o", s(&mesh), "--cells", "8"]);
    let start = Instant::now();
    let run = caoen_ok(&["deviation", s(&mesh), &model, "--max-work", "20s"]);
    let err = stderr(&run);
    assert!(err.contains("an evaluation"), "{err}");
    assert!(err.contains("the limit is 20.0s"), "{err}");
    assert!(err.contains("sampling the field on a "), "{err}");
    assert!(!err.contains("129^3"), "{err}");
    assert!(start.elapsed().as_secs_f64() < 60.0);
    // A limit no grid fits is refused, naming the option.
    let run = caoen(&["deviation", s(&mesh), &model, "--max-work", "0.001s"]);
    let err = stderr(&run);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert!(err.contains("raise it with --max-work"), "{err}");
}
