//! The light examples: a point light fading with distance, a spot light, and an area
//! light's soft shadows (through glass too), as scene files of F-rep objects that
//! `caoen frep export-pov` hands to POV-Ray (`docs/rendering.md` compares the two).

use std::path::Path;

use serde_json::{json, Value};

use super::save_json;
use crate::failure::CliResult;

/// Writes `dir/lights-{point,spot,area}.scene.json`.
pub(super) fn write(dir: &Path) -> CliResult {
    for (name, scene) in [
        ("point", point_scene()),
        ("spot", spot_scene()),
        ("area", area_scene()),
    ] {
        save_json(dir, &format!("lights-{name}.scene.json"), &scene)?;
    }
    Ok(())
}

/// What the three scenes share: camera, background, ambient light and a slab.
fn scene(name: &str, lights: Value, objects: Value) -> Value {
    let mut all = vec![
        json!({"name": "slab", "frep": {"box": {"centre": [0, 0, -0.55], "size": [3.0, 2.4, 0.1]}},
        "material": {"colour": [0.82, 0.8, 0.74], "specular": 0.0}}),
    ];
    all.extend(objects.as_array().into_iter().flatten().cloned());
    json!({
        "format": "caoen-scene/1",
        "name": name,
        "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [0.35, -1.6, 0.9]},
        "background": [0.75, 0.8, 0.88],
        "ambient": [0.2, 0.2, 0.2],
        "max_depth": 5,
        "lights": lights,
        "objects": all
    })
}

/// A point light close above the objects, fading as `2 / (1 + (d / 0.8)^2)`.
pub fn point_scene() -> Value {
    scene(
        "point light fading with distance",
        json!([{"position": [-0.3, -0.45, 0.55], "colour": [1.0, 0.95, 0.85], "intensity": 1.5,
                "fade_distance": 0.8, "fade_power": 2}]),
        json!([
            {"name": "red ball", "frep": {"sphere": {"centre": [-0.55, 0.35, -0.1], "radius": 0.4}},
             "material": {"colour": [0.8, 0.15, 0.1], "specular": 0.3}},
            {"name": "green Cao En solid", "frep": {"cao_en_solid": {"centre": [0.5, -0.1, -0.2], "level": 2.0,
                "polyhedron": "dodecahedron", "q": 12.0, "radius": 0.3}},
             "material": {"colour": [0.3, 0.65, 0.4], "specular": 0.4, "shininess": 60}},
            {"name": "pillar", "frep": {"box": {"centre": [0.35, 0.8, -0.15], "size": [0.3, 0.3, 0.7]}},
             "material": {"colour": [0.35, 0.45, 0.8], "specular": 0.2}}
        ]),
    )
}

/// A spot light on a Cao En icosahedron (a 14 degree cone fading out by 24 degrees),
/// with a dim directional fill.
pub fn spot_scene() -> Value {
    scene(
        "spot light on a Cao En solid",
        json!([
            {"position": [0.9, -1.1, 1.5], "point_at": [0.0, 0.0, -0.3], "radius": 14, "falloff": 24, "tightness": 8,
             "colour": [1.0, 0.97, 0.9], "intensity": 2.0},
            {"direction": [-1.0, -0.4, 0.8], "colour": [0.75, 0.82, 1.0], "intensity": 0.2}
        ]),
        json!([
            {"name": "Cao En solid", "frep": {"cao_en_solid": {"centre": [0.0, 0.0, -0.2], "level": 2.0,
                "polyhedron": "icosahedron", "q": 10.0, "radius": 0.3}},
             "material": {"colour": [0.85, 0.6, 0.3], "specular": 0.5, "shininess": 80}},
            {"name": "ball", "frep": {"sphere": {"centre": [-0.7, 0.5, -0.2], "radius": 0.3}},
             "material": {"colour": [0.3, 0.45, 0.8], "specular": 0.3}}
        ]),
    )
}

/// A 0.7 x 0.7 area light of 9 x 9 samples (split once, then where the shadow
/// changes) over a ball, a pillar and a glass Cao En solid, with a directional fill;
/// rays end at depth 4 (through the glass and on), which keeps the work estimate of
/// its 82 shadow rays a hit within the default `--max-work` at 512 x 512.
pub fn area_scene() -> Value {
    let mut s = scene(
        "area light: soft shadows, through glass too",
        json!([
            {"position": [-0.9, -0.8, 1.5], "colour": [1.0, 0.97, 0.92], "intensity": 1.1,
             "area_light": {"axis1": [0.7, 0, 0], "axis2": [0, 0.7, 0], "size1": 9, "size2": 9, "adaptive": 1}},
            {"direction": [1.0, -0.4, 0.6], "colour": [0.75, 0.82, 1.0], "intensity": 0.25}
        ]),
        json!([
            {"name": "ball", "frep": {"sphere": {"centre": [-0.35, 0.45, -0.15], "radius": 0.35}},
             "material": {"colour": [0.8, 0.15, 0.1], "specular": 0.3}},
            {"name": "pillar", "frep": {"box": {"centre": [0.55, 0.55, -0.1], "size": [0.25, 0.25, 0.8]}},
             "material": {"colour": [0.35, 0.45, 0.8], "specular": 0.2}},
            {"name": "glass Cao En solid", "frep": {"cao_en_solid": {"centre": [0.35, -0.3, -0.2], "level": 2.0,
                "polyhedron": "dodecahedron", "q": 12.0, "radius": 0.28}},
             "material": {"colour": [0.92, 0.96, 1.0], "ior": 1.5, "reflect": 1.0, "shininess": 120,
                          "specular": 0.6, "transmit": 0.9}}
        ]),
    );
    s["max_depth"] = json!(4);
    s
}
