//! `caoen examples`: regenerates every example model, scene, picture and input in
//! examples/, deterministically (a second run writes the same bytes).
//!
//! The models are built here in code and written as surface files, the scenes as scene
//! files, and every picture is rendered from those files or made by the same code as
//! the command it shows (`caoen distort`, `caoen transfer`), so the committed files are
//! exactly what produced the committed pictures.

mod conversion;
mod frep;
mod lights;
mod surfaces;
mod texture;
mod textured;

pub use texture::volume_slices;

use std::path::Path;

use caoen::render::framebuffer::RgbImage;
use caoen::render::renderer::{render, Method, RenderOptions};
use caoen::render::Scene;
use caoen::surface::SurfaceModel;
use serde_json::{json, Value};

use crate::cli::{ExamplesArgs, GlobalArgs};
use crate::commands::note;
use crate::commands::render::render_with_progress;
use crate::failure::{CliError, CliResult};
use crate::output::replace_file;

fn save_json(dir: &Path, name: &str, v: &Value) -> CliResult {
    let text = serde_json::to_string_pretty(v).expect("json values serialise") + "\n";
    replace_file(&dir.join(name), text.as_bytes())
}

fn save_model(dir: &Path, name: &str, model: &SurfaceModel) -> CliResult {
    replace_file(&dir.join(name), (model.to_json() + "\n").as_bytes())
}

fn save_png(global: &GlobalArgs, dir: &Path, name: &str, img: &RgbImage) -> CliResult {
    replace_file(&dir.join(name), &img.encode_png()?)?;
    note(global, format!("wrote {}", dir.join(name).display()));
    Ok(())
}

fn opts(width: u32, height: u32, samples: u32, method: Method) -> RenderOptions {
    RenderOptions {
        width,
        height,
        samples,
        method,
        ..RenderOptions::default()
    }
}

/// Writes `scene` as the scene file `scene_dir/NAME.scene.json`, and renders that file
/// to `dir/NAME.png`.
fn scene_example(
    global: &GlobalArgs,
    (dir, scene_dir): (&Path, &Path),
    name: &str,
    scene: &Value,
    o: &RenderOptions,
) -> CliResult {
    let file = scene_dir.join(format!("{name}.scene.json"));
    save_json(scene_dir, &format!("{name}.scene.json"), scene)?;
    let png = format!("{name}.png");
    let r = render_with_progress(global, &Scene::load(&file, &global.limits)?, o, &png)?;
    save_png(global, dir, &png, &r.image)
}

/// A scene file's contents: its `name`, the camera looking from `view_from` at the
/// origin, and `objects`.
fn scene_json(name: &str, view_from: [f64; 3], objects: Value) -> Value {
    json!({"format": "caoen-scene/1", "name": name, "camera": camera_json(view_from), "objects": objects})
}

fn camera_json(view_from: [f64; 3]) -> Value {
    json!({"projection": "perspective", "fov_deg": 30.0, "view_from": view_from})
}

/// Renders one model per tile with a fixed orthographic camera and lays the tiles out
/// in a grid (row-major).
fn tile_grid(
    models: &[SurfaceModel],
    cols: u32,
    tile: u32,
    samples: u32,
    height: f64,
    limits: &caoen::Limits,
) -> CliResult<RgbImage> {
    let rows = (models.len() as u32).div_ceil(cols);
    let mut out: Option<RgbImage> = None;
    for (i, m) in models.iter().enumerate() {
        let mut scene = Scene::from_model(m.clone(), None, limits)?;
        scene.camera.eye = Some([3.0, -3.9, 2.4]);
        scene.camera.target = Some([0.0; 3]);
        scene.camera.projection = caoen::render::Projection::Orthographic { height };
        let r = render(&scene, &opts(tile, tile, samples, Method::Mesh), &|_, _| {})?;
        let img =
            out.get_or_insert_with(|| RgbImage::filled(cols * tile, rows * tile, scene.background));
        img.blit(&r.image, (i as u32 % cols) * tile, (i as u32 / cols) * tile);
    }
    out.ok_or_else(|| CliError::Failed("no tiles".into()))
}

/// `caoen examples`.
pub fn run(global: &GlobalArgs, a: &ExamplesArgs) -> CliResult {
    let dir = a.out.as_path();
    std::fs::create_dir_all(dir).map_err(|e| CliError::io(dir, e))?;
    let start = std::time::Instant::now();
    surfaces::write(global, dir, a.samples)?;
    texture::write(global, dir, a.samples)?;
    frep::write(global, dir, a.samples)?;
    lights::write(dir)?;
    textured::write_surface(dir)?;
    conversion::write(global, dir)?;
    note(
        global,
        format!(
            "examples regenerated in {:.1} s",
            start.elapsed().as_secs_f64()
        ),
    );
    Ok(())
}
