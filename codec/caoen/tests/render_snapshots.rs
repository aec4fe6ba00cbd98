//! Snapshot tests: small renders compared with stored PNGs by PSNR (not byte equality,
//! so harmless floating-point differences across platforms pass).
//!
//! Set `CAOEN_UPDATE_SNAPSHOTS=1` to rewrite the stored images after a deliberate change.

mod common;

use std::path::PathBuf;

use caoen::render::framebuffer::RgbImage;
use caoen::render::renderer::{render, Method, RenderOptions};
use caoen::render::Scene;
use caoen::surface::gallery;

/// Below this the render has changed visibly.
const MIN_PSNR_DB: f64 = 35.0;

fn snapshot_path(name: &str) -> PathBuf {
    common::repo_path("tests/snapshots").join(format!("{name}.png"))
}

/// PSNR in dB between two 8-bit sRGB images of the same size (infinity when equal).
fn psnr(a: &[u8], b: &[u8]) -> f64 {
    assert_eq!(a.len(), b.len());
    let mse = a
        .iter()
        .zip(b)
        .map(|(x, y)| (*x as f64 - *y as f64).powi(2))
        .sum::<f64>()
        / a.len() as f64;
    if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    }
}

fn check(name: &str, img: &RgbImage) {
    let path = snapshot_path(name);
    if std::env::var_os("CAOEN_UPDATE_SNAPSHOTS").is_some() {
        std::fs::write(&path, img.encode_png().unwrap()).unwrap();
        return;
    }
    let stored = image::open(&path)
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e} (run with CAOEN_UPDATE_SNAPSHOTS=1 to create it)",
                path.display()
            )
        })
        .to_rgb8();
    assert_eq!(
        stored.dimensions(),
        (img.width, img.height),
        "{name}: size changed"
    );
    let p = psnr(stored.as_raw(), &img.to_srgb8());
    assert!(
        p >= MIN_PSNR_DB,
        "{name}: PSNR {p:.1} dB against {} (< {MIN_PSNR_DB})",
        path.display()
    );
}

fn opts(method: Method) -> RenderOptions {
    RenderOptions {
        width: 96,
        height: 72,
        samples: 2,
        method,
        mesh_detail: 5,
        ..RenderOptions::default()
    }
}

fn model_scene(name: &str) -> Scene {
    Scene::from_model(
        gallery::by_name(name).unwrap().unwrap(),
        None,
        &caoen::Limits::default(),
    )
    .unwrap()
}

/// `scene` rendered by `method` (see [`opts`]).
fn rendered(scene: &Scene, method: Method) -> RgbImage {
    render(scene, &opts(method), &|_, _| {}).unwrap().image
}

/// Checks the snapshot `name` against the scene file `rel` rendered by `method`.
fn check_example(name: &str, rel: &str, method: Method) {
    check(name, &rendered(&example_scene(rel), method));
}

/// The scene file `rel` (a path from the repository's root).
fn example_scene(rel: &str) -> Scene {
    Scene::load(&common::repo_path(rel), &caoen::Limits::default()).unwrap()
}

#[test]
fn snapshot_blob_mesh() {
    check("blob-mesh", &rendered(&model_scene("blob"), Method::Mesh));
}

#[test]
fn snapshot_ring_depth_buffer() {
    check("ring-depth", &rendered(&model_scene("ring"), Method::Depth));
}

#[test]
fn snapshot_csg_ray_traced() {
    check_example("csg-ray", "examples/csg.scene.json", Method::Ray);
}

#[test]
fn snapshot_textured_depth_buffer() {
    check_example(
        "textured-depth",
        "examples/textured.scene.json",
        Method::Depth,
    );
}

#[test]
fn snapshot_teapot_mesh() {
    check_example(
        "teapot-mesh",
        "examples/teapot/teapot.scene.json",
        Method::Mesh,
    );
}

#[test]
fn the_psnr_check_rejects_a_different_render() {
    // The check can fail: the blob's snapshot is far from a render of another model,
    // and from the same model with its texture dropped.
    let blob = image::open(snapshot_path("blob-mesh")).unwrap().to_rgb8();
    let ring = rendered(&model_scene("ring"), Method::Mesh);
    assert!(psnr(blob.as_raw(), &ring.to_srgb8()) < MIN_PSNR_DB);
    let textured = image::open(snapshot_path("textured-depth"))
        .unwrap()
        .to_rgb8();
    let mut plain = example_scene("examples/textured.scene.json");
    plain.objects[0].material.texture = None;
    let plain = rendered(&plain, Method::Depth);
    assert!(psnr(textured.as_raw(), &plain.to_srgb8()) < MIN_PSNR_DB);
}
