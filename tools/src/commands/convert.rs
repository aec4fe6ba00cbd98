//! `caoen convert` and `caoen deviation`: polygon meshes into implicit models, and
//! how far a model is from its mesh (`docs/conversion.md`).

use std::path::Path;
use std::time::Instant;

use caoen::conversion::deviation::{self, DepthDeviation, FieldGrid, VertexDeviation};
use caoen::conversion::{self, ImplicitField, InUnitCube, PolygonMesh};
use caoen::render::scene::Shape;
use serde_json::json;

use crate::cli::{ConvertArgs, DeviationArgs, GlobalArgs};
use crate::commands::note;
use crate::failure::{CliError, CliResult};
use crate::output::Outputs;

fn read_mesh(path: &Path) -> CliResult<PolygonMesh> {
    conversion::read(path).map_err(|e| CliError::Failed(e.to_string()))
}

fn topology_text(mesh: &PolygonMesh) -> String {
    let t = mesh.topology();
    format!(
        "{} vertices, {} triangles, {} ({} boundary edges), V - E + F = {}",
        t.vertices,
        t.faces,
        if t.is_closed() { "closed" } else { "open" },
        t.boundary_edges,
        t.euler_characteristic()
    )
}

/// `caoen convert MESH -o MODEL.json`.
pub fn convert(global: &GlobalArgs, a: &ConvertArgs) -> CliResult {
    let mut outputs = Outputs::new(global.force).input(&a.mesh);
    outputs.check_path(&a.output)?;
    let mesh = read_mesh(&a.mesh)?;
    conversion::mesh_file::check_convertible(&mesh, &a.mesh.display().to_string())
        .map_err(|e| CliError::Failed(e.to_string()))?;
    note(
        global,
        format!("{}: {}", a.mesh.display(), topology_text(&mesh)),
    );
    // The fit keeps a few dozen numbers per sample and per condition (three conditions
    // a sample), and each thread its own rows: 1000 bytes a condition bounds the peak
    // measured (1.6 GiB for 400,000 triangles on two threads, 2.75 GiB reported on
    // more; 448 MiB for the 69,451-triangle Stanford bunny, estimated 1.4 GiB).
    let samples = (mesh.positions.len() + mesh.triangles.len()) as u64
        + caoen::conversion::fit::MAX_SAMPLES as u64;
    caoen::budget::check(|| "the conversion's conditions".into(), samples * 3 * 1000)
        .map_err(|e| CliError::Failed(e.to_string()))?;
    let opts = conversion::ConvertOptions {
        max_functions: a.max_functions as usize,
        target: a.target,
        max_angle_deg: a.max_angle,
        descent_sweeps: a.descent as usize,
        ..Default::default()
    };
    let start = Instant::now();
    let result = conversion::convert(&mesh, &opts, &mut |level, functions, r| {
        note(
            global,
            format!(
                "level {level}: radius {:.4}, +{} perturbations ({functions} functions), \
                 vertex distance mean {:.5} max {:.5}, {} vertices over the target, {} \
                 off-surface points on the wrong side ({:.1} s)",
                r.radius,
                r.added,
                r.mean_distance,
                r.max_distance,
                r.over_target,
                r.wrong_side,
                start.elapsed().as_secs_f64()
            ),
        );
    });
    let seconds = start.elapsed().as_secs_f64();
    let name = a
        .mesh
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "mesh".into());
    let model = result
        .model
        .to_frep_json(&format!("{name} (converted)"), mesh.bounds());
    let text = serde_json::to_string(&model).expect("JSON of numbers");
    outputs.write_path(&a.output, text.as_bytes())?;
    let last = result.levels.last();
    if a.json {
        crate::output::print(
            json!({
                "mesh": a.mesh.display().to_string(),
                "output": a.output.display().to_string(),
                "functions": result.model.functions(),
                "seconds": seconds,
                "met_target": result.met_target,
                "levels": result.levels.len(),
                "mean_distance": last.map(|l| l.mean_distance),
                "max_distance": last.map(|l| l.max_distance),
            })
            .to_string()
                + "\n",
        )?;
    } else {
        note(
            global,
            format!(
                "wrote {}: {} functions in {:.1} s{}",
                a.output.display(),
                result.model.functions(),
                seconds,
                if result.met_target {
                    String::new()
                } else {
                    format!(
                        "; {} vertices still over the target (raise --max-functions)",
                        last.map_or(0, |l| l.over_target)
                    )
                }
            ),
        );
    }
    Ok(())
}

/// Everything `caoen deviation` measures.
struct Measured {
    vertex: VertexDeviation,
    depth: Vec<(&'static str, DepthDeviation)>,
    mean_depth: f64,
    mean_all: f64,
    mean_both: f64,
}

fn measure(
    global: &GlobalArgs,
    field: &dyn ImplicitField,
    unit: &PolygonMesh,
    a: &DeviationArgs,
) -> CliResult<(Measured, Option<Vec<u8>>)> {
    let normals = unit.outward_normals();
    let vertex = deviation::vertex_deviation(field, unit, &normals);
    let size = a.size as usize;
    let n = (size / 2 + 1).clamp(65, 257);
    caoen::budget::check(
        || format!("a {n}^3 field grid"),
        (n as u64).pow(3) * 8 + (size * size * 64 * 6) as u64,
    )
    .map_err(|e| CliError::Failed(e.to_string()))?;
    note(global, format!("sampling the field on a {n}^3 grid"));
    let grid = FieldGrid::new(field, n);
    let views = deviation::views(a.views as usize);
    let mut depth = Vec::new();
    let mut tiles = Vec::new();
    for v in &views {
        let m = deviation::mesh_depth(unit, v, size);
        let f = deviation::field_depth(field, &grid, v, size);
        depth.push((v.name, deviation::compare_depth(&m, &f)));
        if a.picture.is_some() {
            tiles.push((
                deviation::shade(&m, v),
                deviation::shade(&f, v),
                deviation::difference_picture(&m, &f, 0.02),
            ));
        }
    }
    let over_views = |f: fn(&DepthDeviation) -> f64| {
        depth.iter().map(|d| f(&d.1)).sum::<f64>() / depth.len() as f64
    };
    let (mean_depth, mean_all, mean_both) = (
        over_views(|d| d.mean),
        over_views(|d| d.mean_all),
        over_views(|d| d.mean_both),
    );
    let picture = a.picture.as_ref().map(|_| {
        let (w, h) = (3 * size, views.len() * size);
        let mut img = image::RgbImage::new(w as u32, h as u32);
        for (row, (mesh, model, diff)) in tiles.iter().enumerate() {
            for k in 0..size * size {
                let (x, y) = ((k % size) as u32, (row * size + k / size) as u32);
                img.put_pixel(x, y, image::Rgb([mesh[k]; 3]));
                img.put_pixel(x + size as u32, y, image::Rgb([model[k]; 3]));
                img.put_pixel(x + 2 * size as u32, y, image::Rgb(diff[k]));
            }
        }
        let mut bytes = Vec::new();
        image::DynamicImage::ImageRgb8(img)
            .write_to(
                &mut std::io::Cursor::new(&mut bytes),
                image::ImageFormat::Png,
            )
            .expect("PNG into memory");
        bytes
    });
    Ok((
        Measured {
            vertex,
            depth,
            mean_depth,
            mean_all,
            mean_both,
        },
        picture,
    ))
}

/// `caoen deviation MESH MODEL.json` or `caoen deviation MESH --rbf N`.
pub fn deviation(global: &GlobalArgs, a: &DeviationArgs) -> CliResult {
    let mut outputs = Outputs::new(global.force)
        .input(&a.mesh)
        .input_opt(a.model.as_ref());
    if let Some(p) = &a.picture {
        outputs.check_path(p)?;
    }
    let mesh = read_mesh(&a.mesh)?;
    let frame = mesh.unit_frame();
    let unit = mesh.transformed(&frame);
    let start = Instant::now();
    let (what, numbers, (m, picture)) = match (&a.model, a.rbf) {
        (Some(path), _) => {
            let scene = crate::commands::frep::load(path)?;
            let fields: Vec<_> = scene
                .objects
                .iter()
                .filter_map(|o| match &o.shape {
                    Shape::Field { node, .. } => Some(node),
                    _ => None,
                })
                .collect();
            let [node] = fields[..] else {
                return Err(CliError::Failed(format!(
                    "{}: holds {} F-rep objects; expected one",
                    path.display(),
                    fields.len()
                )));
            };
            let field = InUnitCube {
                field: node.as_ref(),
                frame,
            };
            (
                path.display().to_string(),
                node.count(),
                measure(global, &field, &unit, a)?,
            )
        }
        (None, Some(n)) => {
            note(global, format!("fitting the RBF baseline with {n} centres"));
            let normals = unit.outward_normals();
            let rbf = conversion::rbf_baseline::fit(&unit, &normals, n as usize, 0.01)
                .map_err(|e| CliError::Failed(e.to_string()))?;
            (
                format!("RBF baseline, {} centres", rbf.centres.len()),
                rbf.numbers(),
                measure(global, &rbf, &unit, a)?,
            )
        }
        (None, None) => return Err(CliError::Usage("give a model file or --rbf N".into())),
    };
    if let (Some(p), Some(bytes)) = (&a.picture, &picture) {
        outputs.write_path(p, bytes)?;
        note(global, format!("wrote {}", p.display()));
    }
    let seconds = start.elapsed().as_secs_f64();
    let v = &m.vertex;
    if a.no_summary {
        return Ok(());
    }
    if a.json {
        let views: Vec<_> = m
            .depth
            .iter()
            .map(|(name, d)| {
                json!({"view": name, "mean": d.mean, "mean_all_pixels": d.mean_all,
                       "mean_both_cover": d.mean_both, "covered": d.covered,
                       "silhouette_mismatch": d.silhouette_mismatch})
            })
            .collect();
        crate::output::print(
            json!({
                "mesh": a.mesh.display().to_string(),
                "model": what,
                "size": numbers,
                "vertex_distance": {"mean": v.mean_distance, "max": v.max_distance},
                "normal_angle_deg": {"mean": v.mean_angle_deg, "max": v.max_angle_deg},
                "unconverged_vertices": v.unconverged,
                "depth": {"mean": m.mean_depth, "mean_all_pixels": m.mean_all,
                          "mean_both_cover": m.mean_both, "views": views},
                "seconds": seconds,
            })
            .to_string()
                + "\n",
        )?;
    } else {
        let mut out = String::new();
        outln!(
            out,
            "mesh:            {} ({})",
            a.mesh.display(),
            topology_text(&mesh)
        );
        outln!(out, "model:           {what} ({numbers} nodes or numbers)");
        outln!(
            out,
            "vertex distance: mean {:.5}, max {:.5} (unit cube)",
            v.mean_distance,
            v.max_distance
        );
        outln!(
            out,
            "normal angle:    mean {:.2}, max {:.2} degrees",
            v.mean_angle_deg,
            v.max_angle_deg
        );
        outln!(
            out,
            "depth buffers:   mean {:.5} where either sees the model, {:.5} where both do, \
             {:.5} over all pixels; {} views of {} px",
            m.mean_depth,
            m.mean_both,
            m.mean_all,
            m.depth.len(),
            a.size
        );
        for (name, d) in &m.depth {
            outln!(
                out,
                "  {name}: mean {:.5}, {} pixels covered, {} silhouette mismatches",
                d.mean,
                d.covered,
                d.silhouette_mismatch
            );
        }
        if v.unconverged > 0 {
            outln!(
                out,
                "{} vertices did not reach the surface along the gradient",
                v.unconverged
            );
        }
        crate::output::print(out)?;
    }
    Ok(())
}
