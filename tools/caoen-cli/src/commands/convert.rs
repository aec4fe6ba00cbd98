//! `caoen convert` and `caoen deviation`: polygon meshes into implicit models, and
//! how far a model is from its mesh (`docs/conversion.md`).

use std::path::Path;
use std::time::Instant;

use caoen::conversion::job::{self, ConvertJob, ConvertReport, Event, Holes};
use caoen::conversion::{self, measure, InUnitCube, MeasureOptions, Measured, PolygonMesh};
use caoen::render::scene::Shape;
use serde_json::json;

use crate::cli::{show_duration, ConvertArgs, DeviationArgs, GlobalArgs, HolesArg};
use crate::commands::note;
use crate::failure::{CliError, CliResult};
use crate::output::Outputs;

fn read_mesh(path: &Path, limits: &caoen::Limits) -> CliResult<PolygonMesh> {
    conversion::read(path, limits).map_err(CliError::library)
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
    if a.json && crate::output::is_stdout(&a.output) {
        return Err(CliError::Usage(
            "-o - and --json: the model takes standard output; the summary cannot".into(),
        ));
    }
    let heartbeat = Heartbeat::start(global.quiet, start);
    let job = ConvertJob {
        max_functions: a.max_functions.map(|n| n as usize),
        target_angle_deg: a.target_angle,
        target_depth: a.target_depth,
        check_size: a.check_size as usize,
        target: a.target,
        max_angle_deg: a.max_angle,
        fill_open: a.fill_open,
        thicken: a.thicken,
        holes: match a.holes {
            HolesArg::Auto => Holes::Auto,
            HolesArg::Open => Holes::Open,
            HolesArg::Close => Holes::Close,
        },
        descent_sweeps: a.descent as usize,
        limits: global.limits.clone(),
    };
    let report = job::convert_file(&a.mesh, &job, &mut |e| match e {
        Event::Working(what) => heartbeat.phase(what, false),
        Event::Note(line) => {
            note(global, line);
            heartbeat.phase(line, true);
        }
        Event::Warning(line) => {
            eprintln!("warning: {line}");
            heartbeat.phase(line, true);
        }
        Event::Phase(what) => {
            note(
                global,
                format!("{what} ({:.1} s)", start.elapsed().as_secs_f64()),
            );
            heartbeat.phase(what, true);
        }
        Event::Level {
            level,
            functions,
            max_functions,
            report: r,
        } => {
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
    })?;
    let text = serde_json::to_string(&report.model).expect("JSON of numbers");
    outputs.write_path(&a.output, text.as_bytes())?;
    drop(heartbeat);
    let seconds = start.elapsed().as_secs_f64();
    if a.json {
        crate::output::print(convert_json(a, &report, seconds).to_string() + "\n")
    } else if crate::output::is_stdout(&a.output) {
        // The model has standard output: the summary goes beside the other notes.
        note(global, convert_text(a, &report, seconds).trim_end());
        Ok(())
    } else {
        crate::output::print(convert_text(a, &report, seconds))
    }
}

/// `caoen convert --json`'s summary.
fn convert_json(a: &ConvertArgs, r: &ConvertReport, seconds: f64) -> serde_json::Value {
    let (m, v, open) = (&r.measured, &r.measured.vertex, &r.openness);
    let views: Vec<_> = m
        .depth
        .iter()
        .map(|(name, d)| {
            json!({"view": name, "mean": d.mean, "mean_all_pixels": d.mean_all,
                   "mean_both_cover": d.mean_both})
        })
        .collect();
    json!({
        "mesh": a.mesh.display().to_string(),
        "output": a.output.display().to_string(),
        "functions": r.functions,
        "max_functions": r.max_functions,
        "seconds": seconds,
        "fit_seconds": r.fit_seconds,
        "met_target": r.met(),
        "targets": {"mean_angle_deg": a.target_angle, "depth_mean_all_pixels": a.target_depth},
        "stop": format!("{:?}", r.stop),
        "advice": r.advice,
        "levels": r.levels,
        "vertices_over_refine_thresholds": r.over_target,
        "open": {"boundary_edges": open.boundary_edges,
                 "non_manifold_edges": open.non_manifold_edges,
                 "boundary_ratio": open.boundary_ratio,
                 "enclosed_fraction": open.enclosed_fraction,
                 "sheet": r.sheet,
                 "boundary_loops": r.boundary_loops,
                 "openings": r.openings,
                 "handled_as": r.handled_as,
                 "parts": r.parts,
                 "thickness": r.thickness},
        "components": {"parts": r.model_parts,
                       "removed": r.removed.iter().map(part_json).collect::<Vec<_>>(),
                       "spurious": r.spurious.iter().map(part_json).collect::<Vec<_>>()},
        "holes": {"mode": format!("{:?}", a.holes).to_lowercase(),
                  "closed_depth_mean_all_pixels": r.closed_depth,
                  "open_depth_mean_all_pixels": r.shell_depth},
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
}

/// A part of a model that matches nothing in the mesh, for `--json`.
fn part_json(p: &caoen::conversion::components::Part) -> serde_json::Value {
    json!({"volume": p.volume, "lo": p.lo, "hi": p.hi, "near_fraction": p.near_fraction})
}

/// `caoen convert`'s summary as text.
fn convert_text(a: &ConvertArgs, r: &ConvertReport, seconds: f64) -> String {
    let (m, v) = (&r.measured, &r.measured.vertex);
    let mut out = String::new();
    outln!(
        out,
        "wrote {}: {} of {} functions in {seconds:.1} s ({}), {}",
        crate::output::shown(&a.output),
        r.functions,
        r.max_functions,
        r.stop_text(),
        r.handled_as
    );
    if r.closed_depth.is_some() || r.shell_depth.is_some() {
        let closed_text = r.closed_depth.map(|c| format!("{:.4}% closed", 100.0 * c));
        let shell_text = r
            .shell_depth
            .map(|s| format!("{:.4}% as a shell with {} openings", 100.0 * s, r.openings));
        outln!(
            out,
            "holes:           {} boundary loops; depth over all pixels {}",
            r.boundary_loops,
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
    let met = |yes: bool| if yes { "met" } else { "not met" };
    outln!(
        out,
        "normal angle:    mean {:.2} degrees (target {}: {}), max {:.1}",
        v.mean_angle_deg,
        a.target_angle,
        met(r.angle_met),
        v.max_angle_deg
    );
    outln!(
        out,
        "depth buffers:   {:.4}% over all pixels (target {}%: {}), {:.4}% where both \
         see the model, {:.4}% where either does; 6 views of {} px",
        100.0 * m.mean_all,
        100.0 * a.target_depth,
        met(r.depth_met),
        100.0 * m.mean_both,
        100.0 * m.mean_depth,
        a.check_size
    );
    for (what, list) in [("cut out", &r.removed), ("NOT cut out", &r.spurious)] {
        for p in list.iter() {
            outln!(
                out,
                "spurious part {what}: {}",
                conversion::components::part_text(p)
            );
        }
    }
    if let Some(advice) = &r.advice {
        outln!(out, "targets not met: {advice}");
    }
    out
}

/// Measures `field` against `unit` as `caoen deviation` asks, the picture as PNG bytes,
/// and the side of the views it measured with: smaller than asked when the field is so
/// costly that the asked one would take longer than `--max-work`.
fn measure_png(
    global: &GlobalArgs,
    field: &dyn conversion::ImplicitField,
    unit: &PolygonMesh,
    mut opts: MeasureOptions,
) -> CliResult<(Measured, Option<Vec<u8>>, usize)> {
    let limit = global.max_work.unwrap_or(crate::cli::DEVIATION_MAX_WORK);
    let per_eval = measure::evaluation_seconds(field);
    let vertices = unit.positions.len();
    let cpu = |o: &MeasureOptions| measure::measure_evaluations(o, vertices) * per_eval;
    let asked = opts;
    // The views shrink by quarters, then the lattice by halves (65, 33, 17): each step
    // about halves the evaluations.
    while cpu(&opts) > limit && (opts.size > 16 || opts.grid > 17) {
        if opts.size > 16 {
            opts.size = (opts.size * 3 / 4).max(16);
            opts.grid = measure::grid_side(opts.size);
        } else {
            opts.grid = opts.grid / 2 + 1;
        }
    }
    let cost = format!(
        "the field costs {:.1} us an evaluation; at --size {} the measurement needs \
         about {} of CPU time",
        per_eval * 1e6,
        asked.size,
        show_duration(cpu(&asked))
    );
    if cpu(&opts) > limit {
        return Err(CliError::Failed(format!(
            "{cost}, and about {} even at --size 16 on a {}^3 grid; the limit is {}: raise \
             it with --max-work {}",
            show_duration(cpu(&opts)),
            opts.grid,
            show_duration(limit),
            show_duration(cpu(&asked).max(1.0) * 1.05)
        )));
    }
    let n = opts.grid;
    if opts != asked {
        note(
            global,
            format!(
                "{cost}: measuring at --size {} on a {n}^3 grid instead, about {} (the \
                 limit is {}; raise --max-work to measure as asked)",
                opts.size,
                show_duration(cpu(&opts)),
                show_duration(limit)
            ),
        );
    }
    note(
        global,
        format!(
            "sampling the field on a {n}^3 grid (about {} of CPU time)",
            show_duration(cpu(&opts))
        ),
    );
    // Nothing else is printed while the field is sampled: a line every few seconds
    // shows the work goes on.
    let heartbeat = Heartbeat::start(global.quiet, Instant::now());
    heartbeat.phase(&format!("sampling the field on a {n}^3 grid"), true);
    let (m, picture) = measure(field, unit, opts, &global.limits.clone())?;
    drop(heartbeat);
    let png = picture
        .map(|p| caoen::image_io::encode(&p, caoen::image_io::OutputFormat::Png8))
        .transpose()?;
    Ok((m, png, opts.size))
}

/// `caoen deviation MESH MODEL.json` or `caoen deviation MESH --rbf N`.
pub fn deviation(global: &GlobalArgs, a: &DeviationArgs) -> CliResult {
    let mut outputs = Outputs::new(global.force)
        .input(&a.mesh)
        .input_opt(a.model.as_ref());
    if let Some(p) = &a.picture {
        outputs.check_path(p)?;
        if a.json && crate::output::is_stdout(p) {
            return Err(CliError::Usage(
                "--picture - and --json: the picture takes standard output; the summary cannot"
                    .into(),
            ));
        }
    }
    let picture_on_stdout = a.picture.as_deref().is_some_and(crate::output::is_stdout);
    let mesh = read_mesh(&a.mesh, &global.limits)?;
    let frame = mesh.unit_frame();
    let unit = mesh.transformed(&frame);
    let start = Instant::now();
    let measure_opts = MeasureOptions {
        size: a.size as usize,
        views: a.views as usize,
        picture: a.picture.is_some(),
        grid: conversion::measure::grid_side(a.size as usize),
    };
    let (what, numbers, (m, picture, size)) = match (&a.model, a.rbf) {
        (Some(path), _) => {
            let scene = crate::commands::frep::load(path, &global.limits)?;
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
                measure_png(global, &field, &unit, measure_opts)?,
            )
        }
        (None, Some(n)) => {
            note(global, format!("fitting the RBF baseline with {n} centres"));
            let normals = unit.outward_normals();
            let rbf =
                conversion::rbf_baseline::fit(&unit, &normals, n as usize, 0.01, &global.limits)
                    .map_err(CliError::library)?;
            (
                format!("RBF baseline, {} centres", rbf.centres.len()),
                rbf.numbers(),
                measure_png(global, &rbf, &unit, measure_opts)?,
            )
        }
        (None, None) => return Err(CliError::Usage("give a model file or --rbf N".into())),
    };
    if let (Some(p), Some(bytes)) = (&a.picture, &picture) {
        outputs.write_path(p, bytes)?;
        note(global, format!("wrote {}", crate::output::shown(p)));
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
                "view_size": size,
                "seconds": seconds,
            })
            .to_string()
                + "\n",
        )?;
    } else {
        let out = summary_text(a, &mesh, &what, numbers, &m, size);
        if picture_on_stdout {
            // The picture has standard output: the summary goes beside the other notes.
            note(global, out.trim_end());
        } else {
            crate::output::print(out)?;
        }
    }
    Ok(())
}

/// The text summary of a deviation measurement: the mesh, the model, the distances and
/// angles at the vertices and the depth buffers' differences, view by view.
fn summary_text(
    a: &DeviationArgs,
    mesh: &PolygonMesh,
    what: &str,
    numbers: usize,
    m: &Measured,
    size: usize,
) -> String {
    let v = &m.vertex;
    let mut out = String::new();
    outln!(
        out,
        "mesh:            {} ({})",
        a.mesh.display(),
        job::topology_text(mesh)
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
        size
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
    out
}
