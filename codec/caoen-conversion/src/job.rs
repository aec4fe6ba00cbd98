//! A whole conversion as `caoen convert` runs it, in one call: the mesh read and
//! checked, open sheets told from solids with holes, the memory bound checked before
//! the fit, the fit, the choice between a closed model and a shell with openings by
//! what each measures, and the verdict against the targets with advice that matches
//! the cause (`docs/conversion.md`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use caoen_base::budget::{Limits, OverBudget};
use serde_json::Value;
use thiserror::Error;

use crate::fit::{self, LevelReport, Progress, Stop};
use crate::measure::{measure, MeasureOptions, Measured};
use crate::mesh_file::{self, MeshError};
use crate::polygon_mesh::Openness;
use crate::{openings, InUnitCube, PolygonMesh};

/// What to do with a solid's holes (boundary loops).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Holes {
    /// Whichever of the closed model and the shell with openings measures closer.
    #[default]
    Auto,
    /// A shell with an opening at each hole, where one can be cut.
    Open,
    /// The closed model only.
    Close,
}

/// The settings of [`convert_file`] and [`convert_mesh`].
#[derive(Debug, Clone, PartialEq)]
pub struct ConvertJob {
    /// The most functions; `None` for [`default_max_functions`].
    pub max_functions: Option<usize>,
    /// The mean normal angle (degrees) the model must reach.
    pub target_angle_deg: f64,
    /// The mean depth error over all pixels the model must reach (fraction of the box).
    pub target_depth: f64,
    /// Side of the depth buffers the model is measured with.
    pub check_size: usize,
    /// The fit's per-vertex deviation target (fraction of the box).
    pub target: f64,
    /// Vertices whose normal is further than this from the gradient are refined too.
    pub max_angle_deg: f64,
    /// Whether an open sheet is converted as the solid its winding number encloses.
    pub fill_open: bool,
    /// What to do with a solid's holes.
    pub holes: Holes,
    /// Sweeps of the local descent after the fit.
    pub descent_sweeps: usize,
    /// The memory the conversion may take.
    pub limits: Limits,
}

impl Default for ConvertJob {
    fn default() -> Self {
        ConvertJob {
            max_functions: None,
            target_angle_deg: 3.0,
            target_depth: 0.002,
            check_size: 256,
            target: 0.001,
            max_angle_deg: 10.0,
            fill_open: false,
            holes: Holes::Auto,
            descent_sweeps: 8,
            limits: Limits::default(),
        }
    }
}

/// What a conversion reports while it works.
#[derive(Debug)]
pub enum Event<'a> {
    /// What is happening now, worth no line of its own (a heartbeat may show it when
    /// nothing else was said for a while).
    Working(&'a str),
    /// A line worth showing: what was found or what starts now.
    Note(&'a str),
    /// A step of the fit starts.
    Phase(&'a str),
    /// A level of the fit is done.
    Level {
        /// The level's number.
        level: usize,
        /// The model's functions so far.
        functions: usize,
        /// The function budget.
        max_functions: usize,
        /// The level's report.
        report: &'a LevelReport,
    },
}

/// Why a conversion failed.
#[derive(Debug, Error)]
pub enum ConvertError {
    /// The mesh could not be read or cannot be converted.
    #[error(transparent)]
    Mesh(#[from] MeshError),
    /// The conversion would need more memory than its limit.
    #[error(transparent)]
    Memory(#[from] OverBudget),
    /// The mesh is an open sheet and `fill_open` was not asked for.
    #[error(
        "{}: an open sheet, not the surface of a solid: {}. Converting it would model a \
         different, closed solid; close the mesh (or give it thickness) first, or pass \
         --fill-open to convert the solid its winding number encloses",
        .mesh.display(), openness_text(.openness)
    )]
    OpenSheet {
        /// The mesh file.
        mesh: PathBuf,
        /// How open it is.
        openness: Openness,
    },
}

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
    /// Whether the mean normal angle met its target.
    pub angle_met: bool,
    /// Whether the depth error met its target.
    pub depth_met: bool,
    /// Advice matching why a target was missed, `None` when both were met.
    pub advice: Option<String>,
}

impl ConvertReport {
    /// Whether both targets were met.
    pub fn met(&self) -> bool {
        self.angle_met && self.depth_met
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

/// Nodes a model with openings adds around the fitted function and the cutters: the
/// transform, the box and its intersection, the shell and the difference.
const SHELL_WRAPPER_NODES: usize = 5;

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

fn openness_text(open: &Openness) -> String {
    format!(
        "{} boundary edges, {} non-manifold edges, boundary length {:.3} of sqrt(area), \
         inside and outside told apart at {:.0}% of probed vertices",
        open.boundary_edges,
        open.non_manifold_edges,
        open.boundary_ratio,
        100.0 * open.enclosed_fraction
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
    events(Event::Working(
        "checking which side is inside (winding numbers)",
    ));
    let open = mesh.openness();
    let sheet = open.is_sheet();
    if sheet && !job.fill_open {
        return Err(ConvertError::OpenSheet {
            mesh: path.to_path_buf(),
            openness: open,
        });
    }
    let kind = if sheet {
        "an open sheet, filled (--fill-open)"
    } else if open.boundary_edges > 0 {
        "a solid with holes"
    } else {
        "a closed surface"
    };
    events(Event::Note(&format!("{kind}: {}", openness_text(&open))));
    let estimate = conversion_memory(mesh);
    job.limits
        .check(|| "the conversion's conditions".into(), estimate)?;
    events(Event::Note(&format!(
        "memory estimate {}",
        caoen_base::budget::human(estimate)
    )));
    let max_functions = job
        .max_functions
        .unwrap_or_else(|| default_max_functions(mesh));
    let opts = fit::ConvertOptions {
        max_functions,
        target: job.target,
        max_angle_deg: job.max_angle_deg,
        descent_sweeps: job.descent_sweeps,
        fit_angle_deg: 0.8 * job.target_angle_deg,
        ..Default::default()
    };
    let fit_start = Instant::now();
    let result = fit::convert(mesh, &opts, &mut |p| match p {
        Progress::Phase(what) => events(Event::Phase(what)),
        Progress::Level(level, functions, report) => events(Event::Level {
            level,
            functions,
            max_functions,
            report,
        }),
    });
    let fit_seconds = fit_start.elapsed().as_secs_f64();
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "mesh".into());
    let title = format!("{name} (converted)");
    events(Event::Note(&format!(
        "measuring the model: {} px depth buffers, 6 views",
        job.check_size
    )));
    let frame = mesh.unit_frame();
    let unit = mesh.transformed(&frame);
    let holed = !sheet && open.boundary_edges > 0;
    let loops = if holed {
        unit.boundary_loops()
    } else {
        Vec::new()
    };
    let measure_opts = MeasureOptions {
        size: job.check_size,
        views: 6,
        picture: false,
        grid: crate::measure::grid_side(job.check_size),
    };
    // A solid with holes may be written as a shell with openings instead: measured
    // like the closed model, on the model file itself.
    let mut shell = None;
    if holed && job.holes != Holes::Close {
        events(Event::Note(&format!(
            "measuring the model with openings at {} boundary loops",
            loops.len()
        )));
        let room = caoen_frep::node::MAX_NODES
            .saturating_sub(result.model.fitted_nodes() + SHELL_WRAPPER_NODES);
        let cuts = openings::openings(&unit, &result.model, &loops, room);
        if !cuts.is_empty() {
            let unit_model = openings::shell_with_openings(
                result.model.fitted_json(),
                &cuts,
                openings::SHELL_THICKNESS,
            );
            let json = result
                .model
                .to_frep_json_of(unit_model, &title, mesh.bounds());
            // A cutter the model file refuses (a patch its checks find degenerate)
            // leaves the closed model rather than failing the fit.
            match caoen_frep::Node::from_json(&json["model"], "model", Path::new("."), &job.limits)
            {
                Ok(node) => {
                    let field = InUnitCube {
                        field: &node,
                        frame,
                    };
                    let (m, _) = measure(&field, &unit, measure_opts, &job.limits)?;
                    shell = Some((m, json, cuts.len()));
                }
                Err(e) => events(Event::Note(&format!("no shell with openings: {e}"))),
            }
        }
    }
    let shell_depth = shell.as_ref().map(|s| s.0.mean_all);
    // The closed model is measured unless the shell was asked for and built.
    let closed = if job.holes == Holes::Open && shell.is_some() {
        None
    } else {
        if holed {
            events(Event::Note("measuring the closed model"));
        }
        Some(measure(&result.model, &unit, measure_opts, &job.limits)?.0)
    };
    let closed_depth = closed.as_ref().map(|m| m.mean_all).filter(|_| holed);
    let use_shell = match (&closed, &shell) {
        (None, Some(_)) => true,
        (Some(c), Some((m, _, _))) => job.holes == Holes::Auto && m.mean_all < c.mean_all,
        _ => false,
    };
    let (measured, model, cut) = match (shell, closed) {
        (_, Some(closed)) if !use_shell => {
            (closed, result.model.to_frep_json(&title, mesh.bounds()), 0)
        }
        (Some((m, json, cut)), _) => (m, json, cut),
        (None, _) => unreachable!("the shell is used only when it was built"),
    };
    let handled_as = if sheet {
        "filled solid (--fill-open)"
    } else if use_shell {
        "shell with openings"
    } else if holed {
        "solid, holes closed"
    } else {
        "solid"
    };
    let mut report = ConvertReport {
        model,
        angle_met: measured.vertex.mean_angle_deg <= job.target_angle_deg,
        depth_met: measured.mean_all <= job.target_depth,
        measured,
        functions: result.model.functions(),
        max_functions,
        stop: result.stop,
        levels: result.levels.len(),
        over_target: result.over_target,
        fit_seconds,
        openness: open,
        sheet,
        boundary_loops: loops.len(),
        openings: cut,
        closed_depth,
        shell_depth,
        handled_as,
        advice: None,
    };
    report.advice = advice(&report, job, (result.mean_angle_deg, result.mean_distance));
    Ok(report)
}

/// Advice that matches why a target was missed, and never what was done already.
fn advice(r: &ConvertReport, job: &ConvertJob, (angle, distance): (f64, f64)) -> Option<String> {
    if r.met() {
        return None;
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
