//! The image-map example: a ball, a cylinder and a box carrying one image by spherical,
//! cylindrical and planar projection (POV-Ray's `map_type` 1, 2 and 0); and the
//! textured-surface example, the same image on the domains of two Cao En surfaces.

use std::path::Path;

use caoen::render::renderer::{render, Method};

use super::{opts, save_json, save_png};
use crate::cli::GlobalArgs;
use crate::failure::{CliError, CliResult};
use crate::output::replace_file;

/// Writes `textured.json`, its image `globe.png` and its render into `sub`.
pub(super) fn write(global: &GlobalArgs, sub: &Path, n: u32) -> CliResult {
    write_globe(&sub.join("globe.png"))?;
    save_json(sub, "textured.json", &textured_scene())?;
    let scene = crate::commands::frep::load(&sub.join("textured.json"), &global.limits)?;
    let r = render(&scene, &opts(400, 300, n, Method::Ray), &|_, _| {})?;
    save_png(global, sub, "textured.png", &r.image)
}

/// The scene of `examples/frep/textured.json`.
pub fn textured_scene() -> serde_json::Value {
    serde_json::json!({
        "format": "caoen-scene/1",
        "name": "image maps by projection",
        "camera": {"projection": "perspective", "fov_deg": 32.0, "view_from": [0.2, -1.6, 0.7]},
        "background": [0.75, 0.8, 0.88],
        "ambient": [0.3, 0.3, 0.3],
        "lights": [
            {"direction": [-0.8, -1.0, 1.2], "colour": [1.0, 0.97, 0.92], "intensity": 1.0},
            {"direction": [1.0, -0.4, 0.6], "colour": [0.75, 0.82, 1.0], "intensity": 0.3}
        ],
        "objects": [
            {"name": "slab", "frep": {"box": {"centre": [0.0, 0.1, -0.45], "size": [2.6, 1.6, 0.1]}},
             "material": {"colour": [0.82, 0.8, 0.74], "specular": 0.0}},
            {"name": "ball", "frep": {"sphere": {"centre": [-0.72, 0.0, -0.05], "radius": 0.35}},
             "material": {"image_map": {"image": "globe.png", "map_type": 1, "interpolate": 2,
                          "rotate_deg": [0.0, 0.0, -70.0], "translate": [-0.72, 0.0, -0.05]},
                          "specular": 0.3}},
            {"name": "cylinder", "frep": {"cylinder": {"centre": [0.0, 0.0, -0.05], "radius": 0.25, "length": 0.7}},
             "material": {"image_map": {"image": "globe.png", "map_type": 2, "interpolate": 2,
                          "scale": [1.0, 1.0, 0.7], "rotate_deg": [0.0, 0.0, -90.0],
                          "translate": [0.0, 0.0, -0.4]}, "specular": 0.3}},
            {"name": "box", "frep": {"box": {"centre": [0.72, 0.0, -0.05], "size": [0.5, 0.5, 0.7]}},
             "material": {"image_map": {"image": "globe.png", "map_type": 0, "interpolate": 2,
                          "scale": [0.5, 1.0, 0.7], "translate": [0.47, 0.0, -0.4]}, "specular": 0.3}}
        ]
    })
}

/// Writes `dir/textured-surface.scene.json` (its image is `frep/globe.png`),
/// `dir/checker.scene.json` and `dir/bumps.scene.json`.
pub(super) fn write_surface(dir: &Path) -> CliResult {
    save_json(dir, "textured-surface.scene.json", &surface_scene())?;
    save_json(dir, "checker.scene.json", &checker_scene())?;
    save_json(dir, "bumps.scene.json", &bumps_scene())
}

/// The scene of `examples/bumps.scene.json`: POV-Ray's `bumps`, `dents` and
/// `wrinkles` normal patterns on a slab, a ball and a Cao En solid.
pub fn bumps_scene() -> serde_json::Value {
    serde_json::json!({
        "format": "caoen-scene/1",
        "name": "bump patterns",
        "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [0.35, -1.6, 0.9]},
        "background": [0.75, 0.8, 0.88],
        "ambient": [0.25, 0.25, 0.25],
        "lights": [
            {"direction": [-0.8, -1.0, 1.2], "colour": [1.0, 0.97, 0.92], "intensity": 1.0},
            {"direction": [1.0, -0.4, 0.6], "colour": [0.75, 0.82, 1.0], "intensity": 0.3}
        ],
        "objects": [
            {"name": "slab", "frep": {"box": {"centre": [0.0, 0.1, -0.55], "size": [2.4, 1.8, 0.1]}},
             "material": {"colour": [0.85, 0.82, 0.75], "specular": 0.0,
                          "normal": {"bumps": 0.6, "scale": 0.15}}},
            {"name": "ball", "frep": {"sphere": {"centre": [-0.45, 0.25, -0.15], "radius": 0.35}},
             "material": {"colour": [0.9, 0.3, 0.2], "specular": 0.3,
                          "normal": {"dents": 3.0, "scale": 0.12}}},
            {"name": "Cao En solid", "frep": {"cao_en_solid": {"centre": [0.45, -0.1, -0.2], "level": 2.0,
                "polyhedron": "dodecahedron", "q": 12.0, "radius": 0.3}},
             "material": {"colour": [0.3, 0.6, 0.4], "specular": 0.4, "shininess": 60,
                          "normal": {"wrinkles": 0.3, "scale": 0.25}}}
        ]
    })
}

/// The scene of `examples/checker.scene.json`: POV-Ray's `checker` pigment on a slab,
/// a ball and a Cao En solid, each with its own cube size (and the ball's turned).
pub fn checker_scene() -> serde_json::Value {
    serde_json::json!({
        "format": "caoen-scene/1",
        "name": "checker pigments",
        "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [0.35, -1.6, 0.9]},
        "background": [0.75, 0.8, 0.88],
        "ambient": [0.25, 0.25, 0.25],
        "lights": [
            {"direction": [-0.8, -1.0, 1.2], "colour": [1.0, 0.97, 0.92], "intensity": 1.0},
            {"direction": [1.0, -0.4, 0.6], "colour": [0.75, 0.82, 1.0], "intensity": 0.3}
        ],
        "objects": [
            {"name": "slab", "frep": {"box": {"centre": [0.0, 0.1, -0.55], "size": [2.4, 1.8, 0.1]}},
             "material": {"checker": {"colours": [[0.85, 0.82, 0.75], [0.3, 0.32, 0.38]], "scale": 0.3},
                          "specular": 0.0}},
            {"name": "ball", "frep": {"sphere": {"centre": [-0.45, 0.25, -0.15], "radius": 0.35}},
             "material": {"checker": {"colours": [[0.9, 0.2, 0.15], [0.95, 0.92, 0.85]], "scale": 0.14,
                          "rotate_deg": [0.0, 0.0, 30.0]}, "specular": 0.3}},
            {"name": "Cao En solid", "frep": {"cao_en_solid": {"centre": [0.45, -0.1, -0.2], "level": 2.0,
                "polyhedron": "dodecahedron", "q": 12.0, "radius": 0.3}},
             "material": {"checker": {"colours": [[0.2, 0.5, 0.3], [0.9, 0.85, 0.3]], "scale": 0.1},
                          "specular": 0.4, "shininess": 60}}
        ]
    })
}

/// The scene of `examples/textured-surface.scene.json`: the blob (sphere domain) and
/// the twisted ring (torus domain) carrying `globe.png` on their domains, on a slab
/// under a key and a fill light, so `export-pov`'s meshes, exact normals and
/// `uv_mapping` are checked against POV-Ray (`docs/rendering.md`).
pub fn surface_scene() -> serde_json::Value {
    serde_json::json!({
        "format": "caoen-scene/1",
        "name": "textured Cao En surfaces",
        "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [0.3, -1.6, 0.8]},
        "background": [0.75, 0.8, 0.88],
        "ambient": [0.3, 0.3, 0.3],
        "lights": [
            {"direction": [-0.8, -1.0, 1.2], "colour": [1.0, 0.97, 0.92], "intensity": 1.0},
            {"direction": [1.0, -0.4, 0.6], "colour": [0.75, 0.82, 1.0], "intensity": 0.3}
        ],
        "objects": [
            {"name": "slab", "frep": {"box": {"centre": [0.05, 0.1, -0.55], "size": [2.0, 1.4, 0.1]}},
             "material": {"colour": [0.82, 0.8, 0.74], "specular": 0.0}},
            {"name": "blob", "surface": "builtin:blob",
             "transform": {"scale": 0.32, "rotate_deg": [0.0, 0.0, 40.0], "translate": [-0.42, 0.2, -0.24]},
             "material": {"texture": "frep/globe.png", "specular": 0.3}},
            {"name": "twisted ring", "surface": "torus-freeform.json",
             "transform": {"scale": 0.28, "rotate_deg": [35.0, 0.0, 0.0], "translate": [0.5, -0.05, -0.2]},
             "material": {"texture": "frep/globe.png", "specular": 0.3}}
        ]
    })
}

/// A smooth 128x64 picture that wraps left to right: colour bands by longitude and
/// latitude with soft round spots, large enough in a render that every texel is
/// magnified (so the bilinear lookups of caoen and POV-Ray agree).
fn write_globe(path: &Path) -> CliResult {
    use std::f64::consts::TAU;
    let (w, h) = (128u32, 64u32);
    let img = image::RgbImage::from_fn(w, h, |i, j| {
        let (u, v) = ((i as f64 + 0.5) / w as f64, (j as f64 + 0.5) / h as f64);
        let (cu, cv) = ((u * 8.0).fract() - 0.5, (v * 4.0).fract() - 0.5);
        // A spot 0.3 cells across with an edge a few texels wide.
        let spot = ((0.3 - (cu * cu + cv * cv).sqrt()) / 0.08).clamp(0.0, 1.0);
        let r = 0.55 + 0.35 * (TAU * u).sin();
        let g = 0.35 + 0.45 * v;
        let b = 0.5 + 0.35 * (TAU * 2.0 * u).cos();
        let mix = |c: f64| 255.0 * (c * (1.0 - spot) + 0.95 * spot);
        image::Rgb([mix(r), mix(g), mix(b)].map(|c| c.round().clamp(0.0, 255.0) as u8))
    });
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| CliError::Failed(format!("{}: {e}", path.display())))?;
    replace_file(path, &png)
}
