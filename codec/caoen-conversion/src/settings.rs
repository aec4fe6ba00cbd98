//! What a conversion is asked, what it says while it works and why it fails, and the
//! fit run with a job's settings: shared by the whole conversion and its parts.

use std::path::PathBuf;

use caoen_base::budget::{Limits, OverBudget};
use thiserror::Error;

use crate::fit::{self, LevelReport, Progress};
use crate::mesh_file::MeshError;
use crate::polygon_mesh::Openness;
use crate::thicken::ThicknessError;
use crate::PolygonMesh;

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

/// The settings of a whole conversion (`convert_file`, `convert_mesh`).
#[derive(Debug, Clone, PartialEq)]
pub struct ConvertJob {
    /// The most functions; `None` for the default budget (`job::default_max_functions`).
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
    /// Convert the solid within this distance (mesh units) of the mesh's triangles
    /// instead of the mesh ([`crate::thicken`]).
    pub thicken: Option<f64>,
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
            thicken: None,
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
    /// A line to show even when notes are not: something is wrong with the result.
    Warning(&'a str),
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
    /// The converted model's own file cannot be loaded back.
    #[error("the converted model cannot be loaded back: {0}")]
    Model(String),
    /// The `thicken` thickness is out of range.
    #[error(transparent)]
    Thickness(#[from] ThicknessError),
    /// The mesh is an open sheet and `fill_open` was not asked for.
    #[error(
        "{}: an open sheet, not the surface of a solid: {}. Converting it would model a \
         different, closed solid; close the mesh first, pass --thicken T to convert the \
         solid within T of it, or --fill-open to convert the solid its winding number \
         encloses{}",
        .mesh.display(), openness_text(.openness), parts_text(.parts)
    )]
    OpenSheet {
        /// The mesh file.
        mesh: PathBuf,
        /// How open it is.
        openness: Openness,
        /// Its connected parts, and of them the sheets (each a sheet by itself).
        parts: (usize, usize),
    },
}

fn parts_text(&(parts, sheets): &(usize, usize)) -> String {
    match parts {
        0 | 1 => String::new(),
        n if sheets == 0 => {
            format!(" (its {n} connected parts are too many to convert one by one)")
        }
        n => format!(" ({sheets} of its {n} connected parts are open sheets by themselves)"),
    }
}

/// How open a mesh is, in one line.
pub(crate) fn openness_text(open: &Openness) -> String {
    format!(
        "{} boundary edges, {} non-manifold edges, boundary length {:.3} of sqrt(area), \
         inside and outside told apart at {:.0}% of probed vertices",
        open.boundary_edges,
        open.non_manifold_edges,
        open.boundary_ratio,
        100.0 * open.enclosed_fraction
    )
}

/// The fit of `mesh` with `max_functions`, its progress as events.
pub(crate) fn run_fit(
    mesh: &PolygonMesh,
    job: &ConvertJob,
    max_functions: usize,
    events: &mut dyn FnMut(Event<'_>),
) -> fit::Conversion {
    let opts = fit::ConvertOptions {
        max_functions,
        target: job.target,
        max_angle_deg: job.max_angle_deg,
        descent_sweeps: job.descent_sweeps,
        fit_angle_deg: 0.8 * job.target_angle_deg,
        ..Default::default()
    };
    fit::convert(mesh, &opts, &mut |p| match p {
        Progress::Phase(what) => events(Event::Phase(what)),
        Progress::Level(level, functions, report) => events(Event::Level {
            level,
            functions,
            max_functions,
            report,
        }),
    })
}
