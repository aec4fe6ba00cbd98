//! The conversion example: the test cow (`tests/data/meshes/spot.obj`, built into the
//! binary) converted by `caoen convert`, and `caoen deviation`'s picture of the model
//! ray cast beside the mesh.

use std::path::Path;

use crate::cli::{ConvertArgs, DeviationArgs, GlobalArgs};
use crate::commands::convert::{convert, deviation};
use crate::failure::{CliError, CliResult};

/// Keenan Crane's spot (CC0).
const SPOT_OBJ: &[u8] = include_bytes!("../../../../../tests/data/meshes/spot.obj");

pub(super) fn write(global: &GlobalArgs, dir: &Path) -> CliResult {
    let sub = dir.join("conversion");
    std::fs::create_dir_all(&sub).map_err(|e| CliError::io(&sub, e))?;
    // The commands run with --force: replacing their own earlier output is the job.
    // `deviation` fits its views to --max-work by the field's measured speed; the
    // example's picture keeps its asked size whatever the machine's load, so its bytes
    // do not depend on it.
    let forced = GlobalArgs {
        force: true,
        max_work: Some(global.max_work.unwrap_or(0.0).max(3600.0)),
        ..global.clone()
    };
    // A fixed file name: the model file is named after the mesh.
    let tmp = tempfile::Builder::new()
        .prefix("caoen-example-")
        .tempdir()
        .map_err(|e| CliError::io(std::env::temp_dir(), e))?;
    let mesh = tmp.path().join("spot.obj");
    std::fs::write(&mesh, SPOT_OBJ).map_err(|e| CliError::io(&mesh, e))?;
    let model = sub.join("spot.json");
    convert(
        &forced,
        &ConvertArgs {
            mesh: mesh.clone(),
            output: model.clone(),
            max_functions: None,
            target_angle: 3.0,
            target_depth: 0.002,
            check_size: 128,
            target: 0.001,
            max_angle: 10.0,
            fill_open: false,
            thicken: None,
            holes: crate::cli::HolesArg::Auto,
            descent: 8,
            json: false,
        },
    )?;
    deviation(
        &GlobalArgs {
            quiet: true,
            ..forced
        },
        &DeviationArgs {
            mesh: mesh.clone(),
            model: Some(model),
            rbf: None,
            views: 4,
            size: 192,
            picture: Some(sub.join("spot.png")),
            json: false,
            no_summary: true,
        },
    )
}
