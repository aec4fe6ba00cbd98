//! The surface examples: the six-point family, a torus-domain freeform surface, a
//! morph, implicit solids and CSG, a compound teapot-like model and a textured blob.

use std::f64::consts::TAU;
use std::path::Path;

use caoen::geometry::vector::normalise;
use caoen::render::renderer::{render, Method};
use caoen::render::texture::Texture;
use caoen::render::Scene;
use caoen::surface::morph::morph;
use caoen::surface::{gallery, Blend, Domain, KeyPoint, Network, SurfaceModel};
use serde_json::json;

use super::{opts, save_model, save_png, scene_example, scene_json, tile_grid};
use crate::cli::GlobalArgs;
use crate::failure::CliResult;
use crate::output::replace_file;

fn kp(source: [f64; 3], shape: [f64; 3], q: f64) -> KeyPoint {
    KeyPoint::new(source.to_vec(), shape.to_vec(), Blend::Exponential, q)
}

/// Six axis points and eight cube diagonals, each pulled to `shape(direction)`.
pub(super) fn fourteen_point(
    name: &str,
    q: f64,
    shape: impl Fn([f64; 3]) -> [f64; 3],
) -> CliResult<SurfaceModel> {
    let mut kps: Vec<KeyPoint> = gallery::axis_points()
        .iter()
        .map(|a| kp(*a, shape(*a), q))
        .collect();
    for sx in [-1.0, 1.0] {
        for sy in [-1.0, 1.0] {
            for sz in [-1.0, 1.0] {
                let d = normalise([sx, sy, sz]);
                kps.push(kp(d, shape(d), q));
            }
        }
    }
    Ok(SurfaceModel::new(
        name,
        Domain::SPHERE,
        Network::new(3, 3, &kps, true)?,
    )?)
}

/// A torus-domain model: a grid of key points on the torus pulled to `shape(t, f)`.
fn torus_model(
    name: &str,
    q: f64,
    nt: usize,
    nf: usize,
    shape: impl Fn(f64, f64) -> [f64; 3],
) -> CliResult<SurfaceModel> {
    let mut kps = Vec::new();
    for i in 0..nt {
        for j in 0..nf {
            let (t, f) = (TAU * i as f64 / nt as f64, TAU * j as f64 / nf as f64);
            let x = Domain::Torus.point(&[t, f])?;
            kps.push(KeyPoint::new(
                x,
                shape(t, f).to_vec(),
                Blend::Exponential,
                q,
            ));
        }
    }
    Ok(SurfaceModel::new(
        name,
        Domain::Torus,
        Network::new(4, 3, &kps, true)?,
    )?)
}

/// Writes the surface examples into `dir` with `n x n` samples per pixel.
pub(super) fn write(global: &GlobalArgs, dir: &Path, n: u32) -> CliResult {
    six_point_family(global, dir, n)?;
    torus_ring(global, dir, n)?;
    morph_strip(global, dir, n)?;
    convex_solids(global, dir, n)?;
    teapot(global, dir, n)?;
    textured_blob(global, dir, n)?;
    Ok(())
}

/// The six-point family (figures 2 and 3): q = 1..6, exponential on top, the
/// normalised exponential below.
fn six_point_family(global: &GlobalArgs, dir: &Path, n: u32) -> CliResult {
    let sub = dir.join("six-point");
    let mut family = Vec::new();
    for normalised in [false, true] {
        for q in 1..=6 {
            let m = gallery::six_point(Blend::Exponential, q as f64, normalised)?;
            let kind = if normalised {
                "normalised"
            } else {
                "exponential"
            };
            save_model(&sub, &format!("{kind}-q{q}.json"), &m)?;
            family.push(m);
        }
    }
    save_png(
        global,
        dir,
        "six-point-family.png",
        &tile_grid(&family, 6, 80, n, 2.6, &global.limits)?,
    )?;
    Ok(())
}

/// A freeform surface on the torus domain: a ring that twists its cross-section
/// into a rounded triangle and swells on one side.
fn torus_ring(global: &GlobalArgs, dir: &Path, n: u32) -> CliResult {
    let torus = torus_model("twisted ring", 10.0, 12, 8, |t, f| {
        let swell = 1.0 + 0.35 * t.cos();
        let minor = 0.32 * swell * (1.0 + 0.25 * (3.0 * f + 2.0 * t).cos());
        let r = 1.0 + minor * f.cos();
        [r * t.cos(), r * t.sin(), minor * f.sin()]
    })?;
    save_model(dir, "torus-freeform.json", &torus)?;
    scene_example(
        global,
        (dir, dir),
        "torus-freeform",
        &scene_json(
            "torus-domain freeform surface",
            [0.9, -1.5, 1.1],
            json!([{"surface": "torus-freeform.json", "material": {"colour": [0.85, 0.55, 0.3], "specular": 0.3}}]),
        ),
        &opts(384, 288, n, Method::Depth),
    )?;
    let scene = Scene::load(&dir.join("torus-freeform.scene.json"), &global.limits)?;
    let r = render(&scene, &opts(384, 288, 1, Method::Depth), &|_, _| {})?;
    replace_file(
        &dir.join("torus-freeform-depth.png"),
        &r.depth.encode_png16()?,
    )?;
    Ok(())
}

/// A morph between models of 6 and 14 key points (the smaller is padded with
/// empty key points), five frames.
fn morph_strip(global: &GlobalArgs, dir: &Path, n: u32) -> CliResult {
    let a_model = gallery::six_point(Blend::Exponential, 5.0, true)?;
    let b_model = fourteen_point("star", 5.0, |d| {
        let diag = d.iter().all(|v| v.abs() > 0.1);
        let s = if diag { 1.35 } else { 0.55 };
        [d[0] * s, d[1] * s, d[2] * s]
    })?;
    save_model(dir, "morph-a.json", &a_model)?;
    save_model(dir, "morph-b.json", &b_model)?;
    let frames: Vec<SurfaceModel> = (0..5)
        .map(|k| {
            let net = morph(&a_model.network, &b_model.network, k as f64 / 4.0)?;
            Ok(SurfaceModel::new(
                format!("morph u={}", k as f64 / 4.0),
                Domain::SPHERE,
                net,
            )?)
        })
        .collect::<CliResult<_>>()?;
    save_png(
        global,
        dir,
        "morph.png",
        &tile_grid(&frames, 5, 96, n, 3.0, &global.limits)?,
    )?;
    // The same morph as an animation, by `caoen morph morph-a.json morph-b.json -o
    // morph.gif --frames 12`.
    crate::commands::morph::run(
        &GlobalArgs {
            force: true,
            ..global.clone()
        },
        &crate::cli::MorphArgs {
            a: dir.join("morph-a.json").to_string_lossy().into_owned(),
            b: dir.join("morph-b.json").to_string_lossy().into_owned(),
            frames: 12,
            output: dir.join("morph.gif"),
            size: "240x180".into(),
            samples: n.min(2),
            detail: 5,
            delay: 100,
            json: false,
        },
    )?;
    Ok(())
}

/// Convex implicit solids from polyhedra, ray traced: one alone, and a CSG of two.
fn convex_solids(global: &GlobalArgs, dir: &Path, n: u32) -> CliResult {
    scene_example(
        global,
        (dir, dir),
        "solid",
        &scene_json(
            "implicit dodecahedron",
            [1.0, -1.7, 1.0],
            json!([{"name": "dodecahedron", "solid": {"polyhedron": "dodecahedron", "radius": 1.0, "q": 12.0, "level": 2.0},
                         "material": {"colour": [0.3, 0.6, 0.4], "specular": 0.4}}]),
        ),
        &opts(320, 240, n, Method::Ray),
    )?;
    scene_example(
        global,
        (dir, dir),
        "csg",
        &scene_json(
            "cube minus icosahedron",
            [1.0, -1.5, 1.1],
            json!([{"name": "carved cube", "csg": {"op": "difference", "operands": [
                {"solid": {"polyhedron": "cube", "radius": 1.0, "q": 16.0}},
                {"solid": {"polyhedron": "icosahedron", "radius": 1.2, "q": 6.0}}
            ]}, "material": {"colour": [0.75, 0.42, 0.35], "specular": 0.35}}]),
        ),
        &opts(320, 240, n, Method::Ray),
    )?;
    // A rim of the carved cube up close: ray traced (left) and its mesh (right), each a
    // 128x128 crop of a 512x384 render shown at twice the size.
    let scene = Scene::load(&dir.join("csg.scene.json"), &global.limits)?;
    let mut crops = caoen::render::framebuffer::RgbImage::filled(512, 256, scene.background);
    for (k, method) in [Method::Ray, Method::Mesh].into_iter().enumerate() {
        let r = render(&scene, &opts(512, 384, n, method), &|_, _| {})?;
        for y in 0..256u32 {
            for x in 0..256u32 {
                let src = r.image.pixels[((110 + y / 2) * 512 + 190 + x / 2) as usize];
                crops.pixels[(y * 512 + 256 * k as u32 + x) as usize] = src;
            }
        }
    }
    save_png(global, dir, "csg-rim.png", &crops)?;
    Ok(())
}

/// A compound teapot-like model: body, lid with knob, spout (sphere domains) and
/// handle (torus domain), placed by transforms.
fn teapot(global: &GlobalArgs, dir: &Path, n: u32) -> CliResult {
    let tea = dir.join("teapot");
    let body = fourteen_point("teapot body", 3.0, |d| {
        let z = if d[2] > 0.0 { 0.75 } else { 0.62 };
        [d[0] * 1.05, d[1] * 1.05, d[2] * z]
    })?;
    let lid = {
        let base = fourteen_point("teapot lid", 3.0, |d| {
            [
                d[0] * 0.62,
                d[1] * 0.62,
                if d[2] > 0.0 { d[2] * 0.2 } else { d[2] * 0.04 },
            ]
        })?;
        // A sharp extra key point at the pole pulls up the knob.
        let mut kps = base.network.key_points();
        kps.push(kp([0.0, 0.0, 1.0], [0.0, 0.0, 0.5], 40.0));
        SurfaceModel::new(
            "teapot lid",
            Domain::SPHERE,
            Network::new(3, 3, &kps, true)?,
        )?
    };
    let spout = fourteen_point("teapot spout", 2.5, |d| {
        let x = if d[0] > 0.0 { 1.0 * d[0] } else { 0.25 * d[0] };
        let r = 0.2 - 0.06 * d[0];
        [x, d[1] * r, d[2] * r]
    })?;
    let handle = torus_model("teapot handle", 12.0, 12, 6, |t, f| {
        let (big, small) = (0.42, 0.075);
        let r = big + small * f.cos();
        [r * t.cos(), r * t.sin(), small * f.sin()]
    })?;
    for (name, m) in [
        ("body.json", &body),
        ("lid.json", &lid),
        ("spout.json", &spout),
        ("handle.json", &handle),
    ] {
        save_model(&tea, name, m)?;
    }
    let glaze = json!({"colour": [0.82, 0.84, 0.9], "specular": 0.6, "shininess": 60.0});
    scene_example(
        global,
        (dir, &tea),
        "teapot",
        &scene_json(
            "teapot-like compound model",
            [0.35, -1.6, 0.75],
            json!([
                {"name": "body", "surface": "body.json", "material": glaze},
                {"name": "lid", "surface": "lid.json", "transform": {"translate": [0.0, 0.0, 0.62]}, "material": glaze},
                {"name": "spout", "surface": "spout.json", "transform": {"rotate_deg": [0.0, -40.0, 0.0], "translate": [0.75, 0.0, 0.05]}, "material": glaze},
                {"name": "handle", "surface": "handle.json", "transform": {"rotate_deg": [90.0, 0.0, 0.0], "translate": [-1.05, 0.0, 0.1]}, "material": glaze}
            ]),
        ),
        &opts(384, 288, n, Method::Mesh),
    )?;
    Ok(())
}

/// A textured surface: a checker texture on the sphere domain of the blob.
fn textured_blob(global: &GlobalArgs, dir: &Path, n: u32) -> CliResult {
    let tex = Texture::checker(
        256,
        128,
        16,
        8,
        [0.9, 0.85, 0.7],
        [0.08, 0.25, 0.5],
        &global.limits,
    )?;
    replace_file(&dir.join("checker.png"), &tex.image().encode_png()?)?;
    let textured = gallery::blob()?.with_texture("checker.png");
    save_model(dir, "textured-blob.json", &textured)?;
    scene_example(
        global,
        (dir, dir),
        "textured",
        &scene_json(
            "textured blob",
            [1.0, -1.6, 0.7],
            json!([{"surface": "textured-blob.json", "material": {"specular": 0.2}}]),
        ),
        &opts(320, 240, n, Method::Depth),
    )?;
    Ok(())
}
