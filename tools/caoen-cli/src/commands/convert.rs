//! `caoen convert` and `caoen deviation`: polygon meshes into implicit models, and
//! how far a model is from its mesh (`docs/conversion.md`).

use std::path::Path;
use std::time::Instant;

use caoen::conversion::deviation::{self, DepthDeviation, FieldGrid, VertexDeviation};
use caoen::conversion::fit::Progress;
use caoen::conversion::{self, openings, ImplicitField, InUnitCube, PolygonMesh};
use caoen::render::scene::Shape;
use serde_json::json;

use crate::cli::{ConvertArgs, DeviationArgs, GlobalArgs, HolesArg};
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

/// The default function budget: 6000, or 3 per vertex on a mesh with more detail, up
/// to 9000 (a model file holds at most 10,000 nodes).
fn default_budget(mesh: &PolygonMesh) -> usize {
    (3 * mesh.positions.len()).clamp(6000, 9000)
}

/// Prints the current phase on stderr whenever nothing else was printed for 4 s.
struct Heartbeat {
    state: std::sync::Arc<std::sync::Mutex<(String, Instant, bool)>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Heartbeat {
    fn start(quiet: bool, started: Instant) -> Heartbeat {
        let state = std::sync::Arc::new(std::sync::Mutex::new((
            String::from("reading"),
            Instant::now(),
            false,
        )));
        let shared = state.clone();
        let thread = (!quiet).then(|| {
            std::thread::spawn(move || loop {
                std::thread::sleep(std::time::Duration::from_millis(250));
                let mut s = shared.lock().unwrap_or_else(|e| e.into_inner());
                if s.2 {
                    return;
                }
                if s.1.elapsed().as_secs_f64() >= 4.0 {
                    eprintln!("  ... {} ({:.1} s)", s.0, started.elapsed().as_secs_f64());
                    s.1 = Instant::now();
                }
            })
        });
        Heartbeat { state, thread }
    }

    /// Says what is happening now; `printed` when a line was just printed.
    fn phase(&self, what: &str, printed: bool) {
        let mut s = self.state.lock().unwrap_or_else(|e| e.into_inner());
        s.0 = what.to_string();
        if printed {
            s.1 = Instant::now();
        }
    }
}

impl Drop for Heartbeat {
    fn drop(&mut self) {
        self.state.lock().unwrap_or_else(|e| e.into_inner()).2 = true;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// `caoen convert MESH -o MODEL.json`.
pub fn convert(global: &GlobalArgs, a: &ConvertArgs) -> CliResult {
    let start = Instant::now();
    let mut outputs = Outputs::new(global.force).input(&a.mesh);
    outputs.check_path(&a.output)?;
    let heartbeat = Heartbeat::start(global.quiet, start);
    let mesh = read_mesh(&a.mesh)?;
    conversion::mesh_file::check_convertible(&mesh, &a.mesh.display().to_string())
        .map_err(|e| CliError::Failed(e.to_string()))?;
    note(
        global,
        format!("{}: {}", a.mesh.display(), topology_text(&mesh)),
    );
    heartbeat.phase("checking which side is inside (winding numbers)", true);
    let open = mesh.openness();
    let sheet = open.is_sheet();
    let open_text = format!(
        "{} boundary edges, {} non-manifold edges, boundary length {:.3} of sqrt(area), \
         inside and outside told apart at {:.0}% of probed vertices",
        open.boundary_edges,
        open.non_manifold_edges,
        open.boundary_ratio,
        100.0 * open.enclosed_fraction
    );
    if sheet && !a.fill_open {
        return Err(CliError::Failed(format!(
            "{}: an open sheet, not the surface of a solid: {open_text}. Converting it \
             would model a different, closed solid; close the mesh (or give it \
             thickness) first, or pass --fill-open to convert the solid its winding \
             number encloses",
            a.mesh.display()
        )));
    }
    note(
        global,
        format!(
            "{}: {open_text}",
            if sheet {
                "an open sheet, filled (--fill-open)"
            } else if open.boundary_edges > 0 {
                "a solid with holes"
            } else {
                "a closed surface"
            }
        ),
    );
    // The fit keeps a few dozen numbers per sample and per condition (three conditions
    // a sample), and each thread its own rows: 1000 bytes a condition bounds the peak
    // measured (1.6 GiB for 400,000 triangles on two threads, 2.75 GiB reported on
    // more; 448 MiB for the 69,451-triangle Stanford bunny, estimated 1.4 GiB).
    // Samples are the fit's vertices (at most MAX_FIT_VERTICES) and at most about
    // MAX_SAMPLES points in the triangles; the mesh's own tables (edges, normals, the
    // unit copy) take about 100 bytes a triangle.
    let samples = mesh
        .positions
        .len()
        .min(caoen::conversion::fit::MAX_FIT_VERTICES) as u64
        + caoen::conversion::fit::MAX_SAMPLES as u64;
    let estimate = samples * 3 * 1000 + mesh.triangles.len() as u64 * 100;
    caoen::budget::check(|| "the conversion's conditions".into(), estimate)
        .map_err(|e| CliError::Failed(e.to_string()))?;
    note(
        global,
        format!("memory estimate {}", caoen::budget::human(estimate)),
    );
    let max_functions = a
        .max_functions
        .map_or_else(|| default_budget(&mesh), |n| n as usize);
    let opts = conversion::ConvertOptions {
        max_functions,
        target: a.target,
        max_angle_deg: a.max_angle,
        descent_sweeps: a.descent as usize,
        fit_angle_deg: 0.8 * a.target_angle,
        ..Default::default()
    };

    let fit_start = Instant::now();
    let result = conversion::convert(&mesh, &opts, &mut |p| match p {
        Progress::Phase(what) => {
            note(
                global,
                format!("{what} ({:.1} s)", start.elapsed().as_secs_f64()),
            );
            heartbeat.phase(what, true);
        }
        Progress::Level(level, functions, r) => {
            note(
                global,
                format!(
                    "level {level}: radius {:.4}, +{} perturbations ({functions} of \
                     {max_functions} functions), vertex distance mean {:.5} max {:.5}, {} \
                     vertices over the target, {} off-surface points on the wrong side \
                     ({:.1} s)",
                    r.radius,
                    r.added,
                    r.mean_distance,
                    r.max_distance,
                    r.over_target,
                    r.wrong_side,
                    start.elapsed().as_secs_f64()
                ),
            );
            heartbeat.phase("fitting the next level", true);
        }
    });
    let fit_seconds = fit_start.elapsed().as_secs_f64();
    let name = a
        .mesh
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "mesh".into());
    let title = format!("{name} (converted)");
    // The summary measures what `caoen deviation` measures, on the model written.
    let msg = format!(
        "measuring the model: {} px depth buffers, 6 views",
        a.check_size
    );
    note(global, &msg);
    heartbeat.phase(&msg, true);
    let frame = mesh.unit_frame();
    let unit = mesh.transformed(&frame);
    let holed = !sheet && open.boundary_edges > 0;
    let loops = if holed {
        unit.boundary_loops()
    } else {
        Vec::new()
    };
    // A solid with holes may be written as a shell with openings instead: measured
    // like the closed model, on the model file itself.
    let mut shell = None;
    if holed && a.holes != HolesArg::Close {
        let msg = format!(
            "measuring the model with openings at {} boundary loops",
            loops.len()
        );
        note(global, &msg);
        heartbeat.phase(&msg, true);
        let room = caoen::frep::node::MAX_NODES
            .saturating_sub(result.model.fitted_nodes() + SHELL_WRAPPER_NODES);
        let openings = openings::openings(&unit, &result.model, &loops, room);
        if !openings.is_empty() {
            let unit_model = openings::shell_with_openings(
                result.model.fitted_json(),
                &openings,
                openings::SHELL_THICKNESS,
            );
            let json = result
                .model
                .to_frep_json_of(unit_model, &title, mesh.bounds());
            // A cutter the model file refuses (a patch its checks find degenerate)
            // leaves the closed model, said on stderr, rather than failing the fit.
            match caoen::frep::Node::from_json(&json["model"], "model", Path::new(".")) {
                Ok(node) => {
                    let field = InUnitCube {
                        field: &node,
                        frame,
                    };
                    let (m, _) = measure(global, &field, &unit, a.check_size as usize, 6, false)?;
                    shell = Some((m, json, openings.len()));
                }
                Err(e) => note(global, format!("no shell with openings: {e}")),
            }
        }
    }
    let shell_all = shell.as_ref().map(|s| s.0.mean_all);
    let shell_cut = shell.as_ref().map_or(0, |s| s.2);
    // The closed model is measured unless the shell was asked for and built.
    let closed = if a.holes == HolesArg::Open && shell.is_some() {
        None
    } else {
        if holed {
            note(global, "measuring the closed model");
            heartbeat.phase("measuring the closed model", true);
        }
        Some(
            measure(
                global,
                &result.model,
                &unit,
                a.check_size as usize,
                6,
                false,
            )?
            .0,
        )
    };
    let closed_all = closed.as_ref().map(|m| m.mean_all);
    let use_shell = match (&closed, &shell) {
        (None, Some(_)) => true,
        (Some(c), Some((m, _, _))) => a.holes == HolesArg::Auto && m.mean_all < c.mean_all,
        _ => false,
    };
    let (m, model, cut) = match (shell, closed) {
        (_, Some(closed)) if !use_shell => {
            (closed, result.model.to_frep_json(&title, mesh.bounds()), 0)
        }
        (Some((m, json, cut)), _) => (m, json, cut),
        (None, _) => unreachable!("the shell is used only when it was built"),
    };
    let text = serde_json::to_string(&model).expect("JSON of numbers");
    outputs.write_path(&a.output, text.as_bytes())?;
    drop(heartbeat);
    let seconds = start.elapsed().as_secs_f64();
    let v = &m.vertex;
    let angle_met = v.mean_angle_deg <= a.target_angle;
    let depth_met = m.mean_all <= a.target_depth;
    let met = angle_met && depth_met;
    let functions = result.model.functions();
    let stop = match result.stop {
        conversion::fit::Stop::Met => "every vertex within the per-vertex targets",
        conversion::fit::Stop::MeanMet => "mean angle and distance within the fit's targets",
        conversion::fit::Stop::Budget => "function budget spent",
        conversion::fit::Stop::SmallestRadius => "smallest radius reached",
    };
    // A model of a mesh with holes differs most in the view that looks into them: when
    // one view's depth error dwarfs the others', that is the cause, and no budget or
    // target helps.
    let (worst_view, worst, others) = {
        let (i, w) = m
            .depth
            .iter()
            .enumerate()
            .map(|(i, d)| (i, d.1.mean_all))
            .fold((0, f64::NEG_INFINITY), |a, b| if b.1 > a.1 { b } else { a });
        let rest: Vec<f64> = (0..m.depth.len())
            .filter(|&j| j != i)
            .map(|j| m.depth[j].1.mean_all)
            .collect();
        let others = rest.iter().sum::<f64>() / rest.len().max(1) as f64;
        (m.depth.get(i).map_or("", |d| d.0), w, others)
    };
    let holes_seen = holed && !depth_met && worst > 3.0 * others;
    let handled_as = if sheet {
        "filled solid (--fill-open)"
    } else if use_shell {
        "shell with openings"
    } else if holed {
        "solid, holes closed"
    } else {
        "solid"
    };
    // Advice that matches the cause, and never what was done already.
    let advice = if met {
        None
    } else if holes_seen && use_shell {
        Some(format!(
            "the model is a shell with openings at {cut} of the mesh's {} boundary loops; \
             the view along {worst_view} still differs most ({:.3}% over all its pixels, \
             against {:.3}% for the other views): the openings follow the holes' outlines \
             only as flat polygons of at most {} corners",
            loops.len(),
            100.0 * worst,
            100.0 * others,
            openings::MAX_CORNERS
        ))
    } else if holes_seen {
        let why = match (a.holes, shell_all) {
            (HolesArg::Close, _) => {
                "; --holes open (or auto) models a shell with an opening at each hole".to_string()
            }
            (_, Some(s)) => format!(
                "; a shell with openings measured worse ({:.3}% over all pixels)",
                100.0 * s
            ),
            (_, None) => "; no hole's outline has an area to cut an opening over".to_string(),
        };
        Some(format!(
            "the mesh has {} boundary edges (holes), which the model closes: the view \
             along {worst_view} looks into them ({:.3}% over all its pixels, against \
             {:.3}% for the other views), so a closed model cannot meet the depth target{why}",
            open.boundary_edges,
            100.0 * worst,
            100.0 * others
        ))
    } else if result.stop == conversion::fit::Stop::Budget {
        Some(format!(
            "the budget of {max_functions} functions was spent: raise --max-functions"
        ))
    } else if sheet {
        Some(
            "the mesh is an open sheet filled into a solid: the model is that solid, not the sheet"
                .to_string(),
        )
    } else if result.stop == conversion::fit::Stop::MeanMet {
        Some(format!(
            "the fit met its own means ({:.2} degrees, distance {:.5}) with {functions} of \
             {max_functions} functions: lower --target-angle to fit further",
            result.mean_angle_deg, result.mean_distance
        ))
    } else {
        Some(format!(
            "the fit stopped at the smallest radius with {functions} of {max_functions} \
             functions: detail finer than the smallest perturbation (or creases and \
             thin parts a smooth function rounds) remains; raising --max-functions will \
             not help"
        ))
    };
    if a.json {
        let views: Vec<_> = m
            .depth
            .iter()
            .map(|(name, d)| {
                json!({"view": name, "mean": d.mean, "mean_all_pixels": d.mean_all,
                       "mean_both_cover": d.mean_both})
            })
            .collect();
        crate::output::print(
            json!({
                "mesh": a.mesh.display().to_string(),
                "output": a.output.display().to_string(),
                "functions": functions,
                "max_functions": max_functions,
                "seconds": seconds,
                "fit_seconds": fit_seconds,
                "met_target": met,
                "targets": {"mean_angle_deg": a.target_angle, "depth_mean_all_pixels": a.target_depth},
                "stop": format!("{:?}", result.stop),
                "advice": advice,
                "levels": result.levels.len(),
                "vertices_over_refine_thresholds": result.over_target,
                "open": {"boundary_edges": open.boundary_edges,
                         "non_manifold_edges": open.non_manifold_edges,
                         "boundary_ratio": open.boundary_ratio,
                         "enclosed_fraction": open.enclosed_fraction,
                         "sheet": sheet,
                         "boundary_loops": loops.len(),
                         "openings": cut,
                         "handled_as": handled_as},
                "holes": {"mode": format!("{:?}", a.holes).to_lowercase(),
                          "closed_depth_mean_all_pixels": closed_all.filter(|_| holed),
                          "open_depth_mean_all_pixels": shell_all},
                "deviation": {
                    "size": a.check_size,
                    "views": 6,
                    "vertex_distance": {"mean": v.mean_distance, "max": v.max_distance},
                    "normal_angle_deg": {"mean": v.mean_angle_deg, "max": v.max_angle_deg},
                    "depth": {"mean": m.mean_depth, "mean_all_pixels": m.mean_all,
                              "mean_both_cover": m.mean_both, "views": views},
                },
                "mean_distance": v.mean_distance,
                "max_distance": v.max_distance,
            })
            .to_string()
                + "\n",
        )?;
    } else {
        let mut out = String::new();
        outln!(
            out,
            "wrote {}: {functions} of {max_functions} functions in {seconds:.1} s ({stop}), \
             {handled_as}",
            a.output.display()
        );
        if holed {
            let closed_text = closed_all.map(|c| format!("{:.4}% closed", 100.0 * c));
            let shell_text = shell_all
                .map(|s| format!("{:.4}% as a shell with {shell_cut} openings", 100.0 * s));
            outln!(
                out,
                "holes:           {} boundary loops; depth over all pixels {}",
                loops.len(),
                [closed_text, shell_text]
                    .into_iter()
                    .flatten()
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        outln!(
            out,
            "vertex distance: mean {:.5}, max {:.5} (unit cube)",
            v.mean_distance,
            v.max_distance
        );
        outln!(
            out,
            "normal angle:    mean {:.2} degrees (target {}: {}), max {:.1}",
            v.mean_angle_deg,
            a.target_angle,
            if angle_met { "met" } else { "not met" },
            v.max_angle_deg
        );
        outln!(
            out,
            "depth buffers:   {:.4}% over all pixels (target {}%: {}), {:.4}% where both \
             see the model, {:.4}% where either does; 6 views of {} px",
            100.0 * m.mean_all,
            100.0 * a.target_depth,
            if depth_met { "met" } else { "not met" },
            100.0 * m.mean_both,
            100.0 * m.mean_depth,
            a.check_size
        );
        if let Some(advice) = &advice {
            outln!(out, "targets not met: {advice}");
        }
        crate::output::print(out)?;
    }
    Ok(())
}

/// Nodes a model with openings adds around the fitted function and the cutters: the
/// transform, the box and its intersection, the shell and the difference.
const SHELL_WRAPPER_NODES: usize = 5;

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
    size: usize,
    views: usize,
    picture: bool,
) -> CliResult<(Measured, Option<Vec<u8>>)> {
    let normals = unit.outward_normals();
    let vertex = deviation::vertex_deviation(field, unit, &normals);
    let n = (size / 2 + 1).clamp(65, 257);
    caoen::budget::check(
        || format!("a {n}^3 field grid"),
        // Values (8 bytes a point), then per cell its top value and step (16) and its
        // flag, while the flags are made.
        (n as u64).pow(3) * 25 + (size * size * 64 * 6) as u64,
    )
    .map_err(|e| CliError::Failed(e.to_string()))?;
    note(global, format!("sampling the field on a {n}^3 grid"));
    let grid = FieldGrid::new(field, n);
    let views = deviation::views(views);
    let mut depth = Vec::new();
    let mut tiles = Vec::new();
    for v in &views {
        let m = deviation::mesh_depth(unit, v, size);
        let f = deviation::field_depth(field, &grid, v, size);
        depth.push((v.name, deviation::compare_depth(&m, &f)));
        if picture {
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
    let picture = picture.then(|| {
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
                measure(
                    global,
                    &field,
                    &unit,
                    a.size as usize,
                    a.views as usize,
                    a.picture.is_some(),
                )?,
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
                measure(
                    global,
                    &rbf,
                    &unit,
                    a.size as usize,
                    a.views as usize,
                    a.picture.is_some(),
                )?,
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
