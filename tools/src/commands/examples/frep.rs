//! The F-rep example: a blended union of a ball and a bored box, as a model file, its
//! ray-cast and mesh renders side by side, and its POV-Ray export.

use std::path::Path;

use caoen::render::renderer::{render, Method};

use super::{opts, save_json, save_png};
use crate::cli::{GlobalArgs, HeightBaseArg, HeightfieldArgs};
use crate::failure::{CliError, CliResult};
use crate::output::replace_file;

/// Writes `frep/` into `dir` with `n x n` samples per pixel.
pub(super) fn write(global: &GlobalArgs, dir: &Path, n: u32) -> CliResult {
    let sub = dir.join("frep");
    std::fs::create_dir_all(&sub).map_err(|e| CliError::io(&sub, e))?;
    save_json(
        &sub,
        "blend.json",
        &serde_json::json!({
            "format": "caoen-frep/1", "name": "blended union",
            "model": {"blend_union": [
                {"sphere": {"centre": [-0.5, 0.0, 0.0], "radius": 0.6}},
                {"difference": [{"box": {"centre": [0.5, 0.0, 0.0], "size": [0.9, 0.9, 0.9]}},
                                {"cylinder": {"centre": [0.5, 0.0, 0.0], "radius": 0.25, "length": 2.0}}], "a": 1.0}
            ], "a0": 0.3, "a1": 0.3, "a2": 0.3},
            "material": {"colour": [0.8, 0.5, 0.3]},
            "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [1.0, -1.6, 0.8]}
        }),
    )?;
    let scene = crate::commands::frep::load(&sub.join("blend.json"))?;
    let ray = render(&scene, &opts(320, 240, n, Method::Ray), &|_, _| {})?;
    let mesh = render(&scene, &opts(320, 240, n, Method::Mesh), &|_, _| {})?;
    let mut pair = caoen::render::framebuffer::RgbImage::filled(640, 240, scene.background);
    pair.blit(&ray.image, 0, 0);
    pair.blit(&mesh.image, 320, 0);
    save_png(global, &sub, "blend.png", &pair)?;
    let camera = scene.camera(512, 512)?;
    let pov = caoen::frep::pov::export(&scene, &camera).map_err(CliError::Failed)?;
    replace_file(&sub.join("blend.pov"), pov.as_bytes())?;

    // The distort example's scene as a height map on each base, thresholded at 0.1:
    // what `caoen heightfield ../distort/input.png --base B --threshold 0.1` writes.
    let mut tiles = Vec::new();
    for (base, name) in [
        (HeightBaseArg::Plane, "plane"),
        (HeightBaseArg::Ellipsoid, "ellipsoid"),
        (HeightBaseArg::Cylinder, "cylinder"),
    ] {
        let args = HeightfieldArgs {
            image: "../distort/input.png".into(),
            output: sub.join(format!("heightfield-{name}.json")),
            base,
            height: 0.25,
            threshold: Some(0.1),
            interp: "bicubic".into(),
            size: "320x240".into(),
            samples: n,
        };
        let model = crate::commands::frep::heightfield_model(&args, "../distort/input.png", 1.5);
        save_json(&sub, &format!("heightfield-{name}.json"), &model)?;
        let scene = crate::commands::frep::load(&args.output)?;
        tiles.push(render(&scene, &opts(320, 240, n, Method::Ray), &|_, _| {})?.image);
    }
    let mut row = caoen::render::framebuffer::RgbImage::filled(960, 240, [1.0; 3]);
    for (i, t) in tiles.iter().enumerate() {
        row.blit(t, 320 * i as u32, 0);
    }
    save_png(global, &sub, "heightfield.png", &row)
}
