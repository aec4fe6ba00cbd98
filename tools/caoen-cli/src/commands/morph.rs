//! `caoen morph A B`: the paper's morph between two surfaces sharing a domain (key
//! points paired by index, the shorter model padded with empty key points), rendered
//! with one camera framed on both so nothing jumps: a folder of frames and a contact
//! sheet, an animated GIF, or an animated PNG. The first frame is A itself and the last
//! B itself, so they equal `caoen surface render` of A and B with that camera.

use std::path::Path;

use caoen::render::framebuffer::RgbImage;
use caoen::render::renderer::{RenderOptions, Rendered};
use caoen::render::Scene;
use caoen::surface::morph::morph;
use caoen::surface::SurfaceModel;

use crate::cli::{GlobalArgs, MorphArgs};
use crate::commands::note;
use crate::commands::render::{parse_size, progress_bar};
use crate::failure::{CliError, CliResult};
use crate::output::{extension_lowercase, print, Outputs};

/// What the output path asks for.
enum Output {
    Folder,
    Gif,
    Apng,
}

/// `caoen morph`.
pub fn run(global: &GlobalArgs, a: &MorphArgs) -> CliResult {
    if crate::output::is_stdout(&a.output) {
        return Err(CliError::Usage(format!(
            "-o {}: morph writes a folder of frames, anim.gif or anim.png; not standard output",
            a.output.display()
        )));
    }
    let ext = extension_lowercase(&a.output);
    let kind = match ext.as_deref() {
        Some("gif") => Output::Gif,
        Some("png") => Output::Apng,
        None => Output::Folder,
        Some(other) => {
            return Err(CliError::Usage(format!(
                "{}: `.{other}`: give a folder, anim.gif or anim.png",
                a.output.display()
            )))
        }
    };
    let (width, height) = parse_size(&a.size)?;
    // One frame at a time plus the contact sheet's quarter-size tiles.
    let sheet =
        caoen::render::RgbImage::memory(width / 2, height / 2).saturating_mul(u64::from(a.frames));
    global.limits.check(
        || format!("{} frames of {width}x{height}", a.frames),
        caoen::render::renderer::render_memory(width, height, a.samples).saturating_add(sheet),
    )?;
    let model_a = crate::commands::surface::load_model(&a.a, &global.limits)?;
    let model_b = crate::commands::surface::load_model(&a.b, &global.limits)?;
    if model_a.domain != model_b.domain {
        return Err(CliError::Failed(format!(
            "{} and {} do not share a domain ({:?} vs {:?}): a morph pairs domain points",
            a.a, a.b, model_a.domain, model_b.domain
        )));
    }
    let frame_names: Vec<String> = (0..a.frames).map(|k| format!("frame-{k:03}.png")).collect();
    let outputs = check_outputs(global, a, &kind, &frame_names)?;

    // One camera for every frame, framed on both models together.
    let mut both = Scene::from_model(model_a.clone(), None, &global.limits)?;
    let b_scene = Scene::from_model(model_b.clone(), None, &global.limits)?;
    both.objects.extend(b_scene.objects);
    let cam = both.camera(width, height)?;
    let target = [0, 1, 2].map(|k| cam.eye[k] + cam.forward[k]);
    let opts = RenderOptions {
        width,
        height,
        samples: a.samples,
        mesh_detail: a.detail,
        ..RenderOptions::default()
    };
    let render_frame = |model: SurfaceModel| -> CliResult<Rendered> {
        let mut scene = Scene::from_model(model, None, &global.limits)?;
        scene.camera.eye = Some(cam.eye);
        scene.camera.target = Some(target);
        scene.camera.up = cam.up;
        scene.camera.projection = cam.projection;
        Ok(caoen::render::render(&scene, &opts, &|_, _| {})?)
    };
    if a.output.extension().is_none() {
        std::fs::create_dir_all(&a.output).map_err(|e| CliError::io(&a.output, e))?;
    }
    let bar = progress_bar(global, "morphing");
    bar.set_length(u64::from(a.frames));
    let n = a.frames;
    let mut tiles = Vec::with_capacity(n as usize);
    let (mut apng_bytes, mut gif_bytes) = (Vec::new(), Vec::new());
    let mut apng: Option<png::Writer<&mut Vec<u8>>> = None;
    let mut gif: Option<image::codecs::gif::GifEncoder<&mut Vec<u8>>> = None;
    match kind {
        Output::Apng => {
            let mut enc = png::Encoder::new(&mut apng_bytes, width, height);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            enc.set_animated(n, 0).map_err(failed)?;
            enc.set_frame_delay(a.delay.min(u16::MAX as u32) as u16, 1000)
                .map_err(failed)?;
            apng = Some(enc.write_header().map_err(failed)?);
        }
        Output::Gif => {
            let mut enc = image::codecs::gif::GifEncoder::new_with_speed(&mut gif_bytes, 10);
            enc.set_repeat(image::codecs::gif::Repeat::Infinite)
                .map_err(failed)?;
            gif = Some(enc);
        }
        Output::Folder => {}
    }
    for k in 0..n {
        let image = render_frame(frame_model(&model_a, &model_b, k, n)?)?.image;
        let png_bytes = image.encode_png()?;
        let rgb = image::load_from_memory(&png_bytes)
            .map_err(failed)?
            .to_rgb8();
        match kind {
            Output::Folder => {
                outputs.write_path(&a.output.join(&frame_names[k as usize]), &png_bytes)?
            }
            Output::Apng => apng
                .as_mut()
                .expect("made above")
                .write_image_data(rgb.as_raw())
                .map_err(failed)?,
            Output::Gif => {
                let rgba = image::DynamicImage::ImageRgb8(rgb).to_rgba8();
                let frame = image::Frame::from_parts(
                    rgba,
                    0,
                    0,
                    image::Delay::from_numer_denom_ms(a.delay, 1),
                );
                gif.as_mut()
                    .expect("made above")
                    .encode_frame(frame)
                    .map_err(failed)?;
            }
        }
        tiles.push(image.downsample(2));
        bar.inc(1);
    }
    bar.finish_and_clear();
    if let Some(w) = apng.take() {
        w.finish().map_err(failed)?;
    }
    // The GIF encoder writes the trailer when dropped; both release their buffers.
    drop(apng);
    drop(gif);
    match kind {
        Output::Folder => {
            let sheet = contact_sheet(&tiles);
            outputs.write_path(&a.output.join("contact.png"), &sheet.encode_png()?)?;
        }
        Output::Apng => outputs.write_path(&a.output, &apng_bytes)?,
        Output::Gif => outputs.write_path(&a.output, &gif_bytes)?,
    }
    if a.json {
        print(&(serde_json::to_string_pretty(&morph_json(a, &cam, target)).expect("json") + "\n"))?;
    }
    note(
        global,
        format!(
            "{} -> {}: {n} frames of {width}x{height} to {}",
            a.a,
            a.b,
            a.output.display()
        ),
    );
    Ok(())
}

/// The outputs a morph writes, checked before any work: a folder's frames and contact
/// sheet, or one animation.
fn check_outputs(
    global: &GlobalArgs,
    a: &MorphArgs,
    kind: &Output,
    frame_names: &[String],
) -> CliResult<Outputs> {
    let mut outputs = Outputs::new(global.force);
    for input in [&a.a, &a.b] {
        if !input.starts_with("builtin:") {
            outputs = outputs.input(Path::new(input));
        }
    }
    match kind {
        Output::Folder => {
            if a.output.exists() && !a.output.is_dir() {
                return Err(CliError::Failed(format!(
                    "{}: exists and is not a folder",
                    a.output.display()
                )));
            }
            for f in frame_names
                .iter()
                .map(String::as_str)
                .chain(["contact.png"])
            {
                outputs.check_path(&a.output.join(f))?;
            }
        }
        _ => outputs.check_path(&a.output)?,
    }
    Ok(outputs)
}

/// Frame `k` of `n`: the ends are the models themselves (padding is exact in theory,
/// but a different key-point count may change summation order in the last bit).
fn frame_model(
    model_a: &SurfaceModel,
    model_b: &SurfaceModel,
    k: u32,
    n: u32,
) -> CliResult<SurfaceModel> {
    Ok(if k == 0 {
        model_a.clone()
    } else if k == n - 1 {
        model_b.clone()
    } else {
        let u = f64::from(k) / f64::from(n - 1);
        let net = morph(&model_a.network, &model_b.network, u)?;
        SurfaceModel::new(format!("morph u={u:.4}"), model_a.domain, net)?
    })
}

/// `caoen morph --json`: the frames and the one camera they share.
fn morph_json(a: &MorphArgs, cam: &caoen::render::Camera, target: [f64; 3]) -> serde_json::Value {
    let (fov, height_ortho) = match cam.projection {
        caoen::render::Projection::Perspective { fov_y_deg } => (Some(fov_y_deg), None),
        caoen::render::Projection::Orthographic { height } => (None, Some(height)),
    };
    serde_json::json!({
        "frames": a.frames, "width": cam.width, "height": cam.height,
        "output": a.output.display().to_string(),
        "camera": {"eye": cam.eye, "target": target, "up": cam.up,
                   "fov_deg": fov, "orthographic_height": height_ortho}
    })
}

fn failed(e: impl std::fmt::Display) -> CliError {
    CliError::Failed(e.to_string())
}

/// The frames in a grid, at most six across.
fn contact_sheet(tiles: &[RgbImage]) -> RgbImage {
    let cols = tiles.len().min(6) as u32;
    let rows = (tiles.len() as u32).div_ceil(cols);
    let (tw, th) = (tiles[0].width, tiles[0].height);
    let mut out = RgbImage::filled(cols * tw, rows * th, [1.0; 3]);
    for (i, t) in tiles.iter().enumerate() {
        out.blit(t, (i as u32 % cols) * tw, (i as u32 / cols) * th);
    }
    out
}
