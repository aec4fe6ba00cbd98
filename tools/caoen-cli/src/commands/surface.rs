//! `caoen surface info|eval|mesh|export`.

use std::path::{Path, PathBuf};

use caoen::render::mesh::{tessellate, NormalMode};
use caoen::render::mesh_io::{write_obj, write_ply};
use caoen::surface::normals::exact_normal;
use caoen::surface::{gallery, SurfaceModel};
use serde_json::json;

use crate::cli::{GlobalArgs, NormalsArg, SurfaceCommand, SurfaceEvalArgs, SurfaceMeshArgs};
use crate::commands::note;
use crate::failure::{CliError, CliResult};
use crate::output::{extension_lowercase, print, Outputs, Target};

/// Loads a model from a file or `builtin:NAME`.
pub fn load_model(spec: &str, limits: &caoen::Limits) -> CliResult<SurfaceModel> {
    if let Some(name) = spec.strip_prefix("builtin:") {
        return gallery::by_name(name)
            .ok_or_else(|| {
                CliError::Usage(format!(
                    "unknown built-in model `{name}`; known: {}",
                    gallery::NAMES.join(", ")
                ))
            })?
            .map_err(Into::into);
    }
    Ok(SurfaceModel::load(Path::new(spec), limits)?)
}

/// Runs a surface subcommand.
pub fn run(global: &GlobalArgs, cmd: SurfaceCommand) -> CliResult {
    match cmd {
        SurfaceCommand::Info(a) => info(&load_model(&a.model, &global.limits)?, a.json),
        SurfaceCommand::Eval(a) => eval(&a, &global.limits),
        SurfaceCommand::Mesh(a) => mesh(global, &a),
        SurfaceCommand::Render(a) => crate::commands::render::run(global, &a),
        SurfaceCommand::Export(a) => {
            let target = Target::from_arg(Some(&a.output), PathBuf::new);
            let mut outputs = Outputs::new(global.force).input(&a.model);
            outputs.check(&target)?;
            let model = load_model(&a.model, &global.limits)?;
            outputs.write(&target, (model.to_json() + "\n").as_bytes())
        }
    }
}

fn info(model: &SurfaceModel, as_json: bool) -> CliResult {
    let net = &model.network;
    let mut blends: Vec<(&str, usize)> = Vec::new();
    for b in net.blends() {
        match blends.iter_mut().find(|(n, _)| *n == b.name()) {
            Some(e) => e.1 += 1,
            None => blends.push((b.name(), 1)),
        }
    }
    let q = net.sharpness();
    let (qmin, qmax) = q
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &v| (a.min(v), b.max(v)));
    let empty = net.weights().iter().filter(|&&w| w == 0.0).count();
    let mut text = String::new();
    if as_json {
        let v = json!({
            "name": model.name, "domain": model.domain, "input_dim": net.input_dim(),
            "output_dim": net.output_dim(), "key_points": net.len(), "empty_key_points": empty,
            "normalised": net.is_normalised(), "blends": blends.iter().map(|(n, c)| json!({"blend": n, "count": c})).collect::<Vec<_>>(),
            "q_min": qmin, "q_max": qmax, "spatial_index": net.uses_support_index(),
        });
        outln!(text, "{}", serde_json::to_string_pretty(&v).expect("json"));
    } else {
        outln!(text, "name:        {}", model.name);
        outln!(
            text,
            "domain:      {:?} (m = {})",
            model.domain,
            net.input_dim()
        );
        outln!(text, "outputs:     p = {}", net.output_dim());
        outln!(text, "key points:  {} ({} empty)", net.len(), empty);
        outln!(text, "normalised:  {}", net.is_normalised());
        let b: Vec<String> = blends.iter().map(|(n, c)| format!("{n} x{c}")).collect();
        outln!(text, "blends:      {}", b.join(", "));
        outln!(text, "sharpness:   q in [{qmin}, {qmax}]");
        outln!(
            text,
            "index:       {}",
            if net.uses_support_index() {
                "compact support (k-d trees)"
            } else {
                "dense"
            }
        );
    }
    print(text)
}

fn parse_list(s: &str) -> CliResult<Vec<f64>> {
    s.split(',')
        .map(|t| {
            t.trim()
                .parse::<f64>()
                .map_err(|_| CliError::Usage(format!("`{t}` in `{s}` is not a number")))
        })
        .collect()
}

/// Most points a `--grid` evaluates.
const MAX_GRID_POINTS: u64 = 16_000_000;

fn parse_size(s: &str) -> CliResult<(usize, usize)> {
    let (a, b) = crate::cli::parse_wxh(s, MAX_GRID_POINTS as u32).map_err(CliError::Usage)?;
    if u64::from(a) * u64::from(b) > MAX_GRID_POINTS {
        return Err(CliError::Usage(format!(
            "`{s}`: a grid has at most {MAX_GRID_POINTS} points"
        )));
    }
    Ok((a as usize, b as usize))
}

fn eval(a: &SurfaceEvalArgs, limits: &caoen::Limits) -> CliResult {
    let model = load_model(&a.model, limits)?;
    let mut points: Vec<Vec<f64>> = Vec::new();
    for s in &a.at {
        points.push(parse_list(s)?);
    }
    for s in &a.param {
        points.push(model.domain.point(&parse_list(s)?)?);
    }
    if let Some(g) = &a.grid {
        let (c, r) = parse_size(g)?;
        let grid = model.domain.grid(c, r)?;
        points.extend(
            grid.points
                .chunks_exact(model.domain.ambient_dim())
                .map(<[f64]>::to_vec),
        );
    }
    if points.is_empty() {
        return Err(CliError::Usage(
            "give at least one of --at, --param or --grid".into(),
        ));
    }
    let net = &model.network;
    let mut rows = Vec::with_capacity(points.len());
    let mut text = String::new();
    for x in &points {
        let (y, jac) = net.eval_with_jacobian(x)?;
        let normal = if a.normal {
            Some(exact_normal(net, &model.domain, x)?)
        } else {
            None
        };
        rows.push((x, y, jac, normal));
    }
    if a.json {
        let v: Vec<_> = rows
            .iter()
            .map(|(x, y, j, n)| {
                let mut o = json!({"x": x, "y": y});
                if a.jacobian {
                    o["jacobian"] = json!(j);
                }
                if let Some(n) = n {
                    o["normal"] = json!(n);
                }
                o
            })
            .collect();
        outln!(text, "{}", serde_json::to_string_pretty(&v).expect("json"));
    } else {
        let fmt = |v: &[f64]| {
            v.iter()
                .map(|x| format!("{x:.12}"))
                .collect::<Vec<_>>()
                .join(" ")
        };
        for (_, y, j, n) in &rows {
            let mut line = fmt(y);
            if a.jacobian {
                line += "  ";
                line += &fmt(j);
            }
            if let Some(n) = n {
                line += "  ";
                line += &fmt(n);
            }
            outln!(text, "{line}");
        }
    }
    print(text)
}

/// The files a mesh write produces, to check before the work: the mesh, and for a
/// textured OBJ its material library and texture copy (unless the texture is that copy).
pub fn mesh_files(path: &Path, texture: Option<&Path>) -> Vec<PathBuf> {
    let mut files = vec![path.to_path_buf()];
    let obj = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    if let (true, Some(tex)) = (obj, texture) {
        files.push(crate::commands::render::mtl_sibling(path));
        let png = crate::commands::render::texture_sibling(path);
        if !crate::commands::render::texture_is_sibling(tex, &png) {
            files.push(png);
        }
    }
    files
}

/// Writes the mesh of `model` to `path` (format by extension) and returns a summary.
pub fn write_mesh(
    outputs: &Outputs,
    model: &SurfaceModel,
    path: &Path,
    detail: u32,
    normals: NormalMode,
    limits: &caoen::Limits,
) -> CliResult<String> {
    write_mesh_textured(outputs, model, path, detail, normals, None, limits)
}

/// Like [`write_mesh`]; with a `texture` file an OBJ also gets `<stem>.mtl` and the
/// texture as `<stem>-texture.png`, referenced by its material. On a stream the mesh
/// is an OBJ without a material (its files would need a name).
pub fn write_mesh_textured(
    outputs: &Outputs,
    model: &SurfaceModel,
    path: &Path,
    detail: u32,
    normals: NormalMode,
    texture: Option<&Path>,
    limits: &caoen::Limits,
) -> CliResult<String> {
    let ext = crate::output::format_extension(path, "obj");
    if !matches!(ext.as_deref(), Some("obj" | "ply")) {
        return Err(CliError::Usage(format!(
            "{}: mesh output must end in .obj or .ply (`-`: OBJ on standard output)",
            path.display()
        )));
    }
    let texture = texture.filter(|_| extension_lowercase(path).is_some());
    let mesh = tessellate(model, detail, normals, limits)?;
    let mut bytes = Vec::new();
    let mut extra = String::new();
    match (ext.as_deref(), texture) {
        (Some("obj"), Some(tex)) => {
            let (mtl, png) =
                crate::commands::render::write_obj_material(outputs, path, tex, limits)?;
            extra = format!(" (+ {mtl}, {png})");
            write_obj(&mesh, &mut bytes, Some((&mtl, "caoen_surface")))
        }
        (Some("obj"), None) => write_obj(&mesh, &mut bytes, None),
        _ => write_ply(&mesh, &mut bytes),
    }
    .map_err(|e| CliError::io(path, e))?;
    outputs.write_path(path, &bytes)?;
    Ok(format!(
        "{}{extra}: {} vertices, {} triangles, Euler characteristic {}",
        crate::output::shown(path),
        mesh.positions.len(),
        mesh.triangles.len(),
        mesh.euler_characteristic()
    ))
}

fn mesh(global: &GlobalArgs, a: &SurfaceMeshArgs) -> CliResult {
    let model = load_model(&a.model, &global.limits)?;
    let normals = match a.normals {
        NormalsArg::Exact => NormalMode::Exact,
        NormalsArg::Interpolated => NormalMode::Interpolated,
    };
    let texture = match &a.texture {
        Some(t) => Some(t.clone()),
        None if !a.model.starts_with("builtin:") => model.texture_path(Some(Path::new(&a.model))),
        None => None,
    };
    let mut outputs = Outputs::new(global.force)
        .input(&a.model)
        .input_opt(texture.as_deref());
    for f in mesh_files(&a.output, texture.as_deref()) {
        outputs.check_path(&f)?;
    }
    let summary = write_mesh_textured(
        &outputs,
        &model,
        &a.output,
        a.detail,
        normals,
        texture.as_deref(),
        &global.limits,
    )?;
    note(global, format!("wrote {summary}"));
    Ok(())
}
