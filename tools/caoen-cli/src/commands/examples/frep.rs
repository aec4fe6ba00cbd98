//! The F-rep example: a blended union of a ball and a bored box, as a model file, its
//! ray-cast and mesh renders side by side, and its POV-Ray export; height fields,
//! carving, and a scene of reflection, refraction and shadows.

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
    let scene = crate::commands::frep::load(&sub.join("blend.json"), &global.limits)?;
    let ray = render(&scene, &opts(320, 240, n, Method::Ray), &|_, _| {})?;
    let mesh = render(&scene, &opts(320, 240, n, Method::Mesh), &|_, _| {})?;
    let mut pair = caoen::render::framebuffer::RgbImage::filled(640, 240, scene.background);
    pair.blit(&ray.image, 0, 0);
    pair.blit(&mesh.image, 320, 0);
    save_png(global, &sub, "blend.png", &pair)?;
    let camera = scene.camera(512, 512)?;
    let pov =
        caoen::render::pov::export(&scene, &camera).map_err(|e| CliError::Failed(e.to_string()))?;
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
        let scene = crate::commands::frep::load(&args.output, &global.limits)?;
        tiles.push(render(&scene, &opts(320, 240, n, Method::Ray), &|_, _| {})?.image);
    }
    let mut row = caoen::render::framebuffer::RgbImage::filled(960, 240, [1.0; 3]);
    for (i, t) in tiles.iter().enumerate() {
        row.blit(t, 320 * i as u32, 0);
    }
    save_png(global, &sub, "heightfield.png", &row)?;

    // Lattice carving: a diagonal lattice (antialiased bars) swept around the z axis
    // through the wall of a superellipsoid cup, open at the top; and relief: the
    // distort example's scene raised on a ball. What `caoen carve lattice.png --on ...
    // --projection cylindrical --shell 0.05` and `caoen relief ../distort/input.png --on
    // ... --depth 0.06` write, with the images named relative to examples/frep.
    write_lattice(&sub.join("lattice.png"))?;
    let cup = serde_json::json!({"difference": [
        {"superellipsoid": {"radii": [0.6, 0.6, 0.8], "exponents": [0.3, 1.0]}},
        {"superellipsoid": {"radii": [0.55, 0.55, 0.75], "exponents": [0.3, 1.0]}},
        {"half_space": {"point": [0.0, 0.0, 0.55], "normal": [0.0, 0.0, -1.0]}}
    ], "a": 1.0});
    save_json(
        &sub,
        "lattice.json",
        &serde_json::json!({
            "format": "caoen-frep/1", "name": "lattice cup",
            "model": {"intersection": [cup, {"pattern": {"image": "lattice.png", "projection": "cylindrical",
                "rect": [-std::f64::consts::PI, -0.8, std::f64::consts::PI, 0.8], "level": 0.5, "interp": "bicubic"}}], "a": 1.0},
            "bounds": {"min": [-0.61, -0.61, -0.81], "max": [0.61, 0.61, 0.81]},
            "material": {"colour": [0.75, 0.6, 0.4], "specular": 0.3},
            "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [1.0, -1.6, 1.1]}
        }),
    )?;
    save_json(
        &sub,
        "relief.json",
        &serde_json::json!({
            "format": "caoen-frep/1", "name": "relief on a ball",
            "model": {"relief": {"sphere": {"radius": 1.0}}, "image": "../distort/input.png",
                      "projection": "spherical", "depth": 0.06, "interp": "bicubic"},
            "material": {"colour": [0.85, 0.82, 0.78]},
            "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [1.0, -1.6, 0.5]}
        }),
    )?;
    let mut pair = caoen::render::framebuffer::RgbImage::filled(640, 240, [1.0; 3]);
    for (k, name) in ["lattice.json", "relief.json"].into_iter().enumerate() {
        let scene = crate::commands::frep::load(&sub.join(name), &global.limits)?;
        let r = render(&scene, &opts(320, 240, n, Method::Ray), &|_, _| {})?;
        pair.blit(&r.image, 320 * k as u32, 0);
    }
    save_png(global, &sub, "carving.png", &pair)?;
    write_mirror_glass(global, &sub, n)?;
    super::textured::write(global, &sub, n)?;
    lithophane(&sub, &global.limits)
}

/// The secondary-ray example: a mirror ball, a glass Cao En solid (a dodecahedron,
/// formula 17) and a red ball on a slab under a key and a fill light, with shadows;
/// its render and its POV-Ray export.
fn write_mirror_glass(global: &GlobalArgs, sub: &Path, n: u32) -> CliResult {
    save_json(sub, "mirror-glass.json", &mirror_glass_scene())?;
    let scene = crate::commands::frep::load(&sub.join("mirror-glass.json"), &global.limits)?;
    let r = render(&scene, &opts(400, 300, n, Method::Ray), &|_, _| {})?;
    save_png(global, sub, "mirror-glass.png", &r.image)?;
    let camera = scene.camera(512, 512)?;
    let pov =
        caoen::render::pov::export(&scene, &camera).map_err(|e| CliError::Failed(e.to_string()))?;
    replace_file(&sub.join("mirror-glass.pov"), pov.as_bytes())
}

/// The scene of `examples/frep/mirror-glass.json`.
pub fn mirror_glass_scene() -> serde_json::Value {
    serde_json::json!({
        "format": "caoen-scene/1",
        "name": "mirror ball and glass Cao En solid",
        "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [0.35, -1.6, 0.9]},
        "background": [0.75, 0.8, 0.88],
        "ambient": [0.25, 0.25, 0.25],
        "lights": [
            {"direction": [-0.8, -0.6, 1.4], "colour": [1.0, 0.97, 0.92], "intensity": 1.0},
            {"direction": [1.0, -0.4, 0.6], "colour": [0.75, 0.82, 1.0], "intensity": 0.3}
        ],
        "max_depth": 5,
        "objects": [
            {"name": "slab", "frep": {"box": {"centre": [0.0, 0.0, -0.55], "size": [3.0, 2.4, 0.1]}},
             "material": {"colour": [0.82, 0.8, 0.74], "specular": 0.0}},
            {"name": "mirror ball", "frep": {"sphere": {"centre": [-0.6, 0.35, -0.05], "radius": 0.45}},
             "material": {"colour": [0.15, 0.15, 0.15], "reflect": 0.85, "specular": 0.6, "shininess": 80}},
            {"name": "red ball", "frep": {"sphere": {"centre": [0.35, 0.75, -0.28], "radius": 0.22}},
             "material": {"colour": [0.8, 0.15, 0.1], "specular": 0.3}},
            {"name": "glass Cao En solid", "frep": {"cao_en_solid": {"polyhedron": "dodecahedron",
                "radius": 0.3, "q": 12.0, "level": 2.0, "centre": [0.45, -0.15, -0.16]}},
             "material": {"colour": [0.92, 0.96, 1.0], "reflect": 1.0, "transmit": 0.9, "ior": 1.5,
                          "specular": 0.6, "shininess": 120}}
        ]
    })
}

/// A lithophane: the distort example's photograph-like scene engraved into a plate 0.1
/// thick (1.5 x 1 across) so that the plate is thicker where the picture is darker
/// (0.1 for black, 0.04 for white), written as a binary STL to print. What `caoen
/// relief ../distort/input.png --on plate.json --projection planar --depth -0.06 -o
/// lithophane.stl --cells 64` writes, the plate being the box of `lithophane.json`.
fn lithophane(sub: &Path, limits: &caoen::Limits) -> CliResult {
    let model = serde_json::json!({
        "format": "caoen-frep/1", "name": "lithophane",
        "model": {"relief": {"box": {"centre": [0.0, 0.0, 0.05], "size": [1.5, 1.0, 0.1]}},
                  "image": "../distort/input.png", "projection": "planar", "depth": -0.06,
                  "interp": "bilinear"},
        "material": {"colour": [0.92, 0.9, 0.85]},
        "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [0.3, -1.2, 1.6]}
    });
    save_json(sub, "lithophane.json", &model)?;
    let scene = crate::commands::frep::load(&sub.join("lithophane.json"), limits)?;
    let Some(caoen::render::scene::Shape::Field { node, bounds }) =
        scene.objects.first().map(|o| &o.shape)
    else {
        return Err(CliError::Failed("lithophane.json: no F-rep model".into()));
    };
    let (mesh, _) = caoen::frep::polygonise::solid_mesh(node, bounds, 64)
        .map_err(|e| CliError::Failed(format!("lithophane.stl: {e}")))?;
    let mut stl = Vec::new();
    caoen::render::mesh_io::write_stl(&mesh, &mut stl)
        .map_err(|e| CliError::io(sub.join("lithophane.stl"), e))?;
    replace_file(&sub.join("lithophane.stl"), &stl)?;
    Ok(())
}

/// A diagonal lattice, 512x256 grey: bright bars (kept by carving) with soft edges,
/// 12 cells around and 4 up.
fn write_lattice(path: &Path) -> CliResult {
    let (w, h) = (512u32, 256u32);
    let img = image::GrayImage::from_fn(w, h, |i, j| {
        let (u, v) = (
            (i as f64 + 0.5) / w as f64 * 12.0,
            (j as f64 + 0.5) / h as f64 * 4.0,
        );
        let bar = |t: f64| (t - t.floor() - 0.5).abs();
        let d = bar(u + v).min(bar(u - v));
        // Bars 0.24 wide with a smooth edge a pixel or two wide.
        let t = ((0.12 - d) / 0.02).clamp(-1.0, 1.0);
        image::Luma([(127.5 + 127.5 * t).round() as u8])
    });
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| CliError::Failed(format!("{}: {e}", path.display())))?;
    replace_file(path, &png)
}
