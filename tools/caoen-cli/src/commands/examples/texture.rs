//! The texture examples: image and surface distortion (`caoen distort`), texture
//! transfer with a projected picture, a domain texture, texture spaces and solid
//! textures (`caoen transfer`), texture control by key points, and a textured morph.
//! Each picture of a command is made by calling that command with the arguments
//! `docs/texture.md` lists, so the example is the command's real output.

use std::path::{Path, PathBuf};

use caoen::image_io;
use caoen::render::framebuffer::RgbImage;
use caoen::render::renderer::{render, Method};
use caoen::render::Scene;
use caoen::surface::morph::morph;
use caoen::surface::{gallery, Blend, KeyPoint, Network, SurfaceModel};

use super::{opts, save_model, save_png};
use crate::cli::{DistortArgs, GlobalArgs, TransferArgs};
use crate::failure::{CliError, CliResult};
use crate::output::replace_file;

/// The moves of `examples/distort/moves.json`.
const MOVES_JSON: &str = r#"[
  {"from": [120, 90], "to": [140, 80]},
  {"from": [260, 90], "to": [250, 110]},
  {"from": [190, 170], "to": [190, 195]},
  {"from": [80, 200], "to": [70, 190]}
]
"#;

/// Writes the texture examples into `dir` with `n x n` samples per pixel.
pub(super) fn write(global: &GlobalArgs, dir: &Path, n: u32) -> CliResult {
    // The commands run with --force: replacing their own earlier output is the job.
    let forced = GlobalArgs {
        force: true,
        ..global.clone()
    };
    distort(&forced, &dir.join("distort"))?;
    transfer(&forced, dir, n)?;
    texture_control(global, dir, n)?;
    textured_morph(global, dir, n)?;
    Ok(())
}

fn distort_args(input: PathBuf, output: PathBuf) -> DistortArgs {
    DistortArgs {
        input,
        output,
        moves: Vec::new(),
        moves_file: None,
        supersample: 3,
        grid: false,
    }
}

/// `examples/distort/`: a corpus scene, four moves, the result with and without the
/// grid, the same moves on the scene's `.cae`, two crossing moves (a fold), and the
/// blob with its +x tip pulled out.
fn distort(global: &GlobalArgs, sub: &Path) -> CliResult {
    use crate::commands::texture::distort;
    std::fs::create_dir_all(sub).map_err(|e| CliError::io(sub, e))?;
    let scene = caoen_corpus::generate(caoen_corpus::Class::Scene, 384, 256, 4);
    let input = image_io::from_dynamic(scene.to_dynamic_image())
        .map_err(|e| CliError::Failed(format!("built-in scene: {e}")))?;
    let input_png = sub.join("input.png");
    let png = image_io::encode(&input, image_io::OutputFormat::natural(input.format()))
        .map_err(|e| crate::commands::codec::encode_error(&input_png, e))?;
    replace_file(&input_png, &png)?;
    replace_file(&sub.join("moves.json"), MOVES_JSON.as_bytes())?;
    let with_moves = |output: &str, grid: bool| DistortArgs {
        moves_file: Some(sub.join("moves.json")),
        grid,
        ..distort_args(input_png.clone(), sub.join(output))
    };
    distort(global, &with_moves("output.png", false))?;
    distort(global, &with_moves("output-grid.png", true))?;
    // The .cae of the input at default settings, kept out of examples/.
    let tmp = tempfile::Builder::new()
        .prefix("caoen-example-")
        .suffix(".cae")
        .tempfile()
        .map_err(|e| CliError::io(std::env::temp_dir(), e))?;
    let cae = caoen::codec::encode(&input, &caoen::codec::EncodeOptions::default())
        .map_err(|e| CliError::Failed(e.to_string()))?;
    std::fs::write(tmp.path(), cae).map_err(|e| CliError::io(tmp.path(), e))?;
    distort(
        global,
        &DistortArgs {
            moves_file: Some(sub.join("moves.json")),
            ..distort_args(tmp.path().to_path_buf(), sub.join("output-cae.png"))
        },
    )?;
    distort(
        global,
        &DistortArgs {
            moves: vec!["140,128:240,128".into(), "240,128:140,128".into()],
            grid: true,
            ..distort_args(input_png.clone(), sub.join("crossing.png"))
        },
    )?;
    distort(
        global,
        &DistortArgs {
            moves: vec!["1.3,0,0:1.8,0.3,0".into()],
            ..distort_args("builtin:blob".into(), sub.join("blob-distorted.json"))
        },
    )?;
    let blob = gallery::blob()?;
    let moved = SurfaceModel::load(&sub.join("blob-distorted.json"), &global.limits)?;
    let pair = side_by_side(
        &[(&blob, None), (&moved, None)],
        240,
        180,
        3,
        &global.limits,
    )?;
    save_png(global, sub, "blob-distorted.png", &pair)
}

fn transfer_args(to: &str, output: PathBuf) -> TransferArgs {
    TransferArgs {
        texture: None,
        from: None,
        project: "spherical".into(),
        bake_size: None,
        bake_samples: 3,
        texture_space: None,
        solid: "checker".into(),
        scale: 0.25,
        colours: None,
        texture_size: "512x256".into(),
        to: to.into(),
        output,
        size: "512x384".into(),
        samples: 2,
        detail: 6,
    }
}

/// `examples/transfer/`: the checker domain texture of the octahedron carried to the
/// blob (render and OBJ + MTL + texture), a picture projected on two different
/// surfaces and carried to the blob, texture spaces, solid textures and a volume.
fn transfer(global: &GlobalArgs, dir: &Path, n: u32) -> CliResult {
    use crate::commands::texture::transfer;
    let sub = dir.join("transfer");
    std::fs::create_dir_all(&sub).map_err(|e| CliError::io(&sub, e))?;
    let samples = n.min(2);
    let checker = dir.join("checker.png");
    let domain = |output: &str| TransferArgs {
        texture: Some(checker.clone()),
        from: Some("builtin:octahedron".into()),
        project: "domain".into(),
        size: "320x240".into(),
        samples,
        detail: 5,
        ..transfer_args("builtin:blob", sub.join(output))
    };
    transfer(global, &domain("blob.png"))?;
    transfer(
        global,
        &TransferArgs {
            detail: 3,
            ..domain("blob.obj")
        },
    )?;

    // `args` rendered into a temporary picture, read back as a tile.
    let tile = |args: TransferArgs| -> CliResult<RgbImage> {
        let tmp = temp_png()?;
        let output = tmp.path().to_path_buf();
        transfer(global, &TransferArgs { output, ..args })?;
        Ok(RgbImage::load(tmp.path(), &global.limits)?)
    };
    let small = || TransferArgs {
        size: "240x180".into(),
        samples,
        detail: 5,
        ..transfer_args("builtin:blob", PathBuf::new())
    };

    // The distort example's scene projected (spherically) on the octahedron and on the
    // six-point surface, each carried to the blob: the source shapes the result.
    let picture = dir.join("distort/input.png");
    let tiles = ["builtin:octahedron", "builtin:six-point"]
        .into_iter()
        .map(|from| {
            tile(TransferArgs {
                texture: Some(picture.clone()),
                from: Some(from.into()),
                ..small()
            })
        });
    let tiles = tiles.collect::<CliResult<Vec<_>>>()?;
    save_png(global, &sub, "projected.png", &hstack(&tiles))?;

    // The blob's own shape and the six-point surface as texture spaces for a checker.
    let tiles = ["builtin:blob", "builtin:six-point"]
        .into_iter()
        .map(|space| {
            tile(TransferArgs {
                texture_space: Some(space.into()),
                project: "domain".into(),
                ..small()
            })
        });
    let tiles = tiles.collect::<CliResult<Vec<_>>>()?;
    save_png(global, &sub, "texture-space.png", &hstack(&tiles))?;

    // The solid textures at scale 0.35, and the example volume.
    let vol = sub.join("volume");
    write_volume(&vol)?;
    let solids = [
        "checker",
        "stripes",
        "rings",
        "marble",
        "volume/volume.json",
    ];
    let tiles = solids.into_iter().map(|solid| {
        let solid = if solid.ends_with(".json") {
            sub.join(solid).to_string_lossy().into_owned()
        } else {
            solid.to_string()
        };
        tile(TransferArgs {
            texture_space: Some("builtin:blob".into()),
            project: "domain".into(),
            solid,
            scale: 0.35,
            size: "256x192".into(),
            ..small()
        })
    });
    let tiles = tiles.collect::<CliResult<Vec<_>>>()?;
    save_png(global, &sub, "solid-textures.png", &hstack(&tiles))
}

/// A fresh private temporary PNG path (deleted when dropped).
fn temp_png() -> CliResult<tempfile::NamedTempFile> {
    tempfile::Builder::new()
        .prefix("caoen-example-")
        .suffix(".png")
        .tempfile()
        .map_err(|e| CliError::io(std::env::temp_dir(), e))
}

/// The example volume's 16 slices of 16x16 (slice `k` is layer `z = k`): an RGB
/// gradient across the cube with darker spherical shells.
pub fn volume_slices() -> Vec<RgbImage> {
    let n = 16u32;
    (0..n)
        .map(|k| {
            let mut pixels = Vec::new();
            for j in 0..n {
                for i in 0..n {
                    let u = [i, j, k].map(|v| (v as f32 + 0.5) / n as f32);
                    let r = u.iter().map(|v| (v - 0.5) * (v - 0.5)).sum::<f32>().sqrt();
                    let shell = if ((r * 8.0) as u32).is_multiple_of(2) {
                        1.0
                    } else {
                        0.35
                    };
                    pixels.push(u.map(|v| (0.1 + 0.8 * v) * shell));
                }
            }
            RgbImage {
                width: n,
                height: n,
                pixels,
            }
        })
        .collect()
}

/// `volume/`: [`volume_slices`] over [-1.5, 1.5]^3.
fn write_volume(vol: &Path) -> CliResult {
    std::fs::create_dir_all(vol).map_err(|e| CliError::io(vol, e))?;
    let mut names = Vec::new();
    for (k, slice) in volume_slices().iter().enumerate() {
        let name = format!("z{k:02}.png");
        replace_file(&vol.join(&name), &slice.encode_png()?)?;
        names.push(name);
    }
    let spec = format!(
        "{{\"slices\": {}, \"min\": [-1.5, -1.5, -1.5], \"max\": [1.5, 1.5, 1.5], \"wrap\": \"clamp\"}}\n",
        serde_json::to_string(&names).expect("names serialise")
    );
    replace_file(&vol.join("volume.json"), spec.as_bytes())
}

/// `texture-control.json` and `.png`: the textured blob with four extra key points
/// around its +x key point, different sources and the same shape vector, so more of
/// the domain (and of the texture) is drawn onto the tip; the picture shows the plain
/// textured blob (left) and this one (right).
fn texture_control(global: &GlobalArgs, dir: &Path, n: u32) -> CliResult {
    let blob = gallery::blob()?;
    let mut kps = blob.network.key_points();
    for (a, b) in [(0.35, 0.0), (-0.35, 0.0), (0.0, 0.35), (0.0, -0.35)] {
        let d = [1.0f64, a, b];
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        kps.push(KeyPoint::new(
            d.iter().map(|v| v / len).collect(),
            vec![1.3, 0.0, 0.0],
            Blend::Exponential,
            6.0,
        ));
    }
    let model = SurfaceModel::new(
        "blob-texture-control",
        blob.domain,
        Network::new(3, 3, &kps, true)?,
    )?
    .with_texture("checker.png");
    save_model(dir, "texture-control.json", &model)?;
    let plain = blob.with_texture("checker.png");
    let file = dir.join("texture-control.json");
    let pair = side_by_side(
        &[(&plain, Some(&file)), (&model, Some(&file))],
        320,
        240,
        n,
        &global.limits,
    )?;
    save_png(global, dir, "texture-control.png", &pair)
}

/// `morph-textured/`: five frames of the morph `morph-a.json -> morph-b.json` with the
/// checker texture as textured surface files, and the frames side by side.
fn textured_morph(global: &GlobalArgs, dir: &Path, n: u32) -> CliResult {
    let a = SurfaceModel::load(&dir.join("morph-a.json"), &global.limits)?;
    let b = SurfaceModel::load(&dir.join("morph-b.json"), &global.limits)?;
    let sub = dir.join("morph-textured");
    std::fs::create_dir_all(&sub).map_err(|e| CliError::io(&sub, e))?;
    let mut frames = Vec::new();
    for k in 0..5 {
        let net = morph(&a.network, &b.network, k as f64 / 4.0)?;
        let model =
            SurfaceModel::new(format!("morph-{k}"), a.domain, net)?.with_texture("../checker.png");
        save_model(&sub, &format!("frame-{k}.json"), &model)?;
        frames.push(model);
    }
    let file = sub.join("frame-0.json");
    let models: Vec<_> = frames.iter().map(|m| (m, Some(file.as_path()))).collect();
    let strip = side_by_side(&models, 200, 160, n, &global.limits)?;
    save_png(global, &sub, "frames.png", &strip)
}

/// Renders each model (its texture resolved next to the given file), framed from the
/// front right, and puts the pictures side by side.
fn side_by_side(
    models: &[(&SurfaceModel, Option<&Path>)],
    width: u32,
    height: u32,
    samples: u32,
    limits: &caoen::Limits,
) -> CliResult<RgbImage> {
    let mut tiles = Vec::new();
    for (model, file) in models {
        let mut scene = Scene::from_model((*model).clone(), *file, limits)?;
        scene.camera.view_from = [1.0, -1.6, 0.7];
        let r = render(
            &scene,
            &opts(width, height, samples, Method::Mesh),
            &|_, _| {},
        )?;
        tiles.push(r.image);
    }
    Ok(hstack(&tiles))
}

/// Pictures of one height side by side.
fn hstack(tiles: &[RgbImage]) -> RgbImage {
    let width = tiles.iter().map(|t| t.width).sum();
    let height = tiles.iter().map(|t| t.height).max().unwrap_or(0);
    let mut out = RgbImage::filled(width, height, [1.0; 3]);
    let mut x = 0;
    for t in tiles {
        out.blit(t, x, 0);
        x += t.width;
    }
    out
}
