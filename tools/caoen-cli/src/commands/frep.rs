//! `caoen frep render|mesh|export-pov`: F-rep models (`docs/frep.md`).

use std::path::Path;

use serde::{Deserialize, Deserializer};

use caoen::json::FieldError;
use caoen::render::scene::Shape;
use caoen::render::{Method, RenderOptions, Scene};

use crate::cli::{
    FrepCommand, FrepExportArgs, FrepMeshArgs, FrepMethodArg, FrepRenderArgs, GlobalArgs,
    HeightBaseArg, HeightfieldArgs, PictureArgs,
};
use crate::commands::note;
use crate::commands::print::{is_mesh_path, mesh_format, write_solid_mesh, MeshFile};
use crate::commands::render::{parse_size, picture_format, render_with_progress};
use crate::failure::{CliError, CliResult};
use crate::output::{extension_lowercase, shown, Outputs};

/// The format tag of an F-rep model file.
pub const FREP_FORMAT: &str = "caoen-frep/1";

/// Runs one `caoen frep` command.
pub fn run(global: &GlobalArgs, cmd: FrepCommand) -> CliResult {
    match cmd {
        FrepCommand::Render(a) => render(global, &a),
        FrepCommand::Mesh(a) => mesh(global, &a),
        FrepCommand::ExportPov(a) => export_pov(global, &a),
    }
}

/// An F-rep model file: its format tag, the model, and the fields the scene it is
/// drawn in takes as written (the scene reader checks them).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile {
    #[serde(rename = "format")]
    _format: FrepFormat,
    model: serde_json::Value,
    #[serde(default, deserialize_with = "present")]
    name: Option<serde_json::Value>,
    #[serde(default, deserialize_with = "present")]
    bounds: Option<serde_json::Value>,
    #[serde(default, deserialize_with = "present")]
    material: Option<serde_json::Value>,
    #[serde(default, deserialize_with = "present")]
    camera: Option<serde_json::Value>,
    #[serde(default, deserialize_with = "present")]
    background: Option<serde_json::Value>,
    #[serde(default, deserialize_with = "present")]
    lights: Option<serde_json::Value>,
}

/// A field that is present, `null` included (the scene decides what `null` means).
fn present<'de, D: Deserializer<'de>>(d: D) -> Result<Option<serde_json::Value>, D::Error> {
    serde_json::Value::deserialize(d).map(Some)
}

/// The format tag of a model file; a scene's is named in the error, since `frep`
/// commands read both.
struct FrepFormat;

impl<'de> Deserialize<'de> for FrepFormat {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let tag = String::deserialize(d)?;
        if tag == FREP_FORMAT {
            return Ok(FrepFormat);
        }
        Err(serde::de::Error::invalid_value(
            serde::de::Unexpected::Str(&tag),
            &"`caoen-frep/1` (a model) or `caoen-scene/1` (a scene)",
        ))
    }
}

/// Loads an F-rep model file (wrapped into a one-object scene) or a scene file.
pub fn load(path: &Path, limits: &caoen::Limits) -> CliResult<Scene> {
    let text = limits
        .read_to_string(path)
        .map_err(|e| CliError::io(path, e))?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let failed = |m: String| CliError::Failed(format!("{}: {m}", path.display()));
    if Scene::is_scene_json(&text) {
        return Scene::from_json(&text, &base, limits).map_err(|e| failed(e.to_string()));
    }
    let v: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| failed(format!("not JSON: {e}")))?;
    // serde's derived structs also take a list of their fields in order.
    if !v.is_object() {
        return Err(failed("expected a JSON object".into()));
    }
    let file: ModelFile = serde_path_to_error::deserialize(&v)
        .map_err(|e| failed(FieldError::from_path_error("", &e).printable().to_string()))?;
    let mut object = serde_json::json!({
        "name": file.name.clone().unwrap_or("model".into()),
        "frep": file.model,
    });
    for (k, x) in [("bounds", file.bounds), ("material", file.material)] {
        if let Some(x) = x {
            object[k] = x;
        }
    }
    let mut scene = serde_json::json!({
        "format": "caoen-scene/1",
        "name": file.name.unwrap_or("F-rep model".into()),
        "objects": [object],
    });
    for (k, x) in [
        ("camera", file.camera),
        ("background", file.background),
        ("lights", file.lights),
    ] {
        if let Some(x) = x {
            scene[k] = x;
        }
    }
    Scene::from_json(&scene.to_string(), &base, limits).map_err(|e| failed(e.to_string()))
}

/// Checks polygonising on `cells`^3 cells against the memory budget, before the model
/// is loaded: `frep mesh` and the mesh render path allocate the same grid.
fn check_cells(cells: u32, limits: &caoen::Limits) -> CliResult {
    limits
        .check(
            || format!("polygonising on {cells}^3 cells"),
            caoen::frep::polygonise::polygonise_memory(cells),
        )
        .map_err(|e| CliError::Failed(e.to_string()))
}

fn render(global: &GlobalArgs, a: &FrepRenderArgs) -> CliResult {
    let format = picture_format(&a.output)?;
    let mut outputs = Outputs::new(global.force).input(&a.model);
    outputs.check_path(&a.output)?;
    if matches!(a.method, FrepMethodArg::Mesh) {
        check_cells(a.cells, &global.limits)?;
    }
    let scene = load(&a.model, &global.limits)?;
    let (width, height) = parse_size(&a.size)?;
    let opts = RenderOptions {
        width,
        height,
        samples: a.samples,
        method: match a.method {
            FrepMethodArg::Ray => Method::Ray,
            FrepMethodArg::Mesh => Method::Mesh,
        },
        polygonise_cells: a.cells as usize,
        ..RenderOptions::default()
    };
    let start = std::time::Instant::now();
    let r = render_with_progress(global, &scene, &opts, "rendering")?;
    outputs.write_path(&a.output, &r.image.encode(format)?)?;
    note(
        global,
        format!(
            "wrote {} ({width}x{height}, {s}x{s} samples, {:.2} s)",
            shown(&a.output),
            start.elapsed().as_secs_f64(),
            s = a.samples
        ),
    );
    Ok(())
}

fn mesh(global: &GlobalArgs, a: &FrepMeshArgs) -> CliResult {
    let mut outputs = Outputs::new(global.force).input(&a.model);
    mesh_format(&a.output, &MeshFile::from_args(&a.file, a.size, a.scale))?;
    outputs.check_path(&a.output)?;
    let scene = load(&a.model, &global.limits)?;
    let fields: Vec<_> = scene
        .objects
        .iter()
        .filter_map(|o| match &o.shape {
            Shape::Field { node, bounds } => Some((node, bounds, o)),
            _ => None,
        })
        .collect();
    let [(node, bounds, object)] = fields[..] else {
        return Err(CliError::Failed(format!(
            "{}: holds {} F-rep objects; mesh takes exactly one",
            a.model.display(),
            fields.len()
        )));
    };
    let file = MeshFile {
        name: object.name.clone(),
        colour: Some(object.material.colour.map(f64::from)),
        ..MeshFile::from_args(&a.file, a.size, a.scale)
    };
    write_solid_mesh(
        global,
        &outputs,
        (node, bounds),
        a.cells,
        &[&a.output],
        &file,
    )
}

fn export_pov(global: &GlobalArgs, a: &FrepExportArgs) -> CliResult {
    let mut outputs = Outputs::new(global.force).input(&a.model);
    outputs.check_path(&a.output)?;
    let scene = load(&a.model, &global.limits)?;
    let (width, height) = parse_size(&a.size)?;
    let camera = scene.camera(width, height)?;
    // POV-Ray cannot read `.cae`: each such image map goes beside the `.pov` as a PNG
    // decoded at the size a render of this size would use.
    let textures = if crate::output::is_stdout(&a.output) {
        None
    } else {
        caoen::render::cae_texture::export_textures(&scene, &camera, &a.output, &global.limits)
            .map_err(|e| CliError::Failed(format!("{}: {e}", a.model.display())))?
    };
    let (scene, textures) = match textures {
        Some((s, t)) => (s, t),
        None => (scene, Vec::new()),
    };
    if textures.is_empty() && caoen::render::cae_texture::has_cae(&scene) {
        return Err(CliError::Usage(
            "a .cae texture is exported as a PNG beside the .pov: give -o a file".into(),
        ));
    }
    for t in &textures {
        outputs.check_path(&t.path)?;
    }
    let bar = crate::commands::render::progress_bar(global, "measuring max_gradient");
    let text = caoen::render::pov::export_with(&scene, &camera, &global.limits, &|done, total| {
        bar.set_length(total);
        bar.set_position(done);
    })
    .map_err(|e| CliError::Failed(format!("{}: {e}", a.model.display())))?;
    bar.finish_and_clear();
    for t in &textures {
        outputs.write_path(&t.path, &t.png)?;
        note(
            global,
            format!(
                "wrote {} (the .cae texture decoded at {}x{})",
                t.path.display(),
                t.size.0,
                t.size.1
            ),
        );
    }
    outputs.write_path(&a.output, text.as_bytes())?;
    // POV-Ray reads a scene from a file only: the hint names one for standard output.
    let input = if crate::output::is_stdout(&a.output) {
        "<scene>.pov".to_string()
    } else {
        a.output.display().to_string()
    };
    note(
        global,
        format!(
            "wrote {} (render with: povray +I{input} +W{width} +H{height} +A0.1 +O<out>.png)",
            shown(&a.output),
        ),
    );
    Ok(())
}

/// The F-rep model of `caoen heightfield`: the image's heights on the chosen base, cut
/// to a finite solid. `image` is the path written into the model.
pub fn heightfield_model(a: &HeightfieldArgs, image: &str, aspect: f64) -> serde_json::Value {
    use serde_json::json;
    use std::f64::consts::{FRAC_PI_2, PI};
    let mut hm = json!({"image": image, "height": a.height, "interp": a.interp});
    if let Some(t) = a.threshold {
        hm["threshold"] = json!(t);
    }
    let top = a.height.max(0.0);
    let model = match a.base {
        HeightBaseArg::Plane => {
            // The image spans 2 units across its longer side; the slab is 0.2 deep.
            let (hw, hh) = if aspect >= 1.0 {
                (1.0, 1.0 / aspect)
            } else {
                (aspect, 1.0)
            };
            hm["base"] = json!("plane");
            hm["rect"] = json!([-hw, -hh, hw, hh]);
            json!({"intersection": [
                {"height_map": hm},
                {"box": {"centre": [0.0, 0.0, 0.5 * top - 0.1], "size": [2.0 * hw, 2.0 * hh, top + 0.2 + 1e-3]}}
            ], "a": 1.0})
        }
        HeightBaseArg::Ellipsoid => {
            hm["base"] = json!({"ellipsoid": [1.0, 1.0, 1.0]});
            hm["rect"] = json!([-PI, -FRAC_PI_2, PI, FRAC_PI_2]);
            json!({"height_map": hm})
        }
        HeightBaseArg::Cylinder => {
            hm["base"] = json!({"cylinder": 1.0});
            hm["rect"] = json!([-PI, -1.0, PI, 1.0]);
            json!({"intersection": [
                {"height_map": hm},
                {"box": {"centre": [0.0, 0.0, 0.0], "size": [2.0 * (1.0 + top), 2.0 * (1.0 + top), 2.0]}}
            ], "a": 1.0})
        }
    };
    json!({
        "format": FREP_FORMAT,
        "name": format!("height field ({})", match a.base {
            HeightBaseArg::Plane => "plane",
            HeightBaseArg::Ellipsoid => "ellipsoid",
            HeightBaseArg::Cylinder => "cylinder",
        }),
        "model": model,
        "material": {"colour": [0.72, 0.7, 0.66], "specular": 0.15},
        "camera": {"projection": "perspective", "fov_deg": 30.0, "view_from": [0.4, -1.4, 1.2]}
    })
}

/// `caoen heightfield`.
pub fn heightfield(global: &GlobalArgs, a: &HeightfieldArgs) -> CliResult {
    let ext = extension_lowercase(&a.output);
    if ext.as_deref() != Some("json") {
        model_or_picture(&a.output)?;
    }
    if !(a.height.is_finite() && a.height.abs() <= 1e3) {
        return Err(CliError::Usage(format!(
            "--height {}: must be finite, at most 1000",
            a.height
        )));
    }
    if a.threshold
        .is_some_and(|t| !(t.is_finite() && t.abs() <= 1e3))
    {
        return Err(CliError::Usage(
            "--threshold: must be finite, at most 1000".into(),
        ));
    }
    let mut outputs = Outputs::new(global.force).input(&a.image);
    outputs.check_path(&a.output)?;
    let header = caoen::image_io::load(&a.image).map_err(|e| CliError::Failed(e.to_string()))?;
    let aspect = header.width() as f64 / header.height() as f64;
    // The model names the image by an absolute path, so it renders from anywhere.
    let image = std::fs::canonicalize(&a.image).map_err(|e| CliError::io(&a.image, e))?;
    let model = heightfield_model(a, &image.to_string_lossy(), aspect);
    write_model(
        global,
        &outputs,
        &model,
        &a.output,
        &a.size,
        a.samples,
        Path::new("."),
    )
}

/// The picture format of an output that is a model (.json) or a render: named by
/// what the command writes when the extension is neither.
fn model_or_picture(output: &Path) -> CliResult<caoen::render::framebuffer::PictureFormat> {
    picture_format(output).map_err(|e| match e {
        CliError::Usage(m) => CliError::Usage(format!("{m} (or .json for the model)")),
        other => other,
    })
}

/// Writes `model` (an F-rep model file's JSON) to `output`: the JSON itself (.json) or
/// its ray-cast render (a picture); file names in it resolve against `base`.
fn write_model(
    global: &GlobalArgs,
    outputs: &Outputs,
    model: &serde_json::Value,
    output: &Path,
    size: &str,
    samples: u32,
    base: &Path,
) -> CliResult {
    let ext = extension_lowercase(output);
    // Refused before any work when the extension is neither a model nor a picture.
    let format = if ext.as_deref() == Some("json") {
        None
    } else {
        Some(model_or_picture(output)?)
    };
    let mut object = serde_json::json!({"frep": model["model"]});
    for k in ["material", "bounds"] {
        if !model[k].is_null() {
            object[k] = model[k].clone();
        }
    }
    let mut scene = serde_json::json!({"format": "caoen-scene/1", "objects": [object]});
    // The name is optional in a model file, and a string when present.
    if model["name"].is_string() {
        scene["name"] = model["name"].clone();
    }
    if !model["camera"].is_null() {
        scene["camera"] = model["camera"].clone();
    }
    let scene = Scene::from_json(&scene.to_string(), base, &global.limits)
        .map_err(|e| CliError::Failed(format!("{}: {e}", output.display())))?;
    // The model is loaded as render would load it before a JSON file is written, so
    // every file written here reads back (nesting, node count and asset limits).
    let Some(format) = format else {
        drop(scene);
        let text = serde_json::to_string_pretty(model).expect("json values serialise") + "\n";
        outputs.write_path(output, text.as_bytes())?;
        note(global, format!("wrote {}", shown(output)));
        return Ok(());
    };
    let (width, height) = parse_size(size)?;
    let opts = RenderOptions {
        width,
        height,
        samples,
        method: Method::Ray,
        ..RenderOptions::default()
    };
    let r = render_with_progress(global, &scene, &opts, "rendering")?;
    outputs.write_path(output, &r.image.encode(format)?)?;
    note(
        global,
        format!("wrote {} ({width}x{height})", shown(output)),
    );
    Ok(())
}

/// What `caoen relief` and `caoen carve` do with the picture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PictureUse {
    /// Displace the model along its normal by the grey levels.
    Relief,
    /// Keep the model where the picture is brighter than the level.
    Carve,
}

/// `caoen relief` and `caoen carve`: a new model file wrapping the model of `--on`.
pub fn picture(global: &GlobalArgs, a: &PictureArgs, what: PictureUse) -> CliResult {
    use serde_json::json;
    let ext = extension_lowercase(&a.output);
    if ext.as_deref() != Some("json") && !is_mesh_path(&a.output) {
        model_or_picture(&a.output)?;
    }
    for (name, v) in [("--depth", a.depth), ("--level", a.level)] {
        if !(v.is_finite() && v.abs() <= 1e3) {
            return Err(CliError::Usage(format!(
                "{name} {v}: must be finite, at most 1000"
            )));
        }
    }
    if a.shell
        .is_some_and(|t| !(t.is_finite() && t > 0.0 && t <= 1e3))
    {
        return Err(CliError::Usage("--shell: a thickness in (0, 1000]".into()));
    }
    let file = picture_mesh_file(a)?;
    let mut outputs = Outputs::new(global.force).input(&a.image).input(&a.on);
    outputs.check_path(&a.output)?;
    let text = global
        .limits
        .read_to_string(&a.on)
        .map_err(|e| CliError::io(&a.on, e))?;
    let on: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| CliError::Failed(format!("{}: not JSON: {e}", a.on.display())))?;
    if on["format"] != FREP_FORMAT {
        return Err(CliError::Failed(format!(
            "{}: --on takes an F-rep model file (format `{FREP_FORMAT}`)",
            a.on.display()
        )));
    }
    // The base model as a scene object first: its errors are reported as such, and
    // its bounds are needed for the shell.
    let base_dir = a.on.parent().map(Path::to_path_buf).unwrap_or_default();
    let scene = load(&a.on, &global.limits)?;
    let Some(Shape::Field { node, bounds }) = scene.objects.first().map(|o| &o.shape) else {
        return Err(CliError::Failed(format!(
            "{}: no F-rep model",
            a.on.display()
        )));
    };
    let image = std::fs::canonicalize(&a.image).map_err(|e| CliError::io(&a.image, e))?;
    let image = image.to_string_lossy();
    let mut model = on.clone();
    let base = on["model"].clone();
    model["model"] = match what {
        PictureUse::Relief => json!({
            "relief": base, "image": image, "projection": a.projection, "depth": a.depth,
            "interp": "bicubic"
        }),
        PictureUse::Carve => {
            let body = match a.shell {
                None => base,
                Some(t) => {
                    // The wall: the model minus itself moved inwards by t (in the
                    // function's units, t times its gradient near the surface).
                    let g = caoen::frep::node::mean_surface_gradient(node, bounds);
                    json!({"difference": [base.clone(), {"offset": base, "by": -t * g}], "a": 1.0})
                }
            };
            let mut pattern = json!({"image": image, "projection": a.projection, "level": a.level});
            if a.projection == "planar" {
                pattern["rect"] = json!([bounds.lo[0], bounds.lo[1], bounds.hi[0], bounds.hi[1]]);
            } else if a.projection == "cylindrical" {
                pattern["rect"] = json!([
                    -std::f64::consts::PI,
                    bounds.lo[2],
                    std::f64::consts::PI,
                    bounds.hi[2]
                ]);
            }
            json!({"intersection": [body, {"pattern": pattern}], "a": 1.0})
        }
    };
    if model.get("bounds").is_none() && what == PictureUse::Carve {
        model["bounds"] = json!({"min": bounds.lo, "max": bounds.hi});
    }
    if let Some(n) = on["name"].as_str() {
        model["name"] = json!(format!(
            "{n}, {}",
            if what == PictureUse::Relief {
                "relief"
            } else {
                "carved"
            }
        ));
    }
    if is_mesh_path(&a.output) {
        let text = model.to_string();
        let v: serde_json::Value = serde_json::from_str(&text).expect("json values round-trip");
        let node = caoen::frep::Node::from_json(&v["model"], "model", &base_dir, &global.limits)
            .map_err(|e| CliError::Failed(format!("{}: {e}", a.output.display())))?;
        let bounds = match node.bounds() {
            Some(b) => b,
            None => *bounds,
        };
        let file = MeshFile {
            name: model["name"].as_str().unwrap_or("model").into(),
            colour: scene
                .objects
                .first()
                .map(|o| o.material.colour.map(f64::from)),
            ..file.expect("a mesh output has its file")
        };
        return write_solid_mesh(
            global,
            &outputs,
            (&node, &bounds),
            a.cells,
            &[&a.output],
            &file,
        );
    }
    // The base model's assets are loaded again with the new model: not twice at once.
    drop(scene);
    let size = a.size.as_deref().unwrap_or("512x384");
    write_model(
        global, &outputs, &model, &a.output, size, a.samples, &base_dir,
    )
}

/// How `relief` and `carve` write a mesh output (`--size` its largest extent), or None
/// for a model or a render (which take no mesh options).
fn picture_mesh_file(a: &PictureArgs) -> CliResult<Option<MeshFile>> {
    if !is_mesh_path(&a.output) {
        if a.scale.is_some() || a.file.ascii {
            return Err(CliError::Usage(format!(
                "{}: --scale and --ascii are for mesh outputs (.stl, .3mf, .obj, .ply)",
                a.output.display()
            )));
        }
        return Ok(None);
    }
    let size = match &a.size {
        Some(s) => Some(crate::cli::length(s).map_err(CliError::Usage)?),
        None => None,
    };
    let file = MeshFile::from_args(&a.file, size, a.scale);
    mesh_format(&a.output, &file)?;
    Ok(Some(file))
}
