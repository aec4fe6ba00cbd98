//! A whole conversion as `caoen convert` runs it, in one call: the mesh read and
//! checked, open sheets told from solids with holes, the memory bound checked before
//! the fit, the fit, the choice between a closed model and a shell with openings by
//! what each measures, and the verdict against the targets with advice that matches
//! the cause (`docs/conversion.md`).

use std::path::Path;
use std::time::Instant;

use caoen_base::budget::Limits;
use serde_json::Value;

use crate::choice::{choose_model, Chosen};
use crate::components::{self, Part};
use crate::fit::{self, Stop};
use crate::measure::{measure, MeasureOptions, Measured};
use crate::mesh_file;
use crate::polygon_mesh::Openness;
use crate::settings::{openness_text, run_fit};
pub use crate::settings::{ConvertError, ConvertJob, Event, Holes};
use crate::thicken;
use crate::{openings, parts, InUnitCube, PolygonMesh};

/// The outcome of a conversion.
#[derive(Debug, Clone)]
pub struct ConvertReport {
    /// The model file (F-rep JSON) to write.
    pub model: Value,
    /// The written model's deviation from the mesh.
    pub measured: Measured,
    /// Functions of the fitted model.
    pub functions: usize,
    /// The function budget the fit had.
    pub max_functions: usize,
    /// Why the fit stopped.
    pub stop: Stop,
    /// Levels the fit ran.
    pub levels: usize,
    /// Vertices over the fit's refinement thresholds at the end.
    pub over_target: usize,
    /// Seconds the fit took (the measurement excluded).
    pub fit_seconds: f64,
    /// How open the mesh is.
    pub openness: Openness,
    /// Whether the mesh is an open sheet (converted filled).
    pub sheet: bool,
    /// The mesh's boundary loops, for a solid with holes.
    pub boundary_loops: usize,
    /// Openings the written model cuts (0 for a closed model).
    pub openings: usize,
    /// The closed model's depth error over all pixels, where it was measured on a holed mesh.
    pub closed_depth: Option<f64>,
    /// The shell's depth error over all pixels, where one was built.
    pub shell_depth: Option<f64>,
    /// How the mesh was modelled, in words.
    pub handled_as: &'static str,
    /// The mesh's connected parts converted one by one and united (0: converted whole).
    pub parts: usize,
    /// The thickness (mesh units) the mesh was given, if it was thickened.
    pub thickness: Option<f64>,
    /// The written model's connected parts (0 where they could not be counted).
    pub model_parts: usize,
    /// Parts of the fitted model that match nothing in the mesh, cut out of the model.
    pub removed: Vec<Part>,
    /// Parts of the written model that match nothing in the mesh and could not be cut.
    pub spurious: Vec<Part>,
    /// Whether the mean normal angle met its target.
    pub angle_met: bool,
    /// Whether the depth error met its target.
    pub depth_met: bool,
    /// Advice matching why a target was missed, `None` when both were met.
    pub advice: Option<String>,
}

impl ConvertReport {
    /// Whether both targets were met and the model has no part the mesh lacks.
    pub fn met(&self) -> bool {
        self.angle_met && self.depth_met && self.spurious.is_empty()
    }

    /// Why the fit stopped, in words.
    pub fn stop_text(&self) -> &'static str {
        match self.stop {
            Stop::Met => "every vertex within the per-vertex targets",
            Stop::MeanMet => "mean angle and distance within the fit's targets",
            Stop::Budget => "function budget spent",
            Stop::SmallestRadius => "smallest radius reached",
        }
    }
}

/// The default function budget: 6000, or 3 per vertex on a mesh with more detail, up
/// to 9000 (a model file holds at most 10,000 nodes).
pub fn default_max_functions(mesh: &PolygonMesh) -> usize {
    (3 * mesh.positions.len()).clamp(6000, 9000)
}

/// Peak memory of the fit: a few dozen numbers per sample and per condition (three
/// conditions a sample), and each thread its own rows, bounded by 1000 bytes a
/// condition (1.6 GiB measured for 400,000 triangles on two threads, 2.75 GiB on
/// more; 448 MiB for the 69,451-triangle Stanford bunny, estimated 1.4 GiB). Samples
/// are the fit's vertices and at most [`fit::MAX_SAMPLES`] points in the triangles;
/// the mesh's own tables take about 100 bytes a triangle.
pub fn conversion_memory(mesh: &PolygonMesh) -> u64 {
    let samples = mesh.positions.len().min(fit::MAX_FIT_VERTICES) as u64 + fit::MAX_SAMPLES as u64;
    samples * 3 * 1000 + mesh.triangles.len() as u64 * 100
}

/// The mesh's size and closedness in one line.
pub fn topology_text(mesh: &PolygonMesh) -> String {
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

/// Reads the mesh at `path` and converts it ([`convert_mesh`]).
pub fn convert_file(
    path: &Path,
    job: &ConvertJob,
    events: &mut dyn FnMut(Event<'_>),
) -> Result<ConvertReport, ConvertError> {
    events(Event::Working("reading"));
    let mesh = mesh_file::read(path, &job.limits)?;
    mesh_file::check_convertible(&mesh, &path.display().to_string())?;
    events(Event::Note(&format!(
        "{}: {}",
        path.display(),
        topology_text(&mesh)
    )));
    convert_mesh(&mesh, path, job, events)
}

/// Converts `mesh` (read from `path`, which names the model and the messages).
pub fn convert_mesh(
    mesh: &PolygonMesh,
    path: &Path,
    job: &ConvertJob,
    events: &mut dyn FnMut(Event<'_>),
) -> Result<ConvertReport, ConvertError> {
    if let Some(thickness) = job.thicken {
        return convert_thickened(mesh, path, job, thickness, events);
    }
    events(Event::Working(
        "checking which side is inside (winding numbers)",
    ));
    let open = mesh.openness();
    let sheet = open.is_sheet() && job.fill_open;
    // A sheet as a whole may be parts that each enclose a solid, their small
    // openings summed over one area.
    let split = if open.is_sheet() && !job.fill_open {
        events(Event::Working("classifying the mesh's connected parts"));
        match parts::solid_parts(mesh) {
            Ok(p) => p,
            Err(counts) => {
                return Err(ConvertError::OpenSheet {
                    mesh: path.to_path_buf(),
                    openness: open,
                    parts: counts,
                })
            }
        }
    } else {
        Vec::new()
    };
    let kind = if sheet {
        "an open sheet, filled (--fill-open)".to_string()
    } else if !split.is_empty() {
        format!(
            "{} connected parts, each a solid by itself, converted one by one",
            split.len()
        )
    } else if open.boundary_edges > 0 {
        "a solid with holes".to_string()
    } else {
        "a closed surface".to_string()
    };
    events(Event::Note(&format!("{kind}: {}", openness_text(&open))));
    let estimate = conversion_memory(mesh)
        + components::components_memory(mesh.triangles.len())
        + if split.is_empty() {
            0
        } else {
            parts::parts_memory(mesh)
        };
    job.limits
        .check(|| "the conversion's conditions".into(), estimate)?;
    events(Event::Note(&format!(
        "memory estimate {}",
        caoen_base::budget::human(estimate)
    )));
    let max_functions = job
        .max_functions
        .unwrap_or_else(|| default_max_functions(mesh));
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "mesh".into());
    let title = format!("{name} (converted)");
    let frame = mesh.unit_frame();
    let unit = mesh.transformed(&frame);
    let measure_opts = MeasureOptions {
        size: job.check_size,
        views: 6,
        picture: false,
        grid: crate::measure::grid_side(job.check_size),
    };
    // The mesh the model is measured and its parts matched against: for parts
    // converted one by one, without the triangles hidden inside other parts.
    let mut seen = unit.clone();
    let fit_start = Instant::now();
    // The parts are counted on the closed model: a shell's wall is thinner than the
    // check's grid, which would break it into grains.
    let (fitted, mut chosen, closed) = if split.is_empty() {
        let result = run_fit(mesh, job, max_functions, events);
        let fit_seconds = fit_start.elapsed().as_secs_f64();
        let chosen = choose_model(mesh, &unit, &open, sheet, &result, &title, job, events)?;
        let closed = result.model.to_frep_json(&title, mesh.bounds());
        (FitSummary::of(&[result], fit_seconds), chosen, closed)
    } else {
        let (union, results) = parts::fit_parts(&split, job, max_functions, &title, events);
        let fit_seconds = fit_start.elapsed().as_secs_f64();
        events(Event::Note(
            "measuring the united parts on the triangles no other part hides",
        ));
        seen = parts::visible(&split).transformed(&frame);
        let measured = measure_file(&union, &seen, frame, measure_opts, &job.limits)?;
        let chosen = Chosen {
            measured,
            model: union.clone(),
            openings: 0,
            closed_depth: None,
            shell_depth: None,
            boundary_loops: 0,
            handled_as: "parts converted one by one and united",
        };
        (FitSummary::of(&results, fit_seconds), chosen, union)
    };
    // Every part of the model must match a part of the mesh: a spurious one is cut
    // out where it can be, else reported.
    events(Event::Note(&format!(
        "checking the model's connected parts against the mesh ({}^3 grid)",
        components::GRID
    )));
    let found = components::of_file(&closed, &seen, frame, &job.limits);
    let (mut removed, mut spurious) = (Vec::new(), Vec::new());
    let mut model_parts = found.as_ref().map_or(0, |f| f.parts.len());
    if let Some(found) = found.filter(|f| !f.spurious().is_empty()) {
        let boxes = components::cut_boxes(&found, &seen, &frame);
        let again = boxes.as_ref().and_then(|b| {
            components::of_file(&components::without(&closed, b), &seen, frame, &job.limits)
        });
        let bad: Vec<Part> = found.spurious().into_iter().cloned().collect();
        match (boxes, again) {
            (Some(boxes), Some(again)) if again.spurious().is_empty() => {
                let cut = components::without(&chosen.model, &boxes);
                for p in &bad {
                    events(Event::Note(&format!(
                        "cut out a spurious part: {}",
                        components::part_text(p)
                    )));
                }
                events(Event::Note("measuring the model without them"));
                chosen.measured = measure_file(&cut, &seen, frame, measure_opts, &job.limits)?;
                chosen.model = cut;
                model_parts = again.parts.len();
                removed = bad;
            }
            _ => {
                for p in &bad {
                    events(Event::Warning(&format!(
                        "the model has a part the mesh lacks, which could not be cut out: {}",
                        components::part_text(p)
                    )));
                }
                spurious = bad;
            }
        }
    }
    let measured = chosen.measured;
    let mut report = ConvertReport {
        model: chosen.model,
        angle_met: measured.vertex.mean_angle_deg <= job.target_angle_deg,
        depth_met: measured.mean_all <= job.target_depth,
        measured,
        functions: fitted.functions,
        max_functions,
        stop: fitted.stop,
        levels: fitted.levels,
        over_target: fitted.over_target,
        fit_seconds: fitted.fit_seconds,
        openness: open,
        sheet,
        boundary_loops: chosen.boundary_loops,
        openings: chosen.openings,
        closed_depth: chosen.closed_depth,
        shell_depth: chosen.shell_depth,
        handled_as: chosen.handled_as,
        parts: split.len(),
        thickness: None,
        model_parts,
        removed,
        spurious,
        advice: None,
    };
    report.advice = advice(&report, job, (fitted.mean_angle_deg, fitted.mean_distance));
    Ok(report)
}

/// The solid within `thickness` of `mesh`'s triangles, converted.
fn convert_thickened(
    mesh: &PolygonMesh,
    path: &Path,
    job: &ConvertJob,
    thickness: f64,
    events: &mut dyn FnMut(Event<'_>),
) -> Result<ConvertReport, ConvertError> {
    let t = thicken::relative(mesh, thickness)?;
    let estimate = thicken::thicken_memory(mesh, t);
    job.limits
        .check(|| "thickening the mesh".into(), estimate)?;
    events(Event::Note(&format!(
        "thickening: the solid within {thickness} of the mesh's triangles ({:.4} of the \
         box), polygonised and decimated (memory estimate {})",
        t,
        caoen_base::budget::human(estimate)
    )));
    let thick = thicken::thickened(mesh, t);
    events(Event::Note(&format!(
        "thickened: {}",
        topology_text(&thick)
    )));
    let inner = ConvertJob {
        thicken: None,
        fill_open: false,
        ..job.clone()
    };
    let mut report = convert_mesh(&thick, path, &inner, events)?;
    report.thickness = Some(thickness);
    report.handled_as = "the solid within the thickness of the mesh (--thicken)";
    Ok(report)
}

/// The model file `file` measured against the unit-cube mesh `unit`.
fn measure_file(
    file: &Value,
    unit: &PolygonMesh,
    frame: crate::UnitFrame,
    opts: MeasureOptions,
    limits: &Limits,
) -> Result<Measured, ConvertError> {
    let node = caoen_frep::Node::from_json(&file["model"], "model", Path::new("."), limits)
        .map_err(|e| ConvertError::Model(e.to_string()))?;
    let field = InUnitCube {
        field: &node,
        frame,
    };
    Ok(measure(&field, unit, opts, limits)?.0)
}

/// What the fit or fits of a conversion came to.
struct FitSummary {
    functions: usize,
    stop: Stop,
    levels: usize,
    over_target: usize,
    fit_seconds: f64,
    mean_angle_deg: f64,
    mean_distance: f64,
}

impl FitSummary {
    /// The fits of a mesh's parts (or its one fit) together: the largest part's stop
    /// unless a budget was spent, means weighted by functions.
    fn of(results: &[fit::Conversion], fit_seconds: f64) -> FitSummary {
        let functions: usize = results.iter().map(|r| r.model.functions()).sum();
        let mean = |f: &dyn Fn(&fit::Conversion) -> f64| {
            results
                .iter()
                .map(|r| f(r) * r.model.functions() as f64)
                .sum::<f64>()
                / functions.max(1) as f64
        };
        let stop = if results.iter().any(|r| r.stop == Stop::Budget) {
            Stop::Budget
        } else {
            results.first().map_or(Stop::Met, |r| r.stop)
        };
        FitSummary {
            functions,
            stop,
            levels: results.iter().map(|r| r.levels.len()).max().unwrap_or(0),
            over_target: results.iter().map(|r| r.over_target).sum(),
            fit_seconds,
            mean_angle_deg: mean(&|r| r.mean_angle_deg),
            mean_distance: mean(&|r| r.mean_distance),
        }
    }
}

/// Advice that matches why a target was missed, and never what was done already.
fn advice(r: &ConvertReport, job: &ConvertJob, (angle, distance): (f64, f64)) -> Option<String> {
    if r.met() {
        return None;
    }
    if let Some(p) = r.spurious.first() {
        return Some(format!(
            "the model has {} part(s) that match nothing in the mesh and reach too near \
             it to be cut out with a box, the largest {}: the fit left surface between its \
             conditions there; a `difference` with a solid over that place in the model \
             file removes it",
            r.spurious.len(),
            components::part_text(p)
        ));
    }
    let m = &r.measured;
    let holed = !r.sheet && r.openness.boundary_edges > 0;
    // A model of a mesh with holes differs most in the view that looks into them: when
    // one view's depth error dwarfs the others', that is the cause, and no budget or
    // target helps.
    let (i, worst) = m
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
    let worst_view = m.depth.get(i).map_or("", |d| d.0);
    let holes_seen = holed && !r.depth_met && worst > 3.0 * others;
    let (functions, max_functions) = (r.functions, r.max_functions);
    Some(if holes_seen && r.openings > 0 {
        format!(
            "the model is a shell with openings at {} of the mesh's {} boundary loops; \
             the view along {worst_view} still differs most ({:.3}% over all its pixels, \
             against {:.3}% for the other views): the openings follow the holes' outlines \
             only as flat polygons of at most {} corners",
            r.openings,
            r.boundary_loops,
            100.0 * worst,
            100.0 * others,
            openings::MAX_CORNERS
        )
    } else if holes_seen {
        let why = match (job.holes, r.shell_depth) {
            (Holes::Close, _) => {
                "; --holes open (or auto) models a shell with an opening at each hole".to_string()
            }
            (_, Some(s)) => format!(
                "; a shell with openings measured worse ({:.3}% over all pixels)",
                100.0 * s
            ),
            (_, None) => "; no hole's outline has an area to cut an opening over".to_string(),
        };
        format!(
            "the mesh has {} boundary edges (holes), which the model closes: the view \
             along {worst_view} looks into them ({:.3}% over all its pixels, against \
             {:.3}% for the other views), so a closed model cannot meet the depth target{why}",
            r.openness.boundary_edges,
            100.0 * worst,
            100.0 * others
        )
    } else if r.stop == Stop::Budget {
        format!("the budget of {max_functions} functions was spent: raise --max-functions")
    } else if r.sheet {
        "the mesh is an open sheet filled into a solid: the model is that solid, not the sheet"
            .to_string()
    } else if r.stop == Stop::MeanMet {
        format!(
            "the fit met its own means ({angle:.2} degrees, distance {distance:.5}) with \
             {functions} of {max_functions} functions: lower --target-angle to fit further"
        )
    } else {
        format!(
            "the fit stopped at the smallest radius with {functions} of {max_functions} \
             functions: detail finer than the smallest perturbation (or creases and \
             thin parts a smooth function rounds) remains; raising --max-functions will \
             not help"
        )
    })
}
