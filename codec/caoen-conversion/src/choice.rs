//! The model written for one fit of a whole mesh: the closed model or, for a solid
//! with holes, a shell with an opening at each hole, whichever measures closer to the
//! mesh (or the one asked for).

use std::path::Path;

use serde_json::Value;

use crate::fit;
use crate::measure::{measure, MeasureOptions, Measured};
use crate::polygon_mesh::Openness;
use crate::settings::{ConvertError, ConvertJob, Event, Holes};
use crate::{openings, InUnitCube, PolygonMesh};

/// Nodes a model with openings adds around the fitted function and the cutters: the
/// transform, the box and its intersection, the shell and the difference.
const SHELL_WRAPPER_NODES: usize = 5;

/// The model written for one fit, as measured.
pub(crate) struct Chosen {
    pub(crate) measured: Measured,
    pub(crate) model: Value,
    pub(crate) openings: usize,
    pub(crate) closed_depth: Option<f64>,
    pub(crate) shell_depth: Option<f64>,
    pub(crate) boundary_loops: usize,
    pub(crate) handled_as: &'static str,
}

/// The closed model of a fit or, for a solid with holes, the shell with openings when
/// it measures closer (or was asked for).
#[allow(clippy::too_many_arguments)]
pub(crate) fn choose_model(
    mesh: &PolygonMesh,
    unit: &PolygonMesh,
    open: &Openness,
    sheet: bool,
    result: &fit::Conversion,
    title: &str,
    job: &ConvertJob,
    events: &mut dyn FnMut(Event<'_>),
) -> Result<Chosen, ConvertError> {
    events(Event::Note(&format!(
        "measuring the model: {} px depth buffers, 6 views",
        job.check_size
    )));
    let frame = mesh.unit_frame();
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
        let cuts = openings::openings(unit, &result.model, &loops, room);
        if !cuts.is_empty() {
            let unit_model = openings::shell_with_openings(
                result.model.fitted_json(),
                &cuts,
                openings::SHELL_THICKNESS,
            );
            let json = result
                .model
                .to_frep_json_of(unit_model, title, mesh.bounds());
            // A cutter the model file refuses (a patch its checks find degenerate)
            // leaves the closed model rather than failing the fit.
            match caoen_frep::Node::from_json(&json["model"], "model", Path::new("."), &job.limits)
            {
                Ok(node) => {
                    let field = InUnitCube {
                        field: &node,
                        frame,
                    };
                    let (m, _) = measure(&field, unit, measure_opts, &job.limits)?;
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
        Some(measure(&result.model, unit, measure_opts, &job.limits)?.0)
    };
    let closed_depth = closed.as_ref().map(|m| m.mean_all).filter(|_| holed);
    let use_shell = match (&closed, &shell) {
        (None, Some(_)) => true,
        (Some(c), Some((m, _, _))) => job.holes == Holes::Auto && m.mean_all < c.mean_all,
        _ => false,
    };
    let (measured, model, cut) = match (shell, closed) {
        (_, Some(closed)) if !use_shell => {
            (closed, result.model.to_frep_json(title, mesh.bounds()), 0)
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
    Ok(Chosen {
        measured,
        model,
        openings: cut,
        closed_depth,
        shell_depth,
        boundary_loops: loops.len(),
        handled_as,
    })
}
