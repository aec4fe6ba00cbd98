//! `caoen distort` (image distortion by moving control points) and `caoen transfer`
//! (texture transfer between surfaces), `docs/texture.md`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use caoen::codec::decoder;
use caoen::image_io;
use caoen::texture::projected::{self, Projected, ProjectionKind};
use caoen::texture::transfer::BakeSource;
use caoen::texture::warp::{self, Move, Warp};
use caoen::texture::TextureError;

use crate::cli::{DistortArgs, GlobalArgs};
use crate::commands::compare::is_cae;
use crate::commands::note;
use crate::failure::{CliError, CliResult};
use crate::output::{extension_lowercase, Outputs, Target};

/// Parses `x,y:x2,y2`.
pub fn parse_move(s: &str) -> CliResult<Move> {
    let bad = || CliError::Usage(format!("--move {s:?}: expected x,y:x2,y2 (pixels)"));
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let pt = |t: &str| -> CliResult<[f64; 2]> {
        let (x, y) = t.split_once(',').ok_or_else(bad)?;
        let x: f64 = x.trim().parse().map_err(|_| bad())?;
        let y: f64 = y.trim().parse().map_err(|_| bad())?;
        if x.is_finite() && y.is_finite() {
            Ok([x, y])
        } else {
            Err(bad())
        }
    };
    Ok(Move {
        from: pt(a)?,
        to: pt(b)?,
    })
}

/// Reads a moves JSON file.
pub fn read_moves(path: &Path, limits: &caoen::Limits) -> CliResult<Vec<Move>> {
    let text = limits
        .read_to_string(path)
        .map_err(|e| CliError::io(path, e))?;
    warp::parse_moves(&text).map_err(|e| CliError::Failed(format!("{}: {e}", path.display())))
}

fn tex_err(e: TextureError) -> CliError {
    CliError::Failed(e.to_string())
}

/// Parses `x,y,z:x2,y2,z2`.
pub fn parse_move3(s: &str) -> CliResult<caoen::texture::warp3d::Move3> {
    let bad = || {
        CliError::Usage(format!(
            "--move {s:?}: expected x,y,z:x2,y2,z2 for a surface"
        ))
    };
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let pt = |t: &str| -> CliResult<[f64; 3]> {
        let v: Vec<f64> = t
            .split(',')
            .map(|x| x.trim().parse::<f64>().map_err(|_| bad()))
            .collect::<CliResult<_>>()?;
        if v.len() == 3 && v.iter().all(|x| x.is_finite()) {
            Ok([v[0], v[1], v[2]])
        } else {
            Err(bad())
        }
    };
    Ok(caoen::texture::warp3d::Move3 {
        from: pt(a)?,
        to: pt(b)?,
    })
}

/// `caoen distort` on a surface model: the 3-D warp.
fn distort_surface(global: &GlobalArgs, a: &DistortArgs) -> CliResult {
    let spec = a.input.to_string_lossy().to_string();
    if a.moves_file.is_some() || a.grid {
        return Err(CliError::Usage(
            "a surface takes --move x,y,z:x2,y2,z2 (no --moves file, no --grid)".into(),
        ));
    }
    let moves: Vec<_> = a
        .moves
        .iter()
        .map(|s| parse_move3(s))
        .collect::<CliResult<_>>()?;
    if moves.is_empty() {
        return Err(CliError::Usage(
            "give at least one --move x,y,z:x2,y2,z2".into(),
        ));
    }
    let ext = crate::output::format_extension(&a.output, "json");
    if !matches!(ext.as_deref(), Some("json" | "obj" | "ply")) {
        return Err(CliError::Usage(format!(
            "{}: a distorted surface is written as .json (model) or .obj/.ply (mesh); `-`: the model on standard output",
            a.output.display()
        )));
    }
    let mut outputs = Outputs::new(global.force).input(&a.input);
    for f in crate::commands::surface::mesh_files(&a.output, None) {
        outputs.check_path(&f)?;
    }
    let model = crate::commands::surface::load_model(&spec, &global.limits)?;
    let mesh = caoen::render::mesh::tessellate(
        &model,
        3,
        caoen::render::mesh::NormalMode::Exact,
        &global.limits,
    )?;
    let (lo, hi) = mesh.bounds();
    let warp = caoen::texture::warp3d::Warp3::new(lo, hi, &moves).map_err(tex_err)?;
    // 32^3 samples over the model's box, like the 2-D check's 128 per side: a fold
    // narrower than a cell (1/31 of the box) can slip through, a crossing cannot.
    let r = warp.check_folds(32);
    if !r.is_consistent() {
        eprintln!(
            "warning: inconsistent moves: the 3-D warp folds over at {} of {} sampled \
             points (min Jacobian determinant {:.3}); the surface may turn inside out there",
            r.folded, r.samples, r.min_det
        );
    }
    let out = warp.apply_to_model(&model).map_err(tex_err)?;
    if ext.as_deref() == Some("json") {
        outputs.write_path(&a.output, out.to_json().as_bytes())?;
    } else {
        crate::commands::surface::write_mesh(
            &outputs,
            &out,
            &a.output,
            6,
            caoen::render::mesh::NormalMode::Exact,
            &global.limits,
        )?;
    }
    note(
        global,
        format!(
            "{spec} -> {}: {} moves, {} anchors",
            crate::output::shown(&a.output),
            moves.len(),
            warp.anchors()
        ),
    );
    Ok(())
}

/// `caoen distort`.
pub fn distort(global: &GlobalArgs, a: &DistortArgs) -> CliResult {
    let is_surface = a.input.to_string_lossy().starts_with("builtin:")
        || a.input
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    if is_surface {
        return distort_surface(global, a);
    }
    let moves = match &a.moves_file {
        Some(p) => read_moves(p, &global.limits)?,
        None => a
            .moves
            .iter()
            .map(|s| parse_move(s))
            .collect::<CliResult<_>>()?,
    };
    if moves.is_empty() {
        return Err(CliError::Usage(
            "give at least one --move x,y:x2,y2 or --moves FILE".into(),
        ));
    }
    let fmt_for = |f| {
        if a.output.as_os_str() == "-" {
            Ok(image_io::OutputFormat::natural(f))
        } else {
            crate::commands::codec::image_format(&a.output, f, "output")
        }
    };
    let target = Target::from_arg(Some(&a.output), PathBuf::new);
    let mut outputs = Outputs::new(global.force)
        .input(&a.input)
        .input_opt(a.moves_file.as_deref());
    outputs.check(&target)?;
    let start = Instant::now();
    // A caoen file is warped through its key points, unless it was coded at a smaller
    // size: the moves are in the image's pixels, so it is warped as decoded at its size.
    enum Source {
        KeyPoints(Box<decoder::Decoded>),
        Pixels(caoen::Raster),
    }
    let source = if is_cae(&a.input) {
        let bytes = global
            .limits
            .read(&a.input)
            .map_err(|e| CliError::io(&a.input, e))?;
        let failed =
            |e: caoen::codec::CodecError| CliError::Failed(format!("{}: {e}", a.input.display()));
        let d = decoder::read(&bytes, caoen::codec::DEFAULT_MAX_PIXELS).map_err(failed)?;
        fmt_for(d.header.format)?;
        if d.header.display.is_some() {
            Source::Pixels(caoen::decode(&bytes, &caoen::DecodeOptions::default()).map_err(failed)?)
        } else {
            Source::KeyPoints(Box::new(d))
        }
    } else {
        let img = image_io::load(&a.input).map_err(|e| CliError::Failed(e.to_string()))?;
        fmt_for(img.format())?;
        Source::Pixels(img)
    };
    let (w, h) = match &source {
        Source::KeyPoints(d) => (d.header.width, d.header.height),
        Source::Pixels(img) => (img.width(), img.height()),
    };
    let warp = Warp::new(w, h, &moves).map_err(tex_err)?;
    check(global, &warp);
    let img = match &source {
        Source::KeyPoints(d) => warp::warp_decoded(d, &warp, a.supersample),
        Source::Pixels(img) => warp::warp_raster(img, &warp, a.supersample),
    }
    .map_err(tex_err)?;
    let img = if a.grid {
        warp::draw_grid(img, &warp).map_err(tex_err)?
    } else {
        img
    };
    let bytes = image_io::encode(&img, fmt_for(img.format())?)
        .map_err(|e| crate::commands::codec::encode_error(Path::new(&target.display()), e))?;
    outputs.write(&target, &bytes)?;
    note(
        global,
        format!(
            "{} -> {}: {} moves, {} anchors, {}x{} in {:.3} s",
            a.input.display(),
            target.display(),
            warp.moves().len(),
            warp.anchors(),
            img.width(),
            img.height(),
            start.elapsed().as_secs_f64()
        ),
    );
    Ok(())
}

/// Warns (always, even with --quiet: it is about the result) on fold-over.
fn check(_global: &GlobalArgs, warp: &Warp) {
    let (w, h) = (warp.frame().width, warp.frame().height);
    let step = (w.max(h) as f64 / 128.0).max(1.0);
    let r = warp.check_folds(step);
    if !r.is_consistent() {
        eprintln!(
            "warning: inconsistent moves: the warp folds over at {} of {} sampled points \
             (min Jacobian determinant {:.3}); overlapping parts are averaged",
            r.folded, r.samples, r.min_det
        );
    }
}

fn failed(e: impl std::fmt::Display) -> CliError {
    CliError::Failed(e.to_string())
}

/// Loads a texture: an image file, or a caoen file decoded first.
fn load_texture(path: &Path, limits: &caoen::Limits) -> CliResult<caoen::render::texture::Texture> {
    use caoen::render::framebuffer::RgbImage;
    use caoen::render::texture::Texture;
    let ext = extension_lowercase(path);
    if matches!(ext.as_deref(), Some("cae" | "exr")) {
        let r = crate::commands::compare::load_any(path, limits)?;
        Texture::new(RgbImage::from_raster(&r, limits).map_err(failed)?, limits).map_err(failed)
    } else {
        Ok(Texture::load(path, limits)?)
    }
}

/// The solid texture of `--solid`, `--scale`, `--colours`: a procedural kind, or a
/// volume spec file (anything ending in .json). Bad parameters are usage errors (exit
/// 2), an unreadable or inconsistent volume is a failure (exit 1).
fn solid_texture(
    a: &crate::cli::TransferArgs,
    limits: &caoen::Limits,
) -> CliResult<caoen::texture::solid::Solid> {
    use caoen::texture::solid::{self, Solid, Volume};
    let spec = Path::new(&a.solid);
    if spec
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
    {
        if a.colours.is_some() {
            return Err(CliError::Usage(
                "--colours applies to procedural solid textures, not to a volume".into(),
            ));
        }
        return Ok(Solid::Volume(Volume::load(spec, limits).map_err(tex_err)?));
    }
    let colours = match &a.colours {
        Some(c) => solid::parse_colours(c).map_err(|e| CliError::Usage(e.to_string()))?,
        None => solid::DEFAULT_COLOURS,
    };
    Solid::procedural(&a.solid, a.scale, colours).map_err(|e| CliError::Usage(e.to_string()))
}

/// The baked texture against the memory budget.
fn check_bake(width: u32, height: u32, limits: &caoen::Limits) -> CliResult {
    limits
        .check(
            || format!("baking a {width}x{height} texture"),
            caoen::texture::transfer::bake_memory(width, height),
        )
        .map_err(|e| CliError::Failed(e.to_string()))
}

/// The longest side of a default bake grid.
pub const MAX_DEFAULT_BAKE: u32 = 4096;

/// The default bake grid for a `width x height` picture rendered at `output`: the
/// picture's size, scaled down (keeping its shape) so the longer side is at most twice
/// the longer output side (finer texels are not seen) and at most
/// [`MAX_DEFAULT_BAKE`]; at least 64 a side where the picture has that many.
pub fn default_bake(width: u32, height: u32, output: (u32, u32)) -> (u32, u32) {
    let cap = output
        .0
        .max(output.1)
        .saturating_mul(2)
        .clamp(64, MAX_DEFAULT_BAKE);
    let longer = width.max(height);
    if longer <= cap {
        return (width, height);
    }
    let s = f64::from(cap) / f64::from(longer);
    let side = |v: u32| ((f64::from(v) * s).round() as u32).clamp(1.min(v), cap);
    (side(width).max(1), side(height).max(1))
}

/// `caoen transfer`.
pub fn transfer(global: &GlobalArgs, a: &crate::cli::TransferArgs) -> CliResult {
    let ext = extension_lowercase(&a.output);
    let picture = if ext.as_deref() == Some("obj") {
        None
    } else {
        Some(
            crate::commands::render::picture_format(&a.output).map_err(|e| match e {
                CliError::Usage(m) => {
                    CliError::Usage(format!("{m} (or .obj for a mesh with its material)"))
                }
                other => other,
            })?,
        )
    };
    let size = crate::commands::render::parse_size(&a.size)?;
    // The transferred texture as a PNG file, for the renderer and the OBJ writer: a
    // fresh private temporary file, deleted when dropped.
    let mut tmp = tempfile::Builder::new()
        .prefix("caoen-transfer-")
        .suffix(".png")
        .tempfile()
        .map_err(|e| CliError::io(std::env::temp_dir(), e))?;
    let solid_spec = Path::new(&a.solid);
    let mut outputs = Outputs::new(global.force)
        .input_opt(a.texture.as_deref())
        .input_opt(a.from.as_deref())
        .input_opt(a.texture_space.as_deref())
        .input(&a.to)
        .input_opt(
            (a.texture_space.is_some()
                && solid_spec
                    .extension()
                    .is_some_and(|e| e.eq_ignore_ascii_case("json")))
            .then_some(solid_spec),
        );
    let to = crate::commands::surface::load_model(&a.to, &global.limits)?;
    let texture = (ext.as_deref() == Some("obj")).then(|| tmp.path());
    for f in crate::commands::surface::mesh_files(&a.output, texture) {
        outputs.check_path(&f)?;
    }
    let start = Instant::now();
    let bar = crate::commands::render::progress_bar(global, "baking");
    let report = |done: u64, total: u64| {
        bar.set_length(total);
        bar.set_position(done);
    };
    let (moved, what) = baked(global, a, &to, size, &report)?;
    bar.finish_and_clear();
    {
        use std::io::Write as _;
        tmp.write_all(&moved.encode_png().map_err(failed)?)
            .and_then(|()| tmp.flush())
            .map_err(|e| CliError::io(tmp.path(), e))?;
    }
    let summary = {
        if ext.as_deref() == Some("obj") {
            crate::commands::surface::write_mesh_textured(
                &outputs,
                &to,
                &a.output,
                a.detail,
                caoen::render::mesh::NormalMode::Exact,
                Some(tmp.path()),
                &global.limits,
            )?
        } else {
            let scene =
                crate::commands::render::load_scene(&a.to, Some(tmp.path()), &global.limits)?;
            let opts = caoen::render::renderer::RenderOptions {
                width: size.0,
                height: size.1,
                samples: a.samples,
                mesh_detail: a.detail,
                ..Default::default()
            };
            let r =
                crate::commands::render::render_with_progress(global, &scene, &opts, "rendering")?;
            let format = picture.unwrap_or(caoen::render::framebuffer::PictureFormat::Png);
            outputs.write_path(&a.output, &r.image.encode(format).map_err(failed)?)?;
            format!(
                "{} ({}x{})",
                crate::output::shown(&a.output),
                size.0,
                size.1
            )
        }
    };
    note(
        global,
        format!(
            "{what} -> {}: wrote {summary} in {:.2} s",
            a.to,
            start.elapsed().as_secs_f64()
        ),
    );
    Ok(())
}

/// The texture moved onto `to` for `transfer`, baked at its texture size, and what it
/// was moved from (for the note).
fn baked(
    global: &GlobalArgs,
    a: &crate::cli::TransferArgs,
    to: &caoen::surface::SurfaceModel,
    size: (u32, u32),
    report: &(dyn Fn(u64, u64) + Sync),
) -> CliResult<(caoen::render::framebuffer::RgbImage, String)> {
    Ok(match (&a.texture_space, &a.texture, &a.from) {
        (Some(space), _, _) => {
            let (tw, th) = crate::commands::render::parse_size(&a.texture_size)?;
            check_bake(tw, th, &global.limits)?;
            let solid = solid_texture(a, &global.limits)?;
            let net = crate::commands::surface::load_model(space, &global.limits)?;
            let sample = |p: [f64; 3]| solid.sample(p);
            (
                caoen::texture::transfer::bake(
                    &BakeSource::Solid {
                        space: &net,
                        solid: &sample,
                    },
                    to,
                    tw,
                    th,
                    a.bake_samples,
                    report,
                )
                .map_err(tex_err)?,
                format!("solid {} through {space}", a.solid),
            )
        }
        (None, Some(texture), Some(from_spec)) => {
            let from = crate::commands::surface::load_model(from_spec, &global.limits)?;
            let tex = load_texture(texture, &global.limits)?;
            let (tw, th) = match &a.bake_size {
                Some(s) => crate::commands::render::parse_size(s)?,
                None => default_bake(tex.image().width, tex.image().height, size),
            };
            check_bake(tw, th, &global.limits)?;
            let moved = match ProjectionKind::parse(&a.project) {
                None => caoen::texture::transfer::transfer(&from, to, &tex, tw, th),
                Some(kind) => {
                    let (lo, hi) = projected::surface_box(&from).map_err(tex_err)?;
                    let picture = Projected::new(tex, kind, lo, hi).map_err(tex_err)?;
                    caoen::texture::transfer::bake(
                        &BakeSource::Projected {
                            from: &from,
                            picture: &picture,
                        },
                        to,
                        tw,
                        th,
                        a.bake_samples,
                        report,
                    )
                }
            };
            (
                moved.map_err(tex_err)?,
                format!("{} ({}) on {from_spec}", texture.display(), a.project),
            )
        }
        _ => {
            return Err(CliError::Usage(
                "give --texture IMG --from A, or --texture-space NET".into(),
            ))
        }
    })
}
