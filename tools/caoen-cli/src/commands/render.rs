//! `caoen surface render`: draw a model or a scene to a PNG by one of the paper's
//! three methods, with progress on stderr.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use caoen::render::framebuffer::PictureFormat;
use caoen::render::mesh::NormalMode;
use caoen::render::raytrace::RayMethod;
use caoen::render::scene::texture_wrap;
use caoen::render::texture::Texture;
use caoen::render::{render, Method, Projection, RenderError, RenderOptions, Rendered, Scene};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::cli::{
    show_duration, GlobalArgs, MethodArg, NormalsArg, ProjectionArg, RayMethodArg,
    SurfaceRenderArgs,
};
use crate::commands::note;
use crate::commands::surface::load_model;
use crate::failure::{CliError, CliResult};
use crate::output::{is_same_file, Outputs};

impl From<RenderError> for CliError {
    fn from(e: RenderError) -> Self {
        match e {
            RenderError::Surface(s) => CliError::Surface(s),
            other => CliError::Failed(other.to_string()),
        }
    }
}

/// Parses `WxH` into a render size.
pub fn parse_size(s: &str) -> CliResult<(u32, u32)> {
    crate::cli::parse_wxh(s, 16384).map_err(CliError::Usage)
}

/// Loads a scene file, or wraps a model file / `builtin:NAME` into a one-object scene.
pub fn load_scene(spec: &str, texture: Option<&Path>, limits: &caoen::Limits) -> CliResult<Scene> {
    let is_file = !spec.starts_with("builtin:");
    if is_file {
        let path = Path::new(spec);
        let text = limits
            .read_to_string(path)
            .map_err(|e| CliError::io(path, e))?;
        if Scene::is_scene_json(&text) {
            if texture.is_some() {
                return Err(CliError::Usage(
                    "--texture applies to a surface model; give textures in the scene's materials"
                        .into(),
                ));
            }
            return Ok(Scene::load(path, limits)?);
        }
    }
    let model = load_model(spec, limits)?;
    let file = is_file.then(|| Path::new(spec));
    let mut scene = Scene::from_model(model, file, limits)?;
    if let Some(t) = texture {
        let Some(caoen::render::scene::SceneObject {
            shape: caoen::render::scene::Shape::Surface { model, .. },
            material,
            ..
        }) = scene.objects.first_mut()
        else {
            unreachable!("from_model makes one surface object");
        };
        material.texture = Some((Arc::new(Texture::load(t, limits)?), texture_wrap(model)?));
        material.colour = [1.0; 3];
    }
    Ok(scene)
}

/// A progress bar on stderr for renders (hidden when quiet or not a terminal).
pub fn progress_bar(global: &GlobalArgs, what: &str) -> ProgressBar {
    if global.quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(1), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:30}] {percent:>3}% {elapsed_precise} eta {eta}")
            .expect("valid template")
            .progress_chars("=> "),
    );
    bar.set_message(what.to_string());
    bar
}

/// Renders with a progress bar.
pub fn render_with_progress(
    global: &GlobalArgs,
    scene: &Scene,
    opts: &RenderOptions,
    what: &str,
) -> CliResult<Rendered> {
    check_work(global, scene, opts)?;
    let bar = progress_bar(global, what);
    // The command's budget (`--max-memory`), whatever limits `opts` was built with.
    let opts = &RenderOptions {
        limits: global.limits.clone(),
        ..opts.clone()
    };
    let result = render(scene, opts, &|done, total| {
        bar.set_length(total);
        bar.set_position(done);
    });
    bar.finish_and_clear();
    Ok(result?)
}

/// Estimates a render's work and refuses one over `--max-work`; a long one is
/// announced with its estimate, since its bar is the only sign of life for a while.
pub fn check_work(global: &GlobalArgs, scene: &Scene, opts: &RenderOptions) -> CliResult {
    let est = caoen::render::work::estimate(scene, opts);
    let cpu = est.cpu_seconds();
    let threads = rayon::current_num_threads().max(1) as f64;
    let shadow_rays = if scene.shadows {
        scene.lighting.shadow_samples()
    } else {
        0
    };
    let what = format!(
        "{:.2e} ray-object tests: {}x{} pixels, {}x{} samples, up to {:.0} rays a sample \
         (max_depth {}), {} objects, {} shadow rays a hit (area lights' samples each)",
        est.tests,
        opts.width,
        opts.height,
        opts.samples,
        opts.samples,
        est.rays_per_sample,
        scene.max_depth,
        scene.objects.len(),
        shadow_rays
    );
    let limit = global.max_work.unwrap_or(crate::cli::RENDER_MAX_WORK);
    if cpu > limit {
        return Err(CliError::Failed(format!(
            "the render needs up to about {} of CPU time ({what}); the limit is {}: \
             raise it with --max-work {}, or render fewer pixels or samples (--size, --samples)",
            show_duration(cpu),
            show_duration(limit),
            show_duration(cpu.max(1.0) * 1.05),
        )));
    }
    if cpu / threads > 3.0 {
        note(
            global,
            format!(
                "estimated up to {} of CPU time, {} on {} threads ({what})",
                show_duration(cpu),
                show_duration(cpu / threads),
                threads
            ),
        );
    }
    Ok(())
}

/// Writes a depth map: 16-bit PNG, or OpenEXR (raw depths) for `.exr`.
pub fn write_depth(outputs: &Outputs, r: &Rendered, path: &Path) -> CliResult {
    let ext = crate::output::format_extension(path, "png");
    let bytes = match ext.as_deref() {
        Some("png") => r.depth.encode_png16()?,
        Some("exr") => r.depth.encode_exr()?,
        _ => {
            return Err(CliError::Usage(format!(
                "{}: depth output must end in .png (16-bit) or .exr",
                path.display()
            )))
        }
    };
    outputs.write_path(path, &bytes)
}

/// Render options from the command line.
pub fn options(a: &SurfaceRenderArgs) -> CliResult<RenderOptions> {
    let (width, height) = parse_size(&a.size)?;
    Ok(RenderOptions {
        width,
        height,
        samples: a.samples,
        method: match a.method {
            MethodArg::Mesh => Method::Mesh,
            MethodArg::Depth => Method::Depth,
            MethodArg::Ray => Method::Ray,
        },
        mesh_detail: a.detail,
        normals: match a.normals {
            NormalsArg::Exact => NormalMode::Exact,
            NormalsArg::Interpolated => NormalMode::Interpolated,
        },
        ray_method: match a.ray_method {
            RayMethodArg::Paper => RayMethod::Paper,
            RayMethodArg::Fast => RayMethod::Fast,
        },
        network_camera: a.camera == "network",
        ..RenderOptions::default()
    })
}

/// The picture format an output's extension asks for, checked before any work: PNG,
/// JPEG, or (a stream such as `-` without an extension) PNG; any other extension is
/// refused, naming it.
pub fn picture_format(path: &std::path::Path) -> CliResult<PictureFormat> {
    match PictureFormat::from_path(path) {
        Ok(f) => Ok(f),
        Err(ext) if ext.is_empty() && crate::output::is_stream(path) => Ok(PictureFormat::Png),
        Err(ext) => Err(CliError::Usage(format!(
            "{}: a picture is written as {}; {}",
            path.display(),
            PictureFormat::EXTENSIONS,
            if ext.is_empty() {
                "the name has no extension".to_string()
            } else {
                format!("`.{ext}` is not one of them")
            }
        ))),
    }
}

/// `caoen surface render`.
pub fn run(global: &GlobalArgs, a: &SurfaceRenderArgs) -> CliResult {
    let opts = options(a)?;
    let format = picture_format(&a.output)?;
    if let Some(d) = &a.depth_out {
        let e = crate::output::format_extension(d, "png");
        if !matches!(e.as_deref(), Some("png" | "exr")) {
            return Err(CliError::Usage(format!(
                "{}: depth output must end in .png (16-bit) or .exr",
                d.display()
            )));
        }
    }
    let mut outputs = Outputs::new(global.force)
        .input(&a.model)
        .input_opt(a.texture.as_deref());
    outputs.check_path(&a.output)?;
    if let Some(d) = &a.depth_out {
        outputs.check_path(d)?;
    }
    let mut scene = load_scene(&a.model, a.texture.as_deref(), &global.limits)?;
    if let Some(p) = a.projection {
        scene.camera.projection = match p {
            ProjectionArg::Perspective => Projection::Perspective { fov_y_deg: 30.0 },
            ProjectionArg::Orthographic => Projection::Orthographic { height: 0.0 },
        };
    }
    let start = std::time::Instant::now();
    let r = render_with_progress(global, &scene, &opts, "rendering")?;
    outputs.write_path(&a.output, &r.image.encode(format)?)?;
    if let Some(d) = &a.depth_out {
        write_depth(&outputs, &r, d)?;
    }
    let s = r.stats;
    note(
        global,
        format!(
            "wrote {} ({}x{}, {}x{} samples, {:.2} s; {} triangles, {} depth samples, {} rays)",
            crate::output::shown(&a.output),
            opts.width,
            opts.height,
            opts.samples,
            opts.samples,
            start.elapsed().as_secs_f64(),
            s.triangles,
            s.depth_samples,
            s.rays
        ),
    );
    if let Some([max, mean]) = s.projection_error {
        note(
            global,
            format!(
                "camera network: vertices within {max:.4} px of the exact projection (mean {mean:.4} px)"
            ),
        );
    }
    if s.unresolved > 0 {
        note(
            global,
            format!("warning: {} depth-buffer triangles hit the subdivision limit; small holes are possible", s.unresolved),
        );
    }
    Ok(())
}

/// The texture written beside an OBJ: `<stem>-texture.png`.
pub fn texture_sibling(obj: &Path) -> PathBuf {
    let stem = obj.file_stem().and_then(|s| s.to_str()).unwrap_or("mesh");
    obj.with_file_name(format!("{stem}-texture.png"))
}

/// The material library written beside an OBJ: `<stem>.mtl`.
pub fn mtl_sibling(obj: &Path) -> PathBuf {
    let stem = obj.file_stem().and_then(|s| s.to_str()).unwrap_or("mesh");
    obj.with_file_name(format!("{stem}.mtl"))
}

/// Whether `texture` already is the OBJ's texture file `png` (a PNG at that path), so
/// there is nothing to copy.
pub fn texture_is_sibling(texture: &Path, png: &Path) -> bool {
    use std::io::Read;
    let mut magic = [0u8; 8];
    is_same_file(texture, png)
        && std::fs::File::open(texture)
            .and_then(|mut f| f.read_exact(&mut magic))
            .is_ok()
        && &magic == PNG_MAGIC
}

const PNG_MAGIC: &[u8; 8] = b"\x89PNG\r\n\x1a\n";

/// Writes `<stem>.mtl` and `<stem>-texture.png` beside the OBJ `obj`, the texture
/// copied from `texture` (re-encoded as PNG if it is not one); returns their file names
/// as the OBJ refers to them.
pub fn write_obj_material(
    outputs: &Outputs,
    obj: &Path,
    texture: &Path,
    limits: &caoen::Limits,
) -> CliResult<(String, String)> {
    let png = texture_sibling(obj);
    if !texture_is_sibling(texture, &png) {
        let bytes = limits.read(texture).map_err(|e| CliError::io(texture, e))?;
        let png_bytes = if bytes.starts_with(PNG_MAGIC) {
            bytes
        } else {
            Texture::load(texture, limits)?.image().encode_png()?
        };
        outputs.write_path(&png, &png_bytes)?;
    }
    let mtl = mtl_sibling(obj);
    let png_name = png
        .file_name()
        .and_then(|s| s.to_str())
        .unwrap_or("texture.png")
        .to_string();
    let mut text = Vec::new();
    caoen::render::mesh_io::write_mtl(&mut text, "caoen_surface", &png_name)
        .map_err(|e| CliError::io(&mtl, e))?;
    outputs.write_path(&mtl, &text)?;
    let mtl_name = mtl
        .file_name()
        .and_then(|s| s.to_str())
        .unwrap_or("mesh.mtl")
        .to_string();
    Ok((mtl_name, png_name))
}
