//! A `.cae` image map sampled at the render's footprint: a close-up equals the render
//! of a large PNG decode of the same file and shows none of the staircase a 64x64 PNG
//! makes; a damaged `.cae` refused with a clear error; the `.cae` scene and the bump
//! patterns example against POV-Ray through `export-pov`.

mod common;
use common::{caoen, caoen_ok, povray_dir, s};

use std::path::{Path, PathBuf};

/// A 64x64 picture with sharp edges, drawn with their coverage (4x4 samples a pixel)
/// so that the edges are straight and round, not already stepped: a blue field above a
/// diagonal, a red disc, cream elsewhere.
fn sharp_picture(path: &Path) {
    let colour = |cx: f64, cy: f64| -> [f64; 3] {
        if (cx - 40.0).powi(2) + (cy - 24.0).powi(2) < 14.0 * 14.0 {
            [200.0, 40.0, 30.0]
        } else if cx * 0.8 + cy < 50.0 {
            [30.0, 60.0, 160.0]
        } else {
            [235.0, 225.0, 200.0]
        }
    };
    let img = image::RgbImage::from_fn(64, 64, |x, y| {
        let mut sum = [0.0; 3];
        for j in 0..4 {
            for i in 0..4 {
                let c = colour(
                    x as f64 + (i as f64 + 0.5) / 4.0,
                    y as f64 + (j as f64 + 0.5) / 4.0,
                );
                for k in 0..3 {
                    sum[k] += c[k] / 16.0;
                }
            }
        }
        image::Rgb(sum.map(|v| v.round() as u8))
    });
    img.save(path).unwrap();
}

/// A close-up scene of a slab whose face carries `image` by a planar map (`interpolate`
/// 2, bilinear, or 0, nearest): the camera looks at about 19 of the image's 64 texels
/// across, around the diagonal edge.
fn close_up(dir: &Path, name: &str, image: &str, interpolate: u32) -> PathBuf {
    let (x, z) = (15.0 / 64.0, 1.0 - 38.0 / 64.0);
    let scene = serde_json::json!({
        "format": "caoen-scene/1",
        "camera": {"eye": [x, -0.61, z], "target": [x, 0.0, z], "fov_deg": 30.0},
        "background": [0.75, 0.8, 0.88],
        "ambient": [0.6, 0.6, 0.6],
        "lights": [{"direction": [0.0, -1.0, 0.0], "colour": [1.0, 1.0, 1.0], "intensity": 0.4}],
        "objects": [{"name": "slab", "frep": {"box": {"centre": [0.5, 0.0, 0.5], "size": [1.2, 0.1, 1.2]}},
            "material": {"image_map": {"image": image, "interpolate": interpolate},
                         "specular": 0.0, "ambient": 1.0, "diffuse": 1.0}}]
    });
    let path = dir.join(format!("{name}.scene.json"));
    std::fs::write(&path, scene.to_string()).unwrap();
    path
}

/// Renders `scene` at `side` pixels square, 2x2 samples; the picture and its file.
fn render(scene: &Path, side: u32) -> (image::RgbImage, PathBuf) {
    let out = scene.with_extension("png");
    caoen_ok(&[
        "frep",
        "render",
        s(scene),
        "-o",
        s(&out),
        "--size",
        &format!("{side}x{side}"),
        "--samples",
        "2",
    ]);
    (image::open(&out).unwrap().to_rgb8(), out)
}

/// The diagonal edge's position on each row (the columns left of it, counted by how
/// far the red channel is from cream towards blue): robust to the edge's blur.
fn edge_positions(img: &image::RgbImage) -> Vec<f64> {
    (0..img.height())
        .map(|y| {
            (0..img.width())
                .map(|x| {
                    let r = img.get_pixel(x, y)[0] as f64;
                    ((235.0 - r) / (235.0 - 30.0)).clamp(0.0, 1.0)
                })
                .sum()
        })
        .collect()
}

/// How the edge steps: the mean absolute second difference of its position from row
/// to row (a straight or gently curved edge is near 0, a staircase of texels large),
/// and how many distinct whole-pixel positions it takes.
fn staircase(img: &image::RgbImage) -> (f64, usize) {
    let p = edge_positions(img);
    let second: f64 = p
        .windows(3)
        .map(|w| (w[2] - 2.0 * w[1] + w[0]).abs())
        .sum::<f64>()
        / (p.len() - 2) as f64;
    let mut distinct: Vec<i64> = p.iter().map(|v| v.round() as i64).collect();
    distinct.sort_unstable();
    distinct.dedup();
    (second, distinct.len())
}

/// Encodes the sharp picture as `pic.cae` in `dir`, and decodes it to PNGs at its own
/// size and at `big` pixels square.
fn cae_and_pngs(dir: &Path, big: u32) -> (PathBuf, PathBuf, PathBuf) {
    let (png, cae) = (dir.join("pic.png"), dir.join("pic.cae"));
    sharp_picture(&png);
    caoen_ok(&["encode", s(&png), "-o", s(&cae), "-q", "90", "--quiet"]);
    let (own, large) = (dir.join("own.png"), dir.join("large.png"));
    caoen_ok(&["decode", s(&cae), "-o", s(&own), "--quiet"]);
    let size = format!("{big}x{big}");
    caoen_ok(&[
        "decode",
        s(&cae),
        "-o",
        s(&large),
        "--size",
        &size,
        "--quiet",
    ]);
    (cae, own, large)
}

/// A close-up of a 64x64 `.cae` texture (19 texels across 256 pixels) renders as the
/// same scene textured by a 2048x2048 PNG decode of the file (PSNR >= 35 dB), and its
/// diagonal edge has none of the texel staircase of the 64x64 PNG decode drawn as
/// POV-Ray's default, nearest texel: its position changes smoothly from row to row
/// (mean second difference under a third of the PNG's) and takes several times as
/// many distinct pixel positions.
#[test]
fn cae_texture_has_no_staircase_close_up() {
    let dir = common::fresh_dir("cae-texture-close-up");
    let (_, own, large) = cae_and_pngs(&dir, 2048);
    let (cae, _) = render(&close_up(&dir, "cae", "pic.cae", 2), 256);
    let (big, _) = render(&close_up(&dir, "large", s(&large), 2), 256);
    let (small, _) = render(&close_up(&dir, "own-nearest", s(&own), 0), 256);
    let (smooth, _) = render(&close_up(&dir, "own-bilinear", s(&own), 2), 256);
    let psnr_big = common::psnr_rgb8(&cae, &big);
    let psnr_small = common::psnr_rgb8(&cae, &small);
    let (s_cae, s_small, s_smooth) = (staircase(&cae), staircase(&small), staircase(&smooth));
    println!(
        "close-up: .cae against the 2048 PNG {psnr_big:.2} dB, against the 64 PNG (nearest) \
         {psnr_small:.2} dB; edge second difference / distinct positions: .cae {:.3} / {}, \
         64 PNG nearest {:.3} / {}, 64 PNG bilinear {:.3} / {}",
        s_cae.0, s_cae.1, s_small.0, s_small.1, s_smooth.0, s_smooth.1
    );
    assert!(psnr_big >= 35.0, "{psnr_big:.2} dB against the large PNG");
    assert!(
        psnr_small < psnr_big,
        "the 64 PNG is as close as the large one"
    );
    assert!(
        s_cae.0 * 3.0 < s_small.0,
        "second difference .cae {:.3}, PNG {:.3}",
        s_cae.0,
        s_small.0
    );
    assert!(
        s_cae.1 >= 3 * s_small.1,
        "distinct positions .cae {}, PNG {}",
        s_cae.1,
        s_small.1
    );
}

/// A `.cae` image map that is not a readable file fails the render with one line that
/// names the field and the file, exit code 1 and no panic; a truncated file and a PNG
/// renamed `.cae` alike.
#[test]
fn damaged_cae_texture_is_refused() {
    let dir = common::fresh_dir("cae-texture-damaged");
    let (cae, _, _) = cae_and_pngs(&dir, 64);
    let bytes = std::fs::read(&cae).unwrap();
    let cut = dir.join("cut.cae");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let renamed = dir.join("renamed.cae");
    std::fs::copy(dir.join("pic.png"), &renamed).unwrap();
    for bad in ["cut.cae", "renamed.cae"] {
        let scene = close_up(&dir, "bad", bad, 2);
        let out = caoen(&[
            "frep",
            "render",
            s(&scene),
            "-o",
            s(&dir.join("bad.png")),
            "--size",
            "32x32",
        ]);
        let err = common::stderr(&out);
        assert_eq!(out.status.code(), Some(1), "{bad}: {err}");
        assert!(!err.contains("panicked"), "{bad}: {err}");
        assert!(
            err.contains("material.image_map.image") && err.contains(bad) && err.contains(".cae"),
            "{bad}: {err}"
        );
        assert_eq!(err.trim().lines().count(), 1, "{bad}: {err}");
    }
}

/// How caoen's render of `scene` and POV-Ray's render of its export agree: silhouette
/// IoU, PSNR, CPU seconds of each (every thread). Both pictures are left in `dir`.
fn against_povray(dir: &Path, scene: &Path) -> (f64, f64, f64, f64) {
    let stem = scene.file_stem().unwrap().to_string_lossy().to_string();
    let (pov, ours, theirs) = (
        dir.join(format!("{stem}.pov")),
        dir.join(format!("{stem}-caoen.png")),
        dir.join(format!("{stem}-povray.png")),
    );
    common::export_pov(scene, &pov, 512);
    let (ok, err, ours_s) = common::run_cpu(
        std::process::Command::new(env!("CARGO_BIN_EXE_caoen")).args([
            "frep",
            "render",
            s(scene),
            "-o",
            s(&ours),
            "--size",
            "512x512",
            "--samples",
            "2",
        ]),
    );
    assert!(ok, "caoen: {err}");
    let theirs_s = common::povray_cpu(&pov, &theirs, 512, "+A0.1");
    let (a, b) = (
        image::open(&ours).unwrap().to_rgb8(),
        image::open(&theirs).unwrap().to_rgb8(),
    );
    let (iou, _) = common::iou(&common::silhouette(&a), &common::silhouette(&b));
    (iou, common::psnr_rgb8(&a, &b), ours_s, theirs_s)
}

/// A ball and a slab carrying the `.cae` picture by spherical and planar maps agree
/// with POV-Ray's render of the export, which reads PNGs decoded beside the `.pov` at
/// the footprint's size: silhouette IoU >= 0.99 and PSNR >= 35 dB.
#[test]
fn cae_texture_export_matches_povray() {
    let Some(dir) = povray_dir("cae-texture-povray") else {
        return;
    };
    cae_and_pngs(&dir, 64);
    let scene = serde_json::json!({
        "format": "caoen-scene/1",
        "name": "cae textures",
        "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [0.35, -1.6, 0.9]},
        "background": [0.75, 0.8, 0.88],
        "ambient": [0.3, 0.3, 0.3],
        "lights": [{"direction": [-0.8, -1.0, 1.2], "colour": [1.0, 0.97, 0.92], "intensity": 1.0}],
        "objects": [
            {"name": "slab", "frep": {"box": {"centre": [0.0, 0.1, -0.55], "size": [2.4, 1.8, 0.1]}},
             "material": {"image_map": {"image": "pic.cae", "map_type": 0, "scale": 0.6,
                          "rotate_deg": [90.0, 0.0, 0.0]}, "specular": 0.0}},
            {"name": "ball", "frep": {"sphere": {"centre": [0.0, 0.2, -0.1], "radius": 0.4}},
             "material": {"image_map": {"image": "pic.cae", "map_type": 1,
                          "translate": [0.0, 0.2, -0.1]}, "specular": 0.3}}
        ]
    });
    let path = dir.join("cae-texture.scene.json");
    std::fs::write(&path, scene.to_string()).unwrap();
    let (iou, psnr, ours, theirs) = against_povray(&dir, &path);
    println!(
        "cae-texture 512x512: IoU {iou:.4}, {psnr:.2} dB, CPU caoen {ours:.2} s, POV-Ray {theirs:.2} s, ratio {:.3}",
        ours / theirs
    );
    assert!(dir.join("cae-texture.scene-texture-0.png").exists());
    assert!(iou >= 0.99, "IoU {iou:.4}");
    assert!(psnr >= 35.0, "{psnr:.2} dB");
}

/// The bump patterns example (`bumps`, `dents` and `wrinkles` on a slab, a ball and a
/// Cao En solid) agrees with POV-Ray's render of its export: silhouette IoU >= 0.99,
/// PSNR >= 35 dB, and caoen takes at most POV-Ray's CPU time.
#[test]
fn bumps_example_matches_povray() {
    let Some(dir) = povray_dir("bumps-povray") else {
        return;
    };
    let scene = common::repo_path("examples/bumps.scene.json");
    let (iou, psnr, ours, theirs) = against_povray(&dir, &scene);
    println!(
        "bumps 512x512: IoU {iou:.4}, {psnr:.2} dB, CPU caoen {ours:.2} s, POV-Ray {theirs:.2} s, ratio {:.3}",
        ours / theirs
    );
    assert!(iou >= 0.99, "IoU {iou:.4}");
    assert!(psnr >= 35.0, "{psnr:.2} dB");
    assert!(
        ours <= theirs,
        "CPU caoen {ours:.2} s, POV-Ray {theirs:.2} s"
    );
}

/// The `.cae` texture's decode is counted with the render's buffers before either is
/// allocated: under a budget too small for the footprint's size the decode is made
/// smaller and the render runs; under one too small for the render at all it is refused
/// with the budget's error, exit code 1, nothing written.
#[test]
fn cae_texture_fits_the_memory_budget() {
    let dir = common::fresh_dir("cae-texture-budget");
    cae_and_pngs(&dir, 64);
    let scene = close_up(&dir, "cae", "pic.cae", 2);
    let run = |budget: &str, out: &Path| {
        caoen(&[
            "frep",
            "render",
            s(&scene),
            "-o",
            s(out),
            "--size",
            "256x256",
            "--samples",
            "2",
            "--max-memory",
            budget,
        ])
    };
    let fits = dir.join("fits.png");
    let r = run("64M", &fits);
    assert!(r.status.success(), "{}", common::stderr(&r));
    assert!(fits.exists());
    let refused = dir.join("refused.png");
    let r = run("24M", &refused);
    let err = common::stderr(&r);
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(err.contains("memory budget"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!refused.exists());
}

/// A `.cae` domain texture (the blob's sphere domain) is decoded at the
/// render's footprint too: the render equals the one textured by a 2048x2048 PNG decode
/// of the file (PSNR >= 35 dB) and is farther from the one textured by the 64x64 decode.
#[test]
fn cae_domain_texture_follows_the_footprint() {
    let dir = common::fresh_dir("cae-domain-texture");
    let (_, own, large) = cae_and_pngs(&dir, 2048);
    let scene = |name: &str, texture: &str| {
        let v = serde_json::json!({
            "format": "caoen-scene/1",
            "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [1.0, -1.6, 0.9]},
            "objects": [{"surface": "builtin:blob", "material": {"texture": texture, "specular": 0.0}}]
        });
        let path = dir.join(format!("{name}.scene.json"));
        std::fs::write(&path, v.to_string()).unwrap();
        path
    };
    let (cae, _) = render(&scene("cae", "pic.cae"), 256);
    let (big, _) = render(&scene("large", s(&large)), 256);
    let (small, _) = render(&scene("own", s(&own)), 256);
    let (near, far) = (
        common::psnr_rgb8(&cae, &big),
        common::psnr_rgb8(&cae, &small),
    );
    println!(
        "domain texture: .cae against the 2048 PNG {near:.2} dB, against the 64 PNG {far:.2} dB"
    );
    assert!(near >= 35.0, "{near:.2} dB");
    assert!(
        far < near,
        "{far:.2} dB against the 64 PNG, {near:.2} dB against the large one"
    );
}
